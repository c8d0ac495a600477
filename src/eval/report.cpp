#include "eval/report.h"

#include "io/html.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "core/error.h"

namespace mosyn::eval {

namespace {

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// Round tick values covering [lo, hi].
std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(hi > lo)) return {lo};
  const double raw = (hi - lo) / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (raw <= m * mag) {
      step = m * mag;
      break;
    }
  for (double t = std::ceil(lo / step) * step; t <= hi + step * 1e-9; t += step) ticks.push_back(std::abs(t) < step * 1e-9 ? 0 : t);
  return ticks;
}

const char* kStyle =
    "body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1000px;padding:0 1em;color:#222}"
    "h1{font-size:1.5em}h2{font-size:1.2em;margin-top:2em;border-bottom:1px solid #ddd}"
    "pre{background:#f6f6f6;padding:1em;overflow:auto;max-height:30em;font-size:0.85em}"
    "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:0.3em 0.7em;text-align:right}"
    "td:first-child,th:first-child{text-align:left}th{background:#f0f0f0}"
    "iframe{width:100%;height:540px;border:1px solid #ccc}.note{color:#666}";

}  // namespace

TrainingCurve read_training_log(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot read the training log");
  TrainingCurve c;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    try {
      const auto j = nlohmann::json::parse(line);
      const double step = j.at("step").get<double>();
      if (j.contains("loss") && j["loss"].is_number()) {
        c.step.push_back(step);
        c.loss.push_back(j["loss"].get<double>());
      }
      if (j.contains("val_loss") && j["val_loss"].is_number()) {
        c.val_step.push_back(step);
        c.val_loss.push_back(j["val_loss"].get<double>());
      }
    } catch (const std::exception&) {
      // A damaged line is skipped: the log is informational.
    }
  }
  return c;
}

std::string training_curve_svg(const TrainingCurve& curve, int width, int height) {
  const std::string open = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(width) + "\" height=\"" +
                           std::to_string(height) + "\" viewBox=\"0 0 " + std::to_string(width) + " " +
                           std::to_string(height) + "\" font-family=\"sans-serif\" font-size=\"11\">";
  std::vector<double> xs = curve.step, ys = curve.loss;
  xs.insert(xs.end(), curve.val_step.begin(), curve.val_step.end());
  ys.insert(ys.end(), curve.val_loss.begin(), curve.val_loss.end());
  std::vector<double> fx, fy;
  for (size_t i = 0; i < xs.size(); ++i)
    if (std::isfinite(xs[i]) && std::isfinite(ys[i])) {
      fx.push_back(xs[i]);
      fy.push_back(ys[i]);
    }
  if (fx.empty())
    return open + "<text x=\"10\" y=\"20\">no logged steps</text></svg>";
  double x0 = *std::min_element(fx.begin(), fx.end()), x1 = *std::max_element(fx.begin(), fx.end());
  double y0 = *std::min_element(fy.begin(), fy.end()), y1 = *std::max_element(fy.begin(), fy.end());
  if (x1 <= x0) x1 = x0 + 1;
  if (y1 <= y0) {
    y0 -= 0.5;
    y1 += 0.5;
  }
  const double pad = 0.05 * (y1 - y0);
  y0 -= pad;
  y1 += pad;
  const double left = 60, right = width - 15.0, top = 25, bottom = height - 35.0;
  auto px = [&](double x) { return left + (x - x0) / (x1 - x0) * (right - left); };
  auto py = [&](double y) { return bottom - (y - y0) / (y1 - y0) * (bottom - top); };
  std::string s = open;
  s += "<rect x=\"" + fmt("%.1f", left) + "\" y=\"" + fmt("%.1f", top) + "\" width=\"" + fmt("%.1f", right - left) +
       "\" height=\"" + fmt("%.1f", bottom - top) + "\" fill=\"none\" stroke=\"#999\"/>";
  for (double t : nice_ticks(x0, x1, 6))
    s += "<line x1=\"" + fmt("%.1f", px(t)) + "\" y1=\"" + fmt("%.1f", bottom) + "\" x2=\"" + fmt("%.1f", px(t)) +
         "\" y2=\"" + fmt("%.1f", bottom + 4) + "\" stroke=\"#999\"/><text x=\"" + fmt("%.1f", px(t)) + "\" y=\"" +
         fmt("%.1f", bottom + 16) + "\" text-anchor=\"middle\">" + fmt("%g", t) + "</text>";
  for (double t : nice_ticks(y0, y1, 5))
    s += "<line x1=\"" + fmt("%.1f", left - 4) + "\" y1=\"" + fmt("%.1f", py(t)) + "\" x2=\"" + fmt("%.1f", right) +
         "\" y2=\"" + fmt("%.1f", py(t)) + "\" stroke=\"#eee\"/><text x=\"" + fmt("%.1f", left - 6) + "\" y=\"" +
         fmt("%.1f", py(t) + 4) + "\" text-anchor=\"end\">" + fmt("%.4g", t) + "</text>";
  s += "<text x=\"" + fmt("%.1f", 0.5 * (left + right)) + "\" y=\"" + std::to_string(height - 4) +
       "\" text-anchor=\"middle\">step</text>";
  auto polyline = [&](const std::vector<double>& x, const std::vector<double>& y, const char* color, const char* cls) {
    std::string pts;
    for (size_t i = 0; i < x.size(); ++i)
      if (std::isfinite(x[i]) && std::isfinite(y[i])) pts += fmt("%.1f", px(x[i])) + "," + fmt("%.1f", py(y[i])) + " ";
    std::string out = "<polyline class=\"" + std::string(cls) + "\" fill=\"none\" stroke=\"" + color +
                      "\" stroke-width=\"1.5\" points=\"" + pts + "\"/>";
    if (x.size() == 1) out += "<circle cx=\"" + fmt("%.1f", px(x[0])) + "\" cy=\"" + fmt("%.1f", py(y[0])) + "\" r=\"3\" fill=\"" + color + "\"/>";
    return out;
  };
  s += polyline(curve.step, curve.loss, "#1f77b4", "loss");
  if (!curve.val_step.empty()) {
    s += polyline(curve.val_step, curve.val_loss, "#d62728", "val_loss");
    for (size_t i = 0; i < curve.val_step.size(); ++i)
      if (std::isfinite(curve.val_loss[i]))
        s += "<circle cx=\"" + fmt("%.1f", px(curve.val_step[i])) + "\" cy=\"" + fmt("%.1f", py(curve.val_loss[i])) +
             "\" r=\"2.5\" fill=\"#d62728\"/>";
  }
  s += "<text x=\"" + fmt("%.1f", left + 8) + "\" y=\"16\" fill=\"#1f77b4\">&#8212; loss</text>";
  if (!curve.val_step.empty()) s += "<text x=\"" + fmt("%.1f", left + 70) + "\" y=\"16\" fill=\"#d62728\">&#8212; val_loss</text>";
  s += "</svg>";
  return s;
}

std::string report_html(const ReportInputs& in) {
  std::string h = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" +
                  io::escape_html(in.title) + "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n";
  h += "<h1>" + io::escape_html(in.title) + "</h1>\n";
  if (in.config.is_object() && in.config.contains("family") && in.config["family"].is_string())
    h += "<p>Model family <b>" + io::escape_html(in.config["family"].get<std::string>()) + "</b></p>\n";

  h += "<h2>Training curves</h2>\n" + training_curve_svg(in.curve) + "\n";
  if (!in.curve.loss.empty())
    h += "<p class=\"note\">" + std::to_string(in.curve.loss.size()) + " logged steps, last loss " +
         format_metric_value(in.curve.loss.back()) +
         (in.curve.val_loss.empty() ? std::string() : ", last val_loss " + format_metric_value(in.curve.val_loss.back())) +
         ".</p>\n";

  h += "<h2>Metrics</h2>\n";
  if (in.metrics) {
    const EvalResult& m = *in.metrics;
    h += "<p class=\"note\">" + std::to_string(m.clips.size()) + " held-out clips of split '" + io::escape_html(m.split) +
         "', " + std::to_string(m.num_samples) + " samples per control, seed " + std::to_string(m.seed) +
         (m.prediction_windows > 0 ? ", " + std::to_string(m.prediction_windows) + " prediction windows" : std::string()) +
         ".</p>\n";
    h += "<table class=\"metrics\">\n<tr><th>metric</th><th>model</th><th>real data</th></tr>\n";
    for (const auto& r : m.rows)
      h += "<tr><td>" + io::escape_html(r.label) + "</td><td>" + format_metric_value(r.model) + "</td><td>" +
           format_metric_value(r.real) + "</td></tr>\n";
    h += "</table>\n";
  } else {
    h += "<p class=\"note\">No evaluation: run <code>mosyn eval RUN --data DATASET --out RUN/metrics.json</code>.</p>\n";
  }

  h += "<h2>Samples</h2>\n";
  if (!in.viewer_page.empty())
    h += "<iframe class=\"viewer\" title=\"samples\" srcdoc=\"" + io::escape_html(in.viewer_page) + "\"></iframe>\n";
  if (!in.viewer_note.empty()) h += "<p class=\"note\">" + io::escape_html(in.viewer_note) + "</p>\n";

  h += "<h2>Config</h2>\n<pre>" + io::escape_html(in.config.dump(2)) + "</pre>\n";
  h += "</body>\n</html>\n";
  return h;
}

}  // namespace mosyn::eval

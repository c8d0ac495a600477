#include "eval/compare.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>

#include "core/error.h"
#include "data/control.h"
#include "data/prepare.h"
#include "eval/protocols/protocols.h"
#include "io/html.h"
#include "nn/sample_job.h"
#include "nn/sampling.h"

namespace mosyn::eval {

namespace {

using detail::kNaN;

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

// The keys of every evaluation merged in order: each evaluation's rows in order; a key new in a
// later one goes after the key that precedes it there.
std::vector<std::pair<std::string, std::string>> merged_keys(const std::vector<EvalResult>& evaluations) {
  std::vector<std::pair<std::string, std::string>> keys;  // key, label
  for (const auto& e : evaluations) {
    size_t at = 0;  // insertion point: after the last key of e seen so far
    for (const auto& r : e.rows) {
      const auto it = std::find_if(keys.begin(), keys.end(), [&](const auto& k) { return k.first == r.key; });
      if (it != keys.end()) {
        at = static_cast<size_t>(it - keys.begin()) + 1;
      } else {
        keys.insert(keys.begin() + static_cast<std::ptrdiff_t>(at), {r.key, r.label});
        ++at;
      }
    }
  }
  return keys;
}

const EvalRow* find_row(const EvalResult& e, const std::string& key) {
  for (const auto& r : e.rows)
    if (r.key == key) return &r;
  return nullptr;
}

// showcase_samples motions of one run along a gentle curve (families that take control) or of
// free generation (the others), with the "walk" label when it has one.
std::vector<ShowcaseMotion> showcase_of(const CompareEntry& e, int column, const CompareOptions& o) {
  std::vector<ShowcaseMotion> out;
  if (o.showcase_samples < 1) return out;
  const nn::LoadedRun& run = *e.run;
  data::PathOptions po;
  po.fps = run.dataset.fps;
  po.seconds = o.showcase_seconds;
  std::vector<float> control = data::smooth_control(data::control_from_path(data::parse_path("0,0 0,2 1.5,4"), po),
                                                    po.fps, run.dataset.layout.root_smoothing_s);
  if (run.traits.control != nn::InputUse::kTakes) std::fill(control.begin(), control.end(), 0.0f);
  const int warmup = nn::warmup_frames(run, o.eval.warmup_s);
  const auto motions = nn::sample_motions(run, control, o.showcase_samples, o.eval.seed, o.eval.temperature,
                                          detail::walk_extras(run, warmup));
  for (size_t k = 0; k < motions.size(); ++k)
    out.push_back({e.name + " " + std::to_string(k + 1), column, nn::decode_motion(run, motions[k])});
  return out;
}

// Fills the columns: runs, then one real column per distinct dataset.
void add_columns(const std::vector<CompareEntry>& entries, CompareResult& r) {
  std::vector<std::string> datasets;
  for (const auto& e : entries) {
    r.columns.push_back({e.name, false, e.run->run_dir, e.dataset_name});
    if (std::find(datasets.begin(), datasets.end(), e.dataset_name) == datasets.end()) datasets.push_back(e.dataset_name);
  }
  for (const auto& d : datasets) {
    const std::string base = std::filesystem::path(d).filename().string();
    r.columns.push_back({datasets.size() == 1 ? "real" : "real (" + (base.empty() ? d : base) + ")", true, "", d});
  }
}

// The rows: each run's model value, each dataset's real value (first run on it with the key).
void add_rows(const std::vector<CompareEntry>& entries, CompareResult& r) {
  for (const auto& [key, label] : merged_keys(r.evaluations)) {
    CompareRow row{key, label, std::vector<double>(r.columns.size(), kNaN)};
    for (size_t c = 0; c < r.columns.size(); ++c) {
      for (size_t i = 0; i < entries.size(); ++i) {
        if (r.columns[c].real ? entries[i].dataset_name != r.columns[c].dataset : i != c) continue;
        if (const EvalRow* er = find_row(r.evaluations[i], key)) {
          row.values[c] = r.columns[c].real ? er->real : er->model;
          break;
        }
      }
    }
    r.rows.push_back(std::move(row));
  }
}

}  // namespace

nlohmann::json CompareResult::to_json() const {
  nlohmann::json j;
  j["format"] = "mosyn-compare-1";
  nlohmann::json cols = nlohmann::json::array(), runs = nlohmann::json::array();
  for (const auto& c : columns)
    cols.push_back({{"name", c.name}, {"kind", c.real ? "real" : "run"}, {"run", c.run_dir}, {"dataset", c.dataset}});
  for (size_t i = 0; i < evaluations.size() && i < columns.size(); ++i) {
    const EvalResult& e = evaluations[i];
    runs.push_back({{"name", columns[i].name}, {"run", e.run_dir}, {"family", e.family}, {"dataset", columns[i].dataset},
                    {"protocols", e.protocols}, {"clips", e.clips}, {"prediction_windows", e.prediction_windows},
                    {"joint_error_clips", e.joint_error_clips}});
  }
  nlohmann::json list = nlohmann::json::array(), map = nlohmann::json::object();
  for (const auto& r : rows) {
    nlohmann::json values = nlohmann::json::array(), by_name = nlohmann::json::object();
    for (size_t c = 0; c < r.values.size() && c < columns.size(); ++c) {
      values.push_back(number_or_null(r.values[c]));
      by_name[columns[c].name] = number_or_null(r.values[c]);
    }
    list.push_back({{"key", r.key}, {"label", r.label}, {"values", values}});
    map[r.key] = by_name;
  }
  j["columns"] = cols;
  j["runs"] = runs;
  j["rows"] = list;
  j["metrics"] = map;
  return j;
}

CompareResult compare(const std::vector<CompareEntry>& entries, const CompareOptions& options,
                      const CompareProgressCallback& progress) {
  if (entries.empty()) throw Error("compare: no run to compare");
  CompareResult r;
  for (const auto& e : entries) {
    if (!e.run || !e.dataset) throw Error("compare: " + e.name + " has no run or no dataset");
    try {
      r.evaluations.push_back(evaluate(*e.run, *e.dataset, options.eval, [&](const EvalProgress& p) {
        if (progress) progress(e.name, p);
      }));
    } catch (const Error& err) {
      throw Error(e.name + ": " + err.what());
    }
  }
  add_columns(entries, r);
  add_rows(entries, r);
  for (size_t i = 0; i < entries.size(); ++i) {
    if (!entries[i].run->model) continue;
    for (auto& m : showcase_of(entries[i], static_cast<int>(i), options)) r.showcase.push_back(std::move(m));
  }
  for (size_t c = entries.size(); c < r.columns.size(); ++c) {  // one real clip per dataset
    for (size_t i = 0; i < entries.size(); ++i) {
      if (entries[i].dataset_name != r.columns[c].dataset || r.evaluations[i].clip_indices.empty()) continue;
      const data::Dataset& d = *entries[i].dataset;
      const data::ClipRecord& rec = d.clips(options.eval.split).at(r.evaluations[i].clip_indices.front());
      r.showcase.push_back({"real: " + rec.source, static_cast<int>(c), data::decode_record(d.info(), rec)});
      break;
    }
  }
  return r;
}

CompareResult compare(const std::vector<std::string>& run_dirs, const std::vector<std::string>& data_dirs,
                      const CompareOptions& options, const CompareProgressCallback& progress) {
  if (run_dirs.empty()) throw Error("compare: no run to compare");
  if (data_dirs.size() != 1 && data_dirs.size() != run_dirs.size())
    throw Error("compare: give one dataset for all runs or one per run (" + std::to_string(run_dirs.size()) +
                " runs, " + std::to_string(data_dirs.size()) + " datasets)");
  std::map<std::string, std::unique_ptr<data::Dataset>> datasets;
  for (const auto& d : data_dirs)
    if (!datasets.count(d)) datasets[d] = std::make_unique<data::Dataset>(data::Dataset::open(d));
  nn::LoadOptions lo;
  lo.threads = options.eval.threads;
  lo.checkpoint = options.eval.checkpoint;
  lo.raw_root = options.eval.raw_root;
  std::vector<nn::LoadedRun> runs;
  for (const auto& dir : run_dirs) runs.push_back(nn::load_run(dir, lo));
  std::vector<CompareEntry> entries;
  for (size_t i = 0; i < run_dirs.size(); ++i) {
    std::string name = std::filesystem::path(run_dirs[i]).lexically_normal().filename().string();
    if (name.empty()) name = std::filesystem::path(run_dirs[i]).lexically_normal().parent_path().filename().string();
    for (size_t j = 0; j < run_dirs.size(); ++j)
      if (j != i && std::filesystem::path(run_dirs[j]).lexically_normal().filename() ==
                        std::filesystem::path(run_dirs[i]).lexically_normal().filename())
        name = run_dirs[i];
    const std::string& data = data_dirs.size() == 1 ? data_dirs.front() : data_dirs[i];
    entries.push_back({name, &runs[i], datasets.at(data).get(), data});
  }
  return compare(entries, options, progress);
}

std::string format_compare_markdown(const CompareResult& result) {
  std::string head = "| metric |", rule = "|---|";
  for (const auto& c : result.columns) {
    head += " " + c.name + " |";
    rule += "---|";
  }
  std::string s = head + "\n" + rule + "\n";
  for (const auto& r : result.rows) {
    s += "| " + r.label + " |";
    for (double v : r.values) s += " " + format_metric_value(v) + " |";
    s += "\n";
  }
  return s;
}

std::string compare_html(const CompareResult& result, const std::string& title, const std::string& viewer_page,
                         const std::string& viewer_note) {
  const char* style =
      "body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1200px;padding:0 1em;color:#222}"
      "h1{font-size:1.5em}h2{font-size:1.2em;margin-top:2em;border-bottom:1px solid #ddd}"
      "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:0.3em 0.7em;text-align:right}"
      "td:first-child,th:first-child{text-align:left}th{background:#f0f0f0}"
      "iframe{width:100%;height:560px;border:1px solid #ccc}.note{color:#666}";
  std::string h = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" +
                  io::escape_html(title) + "</title>\n<style>" + style + "</style>\n</head>\n<body>\n";
  h += "<h1>" + io::escape_html(title) + "</h1>\n<ul>\n";
  for (size_t i = 0; i < result.evaluations.size() && i < result.columns.size(); ++i) {
    const EvalResult& e = result.evaluations[i];
    std::string protocols;
    for (const auto& p : e.protocols) protocols += (protocols.empty() ? "" : ", ") + p;
    h += "<li><b>" + io::escape_html(result.columns[i].name) + "</b>: family " + io::escape_html(e.family) +
         ", dataset " + io::escape_html(result.columns[i].dataset) + ", " + std::to_string(e.clips.size()) +
         " clips, " + std::to_string(e.num_samples) + " samples per control; protocols: " +
         io::escape_html(protocols) + "</li>\n";
  }
  h += "</ul>\n<h2>Metrics</h2>\n<table class=\"compare\">\n<tr><th>metric</th>";
  for (const auto& c : result.columns) h += "<th>" + io::escape_html(c.name) + "</th>";
  h += "</tr>\n";
  for (const auto& r : result.rows) {
    h += "<tr><td>" + io::escape_html(r.label) + "</td>";
    for (double v : r.values) h += "<td>" + format_metric_value(v) + "</td>";
    h += "</tr>\n";
  }
  h += "</table>\n<p class=\"note\">n/a: the metric does not apply to that column (a protocol the run's traits do "
       "not allow, or a figure real data does not have).</p>\n<h2>Samples</h2>\n";
  if (!viewer_page.empty())
    h += "<iframe class=\"viewer\" title=\"samples\" srcdoc=\"" + io::escape_html(viewer_page) + "\"></iframe>\n";
  if (!viewer_note.empty()) h += "<p class=\"note\">" + io::escape_html(viewer_note) + "</p>\n";
  h += "</body>\n</html>\n";
  return h;
}

}  // namespace mosyn::eval

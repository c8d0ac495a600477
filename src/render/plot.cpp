#include "render/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "core/error.h"

namespace mosyn::render {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kLeft = 64, kRight = 16, kTop = 14, kBottom = 30;  // margins (pixels) around the axes
const Rgb kAxis{60, 60, 60}, kGrid{225, 225, 225}, kText{60, 60, 60};

// 3x5 glyphs, one row per 3-bit mask, most significant bit on the left.
const unsigned char* glyph(char c) {
  static const unsigned char kDigits[10][5] = {{7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7},
                                               {5, 5, 7, 1, 1}, {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1},
                                               {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7}};
  static const unsigned char kDot[5] = {0, 0, 0, 0, 2}, kMinus[5] = {0, 0, 7, 0, 0};
  if (c >= '0' && c <= '9') return kDigits[c - '0'];
  if (c == '.') return kDot;
  if (c == '-') return kMinus;
  return nullptr;
}

// A tick value printed with as many decimals as the step needs.
std::string tick_label(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
  char s[48];
  std::snprintf(s, sizeof s, "%.*f", decimals, std::abs(v) < step * 1e-6 ? 0.0 : v);
  return s;
}

struct Frame {
  double x0, x1, y0, y1;
  int w, h;
  double px(double x) const { return kLeft + (x - x0) / (x1 - x0) * (w - kLeft - kRight); }
  double py(double y) const { return h - kBottom - (y - y0) / (y1 - y0) * (h - kTop - kBottom); }
};

// Fills the area between two polylines over the same x (ascending), each pixel column once (so
// many points per column do not stack their opacity): a column covers the extent of lo..hi of
// the segments crossing it.
void fill_between(Image& img, const Frame& f, const std::vector<double>& x, const std::vector<double>& lo,
                  const std::vector<double>& hi, Rgb color, double alpha) {
  const int first = kLeft, last = f.w - kRight;  // columns [first, last)
  std::vector<double> top(last - first, std::numeric_limits<double>::infinity()), bottom(last - first, -top[0]);
  for (size_t i = 0; i + 1 < x.size(); ++i) {
    if (!std::isfinite(lo[i] + hi[i] + lo[i + 1] + hi[i + 1] + x[i] + x[i + 1])) continue;
    const double p0 = f.px(x[i]), p1 = f.px(x[i + 1]);
    for (int c = std::max(first, static_cast<int>(std::floor(p0)));
         c <= std::min(last - 1, static_cast<int>(std::floor(p1))); ++c) {
      const double s = p1 > p0 ? std::clamp((c + 0.5 - p0) / (p1 - p0), 0.0, 1.0) : 0.0;
      top[c - first] = std::min(top[c - first], f.py(hi[i] + s * (hi[i + 1] - hi[i])));
      bottom[c - first] = std::max(bottom[c - first], f.py(lo[i] + s * (lo[i + 1] - lo[i])));
    }
  }
  for (int c = first; c < last; ++c)
    for (int r = std::max(kTop, static_cast<int>(std::ceil(top[c - first] - 0.5)));
         r < std::min(f.h - kBottom, static_cast<int>(std::ceil(bottom[c - first] - 0.5))); ++r)
      img.blend(c, r, color, alpha);
}

void draw_axes(Image& img, const Frame& f) {
  const double xs = nice_step(f.x1 - f.x0, 8), ys = nice_step(f.y1 - f.y0, 6);
  for (double x = std::ceil(f.x0 / xs) * xs; x <= f.x1 + xs * 1e-9; x += xs) {
    img.draw_line(f.px(x), kTop, f.px(x), f.h - kBottom, 1.0, kGrid);
    const std::string t = tick_label(x, xs);
    draw_digits(img, static_cast<int>(f.px(x)) - digits_width(t) / 2, f.h - kBottom + 8, t, kText);
  }
  for (double y = std::ceil(f.y0 / ys) * ys; y <= f.y1 + ys * 1e-9; y += ys) {
    img.draw_line(kLeft, f.py(y), f.w - kRight, f.py(y), 1.0, kGrid);
    const std::string t = tick_label(y, ys);
    draw_digits(img, kLeft - 8 - digits_width(t), static_cast<int>(f.py(y)) - 5, t, kText);
  }
  img.draw_line(kLeft, kTop, kLeft, f.h - kBottom, 1.5, kAxis);
  img.draw_line(kLeft, f.h - kBottom, f.w - kRight, f.h - kBottom, 1.5, kAxis);
}

}  // namespace

PlotOptions::PlotOptions() : x_min(kNaN), x_max(kNaN), y_min(kNaN), y_max(kNaN) {}

double nice_step(double range, int target) {
  if (!(range > 0) || target < 1) return 1.0;
  const double raw = range / target, power = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (m * power >= raw) return m * power;
  return 10.0 * power;
}

int digits_width(const std::string& text, int scale) {
  return text.empty() ? 0 : static_cast<int>(text.size()) * 4 * scale - scale;
}

void draw_digits(Image& image, int x, int y, const std::string& text, Rgb color, int scale) {
  // One glyph cell: a scale x scale square with its top-left corner at (cx, cy), clipped.
  auto fill_cell = [&](int cx, int cy) {
    for (int py = std::max(cy, 0); py < std::min(cy + scale, image.height()); ++py)
      for (int px = std::max(cx, 0); px < std::min(cx + scale, image.width()); ++px) image.set(px, py, color);
  };
  for (size_t k = 0; k < text.size(); ++k) {
    const unsigned char* g = glyph(text[k]);
    for (int cell = 0; g && cell < 15; ++cell)  // 5 rows of 3 cells
      if (g[cell / 3] & (4 >> (cell % 3)))
        fill_cell(x + (static_cast<int>(k) * 4 + cell % 3) * scale, y + (cell / 3) * scale);
  }
}

Image plot_series(const std::vector<PlotSeries>& series, const std::vector<PlotBand>& bands, const PlotOptions& o) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = 0, y1 = -x0;
  for (const auto& s : series) {
    if (s.x.size() != s.y.size() || (!s.spread.empty() && s.spread.size() != s.y.size()))
      throw Error("plot: a curve's x, y and spread differ in length");
    for (size_t i = 0; i < s.y.size(); ++i) {
      const double sp = s.spread.empty() ? 0.0 : s.spread[i];
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i] + sp)) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i] - sp);
      y1 = std::max(y1, s.y[i] + sp);
    }
  }
  for (const auto& b : bands)
    if (std::isfinite(b.y + b.spread)) {
      y0 = std::min(y0, b.y - b.spread);
      y1 = std::max(y1, b.y + b.spread);
    }
  if (!(x1 >= x0) || !(y1 >= y0)) throw Error("plot: nothing finite to draw");
  Frame f{std::isfinite(o.x_min) ? o.x_min : x0, std::isfinite(o.x_max) ? o.x_max : x1,
          std::isfinite(o.y_min) ? o.y_min : y0, std::isfinite(o.y_max) ? o.y_max : y0 + 1.05 * (y1 - y0),
          o.width_px, o.height_px};
  if (!(f.x1 > f.x0)) f.x1 = f.x0 + 1;
  if (!(f.y1 > f.y0)) f.y1 = f.y0 + 1;
  if (o.width_px < kLeft + kRight + 10 || o.height_px < kTop + kBottom + 10) throw Error("plot: image too small");
  Image img(o.width_px, o.height_px);
  draw_axes(img, f);
  for (const auto& b : bands) {
    if (!std::isfinite(b.y + b.spread)) continue;
    fill_between(img, f, {f.x0, f.x1}, {b.y - b.spread, b.y - b.spread}, {b.y + b.spread, b.y + b.spread}, b.color,
                 b.alpha);
    img.draw_line(kLeft, f.py(b.y), o.width_px - kRight, f.py(b.y), 1.5, b.color);
  }
  for (const auto& s : series) {
    if (!s.spread.empty()) {
      std::vector<double> lo(s.y.size()), hi(s.y.size());
      for (size_t i = 0; i < s.y.size(); ++i) lo[i] = s.y[i] - s.spread[i], hi[i] = s.y[i] + s.spread[i];
      fill_between(img, f, s.x, lo, hi, s.color, s.spread_alpha);
    }
    for (size_t i = 0; i + 1 < s.y.size(); ++i)
      if (std::isfinite(s.x[i] + s.y[i] + s.x[i + 1] + s.y[i + 1]))
        img.draw_line(f.px(s.x[i]), f.py(s.y[i]), f.px(s.x[i + 1]), f.py(s.y[i + 1]), 2.0, s.color);
  }
  return img;
}

}  // namespace mosyn::render

// Line plots of statistics over time (e.g. DFN's Fig. 9 from `mosyn eval --plot`): curves with a
// shaded spread, horizontal reference bands, grid lines at round values with numeric tick labels
// drawn in a small built-in digit font. No text beyond numbers: the units are the caller's to state.
#pragma once

#include <string>
#include <vector>

#include "render/canvas.h"

namespace mosyn::render {

// One curve: y over x, optional symmetric spread (empty, or the same length as y) shaded at
// spread_alpha. Non-finite points are skipped (the line breaks there).
struct PlotSeries {
  std::vector<double> x, y, spread;
  Rgb color{31, 119, 180};
  double spread_alpha = 0.25;
};

// A horizontal band y +- spread across the whole plot (e.g. the training data's level), drawn
// beneath the curves with its centre line.
struct PlotBand {
  double y = 0, spread = 0;
  Rgb color{160, 160, 160};
  double alpha = 0.35;
};

struct PlotOptions {
  int width_px = 900, height_px = 420;
  // Axis ranges; NaN = fitted to the data (x: the series' extent; y: from 0 or the smallest value,
  // whichever is lower, to the largest value plus 5%).
  double x_min, x_max, y_min, y_max;
  PlotOptions();
};

// The plot as an image. Throws mosyn::Error when there is nothing finite to draw or a spread's
// length differs from its curve's.
Image plot_series(const std::vector<PlotSeries>& series, const std::vector<PlotBand>& bands,
                  const PlotOptions& options = PlotOptions());

// Grid step for a range: 1, 2 or 5 times a power of ten giving about `target` intervals.
double nice_step(double range, int target);

// Draws text of digits, '.', '-' and ' ' (other characters are left blank) with its top-left corner
// at (x, y), each glyph 3x5 cells of scale x scale pixels with one cell of spacing.
void draw_digits(Image& image, int x, int y, const std::string& text, Rgb color, int scale = 2);

// Width in pixels of draw_digits' text.
int digits_width(const std::string& text, int scale = 2);

}  // namespace mosyn::render

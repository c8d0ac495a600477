// Counting a body's pixels in a screenshot of the viewer (bodies are lit, so their brightness
// varies but their hue stays; the floor, grid, shadows and planted feet are grey). Shared by the
// browser tests of the playback page (tests/render) and the live page (tests/serve).
#pragma once

#include <algorithm>
#include <cmath>

#include "render/canvas.h"

namespace mosyn::render::testing {

// Hue in degrees and saturation of an RGB colour.
inline void hue_saturation(Rgb c, double* hue, double* saturation) {
  const double r = c.r / 255.0, g = c.g / 255.0, b = c.b / 255.0;
  const double hi = std::max({r, g, b}), lo = std::min({r, g, b}), d = hi - lo;
  *saturation = hi > 0 ? d / hi : 0;
  double h = 0;
  if (d > 0) h = hi == r ? std::fmod((g - b) / d + 6, 6.0) : hi == g ? (b - r) / d + 2 : (r - g) / d + 4;
  *hue = 60 * h;
}

// Pixels of a body in colour c.
inline int count_body_pixels(const Image& image, Rgb c) {
  double hue_c, sat_c;
  hue_saturation(c, &hue_c, &sat_c);
  int n = 0;
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x) {
      const Rgb p = image.at(x, y);
      double hue, sat;
      hue_saturation(p, &hue, &sat);
      const double dh = std::abs(hue - hue_c);
      n += sat > 0.35 && std::max({p.r, p.g, p.b}) > 30 && std::min(dh, 360 - dh) < 12;
    }
  return n;
}

}  // namespace mosyn::render::testing

#include "render/canvas.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/error.h"

namespace mosyn::render {

Rgb parse_color(const std::string& hex) {
  auto digit = [&](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    throw Error("colour '" + hex + "' is not #rrggbb");
  };
  if (hex.size() != 7 || hex[0] != '#') throw Error("colour '" + hex + "' is not #rrggbb");
  auto byte = [&](int i) { return static_cast<std::uint8_t>(digit(hex[i]) * 16 + digit(hex[i + 1])); };
  return {byte(1), byte(3), byte(5)};
}

std::string format_color(Rgb color) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", color.r, color.g, color.b);
  return buf;
}

Rgb motion_color(int index) {
  // Channels in {0, 51, 102, 153, 204, 255}: exact in the 6x6x6 GIF colour cube.
  static const Rgb kColors[] = {{204, 0, 51},  {0, 102, 204}, {0, 153, 51},  {255, 102, 0},
                                {153, 0, 204}, {0, 153, 153}, {204, 153, 0}, {255, 0, 153}};
  const int n = static_cast<int>(sizeof kColors / sizeof kColors[0]);
  return kColors[((index % n) + n) % n];
}

Image::Image(int width, int height, Rgb background) : width_(width), height_(height) {
  if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
    throw Error("image size " + std::to_string(width) + "x" + std::to_string(height) + " is not in 1..16384");
  pixels_.resize(static_cast<size_t>(width) * height * 3);
  for (size_t i = 0; i < pixels_.size(); i += 3) {
    pixels_[i] = background.r;
    pixels_[i + 1] = background.g;
    pixels_[i + 2] = background.b;
  }
}

Rgb Image::at(int x, int y) const {
  const size_t i = (static_cast<size_t>(y) * width_ + x) * 3;
  return {pixels_[i], pixels_[i + 1], pixels_[i + 2]};
}

void Image::set(int x, int y, Rgb color) {
  if (x < 0 || y < 0 || x >= width_ || y >= height_) return;
  const size_t i = (static_cast<size_t>(y) * width_ + x) * 3;
  pixels_[i] = color.r;
  pixels_[i + 1] = color.g;
  pixels_[i + 2] = color.b;
}

void Image::blend(int x, int y, Rgb color, double alpha) {
  if (x < 0 || y < 0 || x >= width_ || y >= height_ || alpha <= 0) return;
  alpha = std::min(alpha, 1.0);
  const size_t i = (static_cast<size_t>(y) * width_ + x) * 3;
  auto mix = [alpha](std::uint8_t a, std::uint8_t b) {
    return static_cast<std::uint8_t>(std::lround(a + (b - a) * alpha));
  };
  pixels_[i] = mix(pixels_[i], color.r);
  pixels_[i + 1] = mix(pixels_[i + 1], color.g);
  pixels_[i + 2] = mix(pixels_[i + 2], color.b);
}

void Image::draw_line(double x0, double y0, double x1, double y1, double width_px, Rgb color, double alpha) {
  if (!std::isfinite(x0) || !std::isfinite(y0) || !std::isfinite(x1) || !std::isfinite(y1)) return;
  const double r = std::max(width_px, 0.5) / 2;
  const int xa = std::max(0, static_cast<int>(std::floor(std::min(x0, x1) - r - 1)));
  const int xb = std::min(width_ - 1, static_cast<int>(std::ceil(std::max(x0, x1) + r + 1)));
  const int ya = std::max(0, static_cast<int>(std::floor(std::min(y0, y1) - r - 1)));
  const int yb = std::min(height_ - 1, static_cast<int>(std::ceil(std::max(y0, y1) + r + 1)));
  const double dx = x1 - x0, dy = y1 - y0, len2 = dx * dx + dy * dy;
  for (int y = ya; y <= yb; ++y)
    for (int x = xa; x <= xb; ++x) {
      const double px = x + 0.5, py = y + 0.5;
      const double s = len2 > 0 ? std::clamp(((px - x0) * dx + (py - y0) * dy) / len2, 0.0, 1.0) : 0.0;
      const double d = std::hypot(px - (x0 + s * dx), py - (y0 + s * dy));
      // Coverage falls from 1 to 0 over the pixel straddling the edge.
      const double coverage = std::clamp(r + 0.5 - d, 0.0, 1.0);
      if (coverage > 0) blend(x, y, color, alpha * coverage);
    }
}

void Image::fill_circle(double cx, double cy, double radius_px, Rgb color, double alpha) {
  draw_line(cx, cy, cx, cy, 2 * radius_px, color, alpha);
}

void Image::paste(const Image& other, int x, int y) {
  for (int j = 0; j < other.height(); ++j)
    for (int i = 0; i < other.width(); ++i) set(x + i, y + j, other.at(i, j));
}

}  // namespace mosyn::render

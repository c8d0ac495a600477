// A small software rasteriser on an 8-bit RGB buffer: anti-aliased thick lines and filled circles
// with alpha blending. Coordinates are in pixels, x to the right, y downwards, pixel (i, j) covering
// [i, i + 1) x [j, j + 1) with its centre at (i + 0.5, j + 0.5).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace mosyn::render {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb& o) const { return r == o.r && g == o.g && b == o.b; }
};

// "#rrggbb" (case-insensitive). Throws mosyn::Error for anything else.
Rgb parse_color(const std::string& hex);
// "#rrggbb" (lowercase).
std::string format_color(Rgb color);

// The default colour of motion i (a fixed cycle of 8 distinct colours, each exactly representable
// in the GIF palette of image_io.h).
Rgb motion_color(int index);

class Image {
 public:
  Image() = default;
  // A width x height image filled with `background`. Throws mosyn::Error for non-positive sizes.
  Image(int width, int height, Rgb background = {255, 255, 255});

  int width() const { return width_; }
  int height() const { return height_; }
  // Row-major RGB bytes [height, width, 3].
  const std::vector<std::uint8_t>& pixels() const { return pixels_; }
  std::vector<std::uint8_t>& pixels() { return pixels_; }

  Rgb at(int x, int y) const;
  void set(int x, int y, Rgb color);
  // Mixes color into pixel (x, y) with opacity alpha (0..1); ignores pixels outside the image.
  void blend(int x, int y, Rgb color, double alpha);

  // A segment of the given width (pixels) with round caps; edges anti-aliased over one pixel.
  void draw_line(double x0, double y0, double x1, double y1, double width_px, Rgb color, double alpha = 1.0);
  // A filled disc of the given radius (pixels), edge anti-aliased.
  void fill_circle(double cx, double cy, double radius_px, Rgb color, double alpha = 1.0);
  // Copies `other` with its top-left corner at (x, y), clipped.
  void paste(const Image& other, int x, int y);

 private:
  int width_ = 0, height_ = 0;
  std::vector<std::uint8_t> pixels_;
};

}  // namespace mosyn::render

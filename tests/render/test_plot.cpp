// render/plot.h: grid steps, the digit font and where curves, spreads and bands land in the image.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "render/plot.h"

using namespace mosyn;
using render::Rgb;

namespace {

// Pixels of one exact colour in a column range.
int count_color(const render::Image& img, Rgb color, int x0 = 0, int x1 = -1) {
  if (x1 < 0) x1 = img.width();
  int n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = x0; x < x1; ++x) n += img.at(x, y) == color;
  return n;
}

}  // namespace

TEST(Plot, NiceStepsAreOneTwoOrFiveTimesAPowerOfTen) {
  EXPECT_DOUBLE_EQ(render::nice_step(30.0, 8), 5.0);    // 3.75 -> 5
  EXPECT_DOUBLE_EQ(render::nice_step(10.0, 5), 2.0);
  EXPECT_DOUBLE_EQ(render::nice_step(0.6, 6), 0.1);
  EXPECT_DOUBLE_EQ(render::nice_step(0.35, 6), 0.1);     // 0.0583 -> 0.1
  EXPECT_NEAR(render::nice_step(0.07, 6), 0.02, 1e-12);  // 0.0117 -> 0.02
  EXPECT_DOUBLE_EQ(render::nice_step(0.0, 6), 1.0);      // degenerate range
}

TEST(Plot, DigitsFollowTheGlyphs) {
  render::Image img(20, 12, {255, 255, 255});
  const Rgb ink{0, 0, 0};
  render::draw_digits(img, 1, 1, "1", ink, 1);
  // "1" is 010 / 110 / 010 / 010 / 111.
  const int expected[5][3] = {{0, 1, 0}, {1, 1, 0}, {0, 1, 0}, {0, 1, 0}, {1, 1, 1}};
  for (int r = 0; r < 5; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(img.at(1 + c, 1 + r) == ink, expected[r][c] == 1) << r << "," << c;
  EXPECT_EQ(render::digits_width("1.5", 2), 22);
  render::draw_digits(img, 15, 8, "88", ink, 3);  // clipped at the border, no crash
}

TEST(Plot, CurveBandAndReferenceLandWhereTheirValuesAre) {
  render::PlotSeries s;
  for (int t = 0; t <= 100; ++t) {
    s.x.push_back(t * 0.1);
    s.y.push_back(t < 50 ? 0.2 : 0.6);
    s.spread.push_back(0.05);
  }
  s.color = {200, 0, 0};
  render::PlotBand band{0.4, 0.02, {0, 0, 200}, 1.0};
  render::PlotOptions o;
  o.y_min = 0;
  o.y_max = 1;
  const render::Image img = render::plot_series({s}, {band}, o);
  ASSERT_EQ(img.width(), o.width_px);
  // Plot area: x from 64 to width - 16, y from 14 (value 1) to height - 30 (value 0).
  const double top = 14, bottom = o.height_px - 30;
  auto row_of = [&](double v) { return static_cast<int>(bottom - v * (bottom - top)); };
  const int left_column = 64 + 100, right_column = o.width_px - 16 - 100;
  EXPECT_EQ(img.at(left_column, row_of(0.2)), s.color);   // the curve's first half
  EXPECT_EQ(img.at(right_column, row_of(0.6)), s.color);  // its second half
  EXPECT_EQ(img.at(left_column, row_of(0.4)), band.color);  // the band's centre line
  // The curve's spread is shaded (lighter than the curve, not white) just off the line.
  const Rgb shade = img.at(left_column, row_of(0.2) + 8);
  EXPECT_FALSE(shade == Rgb({255, 255, 255}));
  EXPECT_GT(shade.r, shade.g);
  // Nothing of the curve far from its values.
  EXPECT_EQ(count_color(img, s.color, 0, 60), 0);
}

TEST(Plot, BadInputIsRefused) {
  render::PlotSeries s;
  s.x = {0, 1};
  s.y = {0};
  EXPECT_THROW(render::plot_series({s}, {}), Error);
  s.y = {NAN, NAN};
  EXPECT_THROW(render::plot_series({s}, {}), Error);
  s.y = {0, 1};
  render::PlotOptions tiny;
  tiny.width_px = 20;
  EXPECT_THROW(render::plot_series({s}, {}, tiny), Error);
}

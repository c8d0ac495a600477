// Rasteriser, camera, scene and image files against hand-computed values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "core/error.h"
#include "core/synthetic.h"
#include "io/atomic_file.h"
#include "render/canvas.h"
#include "render/image_io.h"
#include "render/scene.h"
#include "render/view.h"

namespace mosyn::render {
namespace {

const Rgb kWhite{255, 255, 255};

int count_color(const Image& image, Rgb c, int x0 = 0, int x1 = -1) {
  if (x1 < 0) x1 = image.width();
  int n = 0;
  for (int y = 0; y < image.height(); ++y)
    for (int x = x0; x < x1; ++x) n += image.at(x, y) == c;
  return n;
}

RenderMotion walk(int index, double heading = 0.5) {
  Clip clip{make_synthetic_biped(), {}};
  SyntheticWalkOptions o;
  o.start_heading_rad = heading;
  clip.motion = make_synthetic_walk(clip.skeleton, 45, 30.0, o);
  return render_motion_from_clip(clip, motion_color(index), 0.0, "walk" + std::to_string(index));
}

TEST(CanvasTest, Colors) {
  EXPECT_EQ(parse_color("#FF8000"), (Rgb{255, 128, 0}));
  EXPECT_EQ(format_color({1, 171, 255}), "#01abff");
  EXPECT_THROW(parse_color("red"), Error);
  EXPECT_THROW(parse_color("#12345g"), Error);
}

TEST(CanvasTest, ThickLineCoversItsWidth) {
  Image image(20, 10, kWhite);
  const Rgb red{255, 0, 0};
  image.draw_line(4, 5, 18, 5, 4, red);  // rows 3..6 fully inside (|y + 0.5 - 5| <= 1.5)
  for (int y = 3; y <= 6; ++y) EXPECT_EQ(image.at(10, y), red) << y;
  EXPECT_EQ(image.at(10, 1), kWhite);
  EXPECT_EQ(image.at(10, 8), kWhite);
  // Round cap: one pixel beyond the end point still covered, far beyond not.
  EXPECT_EQ(image.at(18, 5), red);
  EXPECT_EQ(image.at(1, 5), kWhite);  // pixel centre (1.5, 5.5) is 2.55 px from the end point
  // Half coverage on the edge row (distance 2.5 from the centre line at radius 2: 0.5 + 2 - 2.5 = 0).
  EXPECT_EQ(image.at(10, 7), kWhite);
}

TEST(CanvasTest, BlendAndCircle) {
  Image image(9, 9, {0, 0, 0});
  image.blend(0, 0, {200, 100, 50}, 0.5);
  EXPECT_EQ(image.at(0, 0), (Rgb{100, 50, 25}));
  image.fill_circle(4.5, 4.5, 2, {255, 255, 255});
  EXPECT_EQ(image.at(4, 4), (Rgb{255, 255, 255}));
  EXPECT_EQ(image.at(5, 4), (Rgb{255, 255, 255}));  // centre distance 1 < 2
  EXPECT_EQ(image.at(6, 4), (Rgb{128, 128, 128}));  // distance 2: half covered
  EXPECT_EQ(image.at(8, 4), (Rgb{0, 0, 0}));        // distance 3.5
  EXPECT_THROW(Image(0, 5), Error);
}

TEST(CameraTest, PresetsAndUpAxis) {
  const Eigen::Vector3d c(1, 1, 1);
  // Orthographic: scale 0.45 * min(w, h) / radius = 0.45 * 100 / 2 = 22.5 px per metre.
  auto p = project(c, CameraPreset::kFront, false, c, 2.0, 200, 100);
  EXPECT_NEAR(p.x(), 100, 1e-12);
  EXPECT_NEAR(p.y(), 50, 1e-12);
  p = project(c + Eigen::Vector3d(1, 0, 0), CameraPreset::kFront, false, c, 2.0, 200, 100);
  EXPECT_NEAR(p.x(), 122.5, 1e-9);
  p = project(c + Eigen::Vector3d(0, 1, 0), CameraPreset::kFront, false, c, 2.0, 200, 100);
  EXPECT_NEAR(p.y(), 27.5, 1e-9);  // up is up on screen
  p = project(c + Eigen::Vector3d(0, 0, 1), CameraPreset::kSide, false, c, 2.0, 200, 100);
  EXPECT_NEAR(p.x(), 77.5, 1e-9);  // from +X, +Z is to the left
  p = project(c + Eigen::Vector3d(0, 0, 1), CameraPreset::kTop, false, c, 2.0, 200, 100);
  EXPECT_NEAR(p.y(), 72.5, 1e-9);  // from above, +Z is down
  EXPECT_NEAR(p.x(), 100, 1e-9);
  // Perspective: the nearest point of the sphere (depth = radius) keeps the orthographic scale.
  p = project(c + Eigen::Vector3d(1, 0, 2), CameraPreset::kFront, true, c, 2.0, 200, 100);
  EXPECT_NEAR(p.x(), 122.5, 1e-9);
  EXPECT_NEAR(to_y_up({0, 0, 1}, 2).y(), 1.0, 1e-15);
  EXPECT_NEAR(to_y_up({1, 0, 0}, 0).y(), 1.0, 1e-15);
  EXPECT_EQ(parse_camera_preset("iso"), CameraPreset::kIso);
  EXPECT_THROW(parse_camera_preset("fish-eye"), Error);
}

TEST(SceneTest, SideBySidePanelsHaveTheirColours) {
  const std::vector<RenderMotion> motions = {walk(0), walk(1, 2.0)};
  RenderOptions o;
  o.width = 400;
  o.height = 200;
  const Image image = render_frame(motions, 0.5, o);
  EXPECT_GT(count_color(image, motions[0].color, 0, 200), 100);
  EXPECT_EQ(count_color(image, motions[1].color, 0, 190), 0);
  EXPECT_GT(count_color(image, motions[1].color, 200, 400), 100);
  EXPECT_EQ(count_color(image, motions[0].color, 210, 400), 0);
  o.overlay = true;
  const Image both = render_frame(motions, 0.5, o);
  EXPECT_GT(count_color(both, motions[0].color), 50);
  EXPECT_GT(count_color(both, motions[1].color), 50);
  EXPECT_NEAR(longest_duration_s(motions), 44 / 30.0, 1e-12);
  EXPECT_THROW(render_frame({}, 0, o), Error);
}

TEST(ImageIoTest, PngRoundTrip) {
  Image image(7, 5, {10, 20, 30});
  image.set(3, 2, {255, 0, 128});
  const Image back = decode_png(encode_png(image));
  ASSERT_EQ(back.width(), 7);
  ASSERT_EQ(back.height(), 5);
  EXPECT_EQ(back.pixels(), image.pixels());
  EXPECT_THROW(decode_png("not a png"), Error);
}

TEST(ImageIoTest, GifPaletteAndFrames) {
  const auto palette = gif_palette();
  ASSERT_EQ(palette.size(), 256u);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(palette[gif_palette_index(motion_color(i))], motion_color(i));
  EXPECT_EQ(gif_palette_index({255, 255, 255}), 215);
  EXPECT_EQ(palette[gif_palette_index({129, 129, 129})], (Rgb{131, 131, 131}));  // nearest grey
  std::vector<Image> frames(3, Image(6, 4, kWhite));
  frames[0].set(1, 1, motion_color(0));
  const GifInfo info = decode_gif(encode_gif(frames, 4));
  EXPECT_EQ(info.num_frames, 3);
  EXPECT_EQ(info.width, 6);
  EXPECT_EQ(info.height, 4);
  EXPECT_EQ(info.first_frame.at(1, 1), motion_color(0));
  EXPECT_EQ(info.first_frame.at(0, 0), kWhite);
  EXPECT_THROW(encode_gif({Image(2, 2), Image(3, 2)}, 4), Error);
}

TEST(ImageIoTest, Mp4WithoutFfmpegSaysSo) {
  const std::string old_path = std::getenv("PATH") ? std::getenv("PATH") : "";
  ::setenv("PATH", "/nonexistent", 1);
  try {
    write_mp4("/tmp/never.mp4", {Image(4, 4)}, 30);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ffmpeg"), std::string::npos) << e.what();
  }
  ::setenv("PATH", old_path.c_str(), 1);
  EXPECT_EQ(find_on_path("definitely-not-a-program-mosyn"), "");
  EXPECT_NE(find_on_path("sh"), "");
}

TEST(ViewTest, PageInlinesScriptAndData) {
  RenderMotion m = walk(0);
  m.name = "</script><b>";
  const std::string json = viewer_data_json({m}, "t");
  EXPECT_NE(json.find("\"fps\":30"), std::string::npos);
  EXPECT_NE(json.find("\"color\":\"#cc0033\""), std::string::npos);
  if (!viewer_available()) {
    EXPECT_THROW(viewer_page({m}), Error);
    GTEST_SKIP() << "built without npm: no viewer script";
  }
  const std::string page = viewer_page({m}, "walk & run");
  EXPECT_NE(page.find("<title>walk &amp; run</title>"), std::string::npos);
  EXPECT_EQ(page.find("</script><b>"), std::string::npos);  // cannot close the data element
  EXPECT_NE(page.find("<\\/script><b>"), std::string::npos);
  EXPECT_NE(page.find("mosyn-data"), std::string::npos);
  EXPECT_EQ(page.find("<script src"), std::string::npos);  // nothing loaded from elsewhere
  EXPECT_EQ(page.find("import "), std::string::npos);
}

}  // namespace
}  // namespace mosyn::render

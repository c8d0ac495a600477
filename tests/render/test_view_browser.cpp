// Opens a page written by write_viewer_page in headless Chromium (Debian's chromium, software
// WebGL through SwiftShader) and checks from a screenshot that the skeletons are drawn while the
// animation plays. Skipped when chromium is not installed or mosyn was built without npm.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/synthetic.h"
#include "render/image_io.h"
#include "render/view.h"

namespace mosyn::render {
namespace {

namespace fs = std::filesystem;

// Pixels close to c (each channel within tol): skeleton bodies use unlit materials, so their
// interior keeps the exact colour; edges are anti-aliased.
int count_near(const Image& image, Rgb c, int tol) {
  int n = 0;
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x) {
      const Rgb p = image.at(x, y);
      n += std::abs(p.r - c.r) <= tol && std::abs(p.g - c.g) <= tol && std::abs(p.b - c.b) <= tol;
    }
  return n;
}

TEST(ViewBrowserTest, SkeletonsAreDrawnMidAnimation) {
  const std::string chromium = find_on_path("chromium");
  if (chromium.empty()) GTEST_SKIP() << "chromium is not installed (make deps installs it)";
  if (!viewer_available()) GTEST_SKIP() << "built without npm: no viewer";

  const fs::path dir = fs::temp_directory_path() / ("mosyn_view_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  Clip clip{make_synthetic_biped(), {}};
  std::vector<RenderMotion> motions;
  for (int i = 0; i < 2; ++i) {
    SyntheticWalkOptions o;
    o.start_heading_rad = 0.3 + 1.2 * i;
    o.turn_rate_rad_s = 0.3 * i;
    clip.motion = make_synthetic_walk(clip.skeleton, 120, 30.0, o);
    motions.push_back(render_motion_from_clip(clip, motion_color(i), 0.0, "walk " + std::to_string(i)));
  }
  const std::string page = (dir / "walk.html").string();
  write_viewer_page(page, motions, "browser test");

  const std::string shot = (dir / "shot.png").string();
  const std::string cmd = "'" + chromium +
                          "' --headless --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader --disable-gpu"
                          " --disable-background-networking --disable-component-update --disable-sync --no-first-run"
                          " --hide-scrollbars --user-data-dir='" +
                          (dir / "profile").string() + "' --screenshot='" + shot +
                          "' --window-size=800,600 --virtual-time-budget=3000 'file://" + page + "' >'" +
                          (dir / "chromium.log").string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(fs::exists(shot)) << "chromium wrote no screenshot (status " << status << "), see "
                                << (dir / "chromium.log").string();
  const Image image = read_png(shot);
  EXPECT_EQ(image.width(), 800);
  // Both skeletons visible in their own colours.
  const int first = count_near(image, motion_color(0), 12), second = count_near(image, motion_color(1), 12);
  EXPECT_GT(first, 150) << "screenshot " << shot;
  EXPECT_GT(second, 150) << "screenshot " << shot;
  // MOSYN_KEEP_TEST_FILES=1 keeps the page and screenshot to look at.
  if (!HasFailure() && !std::getenv("MOSYN_KEEP_TEST_FILES")) fs::remove_all(dir);
}

}  // namespace
}  // namespace mosyn::render

// `mosyn metrics`, `mosyn render` and `mosyn view` as a user runs them.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "core/synthetic.h"
#include "io/bvh.h"
#include "io/json_file.h"
#include "render/image_io.h"
#include "render/view.h"

namespace mosyn {
namespace {

using testing::fresh_dir;
using testing::run_mosyn;
using ::testing::HasSubstr;

std::string write_walk(const std::filesystem::path& dir, const std::string& name, double heading, int frames = 60) {
  Clip clip;
  clip.skeleton = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.start_heading_rad = heading;
  clip.motion = make_synthetic_walk(clip.skeleton, frames, 30.0, o);
  const std::string path = (dir / name).string();
  io::write_bvh(path, io::from_clip(clip));
  return path;
}

TEST(CliEvalTest, MetricsTableAndJson) {
  const auto dir = fresh_dir("metrics");
  const std::string a = write_walk(dir, "a.bvh", 0.0), b = write_walk(dir, "b.bvh", 1.0);
  const std::string ref = write_walk(dir, "ref.bvh", 0.5, 90);
  const std::string json = (dir / "m.json").string();
  const auto r = run_mosyn("metrics " + a + " " + b + " --reference " + ref + " --json " + json);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("| metric | files | reference |"));
  EXPECT_THAT(r.out, HasSubstr("| motions | 2 | 1 |"));
  EXPECT_THAT(r.out, HasSubstr("| frames | 120 | 90 |"));
  EXPECT_THAT(r.out, HasSubstr("APD diversity (m)"));
  EXPECT_THAT(r.out, HasSubstr("FSE"));
  const nlohmann::json j = io::read_json(json);
  EXPECT_EQ(j["metrics"]["motions"].get<double>(), 2);
  EXPECT_GT(j["metrics"]["apd_m"].get<double>(), 0);
  EXPECT_TRUE(j["reference_metrics"]["apd_m"].is_null());  // one reference motion
  EXPECT_EQ(j["footstep_curve"]["f_est"].size(), 100u);
  EXPECT_EQ(j["footstep_curve"]["reference_f_est"].size(), 100u);
  EXPECT_LT(j["metrics"]["bone_length_rmse_cm"].get<double>(), 1e-6);
  EXPECT_EQ(j["mean_pose_distance_curve"]["mean_m"].size(), 60u);
  EXPECT_TRUE(j["reference_mean_pose_distance_curve"].is_null());
}

TEST(CliEvalTest, MetricsErrors) {
  const auto dir = fresh_dir("metrics_errors");
  const std::string a = write_walk(dir, "a.bvh", 0.0);
  EXPECT_EQ(run_mosyn("metrics").exit_code, 2);
  EXPECT_EQ(run_mosyn("metrics " + a + " --v-tol-step 0").exit_code, 2);
  EXPECT_EQ(run_mosyn("metrics " + a + " --foot-joints Foot_L").exit_code, 2);
  const auto missing = run_mosyn("metrics /nonexistent/x.bvh");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("/nonexistent/x.bvh"));
  const auto bad_joint = run_mosyn("metrics " + a + " --foot-joints Foot_L,NoSuchJoint");
  EXPECT_EQ(bad_joint.exit_code, 1);
  EXPECT_THAT(bad_joint.err, HasSubstr("NoSuchJoint"));
  // Heels given explicitly work.
  EXPECT_EQ(run_mosyn("metrics " + a + " --foot-joints Foot_L,Foot_R").exit_code, 0);
}

TEST(CliEvalTest, RenderPngFilmstripAndGif) {
  const auto dir = fresh_dir("render");
  const std::string a = write_walk(dir, "a.bvh", 0.0), b = write_walk(dir, "b.bvh", 1.0);
  const std::string png = (dir / "frame.png").string();
  auto r = run_mosyn("render " + a + " " + b + " --out " + png + " --width 320 --height 200 --camera side");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const render::Image image = render::read_png(png);
  EXPECT_EQ(image.width(), 320);
  EXPECT_EQ(image.height(), 200);
  const std::string strip = (dir / "strip.png").string();
  r = run_mosyn("render " + a + " --out " + strip + " --width 100 --height 120 --filmstrip 4");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(render::read_png(strip).width(), 400);
  const std::string gif = (dir / "anim.gif").string();
  r = run_mosyn("render " + a + " --out " + gif + " --width 80 --height 60 --fps 10");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // 59 frames at 30 fps = 1.967 s; every 0.1 s: 20 frames.
  EXPECT_EQ(render::decode_gif(testing::slurp(gif)).num_frames, 20);
}

TEST(CliEvalTest, RenderErrors) {
  const auto dir = fresh_dir("render_errors");
  const std::string a = write_walk(dir, "a.bvh", 0.0);
  EXPECT_EQ(run_mosyn("render " + a + " --out x.jpg").exit_code, 2);
  EXPECT_EQ(run_mosyn("render " + a + " --out x.png --camera fisheye").exit_code, 2);
  EXPECT_EQ(run_mosyn("render " + a + " --out x.gif --frame 3").exit_code, 2);
  EXPECT_EQ(run_mosyn("render " + a + " --out x.png --frame 3 --filmstrip 2").exit_code, 2);
  EXPECT_EQ(run_mosyn("render " + a + " --out x.png --colors red").exit_code, 2);
  const std::string mp4 = (dir / "a.mp4").string();
  if (render::find_on_path("ffmpeg").empty()) {
    const auto r = run_mosyn("render " + a + " --out " + mp4);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.err, HasSubstr("ffmpeg"));
  } else {
    const auto r = run_mosyn("render " + a + " --out " + mp4 + " --width 64 --height 48");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(std::filesystem::exists(mp4));
  }
}

TEST(CliEvalTest, ViewWritesASelfContainedPage) {
  const auto dir = fresh_dir("view");
  const std::string a = write_walk(dir, "a.bvh", 0.0);
  const std::string page = (dir / "page.html").string();
  EXPECT_EQ(run_mosyn("view " + a + " --out page.txt").exit_code, 2);
  const auto r = run_mosyn("view " + a + " --out " + page + " --colors '#112233'");
  if (!render::viewer_available()) {
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.err, HasSubstr("npm"));
    return;
  }
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("file://"));
  const std::string html = testing::slurp(page);
  EXPECT_THAT(html, HasSubstr("\"color\":\"#112233\""));
  EXPECT_THAT(html, HasSubstr("<title>mosyn: a.bvh</title>"));
}

}  // namespace
}  // namespace mosyn

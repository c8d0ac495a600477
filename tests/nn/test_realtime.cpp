// Real-time generation with a model that reads the path ahead (the shipped real-time MoGlow): the
// Generator feeds it its controller's prediction, so frame t depends on the input up to t only;
// steered by a stick it goes where the stick says, and told to stand it stands over its root.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "data/control.h"
#include "nn/generator.h"
#include "nn/moglow/moglow.h"
#include "nn/moglow/moglow_stream.h"
#include "nn/run.h"
#include "nn/sampling.h"

using namespace mosyn;

namespace {

const std::string kModel = MOSYN_SOURCE_DIR "/models/moglow-realtime";

const nn::LoadedRun& shipped() {
  static const nn::LoadedRun run = nn::load_run(kModel, {"checkpoint.pt", "cpu", 1});
  return run;
}

// Walking forward at speed_mps, turning at turn_rad_s, for `frames` frames at fps.
std::vector<float> walk(int frames, double fps, double speed_mps, double turn_rad_s) {
  std::vector<float> c;
  for (int f = 0; f < frames; ++f) {
    const bool first = f == 0;  // row 0 is the delta into frame 0
    c.insert(c.end(), {0.0f, first ? 0.0f : float(speed_mps / fps), first ? 0.0f : float(turn_rad_s / fps)});
  }
  return c;
}

// Horizontal distance (metres) between character k's hips and its root after the last step.
double hips_from_root_m(const nn::Generator& g, int k) {
  const auto& sk = g.run().dataset.skeleton;
  const Eigen::Vector3d d = (g.joint_transforms(k).root_translation - g.root(k).position) * sk.meters_per_unit;
  return std::hypot(d.x(), d.z());
}

TEST(Realtime, TheModelReadsAPathAheadAndStillStreams) {
  ASSERT_GT(shipped().traits.control_ahead_frames, 0);
  EXPECT_TRUE(shipped().traits.streaming);
}

TEST(Realtime, FramesDependOnTheControlUpToThemOnly) {
  const auto& run = shipped();
  const double fps = run.dataset.fps;
  const int frames = 80, t = 40;
  auto a = walk(frames, fps, 1.3, 0.0);
  auto b = a;
  for (int f = t + 1; f < frames; ++f) {  // after frame t: slower and turning
    b[f * 3 + 1] = float(0.6 / fps);
    b[f * 3 + 2] = float(0.8 / fps);
  }
  nn::SampleExtras extras;
  extras.warmup_frames = 10;
  const auto ma = nn::stream_motions(run, a, 2, 7, 1.0, extras);
  const auto mb = nn::stream_motions(run, b, 2, 7, 1.0, extras);
  const size_t d = static_cast<size_t>(run.context.pose_dim);
  for (int k = 0; k < 2; ++k) {
    for (size_t i = 0; i < (t + 1) * d; ++i) ASSERT_EQ(ma[k].pose[i], mb[k].pose[i]) << "frame " << i / d;
    double after = 0;
    for (size_t i = (t + 1) * d; i < frames * d; ++i) after = std::max(after, double(std::abs(ma[k].pose[i] - mb[k].pose[i])));
    EXPECT_GT(after, 1e-3);  // and the later input does change the later frames
  }
  // The offline sampler of the same model reads the real path ahead: there frame t does change.
  const auto offline_a = nn::sample_motions(run, a, 1, 7, 1.0, extras);
  const auto offline_b = nn::sample_motions(run, b, 1, 7, 1.0, extras);
  double before = 0;
  for (size_t i = 0; i < (t + 1) * d; ++i)
    before = std::max(before, double(std::abs(offline_a[0].pose[i] - offline_b[0].pose[i])));
  EXPECT_GT(before, 1e-3);
}

TEST(Realtime, SameSeedRepeatsOtherSeedsDiffer) {
  const auto& run = shipped();
  const auto c = walk(40, run.dataset.fps, 1.2, 0.2);
  nn::SampleExtras extras;
  extras.warmup_frames = 5;
  const auto one = nn::stream_motions(run, c, 2, 3, 1.0, extras);
  const auto again = nn::stream_motions(run, c, 2, 3, 1.0, extras);
  const auto other = nn::stream_motions(run, c, 2, 4, 1.0, extras);
  EXPECT_EQ(one[0], again[0]);
  EXPECT_EQ(one[1], again[1]);
  EXPECT_NE(one[0].pose, other[0].pose);
  EXPECT_NE(one[0].pose, one[1].pose);
}

TEST(Realtime, AStickSteersTheRootAndTheBodyFollows) {
  nn::GeneratorOptions o;
  o.batch = 1;
  o.seed = 5;
  o.warmup_frames = 20;
  nn::Generator g(shipped(), o);
  const double fps = g.run().dataset.fps, mpu = g.run().dataset.skeleton.meters_per_unit;
  // Walk towards +x at 1.3 m/s facing +x for 8 s.
  for (int f = 0; f < static_cast<int>(8 * fps); ++f) g.step_stick({1.3f, 0.0f, float(M_PI / 2)});
  const Eigen::Vector3d at_m = g.root(0).position * mpu;
  EXPECT_GT(at_m.x(), 6.0);
  EXPECT_LT(std::abs(at_m.z()), 0.5);
  EXPECT_NEAR(std::remainder(g.root(0).heading_rad - M_PI / 2, 2 * M_PI), 0.0, 0.05);
  EXPECT_LT(hips_from_root_m(g, 0), 0.4);
  // Bad input: wrong size, NaN.
  EXPECT_THROW(g.step_stick({1.0f, 0.0f}), Error);
  EXPECT_THROW(g.step_stick({NAN, 0.0f, 0.0f}), Error);
}

TEST(Realtime, FollowsADrawnPath) {
  const auto& run = shipped();
  data::PathOptions po;
  po.speed_mps = 1.2;
  po.fps = run.dataset.fps;
  po.seconds = 13;  // the path takes about 10 s; the springs settle after it
  const auto control = data::control_from_path(data::parse_path("0,0 2,2 0,4 2,6 0,8"), po);
  const auto drawn = data::integrate_control(control);  // the path in the frame samples start in
  const auto motions = nn::stream_motions(run, control, 2, 9, 1.0, {});
  const double mpu = run.dataset.skeleton.meters_per_unit;
  for (const auto& m : motions) {
    const Clip clip = nn::decode_motion(run, m);
    double worst = 0;
    for (int f = 0; f < clip.motion.num_frames; ++f) {
      const Eigen::Vector3d hips = clip.motion.translation(f, 0) * mpu;
      double nearest = 1e9;
      for (const auto& p : drawn) nearest = std::min(nearest, std::hypot(hips.x() - p.x(), hips.z() - p.z()));
      worst = std::max(worst, nearest);
    }
    EXPECT_LT(worst, 0.5);
    const Eigen::Vector3d end = clip.motion.translation(clip.motion.num_frames - 1, 0) * mpu;
    EXPECT_LT(std::hypot(end.x() - drawn.back().x(), end.z() - drawn.back().z()), 0.5);
  }
}

TEST(Realtime, StreamsShareOneLoadedModel) {
  auto* moglow = dynamic_cast<nn::MoGlowImpl*>(shipped().model.get());
  ASSERT_NE(moglow, nullptr);
  nn::GeneratorOptions o;
  o.batch = 2;
  nn::Generator a(shipped(), o), b(shipped(), o);
  EXPECT_EQ(a.run().model.get(), b.run().model.get());
  // The weights rearranged for inference exist once: the model's cache and both streams hold them.
  const auto net = moglow->inference();
  EXPECT_EQ(net.get(), moglow->inference().get());
  EXPECT_GE(net.use_count(), 4);
}

TEST(Realtime, StandingStillStaysOverTheRoot) {
  nn::GeneratorOptions o;
  o.batch = 4;
  o.seed = 11;
  o.warmup_frames = static_cast<int>(shipped().traits.default_warmup_s * shipped().dataset.fps);  // as the C ABI's default
  nn::Generator g(shipped(), o);
  const int frames = static_cast<int>(10 * g.run().dataset.fps);
  double worst = 0;
  for (int f = 0; f < frames; ++f) {
    g.step_stick(std::vector<float>(12, 0.0f));
    for (int k = 0; k < 4; ++k) worst = std::max(worst, hips_from_root_m(g, k));
  }
  EXPECT_LT(worst, 0.25);
  for (int k = 0; k < 4; ++k) EXPECT_LT(g.root(k).position.norm() * g.run().dataset.skeleton.meters_per_unit, 1e-9);
}

}  // namespace

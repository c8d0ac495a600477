// The planted-heel term (nn/objectives/foot_terms.h) by hand: a heel that moves 1 cm a frame at 30 fps
// where the data's heel is planted glides at 0.3 m/s; the valid mask and the planted mask choose
// which steps count.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "nn/objectives/foot_terms.h"
#include "nn_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;

namespace {

// The pose of `still` [1, T, D] with the left heel moved sideways (x) by metres_per_frame a frame
// over the second half: at 30 fps 0.01 m a frame is 0.3 m/s on the steps into frames T/2..T-1.
torch::Tensor left_heel_moving(const Batch& still, const Skeleton& s, double metres_per_frame) {
  const int64_t frames = still.pose.size(1), left_x = 3 * s.find("Foot_L");
  auto pose = still.pose.clone();
  for (int64_t t = frames / 2; t < frames; ++t) pose[0][t][left_x] += metres_per_frame * (t - frames / 2 + 1);
  return pose;
}

}  // namespace

TEST(FootTerms, MeanSpeedOfMadeHeelsWhereDataHeelsArePlanted) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const int frames = 20;
  const Batch real = nn::testing::standing_batch(s, ctx, frames);  // both heels planted throughout
  const FootTerms term(ctx, "test");
  ASSERT_EQ(term.heels().size(), 2u);
  const int64_t left_x = 3 * s.find("Foot_L");  // sideways (x) feature of the left ankle
  // The left heel slides 1 cm sideways per frame over the second half; the right stays put.
  const auto made = left_heel_moving(real, s, 0.01);
  // Steps into frames 10..19 (indices 9..18 of 19): the left heel at 0.3 m/s, over 19 x 2 planted.
  const double expected = 10 * 0.3 / (19 * 2);
  EXPECT_NEAR(term.mean_planted_speed(made, real.pose, real.control).item<double>(), expected, 1e-4);
  EXPECT_NEAR(term.mean_planted_speed(real.pose, real.pose, real.control).item<double>(), 0.0, 1e-4);  // 30 fps x the 1e-6 m floor of the speed
  // Only the steps into the first half count: none moves.
  auto first_half = torch::zeros({1, frames - 1});
  first_half.narrow(1, 0, frames / 2 - 1).fill_(1.0);
  EXPECT_NEAR(term.mean_planted_speed(made, real.pose, real.control, first_half).item<double>(), 0.0, 1e-4);  // 30 fps x the 1e-6 m floor of the speed
  // When the data's own heels move (the made pose taken as data), the moving steps are not
  // planted: only the still heel and the first half count, all at 0 m/s.
  EXPECT_NEAR(term.mean_planted_speed(made, made, real.control).item<double>(), 0.0, 1e-4);  // 30 fps x the 1e-6 m floor of the speed
  // Differentiable in the made pose: the gradient reaches exactly the moved heel's features.
  auto made_var = made.clone().requires_grad_(true);
  term.mean_planted_speed(made_var, real.pose, real.control).backward();
  EXPECT_GT(made_var.grad()[0][frames - 1][left_x].abs().item<double>(), 0.0);
  EXPECT_EQ(made_var.grad()[0][0][left_x].item<double>(), 0.0);
  EXPECT_THROW(FootTerms(nn::testing::small_context(), "test"), Error);
  EXPECT_THROW(FootTerms().mean_planted_speed(made, real.pose, real.control), Error);
}

// The heel-speed error (mean_speed_error) by hand: |made - real| speed over every (heel, step),
// so, unlike the planted term, a made heel that stays put while the data's heel moves costs as
// much as the reverse.
TEST(FootTerms, MeanSpeedErrorChargesGlideAndLingerAlike) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const int frames = 20;
  const Batch still = nn::testing::standing_batch(s, ctx, frames);
  const FootTerms term(ctx, "test");
  const int64_t left_x = 3 * s.find("Foot_L");
  const auto moving = left_heel_moving(still, s, 0.01);  // the left heel at 0.3 m/s over the steps into frames 10..19
  const double expected = 10 * 0.3 / (19 * 2);
  EXPECT_NEAR(term.mean_speed_error(moving, still.pose, still.control).item<double>(), expected, 1e-4);
  // The made heel lingers where the data's swings: the planted term sees nothing, this does.
  EXPECT_NEAR(term.mean_speed_error(still.pose, moving, still.control).item<double>(), expected, 1e-4);
  EXPECT_NEAR(term.mean_planted_speed(still.pose, moving, still.control).item<double>(), 0.0, 1e-4);
  EXPECT_NEAR(term.mean_speed_error(moving, moving, still.control).item<double>(), 0.0, 1e-4);
  // The valid mask: only the steps into the first half count, where both stand.
  auto first_half = torch::zeros({1, frames - 1});
  first_half.narrow(1, 0, frames / 2 - 1).fill_(1.0);
  EXPECT_NEAR(term.mean_speed_error(still.pose, moving, still.control, first_half).item<double>(), 0.0, 1e-4);
  // A heel at half the data's speed: half the error, and the gradient speeds it up.
  const auto slow = left_heel_moving(still, s, 0.005);
  EXPECT_NEAR(term.mean_speed_error(slow, moving, still.control).item<double>(), expected / 2, 1e-4);
  auto made_var = slow.clone().requires_grad_(true);
  term.mean_speed_error(made_var, moving, still.control).backward();
  EXPECT_TRUE(torch::isfinite(made_var.grad()).all().item<bool>());
  EXPECT_LT(made_var.grad()[0][frames - 1][left_x].item<double>(), 0.0);  // further along: faster
}

// The lingering-heel term (mean_lingering_speed) by hand: where the data's heel has lifted (0.3
// m/s), a made heel that stays put costs the planted threshold, 0.15 m/s; one at 0.06 m/s costs
// 0.09; one as fast as the threshold or the data's costs nothing, nor does anything where the
// data's heel is planted.
TEST(FootTerms, MeanLingeringSpeedChargesAHeelStillWhereTheDataLifts) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const int frames = 20;
  const Batch still = nn::testing::standing_batch(s, ctx, frames);
  const FootTerms term(ctx, "test");
  const int64_t left_x = 3 * s.find("Foot_L");
  const auto lifted = left_heel_moving(still, s, 0.01);  // 0.3 m/s at 30 fps
  const double threshold = kDefaultPlantedMps;
  EXPECT_NEAR(term.mean_lingering_speed(still.pose, lifted, still.control).item<double>(), threshold, 1e-4);
  EXPECT_NEAR(term.mean_lingering_speed(left_heel_moving(still, s, 0.002), lifted, still.control).item<double>(), threshold - 0.06, 1e-4);
  EXPECT_NEAR(term.mean_lingering_speed(left_heel_moving(still, s, 0.005), lifted, still.control).item<double>(), 0.0, 1e-4);
  EXPECT_NEAR(term.mean_lingering_speed(lifted, lifted, still.control).item<double>(), 0.0, 1e-4);
  // Nothing lifted: 0, however the made heel moves (that is the planted term's part).
  EXPECT_NEAR(term.mean_lingering_speed(lifted, still.pose, still.control).item<double>(), 0.0, 1e-6);
  // The valid mask: only the steps into the first half count, where nothing has lifted.
  auto first_half = torch::zeros({1, frames - 1});
  first_half.narrow(1, 0, frames / 2 - 1).fill_(1.0);
  EXPECT_NEAR(term.mean_lingering_speed(still.pose, lifted, still.control, first_half).item<double>(), 0.0, 1e-6);
  // The speeds computed once give every term the same value as computing them per term.
  const auto slow = left_heel_moving(still, s, 0.002);
  const FootTerms::HeelSpeeds speeds = term.speeds(slow, lifted, still.control);
  EXPECT_EQ(term.mean_lingering_speed(speeds).item<double>(),
            term.mean_lingering_speed(slow, lifted, still.control).item<double>());
  EXPECT_EQ(term.mean_speed_error(speeds, first_half).item<double>(),
            term.mean_speed_error(slow, lifted, still.control, first_half).item<double>());
  EXPECT_EQ(term.mean_planted_speed(speeds).item<double>(), term.mean_planted_speed(slow, lifted, still.control).item<double>());
  // The gradient speeds a lingering heel up.
  auto made_var = slow.clone().requires_grad_(true);
  term.mean_lingering_speed(made_var, lifted, still.control).backward();
  EXPECT_TRUE(torch::isfinite(made_var.grad()).all().item<bool>());
  EXPECT_LT(made_var.grad()[0][frames - 1][left_x].item<double>(), 0.0);
}

// The pelvis term (mean_pelvis_offset_m) by hand: a made pelvis 3 cm sideways and 4 cm back of the
// data's over the second half of the frames is 5 cm off there and 0 before; height is ignored.
TEST(FootTerms, MeanPelvisOffsetIsTheHorizontalDistanceToTheData) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const int frames = 20;
  const Batch still = nn::testing::standing_batch(s, ctx, frames);
  const FootTerms term(ctx, "test");
  ASSERT_EQ(s.parents[0], -1);  // the pelvis: joint 0, features 0..2 (x, y up, z)
  auto behind = still.pose.clone();
  for (int64_t t = frames / 2; t < frames; ++t) {
    behind[0][t][0] += 0.03;
    behind[0][t][1] += 0.5;  // a bob is not a drift
    behind[0][t][2] -= 0.04;
  }
  EXPECT_NEAR(term.mean_pelvis_offset_m(behind, still.pose).item<double>(), 0.05 * (frames / 2) / frames, 1e-5);
  EXPECT_NEAR(term.mean_pelvis_offset_m(still.pose, behind).item<double>(), 0.025, 1e-5);  // symmetric
  EXPECT_NEAR(term.mean_pelvis_offset_m(still.pose, still.pose).item<double>(), 0.0, 1e-5);
  auto second_half = torch::zeros({1, frames});
  second_half.narrow(1, frames / 2, frames / 2).fill_(1.0);
  EXPECT_NEAR(term.mean_pelvis_offset_m(behind, still.pose, second_half).item<double>(), 0.05, 1e-5);
  // The gradient pulls the made pelvis back onto the data's, and touches nothing else.
  auto made_var = behind.clone().requires_grad_(true);
  term.mean_pelvis_offset_m(made_var, still.pose).backward();
  const auto g = made_var.grad()[0][frames - 1];
  EXPECT_GT(g[0].item<double>(), 0.0);
  EXPECT_LT(g[2].item<double>(), 0.0);
  EXPECT_EQ(g[1].item<double>(), 0.0);
  EXPECT_EQ(made_var.grad().abs().sum().item<double>(), made_var.grad().narrow(2, 0, 3).abs().sum().item<double>());
  EXPECT_TRUE(torch::isfinite(made_var.grad()).all().item<bool>());  // also where the offset is 0
}

namespace {

// The pose of `still` [1, T, D] with both heels moving back (−z, in the root's heading frame) by
// metres_per_frame a frame, and the control of a root stepping forward root_step_m a frame: in
// the world the heels move forward at (root_step_m − metres_per_frame) x 30 m/s.
Batch heels_behind_a_moving_root(const Batch& still, const Skeleton& s, double root_step_m, double metres_per_frame) {
  Batch b{still.pose.clone(), still.control.clone(), {}, {}};
  b.control.select(2, 1).fill_(root_step_m);
  for (const char* heel : {"Foot_L", "Foot_R"}) {
    const int64_t z = 3 * s.find(heel) + 2;
    for (int64_t t = 0; t < b.pose.size(1); ++t) b.pose[0][t][z] -= metres_per_frame * t;
  }
  return b;
}

}  // namespace

// planted_speed_fraction by hand: behind a root at 3 m/s (0.1 m a frame at 30 fps) a heel at
// 0.2 m/s is planted under max(0.15, 0.1 x 3) = 0.3 m/s, not under the fixed 0.15; behind a
// root at 1.2 m/s the threshold stays 0.15. The lingering term uses the same threshold.
TEST(FootTerms, PlantedThresholdRisesWithTheRootSpeed) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const Batch still = nn::testing::standing_batch(s, ctx, 12);
  FootTermOptions scaled_options;
  scaled_options.planted_speed_fraction = 0.1;
  const FootTerms fixed(ctx, "test"), scaled(ctx, "test", scaled_options);
  const Batch running = heels_behind_a_moving_root(still, s, 0.1, 0.1 - 0.2 / 30);  // heels at 0.2 m/s
  const auto speeds = scaled.speeds(running.pose, running.pose, running.control);
  ASSERT_TRUE(speeds.planted_below_mps.defined());
  EXPECT_NEAR(speeds.planted_below_mps.min().item<double>(), 0.3, 1e-5);
  EXPECT_NEAR(speeds.real_mps.mean().item<double>(), 0.2, 1e-4);
  EXPECT_EQ(fixed.speeds(running.pose, running.pose, running.control).planted_below_mps.dim(), 0);
  EXPECT_NEAR(scaled.mean_planted_speed(running.pose, running.pose, running.control).item<double>(), 0.2, 1e-4);
  EXPECT_NEAR(fixed.mean_planted_speed(running.pose, running.pose, running.control).item<double>(), 0.0, 1e-6);
  // Behind a walking root the threshold is the fixed one: the same 0.2-m/s heel is not planted.
  const Batch walking = heels_behind_a_moving_root(still, s, 0.04, 0.04 - 0.2 / 30);
  EXPECT_NEAR(scaled.mean_planted_speed(walking.pose, walking.pose, walking.control).item<double>(), 0.0, 1e-6);
  // A heel planted in the world (moving back at the root's step) where the data's runs at 0.5 m/s,
  // lifted under either threshold: it lingers 0.3 below the scaled one, 0.15 below the fixed.
  const Batch lifted = heels_behind_a_moving_root(still, s, 0.1, 0.1 - 0.5 / 30);
  const Batch planted = heels_behind_a_moving_root(still, s, 0.1, 0.1);
  EXPECT_NEAR(scaled.mean_lingering_speed(planted.pose, lifted.pose, lifted.control).item<double>(), 0.3, 1e-4);
  EXPECT_NEAR(fixed.mean_lingering_speed(planted.pose, lifted.pose, lifted.control).item<double>(), 0.15, 1e-4);
  FootTermOptions negative;
  negative.planted_speed_fraction = -0.1;
  EXPECT_THROW(FootTerms(ctx, "test", negative), Error);
}

// planted_mps by hand: behind a root at 1.2 m/s a data heel rolling at 0.1 m/s is planted under the
// default 0.15 m/s and lifted under 0.08, so a made heel sliding at 0.3 m/s there costs the planted
// term 0.3 or nothing, and a made heel standing still costs the lingering term nothing or 0.08.
// The speed-scaled threshold floors at planted_mps.
TEST(FootTerms, PlantedThresholdIsAnOption) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const Batch still = nn::testing::standing_batch(s, ctx, 12);
  FootTermOptions low;
  low.planted_mps = 0.08;
  const FootTerms fixed(ctx, "test"), lowered(ctx, "test", low);
  const Batch rolling = heels_behind_a_moving_root(still, s, 0.04, 0.04 - 0.1 / 30);
  const Batch sliding = heels_behind_a_moving_root(still, s, 0.04, 0.04 - 0.3 / 30);
  const Batch standing = heels_behind_a_moving_root(still, s, 0.04, 0.04);
  const auto& control = rolling.control;
  EXPECT_NEAR(lowered.speeds(sliding.pose, rolling.pose, control).planted_below_mps.item<double>(), 0.08, 1e-6);  // float32
  EXPECT_NEAR(fixed.mean_planted_speed(sliding.pose, rolling.pose, control).item<double>(), 0.3, 1e-4);
  EXPECT_NEAR(lowered.mean_planted_speed(sliding.pose, rolling.pose, control).item<double>(), 0.0, 1e-6);
  EXPECT_NEAR(fixed.mean_lingering_speed(standing.pose, rolling.pose, control).item<double>(), 0.0, 1e-6);
  EXPECT_NEAR(lowered.mean_lingering_speed(standing.pose, rolling.pose, control).item<double>(), 0.08, 1e-4);
  // The stance term: a made heel whose slowest step is 0.1 m/s misses the lowered bar by 0.02 where
  // the data's heel stands, and meets the default one.
  const auto stance = [&](const FootTerms& term) {
    return term.mean_missed_stance(term.speeds(rolling.pose, standing.pose, control), 5).item<double>();
  };
  EXPECT_NEAR(stance(fixed), 0.0, 1e-6);
  EXPECT_NEAR(stance(lowered), 0.02, 1e-4);
  FootTermOptions scaled = low;
  scaled.planted_speed_fraction = 0.01;  // 0.012 m/s at 1.2 m/s: under the floor
  const FootTerms floored(ctx, "test", scaled);
  EXPECT_NEAR(floored.speeds(sliding.pose, rolling.pose, control).planted_below_mps.max().item<double>(), 0.08, 1e-6);
  for (double bad : {0.0, -0.1, 1.5, std::nan("")}) {
    FootTermOptions o;
    o.planted_mps = bad;
    EXPECT_THROW(FootTerms(ctx, "test", o), Error);
  }
}

// The phase-free stance term by hand over runs of 3 steps (four runs in six steps). Heel 0's data
// plant at step 1 only, so only the runs 0-2 and 1-3 count: the made heel's slowest step in the
// first is 0.9 m/s (0.75 above 0.15), and in the second it stops at step 3, two steps after the
// data's, which costs nothing. Heel 1's data stay planted: the made heel's slowest steps are 0.5,
// 0.6, 0.7 and 0.8 m/s. The gradient reaches each counted run's slowest step only.
TEST(FootTerms, MissedStanceChargesAHeelThatNeverStopsInARun) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const FootTerms term(ctx, "test");
  const auto opts = torch::dtype(torch::kFloat64);
  auto made = torch::tensor({1.0, 0.9, 1.1, 0.1, 1.0, 1.0, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0}, opts)
                  .reshape({1, 2, 6}).transpose(1, 2).contiguous().requires_grad_(true);  // [1, 6, 2]
  const auto real = torch::tensor({1.0, 0.05, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, opts)
                        .reshape({1, 2, 6}).transpose(1, 2).contiguous();
  const FootTerms::HeelSpeeds speeds{made, real, {}};
  const auto missed = term.mean_missed_stance(speeds, 3);
  EXPECT_NEAR(missed.item<double>(), (0.75 + 0.35 + 0.45 + 0.55 + 0.65) / 6, 1e-12);
  missed.backward();
  const auto grad = made.grad();
  EXPECT_NEAR(grad[0][1][0].item<double>(), 1.0 / 6, 1e-12);
  EXPECT_NEAR(grad[0][3][0].item<double>(), 0.0, 1e-12);  // stopped: relu's flat side
  for (int t = 0; t < 4; ++t) EXPECT_NEAR(grad[0][t][1].item<double>(), 1.0 / 6, 1e-12);
  for (int t = 4; t < 6; ++t) EXPECT_NEAR(grad[0][t][1].item<double>(), 0.0, 1e-12);
  // Step 5 padded: the run 3-5 leaves (only heel 1's counted).
  const auto valid = torch::tensor({1.0, 1.0, 1.0, 1.0, 1.0, 0.0}, opts).reshape({1, 6});
  EXPECT_NEAR(term.mean_missed_stance(speeds, 3, valid).item<double>(), (0.75 + 0.35 + 0.45 + 0.55) / 5, 1e-12);
  // A speed-scaled threshold of 0.5 m/s: heel 0's first run 0.4 above, heel 1's 0, 0.1, 0.2, 0.3.
  const FootTerms::HeelSpeeds scaled{made, real, torch::full({1, 6, 1}, 0.5, opts)};
  EXPECT_NEAR(term.mean_missed_stance(scaled, 3).item<double>(), (0.4 + 0.1 + 0.2 + 0.3) / 6, 1e-12);
  // Fewer steps than a run: nothing counts. A run of no steps is an error.
  EXPECT_NEAR(term.mean_missed_stance(speeds, 7).item<double>(), 0.0, 1e-12);
  EXPECT_THROW(term.mean_missed_stance(speeds, 0), Error);
  // Relative to the data: each counted run's bar is the real heel's slowest step there. Heel 0's
  // stop at 0.1 m/s, free under the 0.15 threshold, now pays 0.05 over the data's 0.05; its first
  // run 0.85; heel 1's data stand at 0, so its runs pay their whole slowest speed.
  EXPECT_NEAR(term.mean_missed_stance(speeds, 3, {}, /*relative_to_data=*/true).item<double>(),
              (0.85 + 0.05 + 0.5 + 0.6 + 0.7 + 0.8) / 6, 1e-12);
}

// The slow-share term against a brute-force loop: over runs of 3 steps in which the real heel
// plants, per level L of 0.15 / 0.3 / 0.6 m/s, max(0, the made heel's soft share of steps slower
// than L (sigmoid((L - v) / 0.2 L)) minus the real heel's hard share), summed over levels, averaged
// over counted runs. Heel 0 stands for three steps where the data's plants for one (charged), heel
// 1 creeps at 0.2 m/s where the data's stands (its share is below the data's: free).
TEST(FootTerms, SlowShareChargesAHeelSlowLongerThanTheData) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const FootTerms term(ctx, "test");
  const auto opts = torch::dtype(torch::kFloat64);
  const std::vector<std::vector<double>> made_v = {{0.0, 0.0, 0.0, 1.0, 1.0, 1.0}, {0.2, 0.2, 0.2, 0.2, 0.2, 0.2}};
  const std::vector<std::vector<double>> real_v = {{1.0, 0.05, 1.0, 1.0, 1.0, 1.0}, {0.0, 0.0, 0.0, 0.0, 0.0, 0.0}};
  const auto as_tensor = [&](const std::vector<std::vector<double>>& v) {
    std::vector<double> flat;
    for (const auto& heel : v) flat.insert(flat.end(), heel.begin(), heel.end());
    return torch::tensor(flat, opts).reshape({1, 2, 6}).transpose(1, 2).contiguous();  // [1, 6, 2]
  };
  auto made = as_tensor(made_v).requires_grad_(true);
  const FootTerms::HeelSpeeds speeds{made, as_tensor(real_v), {}, {}};
  const int window = 3;
  double sum = 0;
  int counted = 0;
  for (int k = 0; k < 2; ++k)
    for (int r = 0; r + window <= 6; ++r) {
      bool plants = false;
      for (int t = r; t < r + window; ++t) plants = plants || real_v[k][t] < 0.15;
      if (!plants) continue;
      ++counted;
      for (double level : {0.15, 0.3, 0.6}) {
        double made_share = 0, real_share = 0;
        for (int t = r; t < r + window; ++t) {
          made_share += 1.0 / (1.0 + std::exp(-(level - made_v[k][t]) / (0.2 * level))) / window;
          real_share += (real_v[k][t] < level ? 1.0 : 0.0) / window;
        }
        sum += std::max(0.0, made_share - real_share);
      }
    }
  ASSERT_EQ(counted, 2 + 4);
  const auto share = term.mean_excess_slow_share(speeds, window);
  EXPECT_NEAR(share.item<double>(), sum / counted, 1e-12);
  EXPECT_GT(share.item<double>(), 0.4);  // heel 0: three slow steps of three where the data has one
  share.backward();
  EXPECT_LT(made.grad()[0][0][0].item<double>(), 0.0);  // the cure is a faster heel
  for (int t = 0; t < 6; ++t) EXPECT_EQ(made.grad()[0][t][1].item<double>(), 0.0);  // heel 1 is free
  EXPECT_NEAR(term.mean_excess_slow_share(speeds, 7).item<double>(), 0.0, 1e-12);
  EXPECT_THROW(term.mean_excess_slow_share(speeds, 0), Error);
}

// The speed-distribution term by hand: each heel's steps clamped at the cap and sorted, the made
// and the real compared pair by pair. A made heel slow for the data's number of steps at another
// phase costs nothing; one slow for longer costs the difference; left-out steps drop out of both.
TEST(FootTerms, SortedSpeedErrorComparesTheHeelsSpeedDistributions) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const FootTerms term(ctx, "test");
  const auto opts = torch::dtype(torch::kFloat64);
  const auto as_tensor = [&](const std::vector<std::vector<double>>& v) {  // heels x steps -> [1, 6, 2]
    std::vector<double> flat;
    for (const auto& heel : v) flat.insert(flat.end(), heel.begin(), heel.end());
    return torch::tensor(flat, opts).reshape({1, 2, 6}).transpose(1, 2).contiguous();
  };
  const std::vector<std::vector<double>> real_v = {{2.0, 0.05, 0.05, 2.0, 2.0, 2.0}, {0.3, 0.1, 2.0, 2.0, 2.0, 0.4}};
  // Heel 0: the data's two slow steps two steps later (no cost); heel 1: slow for four steps.
  const std::vector<std::vector<double>> made_v = {{1.5, 3.0, 2.0, 0.05, 0.05, 0.9}, {0.0, 0.1, 0.2, 0.2, 2.0, 2.0}};
  auto made = as_tensor(made_v).requires_grad_(true);
  const FootTerms::HeelSpeeds speeds{made, as_tensor(real_v), {}, {}};
  const double cap = 0.6;
  // By hand, heel 1 sorted and clamped: made 0, 0.1, 0.2, 0.2, 0.6, 0.6; real 0.1, 0.3, 0.4, 0.6, 0.6, 0.6.
  const double heel1 = (0.1 + 0.2 + 0.2 + 0.4 + 0 + 0) / 6;
  const auto error = term.mean_sorted_speed_error(speeds, {}, cap);
  EXPECT_NEAR(error.item<double>(), (0.0 + heel1) / 2, 1e-12);
  error.backward();
  for (int t = 0; t < 6; ++t) EXPECT_EQ(made.grad()[0][t][0].item<double>(), 0.0);  // heel 0 is free
  for (int t = 0; t < 4; ++t) EXPECT_LT(made.grad()[0][t][1].item<double>(), 0.0);  // heel 1's slow steps: faster
  EXPECT_EQ(made.grad()[0][4][1].item<double>(), 0.0);     // above the cap: the swing is free
  // Leaving out steps 4-5 compares the first four of each heel: heel 0 made 1.5, 3, 2, 0.05 -> 0.05,
  // 0.6, 0.6, 0.6 against 0.05, 0.05, 0.6, 0.6; heel 1 made 0, 0.1, 0.2, 0.2 against 0.1, 0.3, 0.6, 0.6.
  const auto valid = torch::tensor({1.0, 1.0, 1.0, 1.0, 0.0, 0.0}, opts).unsqueeze(0);
  const double heel0_valid = 0.55 / 4, heel1_valid = (0.1 + 0.2 + 0.4 + 0.4) / 4;
  EXPECT_NEAR(term.mean_sorted_speed_error(speeds, valid, cap).item<double>(), (heel0_valid + heel1_valid) / 2, 1e-12);
  EXPECT_NEAR(term.mean_sorted_speed_error(speeds, torch::zeros_like(valid), cap).item<double>(), 0.0, 1e-12);
  EXPECT_THROW(term.mean_sorted_speed_error(speeds, {}, 0.0), Error);
  EXPECT_THROW(term.mean_sorted_speed_error(speeds, {}, cap, 0.5), Error);  // no root speeds
  // A speed-scaled cap: the root at 2 m/s, f = 0.5 -> cap 1 m/s. Heel 0 sorted: made 0.05, 0.05,
  // 0.9, 1, 1, 1 against 0.05, 0.05, 1, 1, 1, 1; heel 1: made 0, 0.1, 0.2, 0.2, 1, 1 against 0.1,
  // 0.3, 0.4, 1, 1, 1. With f = 0.1 the fixed cap (0.6) is the larger.
  const FootTerms::HeelSpeeds at_speed{made, as_tensor(real_v), {}, torch::full({1, 6, 1}, 2.0, opts)};
  EXPECT_NEAR(term.mean_sorted_speed_error(at_speed, {}, cap, 0.5).item<double>(), (0.1 / 6 + 1.3 / 6) / 2, 1e-12);
  EXPECT_NEAR(term.mean_sorted_speed_error(at_speed, {}, cap, 0.1).item<double>(), (0.0 + heel1) / 2, 1e-12);
  EXPECT_THROW(term.mean_sorted_speed_error(at_speed, {}, cap, -0.1), Error);
}

// with_toes: the terms read each ankle's first child (the toes) beside the heels, so a toe that
// slides where the data's stands costs as a heel does, averaged over four joints instead of two.
TEST(FootTerms, WithToesReadsEachAnklesChild) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const int frames = 20;
  const Batch real = nn::testing::standing_batch(s, ctx, frames);
  FootTermOptions toes;
  toes.with_toes = true;
  const FootTerms heels(ctx, "test"), both(ctx, "test", toes);
  ASSERT_EQ(both.heels().size(), 4u);
  const auto& joints = both.body().point_joints();  // the skeleton joint of each point
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(both.heels()[k], heels.heels()[k]);
    EXPECT_EQ(joints[both.heels()[2 + k]], s.children(joints[heels.heels()[k]]).front());
  }
  EXPECT_EQ(s.joint_names[joints[both.heels()[2]]].rfind("Toes", 0), 0u);
  auto made = left_heel_moving(real, s, 0.01);  // the left heel at 0.3 m/s over the second half
  EXPECT_EQ(both.speeds(made, real.pose, real.control).made_mps.size(2), 4);
  EXPECT_NEAR(both.mean_planted_speed(made, real.pose, real.control).item<double>(), 10 * 0.3 / (19 * 4), 1e-4);
  // The left toes slide with it: twice the glide over the same four joints.
  const int64_t toe_x = 3 * s.find("Toes_L");
  for (int64_t t = frames / 2; t < frames; ++t) made[0][t][toe_x] += 0.01 * (t - frames / 2 + 1);
  EXPECT_NEAR(both.mean_planted_speed(made, real.pose, real.control).item<double>(), 2 * 10 * 0.3 / (19 * 4), 1e-4);
  EXPECT_NEAR(heels.mean_planted_speed(made, real.pose, real.control).item<double>(), 10 * 0.3 / (19 * 2), 1e-4);
  // The toes at weight 0.25: a weighted mean, each toe's steps counting a quarter of a heel's.
  FootTermOptions light_toes = toes;
  light_toes.toe_weight = 0.25;
  const FootTerms light(ctx, "test", light_toes);
  const double weighted = (10 * 0.3 + 0.25 * 10 * 0.3) / (19 * 2 + 0.25 * 19 * 2);
  EXPECT_NEAR(light.mean_planted_speed(made, real.pose, real.control).item<double>(), weighted, 1e-4);
  EXPECT_NEAR(light.mean_speed_error(made, real.pose, real.control).item<double>(), weighted, 1e-4);
  for (double bad : {0.0, 1.5}) {
    FootTermOptions o = toes;
    o.toe_weight = bad;
    EXPECT_THROW(FootTerms(ctx, "test", o), Error);
  }
}

// The toe-slide term by hand (the independent check's skating as a cost): on the floor (its lowest
// height over the sequence), a toe moving 1 cm a frame at 30 fps costs 0.3 - 0.1 m/s times
// sigmoid(1 cm / 3 mm); lifted 5 cm it costs almost nothing, as does one under 0.1 m/s; the
// gradient slows the toe and never lifts it.
TEST(FootTerms, ToeSlideChargesALowToeMovingFasterThanTheCheckAllows) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const int frames = 20;
  const Batch real = nn::testing::standing_batch(s, ctx, frames);
  const FootTerms term(ctx, "test");
  ASSERT_EQ(term.toes().size(), 2u);
  const auto& joints = term.body().point_joints();
  EXPECT_EQ(joints[term.toes()[0]], s.children(joints[term.heels()[0]]).front());
  const int64_t toe_x = 3 * s.find("Toes_L"), toe_y = toe_x + 1;
  const auto low = [](double above_floor_m) {
    return 1.0 / (1.0 + std::exp(-(FootTerms::kLowToeM - above_floor_m) / FootTerms::kLowSoftnessM));
  };
  EXPECT_NEAR(term.mean_toe_slide(real.pose, real.control).item<double>(), 0.0, 1e-6);
  auto sliding = real.pose.clone();  // the left toe slides over the second half (steps 9..18)
  for (int64_t t = frames / 2; t < frames; ++t) sliding[0][t][toe_x] += 0.01 * (t - frames / 2 + 1);
  EXPECT_NEAR(term.mean_toe_slide(sliding, real.control).item<double>(), 10 * 0.2 * low(0) / (19 * 2), 1e-5);
  // Steps 0..9 only: the first slide, into frame 10.
  auto first = torch::zeros({1, frames - 1});
  first.narrow(1, 0, 10).fill_(1.0);
  EXPECT_NEAR(term.mean_toe_slide(sliding, real.control, first).item<double>(), 0.2 * low(0) / (10 * 2), 1e-5);
  // Lifted 5 cm while it slides: only the step off the floor (from frame 9) costs.
  auto lifted = sliding.clone();
  lifted.narrow(1, frames / 2, frames / 2).select(2, toe_y) += 0.05;
  EXPECT_NEAR(term.mean_toe_slide(lifted, real.control).item<double>(), (0.2 * low(0) + 9 * 0.2 * low(0.05)) / 38, 1e-5);
  // Under 0.1 m/s (2 mm a frame at 30 fps, 0.06 m/s): free.
  auto creeping = real.pose.clone();
  for (int64_t t = 0; t < frames; ++t) creeping[0][t][toe_x] += 0.002 * t;
  EXPECT_NEAR(term.mean_toe_slide(creeping, real.control).item<double>(), 0.0, 1e-6);
  // The gradient slows a sliding low toe and does not lift it.
  auto made = sliding.clone().requires_grad_(true);
  term.mean_toe_slide(made, real.control).backward();
  EXPECT_GT(made.grad()[0][frames - 1][toe_x].item<double>(), 0.0);   // the last frame back
  EXPECT_EQ(made.grad()[0][frames - 2][toe_y].item<double>(), 0.0);
  EXPECT_EQ(made.grad()[0][0][toe_x].item<double>(), 0.0);
  // The term charges what the made toes slide beyond the data's of the same row: two rows, the
  // first made sliding where the data stand, the second standing where the data slide.
  const auto made_rows = torch::cat({sliding, real.pose}), real_rows = torch::cat({real.pose, sliding});
  const auto control_rows = torch::cat({real.control, real.control});
  const auto per_row = term.toe_slide_per_row(made_rows, control_rows);
  ASSERT_EQ(per_row.size(0), 2);
  EXPECT_NEAR(per_row[0].item<double>(), 10 * 0.2 * low(0) / 38, 1e-5);
  EXPECT_NEAR(per_row[1].item<double>(), 0.0, 1e-6);
  EXPECT_NEAR(term.mean_excess_toe_slide(made_rows, real_rows, control_rows).item<double>(), 10 * 0.2 * low(0) / 38 / 2,
              1e-5);
  EXPECT_NEAR(term.mean_excess_toe_slide(sliding, sliding, real.control).item<double>(), 0.0, 1e-9);
}

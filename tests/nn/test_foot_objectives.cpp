// The shared foot objectives (nn/objectives/): the body's points in every pose form against the
// double-precision encoder (core forward kinematics through data::encode), the made root steps
// against a hand computation, the terms' entry point, the bone lengths, and the field list as a
// family's config includes it.
#include <gtest/gtest.h>

#include <random>

#include "core/error.h"
#include "core/markers.h"
#include "nn/objectives/body_points.h"
#include "nn/objectives/foot_objectives.h"
#include "nn/options_fields.h"
#include "foot_test_util.h"
#include "nn_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;
using nn::testing::encoded_batch;
using nn::testing::form_context;

namespace {

// A synthetic walk of s with every joint's local rotation turned a little at random (so that the
// forward kinematics meet every joint's rotation, not only the walk's leg swings).
Motion perturbed_walk(const Skeleton& s, int frames) {
  Motion m = make_synthetic_walk(s, frames, 30.0, SyntheticWalkOptions{});
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 0.15);
  for (int t = 0; t < frames; ++t)
    for (int j = 1; j < s.num_joints(); ++j)
      m.rotation(t, j) = (m.rotation(t, j) * Eigen::Quaterniond(1.0, n(rng), n(rng), n(rng)).normalized()).normalized();
  return m;
}

// The positions features of joint j, [1, T, 3].
torch::Tensor joint_of(const Batch& positions, int j) { return positions.pose.narrow(-1, 3 * j, 3); }

}  // namespace

// Rotations form: the points from the differentiable forward kinematics equal the joints of the
// positions form of the same motion (computed by core forward kinematics in double precision),
// with the root's floor offsets (smoothed root path) and without (raw root path).
TEST(BodyPoints, RotationsFormMatchesThePositionsOfCoreForwardKinematics) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = perturbed_walk(s, 24);
  for (double smoothing : {0.0, 0.3}) {
    const ModelContext rot = form_context(s, data::PoseForm::kRotations, smoothing);
    const ModelContext pos = form_context(s, data::PoseForm::kPositions, smoothing);
    const BodyPoints points(rot, "test");
    ASSERT_EQ(points.num_points(), 5);
    ASSERT_TRUE(points.has_toes());
    const auto made = points.points_m(encoded_batch(s, m, rot).pose);  // [1, T, 5, 3]
    const Batch reference = encoded_batch(s, m, pos);
    for (int p = 0; p < points.num_points(); ++p) {
      const auto expected = joint_of(reference, points.point_joints()[p]);
      EXPECT_LT((made.select(2, p) - expected).abs().max().item<double>(), 2e-5) << "point " << p << " smoothing "
                                                                                << smoothing;
    }
    EXPECT_EQ(s.joint_names[points.point_joints()[0]], "Foot_L");
    EXPECT_EQ(points.point_joints()[points.pelvis_point()], 0);
  }
  // Differentiable: the gradient of a heel reaches the leg's rotations and the root's height.
  const ModelContext rot = form_context(s, data::PoseForm::kRotations, 0.3);
  auto pose = encoded_batch(s, m, rot).pose.requires_grad_(true);
  BodyPoints(rot, "test").points_m(pose).select(2, 0).sum().backward();
  EXPECT_GT(pose.grad().select(2, 0).abs().sum().item<double>(), 0.0);  // the height
  const int shin_slot = 7 + 6 * (s.find("Foot_L") - 2);                 // the shin's 6D (the ankle's parent)
  EXPECT_GT(pose.grad().narrow(2, shin_slot, 6).abs().sum().item<double>(), 0.0);
}

// Markers form: the heels and toes are the LHEE / RHEE / LTOE / RTOE markers, the pelvis the mean
// of the four waist markers; the rigid pairs keep their rest lengths on the encoded motion.
TEST(BodyPoints, MarkersFormReadsHeelToeAndWaistMarkers) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = form_context(s, data::PoseForm::kMarkers, 0.3);
  const Batch batch = encoded_batch(s, perturbed_walk(s, 12), ctx);
  const BodyPoints points(ctx, "test");
  const auto& names = cmu41_marker_names();
  auto marker = [&](const std::string& name) {
    return joint_of(batch, static_cast<int>(std::find(names.begin(), names.end(), name) - names.begin()));
  };
  const auto p = points.points_m(batch.pose);
  EXPECT_TRUE(torch::equal(p.select(2, 0), marker("LHEE")));
  EXPECT_TRUE(torch::equal(p.select(2, 3), marker("RTOE")));
  const auto waist = (marker("LFWT") + marker("RFWT") + marker("LBWT") + marker("RBWT")) / 4.0;
  EXPECT_LT((p.select(2, 4) - waist).abs().max().item<double>(), 1e-6);
  ASSERT_GT(points.num_pairs(), 0);
  const auto error = points.pair_lengths_m(batch.pose) - points.rest_lengths_m().to(torch::kFloat);
  EXPECT_LT(error.abs().max().item<double>(), 1e-4);
}

// Two controls: the made heels move with the made root steps. A standing body whose made root
// steps 1 cm sideways a frame (at 30 fps) moves its heels over the ground at 0.3 m/s, while the
// data's (standing, its own control) stay planted: the planted term and the speed error are 0.3.
TEST(FootTerms, MadeControlMovesTheMadeHeels) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const Batch real = nn::testing::standing_batch(s, ctx, 20);
  auto made_control = real.control.clone();
  made_control.select(2, 0) += 0.01;
  const FootTerms terms(ctx, "test");
  const auto speeds = terms.speeds(real.pose, made_control, real.pose, real.control);
  EXPECT_NEAR(speeds.made_mps.mean().item<double>(), 0.3, 1e-4);
  EXPECT_NEAR(speeds.real_mps.max().item<double>(), 0.0, 1e-4);
  EXPECT_NEAR(terms.mean_planted_speed(speeds).item<double>(), 0.3, 1e-4);
  EXPECT_NEAR(terms.mean_speed_error(speeds).item<double>(), 0.3, 1e-4);
  // With the data's control on both sides nothing moves.
  EXPECT_NEAR(terms.mean_planted_speed(real.pose, real.pose, real.control).item<double>(), 0.0, 1e-4);
  // The toes slide with the root too: 0.3 - 0.1 m/s, times their lowness (both on the floor).
  const double low = 1.0 / (1.0 + std::exp(-FootTerms::kLowToeM / FootTerms::kLowSoftnessM));
  EXPECT_NEAR(terms.mean_excess_toe_slide(real.pose, made_control, real.pose, real.control, {}).item<double>(),
              0.2 * low, 1e-4);
}

// The bone-length term: 0 on the data; a left foot lowered 5 cm (with its toes) stretches the
// shin alone (the foot and toes move rigidly), by the change of the knee-to-ankle distance,
// averaged over every bone and frame.
TEST(FootTerms, BoneLengthsAgainstTheSkeleton) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::positions_context(s);
  const Batch real = nn::testing::standing_batch(s, ctx, 6);
  FootTermOptions o;
  o.bone_lengths = true;
  const FootTerms terms(ctx, "test", o);
  const int bones = terms.body().num_pairs();
  ASSERT_GT(bones, 4);
  EXPECT_NEAR(terms.mean_bone_length_error_m(real.pose).item<double>(), 0.0, 1e-5);
  const int foot = s.find("Foot_L"), knee = s.parents[foot];
  auto made = real.pose.clone();
  std::vector<int> moved = {foot};
  for (int j = foot + 1; j < s.num_joints(); ++j)
    if (std::find(moved.begin(), moved.end(), s.parents[j]) != moved.end()) moved.push_back(j);
  for (int j : moved) made.select(2, 3 * j + 1) -= 0.05;
  const auto shin = [&](const torch::Tensor& pose) {
    return (pose.narrow(-1, 3 * foot, 3) - pose.narrow(-1, 3 * knee, 3)).norm(2, -1);
  };
  const double stretch = (shin(made) - shin(real.pose)).abs().mean().item<double>();
  EXPECT_GT(stretch, 0.04);
  EXPECT_NEAR(terms.mean_bone_length_error_m(made).item<double>(), stretch / bones, 1e-5);
  // Rotations keep their bones: the term is refused there.
  EXPECT_THROW(FootTerms(form_context(s, data::PoseForm::kRotations, 0.3), "test", o), Error);
}

// The entry point: made == real costs nothing; every term on is logged, and added (times its
// weight) only in training.
TEST(FootObjectives, AddsWeightedTermsInTrainingAndLogsThem) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = form_context(s, data::PoseForm::kRotations, 0.3);
  SyntheticWalkOptions standing;  // every heel planted
  standing.speed_mps = 0.0;
  standing.leg_swing_rad = 0.0;
  standing.sway_rad = 0.0;
  standing.cycle_hz = 0.0;
  const Batch real = encoded_batch(s, make_synthetic_walk(s, 40, 30.0, standing), ctx);
  FootObjectiveOptions o;
  o.foot_contact_weight = 2.0;
  o.heel_speed_weight = 1.0;
  o.lift_off_weight = 1.0;
  o.pelvis_follow_weight = 1.0;
  o.toe_slide_weight = 1.0;
  o.speed_distribution_weight = 1.0;
  o.stance_weight = 1.0;
  o.stance_window_s = 0.3;
  const FootObjectives foot(ctx, o, "test");
  ASSERT_TRUE(foot.on());
  auto loss = torch::zeros({});
  LossTerms out;
  foot.add({real.pose, real.control, real.pose, real.control, {}, {}, {}}, /*training=*/true, &loss, &out);
  for (const char* name : {"planted_heel_mps", "heel_speed_error_mps", "lingering_heel_mps", "pelvis_offset_m",
                           "toe_slide_mps", "speed_distribution_mps", "missed_stance_mps"}) {
    ASSERT_EQ(out.terms.count(name), 1u) << name;
    EXPECT_LT(out.terms.at(name).item<double>(), 0.01) << name;  // the float floor of the speeds
  }
  EXPECT_EQ(out.terms.count("excess_slow_share"), 0u);  // off
  // A made body that sinks 3 cm and slides 1 cm a frame sideways over the standing data: every term
  // logged; the loss is their weighted sum in training, unchanged outside it.
  auto made = real.pose.clone();
  made.select(2, 0) -= 0.03;
  made.select(2, ctx.pose_dim - 2) += 0.01 * torch::arange(40).to(torch::kFloat);
  LossTerms train, eval;
  auto train_loss = torch::zeros({}), eval_loss = torch::zeros({});
  foot.add({made, real.control, real.pose, real.control, {}, {}, {}}, true, &train_loss, &train);
  foot.add({made, real.control, real.pose, real.control, {}, {}, {}}, false, &eval_loss, &eval);
  EXPECT_EQ(eval_loss.item<double>(), 0.0);
  double sum = 0;
  for (const auto& [name, value] : train.terms) sum += (name == "planted_heel_mps" ? 2.0 : 1.0) * value.item<double>();
  EXPECT_NEAR(train_loss.item<double>(), sum, 1e-5);
  EXPECT_NEAR(train.terms.at("planted_heel_mps").item<double>(), 0.3, 1e-3);  // 1 cm a frame at 30 fps
  EXPECT_NEAR(train.terms.at("heel_speed_error_mps").item<double>(), 0.3, 1e-3);
  EXPECT_NEAR(train.terms.at("pelvis_offset_m").item<double>(), 0.01 * 39 / 2.0, 1e-3);  // mean of 0..0.39 m
  // The valid frames: only the first frame counts, so no step does.
  LossTerms first;
  auto first_loss = torch::zeros({});
  auto valid = torch::zeros({1, 40});
  valid[0][0] = 1.0;
  foot.add({made, real.control, real.pose, real.control, valid, {}, {}}, true, &first_loss, &first);
  EXPECT_EQ(first.terms.at("planted_heel_mps").item<double>(), 0.0);
  // Off: nothing logged.
  LossTerms none;
  FootObjectives().add({made, real.control, real.pose, real.control, {}, {}, {}}, true, &first_loss, &none);
  EXPECT_TRUE(none.terms.empty());
}

// OptionFields::include: a family's list reads, checks and writes the shared fields at its top
// level, its errors naming the family, and writes each only off its default.
TEST(FootObjectives, FieldsIncludedInAFamilysList) {
  struct Toy {
    int n = 1;
    FootObjectiveOptions foot;
  };
  const auto fields =
      OptionFields<Toy>("toy").field("n", &Toy::n, "count", at_least(1)).include(&Toy::foot, foot_objective_fields());
  Toy t;
  fields.read({{"n", 2}, {"foot_contact_weight", 0.5}, {"toe_terms", true}, {"planted_mps", 0.1}}, &t);
  EXPECT_EQ(t.n, 2);
  EXPECT_EQ(t.foot.foot_contact_weight, 0.5);
  EXPECT_TRUE(t.foot.toe_terms);
  fields.check(t);
  EXPECT_EQ(fields.write(t), (nlohmann::json{{"n", 2}, {"foot_contact_weight", 0.5}, {"toe_terms", true},
                                             {"planted_mps", 0.1}}));
  EXPECT_EQ(fields.write(Toy{}), (nlohmann::json{{"n", 1}}));  // defaults stay unwritten
  auto message = [&](const nlohmann::json& config) -> std::string {
    try {
      Toy o;
      fields.read(config, &o);
      fields.check(o);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message({{"heel_speed_weight", "x"}}), "toy config: 'heel_speed_weight' must be a number");
  EXPECT_EQ(message({{"heel_speed_weight", -1}}), "toy config: heel_speed_weight must be >= 0");
  EXPECT_EQ(message({{"toe_term_weight", 0.5}}), "toy config: toe_term_weight needs toe_terms");
  EXPECT_EQ(message({{"lift_off_labels", {"walk"}}}).rfind("toy config: ", 0), 0u);
  EXPECT_EQ(message({{"nope", 1}}), "toy config: unknown key 'nope'");
  bool documented = false;
  for (const auto& [key, doc] : fields.docs()) documented = documented || key == "bone_length_weight";
  EXPECT_TRUE(documented);
}

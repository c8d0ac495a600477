// The shared terms on free draws (nn/objectives/draw_objectives.h): the speed term against a hand
// computation and its gradient into the made root steps, the foot terms' names and their silence on
// a draw equal to the data, the weights only in training, and the field list.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/synthetic.h"
#include "nn/objectives/draw_objectives.h"
#include "foot_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;
using nn::testing::form_context;
using nn::testing::walk_batch;

TEST(DrawObjectives, SpeedRatioExcessMatchesTheFormula) {
  const auto made = torch::tensor({0.5, 1.0, 2.0, 0.0}, torch::kDouble);
  const auto real = torch::tensor({1.0, 1.0, 1.0, 1.0}, torch::kDouble);
  const auto exact = speed_ratio_excess(made, real, 1.0, 0.05);
  const auto banded = speed_ratio_excess(made, real, 1.5, 0.05);
  for (int i = 0; i < 4; ++i) {
    const double a = made[i].item<double>(), b = real[i].item<double>();
    const double r = std::abs(std::log(a + 0.05) - std::log(b + 0.05));
    EXPECT_NEAR(exact[i].item<double>(), r * r, 1e-12) << i;
    const double e = std::max(0.0, r - std::log(1.5));
    EXPECT_NEAR(banded[i].item<double>(), e * e, 1e-12) << i;
  }
  EXPECT_EQ(banded[1].item<double>(), 0.0);
  EXPECT_THROW(speed_ratio_excess(made, real, 0.9), Error);
}

// A draw that is the data window itself costs nothing; one whose root moves at half the data's
// speed pays log(2)^2 (floor aside) and its gradient reaches the made root steps; the weights enter
// the loss only in training, the terms are logged in both.
TEST(DrawObjectives, ChargesADrawThatMovesSlowerThanItsWindow) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = form_context(s, data::PoseForm::kPositions, 0.3);
  const Batch real = walk_batch(s, ctx, 40);
  DrawObjectiveOptions o;
  o.draw_speed_weight = 2.0;
  o.draw_stance_weight = o.draw_speed_distribution_weight = o.draw_toe_slide_weight = 1.0;
  const DrawObjectives draw(ctx, o, FootObjectiveOptions{}, "test");
  ASSERT_TRUE(draw.on());

  torch::Tensor loss = torch::zeros({});
  LossTerms same;
  draw.add({real.pose, real.control, real.pose, real.control, {}, {}, {}}, true, &loss, &same);
  for (const char* name : {"draw_speed", "draw_missed_stance_mps", "draw_speed_distribution_mps", "draw_toe_slide_mps"}) {
    ASSERT_TRUE(same.terms.count(name)) << name;
    EXPECT_NEAR(same.terms[name].item<double>(), 0.0, 1e-6) << name;
  }
  EXPECT_NEAR(same.terms["draw_root_mps"].item<double>(), same.terms["real_root_mps"].item<double>(), 1e-6);

  auto slow = real.control.clone();
  slow.narrow(-1, 0, 2).mul_(0.5);  // half of every root step (sideways, forward)
  slow.requires_grad_(true);
  torch::Tensor trained = torch::zeros({});
  LossTerms terms;
  draw.add({real.pose, slow, real.pose, real.control, {}, {}, {}}, true, &trained, &terms);
  const double real_mps = terms.terms["real_root_mps"].item<double>();
  ASSERT_GT(real_mps, 0.3);
  const double r = std::log(0.5 * real_mps + kDrawSpeedFloorMps) - std::log(real_mps + kDrawSpeedFloorMps);
  EXPECT_NEAR(terms.terms["draw_speed"].item<double>(), r * r, 0.02 * r * r);  // every step moves alike
  EXPECT_GT(terms.terms["draw_toe_slide_mps"].item<double>(), 0.0);          // the feet now glide back
  trained.backward();
  EXPECT_LT(slow.grad().narrow(-1, 1, 1).sum().item<double>(), 0.0);  // faster forward steps lower it

  torch::Tensor validation = torch::zeros({});
  LossTerms logged;
  draw.add({real.pose, slow.detach(), real.pose, real.control, {}, {}, {}}, false, &validation, &logged);
  EXPECT_EQ(validation.item<double>(), 0.0);
  EXPECT_NEAR(logged.terms["draw_speed"].item<double>(), terms.terms["draw_speed"].item<double>(), 1e-9);
}

TEST(DrawObjectives, FieldsWriteOnlyWhatIsOnAndCheckRanges) {
  DrawObjectiveOptions o;
  EXPECT_TRUE(draw_objective_fields().write(o).empty());
  o.draw_toe_slide_weight = 3.0;
  const auto json = draw_objective_fields().write(o);
  EXPECT_EQ(json.size(), 1u);
  EXPECT_EQ(json.at("draw_toe_slide_weight").get<double>(), 3.0);
  DrawObjectiveOptions back;
  draw_objective_fields().read(json, &back);
  EXPECT_EQ(back.draw_toe_slide_weight, 3.0);
  DrawObjectiveOptions bad;
  draw_objective_fields().read({{"draw_speed_tolerance", 0.5}}, &bad);
  EXPECT_THROW(draw_objective_fields().check(bad), Error);
  // The draw's foot options keep the family's thresholds and only the three draw weights.
  FootObjectiveOptions family;
  family.foot_contact_weight = 1.0;
  family.planted_mps = 0.2;
  const auto foot = back.foot(family);
  EXPECT_EQ(foot.foot_contact_weight, 0.0);
  EXPECT_EQ(foot.toe_slide_weight, 3.0);
  EXPECT_EQ(foot.planted_mps, 0.2);
}

// MoGlow's training terms on free-running draws (nn/moglow/moglow.h: the heel, pelvis, stance,
// speed-distribution and toe terms, lift_off_labels), each against its value by hand.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "core/error.h"
#include "core/synthetic.h"
#include "moglow_test_util.h"
#include "nn/moglow/moglow.h"
#include "nn_test_util.h"

using namespace mosyn::nn;
using mosyn::nn::testing::randomise;

// The free-running planted-heel term (foot_contact_rollout): at temperature 0 its draws are
// exactly what sampling makes from the window's first tau frames along the window's control
// (the stream's fused inference net against the reference flow), and the term is their planted
// heels' speed from frame to frame.
namespace {

// A standing biped's 12-frame window (float64), and a small MoGlow config whose planted-heel term
// draws k frames (4 unless given) at temperature 0 from its first tau = 2.
struct RolloutSetup {
  explicit RolloutSetup(int64_t draws = 4) : k(draws) {
    cfg = {{"num_steps", 3},          {"hidden", 16},
           {"tau", tau},              {"dropout", 0.0},
           {"residual", true},        {"foot_contact_weight", 1.0},
           {"foot_contact_rollout", k}, {"foot_contact_temperature", 0.0}};
  }
  const mosyn::Skeleton s = mosyn::make_synthetic_biped();
  const ModelContext ctx = mosyn::nn::testing::positions_context(s);
  const Batch batch = mosyn::nn::testing::standing_batch(s, ctx, 12);
  const torch::Tensor pose = batch.pose.to(torch::kFloat64), control = batch.control.to(torch::kFloat64);
  static constexpr int64_t tau = 2;
  const int64_t k;
  nlohmann::json cfg;
  // The same sampling the term's draws are: the window's first tau frames (or `prefix` [1, tau, D],
  // e.g. the mean pose of a cold start), then k along its control.
  SampleRequest request(const torch::Tensor& prefix = {}) const {
    SampleRequest req;
    req.prefix_pose = prefix.defined() ? prefix : pose.narrow(1, 0, tau);
    req.prefix_control = control.narrow(1, 0, tau);
    req.control = control.narrow(1, tau, k);
    req.temperature = 0.0;
    return req;
  }
  // Random weights (randomise at `scale`), alike for every config of the same shapes: seeded before
  // create_model too, whose own initial weights randomise leaves.
  std::shared_ptr<MoGlowImpl> model(double scale = 0.3) const {
    torch::manual_seed(1);
    auto m = std::dynamic_pointer_cast<MoGlowImpl>(create_model("moglow", cfg, ctx));
    m->to(torch::kFloat64);
    randomise(*m, scale);
    return m;
  }
};

}  // namespace

TEST(MoGlowHeelTerms, FootContactRolloutIsSamplingFromTheWindowStart) {
  const RolloutSetup r;
  const auto& [s, ctx, pose, control] = std::tie(r.s, r.ctx, r.pose, r.control);
  const int64_t tau = RolloutSetup::tau, k = r.k;
  auto model = r.model();
  model->eval();
  const double planted = model->loss(Batch{pose, control, {}, {}}).terms.at("planted_heel_mps").item<double>();
  const auto drawn = model->sample(r.request()).pose;  // [1, k, D]
  double sum = 0;
  for (int heel : {s.find("Foot_L"), s.find("Foot_R")})
    for (int64_t t = 0; t < k; ++t) {
      const auto before = t == 0 ? pose[0][tau - 1] : drawn[0][t - 1];  // standing: no root step
      sum += std::hypot((drawn[0][t][3 * heel] - before[3 * heel]).item<double>(),
                        (drawn[0][t][3 * heel + 2] - before[3 * heel + 2]).item<double>()) * ctx.fps;
    }
  EXPECT_NEAR(planted, sum / (2 * k), 1e-6);
  EXPECT_GT(planted, 0.0);
}

// The other terms on the same draws, each by hand; training adds weight x term to the loss.
TEST(MoGlowHeelTerms, HeelAndPelvisTermsOnTheRolloutAddWeightTimesTerm) {
  RolloutSetup r;
  const auto& [ctx, pose, control] = std::tie(r.ctx, r.pose, r.control);
  nlohmann::json& cfg = r.cfg;
  const int64_t tau = RolloutSetup::tau, k = r.k;
  // The heel-speed error: standing data's heels do not move, so on every frame it is the made
  // heel's speed, the planted term's value, less the data heel's floor speed sqrt(1e-12) m a
  // frame (nn::joint_ground_speed_mps).
  cfg["heel_speed_weight"] = 0.5;
  auto both = r.model();
  auto loss_in = [&](bool training) {
    both->train(training);
    return both->loss(Batch{pose, control, {}, {}});
  };
  const LossTerms eval_terms = loss_in(false), train_terms = loss_in(true);
  const double error = eval_terms.terms.at("heel_speed_error_mps").item<double>();
  EXPECT_NEAR(error, eval_terms.terms.at("planted_heel_mps").item<double>() - 1e-6 * ctx.fps, 1e-8);
  EXPECT_GT(error, 0.0);
  EXPECT_NEAR(train_terms.loss().item<double>(),
              eval_terms.loss().item<double>() + 1.0 * eval_terms.terms.at("planted_heel_mps").item<double>() + 0.5 * error,
              1e-6);

  // The lingering-heel term on the same draws: standing data's heels never lift, so it is 0, is
  // logged, and training adds weight x term.
  cfg["lift_off_weight"] = 0.25;
  both = r.model();
  const LossTerms eval_all = loss_in(false), train_all = loss_in(true);
  EXPECT_NEAR(eval_all.terms.at("lingering_heel_mps").item<double>(), 0.0, 1e-12);
  EXPECT_NEAR(train_all.loss().item<double>(),
              eval_all.loss().item<double>() + 1.0 * eval_all.terms.at("planted_heel_mps").item<double>() +
                  0.5 * eval_all.terms.at("heel_speed_error_mps").item<double>(),
              1e-6);
  // The pelvis term on the same draws: the drawn pelvis' horizontal distance from the data's,
  // by hand over the k drawn frames; training adds weight x term.
  cfg["lift_off_weight"] = 0.0;
  cfg["pelvis_follow_weight"] = 2.0;
  both = r.model();
  const auto drawn_both = both->sample(r.request()).pose;
  double pelvis = 0;
  for (int64_t t = 0; t < k; ++t)
    pelvis += std::hypot((drawn_both[0][t][0] - pose[0][tau + t][0]).item<double>(),
                         (drawn_both[0][t][2] - pose[0][tau + t][2]).item<double>());
  const LossTerms eval_pelvis = loss_in(false), train_pelvis = loss_in(true);
  EXPECT_NEAR(eval_pelvis.terms.at("pelvis_offset_m").item<double>(), pelvis / k, 1e-6);
  EXPECT_GT(pelvis, 0.0);
  EXPECT_NEAR(train_pelvis.loss().item<double>(),
              eval_pelvis.loss().item<double>() + 1.0 * eval_pelvis.terms.at("planted_heel_mps").item<double>() +
                  0.5 * eval_pelvis.terms.at("heel_speed_error_mps").item<double>() +
                  2.0 * eval_pelvis.terms.at("pelvis_offset_m").item<double>(),
              1e-6);
  cfg["pelvis_follow_weight"] = -1.0;
  EXPECT_THROW(create_model("moglow", cfg, ctx), mosyn::Error);
  cfg["pelvis_follow_weight"] = 0.0;
  cfg["planted_speed_fraction"] = -0.1;
  EXPECT_THROW(create_model("moglow", cfg, ctx), mosyn::Error);
  cfg["planted_speed_fraction"] = 0.1;  // read, kept in the resolved config (its effect: test_foot_terms)
  EXPECT_DOUBLE_EQ(create_model("moglow", cfg, ctx)->config().at("planted_speed_fraction").get<double>(), 0.1);
  cfg.erase("planted_speed_fraction");
  cfg["lift_off_weight"] = -1.0;
  EXPECT_THROW(create_model("moglow", cfg, ctx), mosyn::Error);
  cfg["lift_off_weight"] = 0.0;
  cfg["heel_speed_weight"] = -1.0;
  EXPECT_THROW(create_model("moglow", cfg, ctx), mosyn::Error);
}

namespace {

// Each heel's ground speed (m/s) over the k draws [1, k, D] of a standing control, the first
// step from `before` [D] (standing: no root step): per heel, k speeds.
std::vector<std::vector<double>> drawn_heel_mps(const torch::Tensor& drawn, const torch::Tensor& before,
                                                const mosyn::Skeleton& s, double fps) {
  std::vector<std::vector<double>> out;
  for (int heel : {s.find("Foot_L"), s.find("Foot_R")}) {
    std::vector<double> mps;
    for (int64_t t = 0; t < drawn.size(1); ++t) {
      const auto prev = t == 0 ? before : drawn[0][t - 1];
      mps.push_back(std::hypot((drawn[0][t][3 * heel] - prev[3 * heel]).item<double>(),
                               (drawn[0][t][3 * heel + 2] - prev[3 * heel + 2]).item<double>()) * fps);
    }
    out.push_back(mps);
  }
  return out;
}

// The stance term by hand: mean over heels and runs of `window` steps of max(0, slowest - 0.15).
double missed_stance_by_hand(const std::vector<std::vector<double>>& mps, int64_t window) {
  double sum = 0;
  int64_t runs = 0;
  for (const auto& heel : mps)
    for (size_t r = 0; r + window <= heel.size(); ++r, ++runs)
      sum += std::max(0.0, *std::min_element(heel.begin() + r, heel.begin() + r + window) - 0.15);
  return sum / runs;
}

}  // namespace

// The stance term and phase_locked_frames on the free-running draws (temperature 0: what
// sampling makes from the window's first tau frames): standing data's heels stay planted, so
// every run of stance_window_s (3 steps at 30 fps) counts, at the made heel's slowest speed in it
// above 0.15 m/s; the planted-heel term reads the first phase_locked_frames draws only; training
// adds weight x each term. With cold_start_fraction 1 the draws are what sampling makes without
// a prefix (the mean pose as history), and the phase-locked term reads no row.
TEST(MoGlowHeelTerms, StanceTermReadsEveryDrawAndPhaseLockedTermsTheFirst) {
  RolloutSetup r(8);
  const auto& [s, ctx, pose, control] = std::tie(r.s, r.ctx, r.pose, r.control);
  const int64_t tau = RolloutSetup::tau, locked = 3, window = 3;
  nlohmann::json& cfg = r.cfg;
  cfg["stance_weight"] = 2.0;
  cfg["stance_window_s"] = window / 30.0;
  cfg["phase_locked_frames"] = locked;
  for (const bool cold : {false, true}) {
    cfg["cold_start_fraction"] = cold ? 1.0 : 0.0;
    auto model = r.model();
    const SampleRequest req = r.request(cold ? torch::zeros_like(pose.narrow(1, 0, tau)) : torch::Tensor());
    model->eval();
    const auto drawn = model->sample(req).pose;  // [1, k, D]
    const auto mps = drawn_heel_mps(drawn, req.prefix_pose[0][tau - 1], s, ctx.fps);
    const double missed = missed_stance_by_hand(mps, window);
    const double planted = cold ? 0.0 : (std::accumulate(mps[0].begin(), mps[0].begin() + locked, 0.0) +
                                         std::accumulate(mps[1].begin(), mps[1].begin() + locked, 0.0)) /
                                            (2 * locked);
    const LossTerms eval_terms = model->loss(Batch{pose, control, {}, {}});
    EXPECT_NEAR(eval_terms.terms.at("planted_heel_mps").item<double>(), planted, 1e-6) << cold;
    EXPECT_NEAR(eval_terms.terms.at("missed_stance_mps").item<double>(), missed, 1e-6) << cold;
    EXPECT_GT(missed, 0.0);
    model->train();
    EXPECT_NEAR(model->loss(Batch{pose, control, {}, {}}).loss().item<double>(),
                eval_terms.loss().item<double>() + planted + 2.0 * missed, 1e-6);
  }
  cfg["cold_start_fraction"] = 0.0;
  EXPECT_DOUBLE_EQ(create_model("moglow", cfg, ctx)->config().at("stance_window_s").get<double>(), window / 30.0);
  cfg["toe_terms"] = true;  // read, kept (its effect: test_foot_terms's WithToesReadsEachAnklesChild)
  EXPECT_TRUE(create_model("moglow", cfg, ctx)->config().at("toe_terms").get<bool>());
  cfg["toe_term_weight"] = 0.3;  // read, kept (its effect: WithToesReadsEachAnklesChild)
  EXPECT_DOUBLE_EQ(create_model("moglow", cfg, ctx)->config().at("toe_term_weight").get<double>(), 0.3);
  for (const double bad : {0.0, 1.5}) {  // a weight in (0, 1]
    nlohmann::json wrong = cfg;
    wrong["toe_term_weight"] = bad;
    EXPECT_THROW(create_model("moglow", wrong, ctx), mosyn::Error) << bad;
  }
  cfg.erase("toe_terms");  // a toe weight without the toes is an error
  EXPECT_THROW(create_model("moglow", cfg, ctx), mosyn::Error);
  cfg.erase("toe_term_weight");
  for (const auto& [key, bad] : std::vector<std::pair<std::string, nlohmann::json>>{
           {"stance_weight", -1.0}, {"stance_window_s", 0.0}, {"phase_locked_frames", -1},
           {"cold_start_fraction", 1.5}}) {
    nlohmann::json wrong = cfg;
    wrong[key] = bad;
    EXPECT_THROW(create_model("moglow", wrong, ctx), mosyn::Error) << key;
  }
  nlohmann::json teacher_forced = cfg;  // a cold start needs free-running draws
  teacher_forced["cold_start_fraction"] = 0.5;
  teacher_forced["foot_contact_rollout"] = 0;
  EXPECT_THROW(create_model("moglow", teacher_forced, ctx), mosyn::Error);
}

// The speed-distribution term on the free-running draws (temperature 0) by hand: per heel, the
// drawn and the data's speeds over draws 2..k, capped at speed_distribution_cap_mps and sorted,
// compared pair by pair; training adds weight x the term. Its options are read and checked.
TEST(MoGlowHeelTerms, SpeedDistributionTermComparesTheDrawsSpeedsWithTheData) {
  RolloutSetup r(8);
  const auto& [s, ctx, pose, control] = std::tie(r.s, r.ctx, r.pose, r.control);
  const int64_t tau = RolloutSetup::tau;
  const double weight = 2.0;
  nlohmann::json& cfg = r.cfg;
  cfg.erase("foot_contact_weight");
  cfg["speed_distribution_weight"] = weight;
  const double scale = 0.02;  // gentle: the drawn heels move about 1-2 m/s
  auto model = r.model(scale);
  model->eval();
  const SampleRequest req = r.request();
  const auto mps = drawn_heel_mps(model->sample(req).pose, req.prefix_pose[0][tau - 1], s, ctx.fps);
  // The data's heels stand (0 m/s, to float32 rounding of the standing pose: 3e-5 m/s), so the
  // sorted comparison leaves each drawn speed, capped; the cap sits among the drawn speeds.
  std::vector<double> drawn_later;
  for (const auto& heel : mps) drawn_later.insert(drawn_later.end(), heel.begin() + 1, heel.end());
  std::sort(drawn_later.begin(), drawn_later.end());
  const double cap = drawn_later[drawn_later.size() / 2];
  ASSERT_LE(cap, 10.0);  // the option's largest
  cfg["speed_distribution_cap_mps"] = cap;
  model = r.model(scale);
  model->eval();
  double by_hand = 0;
  for (double v : drawn_later) by_hand += std::min(v, cap) / drawn_later.size();
  const LossTerms eval_terms = model->loss(Batch{pose, control, {}, {}});
  EXPECT_NEAR(eval_terms.terms.at("speed_distribution_mps").item<double>(), by_hand, 1e-4);
  EXPECT_GT(by_hand, 0.0);
  model->train();
  const LossTerms train_terms = model->loss(Batch{pose, control, {}, {}});
  const double term = train_terms.terms.at("speed_distribution_mps").item<double>();
  EXPECT_NEAR(term, eval_terms.terms.at("speed_distribution_mps").item<double>(), 1e-9);
  EXPECT_NEAR(train_terms.loss().item<double>(), eval_terms.loss().item<double>() + weight * term, 1e-9);
  EXPECT_DOUBLE_EQ(model->config().at("speed_distribution_cap_mps").get<double>(), cap);
  cfg["speed_distribution_cap_fraction"] = 0.5;
  EXPECT_DOUBLE_EQ(create_model("moglow", cfg, ctx)->config().at("speed_distribution_cap_fraction").get<double>(), 0.5);
  for (const auto& [key, bad] : std::vector<std::pair<std::string, double>>{
           {"speed_distribution_cap_mps", 0.0}, {"speed_distribution_cap_mps", 11.0},
           {"speed_distribution_cap_fraction", -0.5}, {"speed_distribution_weight", -1.0}}) {
    nlohmann::json wrong = cfg;
    wrong[key] = bad;
    EXPECT_THROW(create_model("moglow", wrong, ctx), mosyn::Error) << key << " " << bad;
  }
}

// The toe-slide term on the free-running draws by hand (temperature 0: what sampling makes from
// the window's first tau frames; standing control, so a toe's ground step is its own): over the
// steps between draws, each toe's floor its lowest drawn height; the standing data's toes do not
// slide, so all of it is the draws' excess; training adds weight x term.
TEST(MoGlowHeelTerms, ToeSlideTermReadsTheDrawnToes) {
  RolloutSetup r(8);
  const auto& [s, ctx, pose, control] = std::tie(r.s, r.ctx, r.pose, r.control);
  const int64_t k = r.k;
  nlohmann::json& cfg = r.cfg;
  cfg.erase("foot_contact_weight");
  cfg["toe_slide_weight"] = 3.0;
  auto model = r.model();
  const SampleRequest req = r.request();
  model->eval();
  const auto drawn = model->sample(req).pose;  // [1, k, D]
  double slide = 0;
  for (int toe : {s.find("Toes_L"), s.find("Toes_R")}) {
    double floor = 1e9;
    for (int64_t t = 0; t < k; ++t) floor = std::min(floor, drawn[0][t][3 * toe + 1].item<double>());
    for (int64_t t = 1; t < k; ++t) {
      const double mps = std::hypot((drawn[0][t][3 * toe] - drawn[0][t - 1][3 * toe]).item<double>(),
                                    (drawn[0][t][3 * toe + 2] - drawn[0][t - 1][3 * toe + 2]).item<double>()) * ctx.fps;
      const double above = drawn[0][t - 1][3 * toe + 1].item<double>() - floor;
      slide += std::max(0.0, mps - 0.1) / (1.0 + std::exp(-(0.01 - above) / 0.003));
    }
  }
  slide /= 2.0 * (k - 1);
  const LossTerms eval_terms = model->loss(Batch{pose, control, {}, {}});
  EXPECT_NEAR(eval_terms.terms.at("toe_slide_mps").item<double>(), slide, 1e-6);
  EXPECT_GT(slide, 0.0);
  model->train();
  EXPECT_NEAR(model->loss(Batch{pose, control, {}, {}}).loss().item<double>(), eval_terms.loss().item<double>() + 3.0 * slide,
              1e-6);
  EXPECT_DOUBLE_EQ(model->config().at("toe_slide_weight").get<double>(), 3.0);
  for (const auto& [key, bad] : std::vector<std::pair<std::string, nlohmann::json>>{{"toe_slide_weight", -1.0},
                                                                                   {"foot_contact_rollout", 0}}) {
    nlohmann::json wrong = cfg;  // negative; and no free-running draws to read
    wrong[key] = bad;
    EXPECT_THROW(create_model("moglow", wrong, ctx), mosyn::Error) << key;
  }
}

// toe_slide_below_root_mps: the term reads only the steps into draws whose control (the data's root)
// moves slower than the bar. The control stands for the first `slow` draws and walks at 1 m/s after,
// so the steps read are the standing ones, by hand as above; a control walking everywhere leaves none.
TEST(MoGlowHeelTerms, ToeSlideBelowRootSpeedReadsTheSlowStepsOnly) {
  RolloutSetup r(8);
  const auto& [s, ctx, pose] = std::tie(r.s, r.ctx, r.pose);
  const int64_t k = r.k, tau = RolloutSetup::tau, slow = 5;
  auto control = r.control.clone();  // positions_context's statistics are 0 / 1: standardised = raw
  control.narrow(1, tau + slow, k - slow).select(2, 1).fill_(1.0 / ctx.fps);  // forward 1 m/s
  nlohmann::json& cfg = r.cfg;
  cfg.erase("foot_contact_weight");
  cfg["toe_slide_weight"] = 3.0;
  cfg["toe_slide_below_root_mps"] = 0.5;
  auto model = r.model();
  model->eval();
  SampleRequest req = r.request();
  req.control = control.narrow(1, tau, k);
  const auto drawn = model->sample(req).pose;  // [1, k, D]
  double slide = 0;
  for (int toe : {s.find("Toes_L"), s.find("Toes_R")}) {
    double floor = 1e9;
    for (int64_t t = 0; t < k; ++t) floor = std::min(floor, drawn[0][t][3 * toe + 1].item<double>());
    for (int64_t t = 1; t < slow; ++t) {  // the steps into draws 1 .. slow - 1 stand
      const double mps = std::hypot((drawn[0][t][3 * toe] - drawn[0][t - 1][3 * toe]).item<double>(),
                                    (drawn[0][t][3 * toe + 2] - drawn[0][t - 1][3 * toe + 2]).item<double>()) * ctx.fps;
      const double above = drawn[0][t - 1][3 * toe + 1].item<double>() - floor;
      slide += std::max(0.0, mps - 0.1) / (1.0 + std::exp(-(0.01 - above) / 0.003));
    }
  }
  slide /= 2.0 * (slow - 1);
  EXPECT_GT(slide, 0.0);
  EXPECT_NEAR(model->loss(Batch{pose, control, {}, {}}).terms.at("toe_slide_mps").item<double>(), slide, 1e-6);
  EXPECT_DOUBLE_EQ(model->config().at("toe_slide_below_root_mps").get<double>(), 0.5);
  cfg["toe_slide_below_root_mps"] = 0.01;  // the standing steps' 0 m/s is below it, too: same reading
  auto low_bar = r.model();
  low_bar->eval();
  EXPECT_NEAR(low_bar->loss(Batch{pose, control, {}, {}}).terms.at("toe_slide_mps").item<double>(), slide, 1e-6);
  // A control walking everywhere leaves no step to read: the term is 0, not NaN.
  control.narrow(1, tau, k).select(2, 1).fill_(1.0 / ctx.fps);
  auto walking = r.model();
  walking->eval();
  EXPECT_EQ(walking->loss(Batch{pose, control, {}, {}}).terms.at("toe_slide_mps").item<double>(), 0.0);
  for (const auto& [key, bad] : std::vector<std::pair<std::string, double>>{{"toe_slide_below_root_mps", -0.1},
                                                                             {"toe_slide_weight", 0.0}}) {
    nlohmann::json wrong = cfg;  // negative; and no toe-slide term to gate
    wrong[key] = bad;
    EXPECT_THROW(create_model("moglow", wrong, ctx), mosyn::Error) << key;
  }
}

namespace {

// Two windows of a synthetic walk at 1.2 and 1.7 m/s labelled walk and run (style neutral), in a
// context with those vocabularies, and the value of a logged term on them by a small MoGlow at
// temperature 0 whose weights stay near the residual's transport (its drawn heels nearly planted).
struct TwoLabelledWalks {
  TwoLabelledWalks() : ctx(r.ctx) {
    ctx.num_content = 2;
    ctx.num_style = 1;
    ctx.content_labels = {"walk", "run"};
    ctx.style_labels = {"neutral"};
    const int frames = 12;
    for (const double speed : {1.2, 1.7}) {
      mosyn::SyntheticWalkOptions o;
      o.speed_mps = speed;
      o.cycle_hz = speed;
      std::vector<float> pose, control;
      mosyn::data::encode(r.s, mosyn::make_synthetic_walk(r.s, frames, ctx.fps, o), ctx.layout, &pose, &control);
      poses.push_back(torch::from_blob(pose.data(), {1, frames, ctx.pose_dim}, torch::kFloat).to(torch::kFloat64));
      controls.push_back(torch::from_blob(control.data(), {1, frames, 3}, torch::kFloat).to(torch::kFloat64));
    }
    both = Batch{torch::cat(poses), torch::cat(controls), torch::tensor({0L, 1L}), torch::tensor({0L, 0L})};
    cfg = r.cfg;
    cfg.erase("foot_contact_weight");
  }
  Batch alone(int row) const { return Batch{poses[row], controls[row], {}, {}}; }
  double term(const std::string& name, const nlohmann::json& patch, const Batch& batch) const {
    nlohmann::json c = cfg;
    c.merge_patch(patch);
    torch::manual_seed(1);
    auto m = std::dynamic_pointer_cast<MoGlowImpl>(create_model("moglow", c, ctx));
    m->to(torch::kFloat64);
    randomise(*m, 0.002);
    m->eval();
    return m->loss(batch).terms.at(name).item<double>();
  }
  RolloutSetup r{8};
  ModelContext ctx;
  std::vector<torch::Tensor> poses, controls;
  Batch both;
  nlohmann::json cfg;
};

}  // namespace

// lift_off_labels: the lingering-heel term reads only the windows of the labels it names, so on the
// two labelled walks it is each row's own term, the unrestricted term on "*:*", and 0 where no
// row matches. Unknown labels, malformed patterns and a context without vocabularies are errors;
// the option is kept in the resolved config.
TEST(MoGlowHeelTerms, LiftOffLabelsLimitTheLingeringTermToTheirWindows) {
  const TwoLabelledWalks w;
  const nlohmann::json on = {{"lift_off_weight", 1.0}};
  auto lingering = [&](const nlohmann::json& labels, const Batch& batch) {
    nlohmann::json patch = on;
    if (!labels.is_null()) patch["lift_off_labels"] = labels;
    return w.term("lingering_heel_mps", patch, batch);
  };
  const double walk_alone = lingering({}, w.alone(0)), run_alone = lingering({}, w.alone(1));
  EXPECT_GT(walk_alone, 0.0);
  EXPECT_GT(run_alone, 0.0);
  EXPECT_GT(std::abs(walk_alone - run_alone), 1e-6);
  EXPECT_NEAR(lingering({"walk:*"}, w.both), walk_alone, 1e-9);
  EXPECT_NEAR(lingering({"run:neutral"}, w.both), run_alone, 1e-9);
  EXPECT_NEAR(lingering({"*:*"}, w.both), lingering({}, w.both), 1e-12);
  EXPECT_NEAR(lingering({"walk:*", "run:*"}, w.both), lingering({}, w.both), 1e-12);
  EXPECT_DOUBLE_EQ(lingering({"walk:*"}, Batch{w.both.pose, w.both.control, {}, {}}), 0.0);  // unlabelled rows
  nlohmann::json kept = w.cfg;
  kept.merge_patch(on);
  kept["lift_off_labels"] = {"run:*"};
  EXPECT_EQ(create_model("moglow", kept, w.ctx)->config().at("lift_off_labels"), nlohmann::json({"run:*"}));
  EXPECT_FALSE(create_model("moglow", w.cfg, w.ctx)->config().contains("lift_off_labels"));
  for (const nlohmann::json& bad : {nlohmann::json({"jog:*"}), nlohmann::json({"run"}), nlohmann::json({"a:b:c"}),
                                    nlohmann::json({1}), nlohmann::json("run:*")}) {
    nlohmann::json wrong = kept;
    wrong["lift_off_labels"] = bad;
    EXPECT_THROW(create_model("moglow", wrong, w.ctx), mosyn::Error) << bad.dump();
  }
  try {
    create_model("moglow", kept, w.r.ctx);  // no labels: "run" is unknown
    ADD_FAILURE() << "expected an error";
  } catch (const mosyn::Error& e) {
    EXPECT_NE(std::string(e.what()).find("lift_off_labels"), std::string::npos) << e.what();
  }
  ModelContext no_vocabularies = w.ctx;
  no_vocabularies.content_labels.clear();
  EXPECT_THROW(create_model("moglow", kept, no_vocabularies), mosyn::Error);
}

// heel_label_weights: a window's factor weighs it in the terms' means. The two labelled walks have
// as many drawn frames each, so the pelvis and speed-distribution terms on both are the factors'
// weighted mean of each walk's own term; equal factors change nothing, a factor of 0 leaves a
// window out, and the factors of every matching pattern multiply.
TEST(MoGlowHeelTerms, HeelLabelWeightsWeighTheWindowsInTheTermsMeans) {
  const TwoLabelledWalks w;
  for (const auto& [name, on] : std::vector<std::pair<std::string, nlohmann::json>>{
           {"pelvis_offset_m", {{"pelvis_follow_weight", 1.0}}},
           {"speed_distribution_mps", {{"speed_distribution_weight", 1.0}}}}) {
    auto term = [&](const nlohmann::json& factors, const Batch& batch) {
      nlohmann::json patch = on;
      if (!factors.is_null()) patch["heel_label_weights"] = factors;
      return w.term(name, patch, batch);
    };
    const double walk_alone = term({}, w.alone(0)), run_alone = term({}, w.alone(1));
    EXPECT_GT(std::abs(walk_alone - run_alone), 1e-6) << name;
    EXPECT_NEAR(term({}, w.both), (walk_alone + run_alone) / 2, 1e-9) << name;
    EXPECT_NEAR(term({{"run:*", 3.0}}, w.both), (walk_alone + 3 * run_alone) / 4, 1e-9) << name;
    EXPECT_NEAR(term({{"*:*", 2.0}}, w.both), (walk_alone + run_alone) / 2, 1e-9) << name;
    EXPECT_NEAR(term({{"walk:*", 0.0}}, w.both), run_alone, 1e-9) << name;
    EXPECT_NEAR(term({{"run:*", 2.0}, {"*:neutral", 1.5}}, w.both), (1.5 * walk_alone + 3 * run_alone) / 4.5, 1e-9)
        << name;
  }
  nlohmann::json kept = w.cfg;
  kept["pelvis_follow_weight"] = 1.0;
  kept["heel_label_weights"] = {{"run:elderly", 3.0}};
  EXPECT_THROW(create_model("moglow", kept, w.ctx), mosyn::Error);  // no style "elderly"
  kept["heel_label_weights"] = {{"run:*", 3.0}};
  EXPECT_EQ(create_model("moglow", kept, w.ctx)->config().at("heel_label_weights"), nlohmann::json({{"run:*", 3.0}}));
  EXPECT_FALSE(create_model("moglow", w.cfg, w.ctx)->config().contains("heel_label_weights"));
  for (const nlohmann::json& bad : {nlohmann::json({{"run", 2.0}}), nlohmann::json({{"run:*", -1.0}}),
                                    nlohmann::json({{"run:*", "x"}}), nlohmann::json({"run:*"})}) {
    nlohmann::json wrong = kept;
    wrong["heel_label_weights"] = bad;
    EXPECT_THROW(create_model("moglow", wrong, w.ctx), mosyn::Error) << bad.dump();
  }
}

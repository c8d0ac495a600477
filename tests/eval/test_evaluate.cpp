// eval::evaluate on a tiny synthetic dataset with a tiny MoGlow run, a tiny recurrent VAE and a
// tiny classifier trained here for a few steps: every metric present and finite, the real-data
// column equal to the metrics computed directly on the decoded held-out clips; the report page.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <torch/utils.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <filesystem>

#include "core/error.h"
#include "data/prepare.h"
#include "eval/compare.h"
#include "eval/evaluate.h"
#include "data/control.h"
#include "eval/path_protocol.h"
#include "eval/protocol.h"
#include "eval/protocols/protocols.h"
#include "eval/report.h"
#include "metrics/set_metrics.h"
#include "nn/run.h"
#include "nn/training/train.h"

using namespace mosyn;
namespace fs = std::filesystem;
using ::testing::HasSubstr;

namespace {

class EvaluateTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    torch::set_num_threads(1);
    root_ = new fs::path(fs::temp_directory_path() / ("mosyn_evaluate_" + std::to_string(::getpid())));
    fs::remove_all(*root_);
    fs::create_directories(*root_);
    // The committed tiny models of tests/models (scripts/make_test_models.sh): MoGlow and the
    // classifier on the synthetic walks' joint rotations, the recurrent VAE on their positions.
    const fs::path models = fs::path(MOSYN_SOURCE_DIR) / "tests" / "models";
    for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
             {"dataset-rotations", "dataset"}, {"dataset-positions", "positions"}, {"moglow", "run"},
             {"rvae", "rvae"}, {"classifier", "classifier"}})
      fs::copy(models / from, *root_ / to, fs::copy_options::recursive);
    dataset_ = new data::Dataset(data::Dataset::open((*root_ / "dataset").string()));
    positions_ = new data::Dataset(data::Dataset::open((*root_ / "positions").string()));

    eval::EvalOptions e;
    e.num_samples = 3;
    e.max_clips = 4;
    e.seed = 5;
    e.prefix_s = 0.5;
    e.horizon_s = 1.0;
    e.error_frames = {20, 60, 120};  // 0.33, 1, 2 s: frames 10, 30, 60 of the 90-frame clips
    e.classifier_dir = (*root_ / "classifier").string();
    e.threads = 1;
    result_ = new eval::EvalResult(eval::evaluate((*root_ / "run").string(), *dataset_, e,
                                                  [](const eval::EvalProgress& pr) { ++progress_calls_; }));
  }
  static void TearDownTestSuite() {
    delete result_;
    delete dataset_;
    delete positions_;
    fs::remove_all(*root_);
    delete root_;
  }
  static fs::path* root_;
  static data::Dataset* dataset_;
  static data::Dataset* positions_;
  static eval::EvalResult* result_;
  static int progress_calls_;
};
fs::path* EvaluateTest::root_ = nullptr;
data::Dataset* EvaluateTest::dataset_ = nullptr;
data::Dataset* EvaluateTest::positions_ = nullptr;
eval::EvalResult* EvaluateTest::result_ = nullptr;
int EvaluateTest::progress_calls_ = 0;

}  // namespace

TEST_F(EvaluateTest, EveryMetricIsPresentAndFinite) {
  const eval::EvalResult& r = *result_;
  EXPECT_EQ(r.family, "moglow");
  EXPECT_EQ(r.num_samples, 3);
  EXPECT_EQ(r.clips.size(), 4u);
  EXPECT_EQ(r.prediction_windows, 4);
  EXPECT_GT(progress_calls_, 4);
  for (const char* key :
       {"motions", "frames", "footsteps.max_steps", "foot_skating_ratio", "pelvis_ground_speed_mps", "bone_length_rmse_cm", "spectral_entropy",
        "apd_m", "mean_pose_distance_m", "diversity.apd_m", "diversity.mean_pose_distance_m", "fse",
        "prediction.apd_m", "prediction.ade_m", "prediction.fde_m", "prediction.mmade_m", "prediction.mmfde_m",
        "prediction.fse", "joint_error.motion_prior.f20", "joint_error.pose_prior.f120",
        "joint_error.motion_initial.f60", "joint_error.pose_initial.f20", "validity.bdf_m", "classifier.content_acc", "classifier.style_acc", "classifier.is", "classifier.fid"}) {
    SCOPED_TRACE(key);
    ASSERT_NO_THROW(r.row(key));
    EXPECT_TRUE(std::isfinite(r.row(key).model));
  }
  // Real data: one motion per control, so no per-control diversity and no prediction error.
  EXPECT_TRUE(std::isnan(r.row("diversity.apd_m").real));
  EXPECT_TRUE(std::isnan(r.row("prediction.ade_m").real));
  EXPECT_EQ(r.row("fse").real, 0.0);
  EXPECT_LT(r.row("validity.bdf_m").model, 1e-6);  // decoded through the skeleton: exact bones
  EXPECT_TRUE(std::isfinite(r.row("classifier.fid").real));  // two halves of the real clips
  EXPECT_GT(r.row("diversity.apd_m").model, 0.0);
  EXPECT_GE(r.row("prediction.mmade_m").model, 0.0);
  // The constant-velocity baseline of the same windows, and the model's ADE over it.
  EXPECT_GT(r.row("prediction.cv_ade_m").model, 0.0);
  EXPECT_GT(r.row("prediction.cv_fde_m").model, 0.0);
  EXPECT_NEAR(r.row("prediction.ade_over_cv").model, r.row("prediction.ade_m").model / r.row("prediction.cv_ade_m").model,
              1e-12);
  EXPECT_GE(r.row("classifier.is").model, 1.0 - 1e-9);
  EXPECT_EQ(r.row("motions").model, 4.0);  // one replicate set per sample index, as many motions as clips
  EXPECT_EQ(r.row("motions").real, 4.0);
  EXPECT_EQ(r.joint_error_clips, 4);
  EXPECT_TRUE(std::isnan(r.row("joint_error.motion_prior.f60").real));
  for (const char* setting : {"motion_prior", "pose_prior", "motion_initial", "pose_initial"})
    for (int f : {20, 60, 120}) EXPECT_GT(r.row(std::string("joint_error.") + setting + ".f" + std::to_string(f)).model, 0.0);
  EXPECT_THAT(r.row("joint_error.pose_initial.f120").label, HasSubstr("4 initial frames at 2.00 s (cm)"));
}

// A classifier run is scored on the same held-out clips: its rows are the recognition protocol's
// real column (the same windows through the same network), and per label.
TEST_F(EvaluateTest, AClassifierIsScoredOnTheHeldOutClips) {
  eval::EvalOptions e;
  e.max_clips = 4;
  e.threads = 1;
  const eval::EvalResult c = eval::evaluate((*root_ / "classifier").string(), *dataset_, e);
  EXPECT_EQ(c.family, "classifier");
  EXPECT_EQ(c.clips, result_->clips);
  EXPECT_EQ(c.row("classifier.content_acc").model, result_->row("classifier.content_acc").real);
  EXPECT_EQ(c.row("classifier.style_acc").model, result_->row("classifier.style_acc").real);
  EXPECT_EQ(c.row("classifier.is").model, result_->row("classifier.is").real);
  EXPECT_EQ(c.row("classifier.fid_floor").model, result_->row("classifier.fid").real);
  EXPECT_TRUE(std::isnan(c.row("classifier.content_acc").real));
  EXPECT_GE(c.row("classifier.windows").model, 4.0);  // at least one window per clip
  // A row for every content the clips hold and none for the others.
  const data::DatasetInfo& info = dataset_->info();
  for (size_t k = 0; k < info.content_labels.size(); ++k) {
    bool held = false;
    for (int i : c.clip_indices) held |= dataset_->clips("val")[i].content == static_cast<int>(k);
    const std::string key = "classifier.content_acc." + info.content_labels[k];
    SCOPED_TRACE(key);
    bool found = false;
    for (const auto& row : c.rows) found |= row.key == key;
    EXPECT_EQ(found, held);
    if (found) EXPECT_TRUE(c.row(key).model >= 0 && c.row(key).model <= 100);
  }
}

TEST_F(EvaluateTest, JointErrorsNeedLongEnoughClips) {
  eval::EvalOptions e;
  e.num_samples = 1;
  e.max_clips = 2;
  e.prediction = false;
  e.threads = 1;
  e.error_frames = {70, 400};  // 400 @ 60 Hz = frame 200 of 90-frame clips: no clip qualifies
  const auto r = eval::evaluate((*root_ / "run").string(), *dataset_, e);
  EXPECT_EQ(r.joint_error_clips, 0);
  EXPECT_TRUE(std::isnan(r.row("joint_error.motion_prior.f70").model));
  e.error_frames = {2};  // frame 1 lies inside the 4 initial frames
  EXPECT_THROW(eval::evaluate((*root_ / "run").string(), *dataset_, e), Error);
  e.joint_errors = false;
  EXPECT_THROW(eval::evaluate((*root_ / "run").string(), *dataset_, e).row("joint_error.motion_prior.f2"), Error);
}

// The recurrent VAE is not streaming, yet continues a prefix: the same protocol runs without a
// family special case, prediction included; the rotation-form classifier scores its joint-position
// samples through decoding and re-encoding.
TEST_F(EvaluateTest, RecurrentVaeIsEvaluatedTheSameWay) {
  eval::EvalOptions e;
  e.num_samples = 2;
  e.max_clips = 2;
  e.prefix_s = 0.5;
  e.horizon_s = 1.0;
  e.warmup_s = 0;
  e.error_frames = {20, 120};
  e.threads = 1;
  e.classifier_dir = (*root_ / "classifier").string();
  const auto r = eval::evaluate((*root_ / "rvae").string(), *positions_, e);
  EXPECT_EQ(r.family, "rvae");
  EXPECT_EQ(r.prediction_windows, 2);
  EXPECT_EQ(r.joint_error_clips, 2);
  for (const char* key : {"foot_skating_ratio", "diversity.apd_m", "prediction.ade_m", "joint_error.motion_prior.f20",
                          "joint_error.pose_initial.f120", "classifier.content_acc", "classifier.is", "classifier.fid"}) {
    SCOPED_TRACE(key);
    EXPECT_TRUE(std::isfinite(r.row(key).model));
  }
  // The same held-out clips in either form (same files, same split seed).
  EXPECT_EQ(r.clips, (std::vector<std::string>{result_->clips[0], result_->clips[2]}));  // every other of 4
  EXPECT_TRUE(std::isfinite(r.row("classifier.is").real));
}

// The drawn-paths protocol and the foot-locked rows come in addition to the raw rows, which they
// leave unchanged.
TEST_F(EvaluateTest, DrawnPathsAndFootLockedRows) {
  eval::EvalOptions e;
  e.num_samples = 1;
  e.max_clips = 4;  // a walk among them
  e.prediction = false;
  e.joint_errors = false;
  e.threads = 1;
  const auto plain = eval::evaluate((*root_ / "run").string(), *dataset_, e);
  e.synthetic_paths = true;
  e.foot_lock = true;
  const auto r = eval::evaluate((*root_ / "run").string(), *dataset_, e);
  EXPECT_EQ(r.row("foot_skating_ratio").model, plain.row("foot_skating_ratio").model);
  EXPECT_EQ(r.row("paths.motions").model, static_cast<double>(eval::synthetic_paths().size()));
  // The paths ask for walking: their real column is the held-out walks' (the per-content walk
  // rows; pooled over every clip only when none of the chosen clips walks). These walks' footstep
  // tolerance differs from the pooled clips'.
  const double walk_skating = plain.row("locomotion.walk.foot_skating_ratio").real;
  const double walk_v_tol95 = plain.row("locomotion.walk.footsteps.v_tol95_cmps").real;
  EXPECT_NE(walk_v_tol95, plain.row("footsteps.v_tol95_cmps").real);
  EXPECT_EQ(r.row("paths.footsteps.v_tol95_cmps").real, walk_v_tol95);
  EXPECT_EQ(r.row("paths.foot_skating_ratio").real, walk_skating);
  // (The model column may be n/a: a 6-step model need not make footsteps along a drawn path.)
  EXPECT_TRUE(std::isfinite(r.row("paths.footsteps.v_tol95_cmps").real));
  for (const auto& path : eval::synthetic_paths()) {  // per path: the same real column, the path's own samples
    const std::string key = "paths." + path.name + ".foot_skating_ratio";
    EXPECT_EQ(r.row(key).real, walk_skating) << key;
    EXPECT_THAT(r.row(key).label, HasSubstr("(path " + path.name + ")"));
    EXPECT_NO_THROW(r.row("paths." + path.name + ".footsteps.v_tol95_cmps"));
  }
  EXPECT_THROW(r.row("paths.curve.apd_m"), Error);  // only footsteps and skating per path
  // Every drawn frame falls in one phase; the paths stand at the end, so some frames stand.
  double phase_frames = 0;
  for (const char* phase : {"steady", "changing", "standing"})
    phase_frames += r.row(std::string("paths.phases.") + phase + ".frames").model;
  EXPECT_GT(r.row("paths.phases.standing.frames").model, 0);
  EXPECT_GT(r.row("paths.phases.steady.frames").model, 0);
  EXPECT_EQ(phase_frames + static_cast<double>(eval::synthetic_paths().size()), r.row("paths.frames").model);
  EXPECT_TRUE(std::isnan(r.row("paths.phases.standing.slower_foot_speed_mps").real));  // no real standing
  EXPECT_TRUE(std::isfinite(r.row("paths.phases.steady.slower_foot_speed_mps").real));
  // The steady parts' footsteps beside the same real clips.
  EXPECT_EQ(r.row("paths.steady.foot_skating_ratio").real, walk_skating);
  EXPECT_THAT(r.row("paths.steady.footsteps.v_tol95_cmps").label, HasSubstr("(drawn paths, at speed)"));
  EXPECT_TRUE(std::isfinite(r.row("foot_locked.foot_skating_ratio").model));
  EXPECT_THAT(r.row("foot_locked.foot_skating_ratio").label, HasSubstr("(foot-locked)"));
}

// steady_parts cuts out the runs of steady frames that last at least min_frames, frame for frame.
TEST(PathProtocol, SteadyPartsCutTheLongSteadyRuns) {
  eval::MotionPositions m;
  m.name = "curve";
  m.num_frames = 100;
  m.num_joints = 2;
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < m.num_joints; ++j) m.positions_m.emplace_back(t, j, 0.5 * t);
  using P = eval::PathPhase;
  std::vector<P> phases;
  for (auto [phase, n] : std::vector<std::pair<P, int>>{
           {P::kChanging, 10}, {P::kSteady, 40}, {P::kChanging, 5}, {P::kSteady, 10}, {P::kStanding, 5}, {P::kSteady, 30}})
    phases.insert(phases.end(), n, phase);
  const auto parts = eval::steady_parts({m}, {phases}, 30);
  ASSERT_EQ(parts.size(), 2u);  // the 10-frame run is too short
  EXPECT_EQ(parts[0].num_frames, 40);
  EXPECT_EQ(parts[0].name, "curve");
  EXPECT_EQ(parts[0].position(0, 1), Eigen::Vector3d(10, 1, 5));
  EXPECT_EQ(parts[0].position(39, 0), Eigen::Vector3d(49, 0, 24.5));
  EXPECT_EQ(parts[1].num_frames, 30);
  EXPECT_EQ(parts[1].position(0, 0), Eigen::Vector3d(70, 0, 35));
  EXPECT_EQ(parts[1].positions_m.size(), 60u);
  EXPECT_TRUE(eval::steady_parts({m}, {phases}, 41).empty());
}

// A drawn path's phases: standing at the pause and at the end, starting and stopping around them,
// steady in between; exactly as the speed of the path as drawn says.
TEST(PathPhases, StartsStopsAndStandingOfADrawnPath) {
  data::PathOptions po;
  po.speed_mps = 1.0;
  po.fps = 10;
  po.accel_s = 0.5;
  const std::vector<float> control = data::control_from_path(data::parse_path("0,0 0,3,2 0,6"), po);
  const auto phases = eval::path_phases(control, po.fps, po.speed_mps);
  ASSERT_EQ(phases.size(), control.size() / 3);
  int counts[3] = {0, 0, 0};
  for (size_t t = 0; t < phases.size(); ++t) {
    const double v = std::hypot(control[3 * t], control[3 * t + 1]) * po.fps;
    const auto expected = v >= 0.9 ? eval::PathPhase::kSteady : v < 0.05 ? eval::PathPhase::kStanding : eval::PathPhase::kChanging;
    EXPECT_EQ(phases[t], expected) << t;
    ++counts[static_cast<int>(phases[t])];
  }
  EXPECT_GT(counts[0], 30);  // most of 6 m at 1 m/s
  EXPECT_GE(counts[2], 20);  // the 2-s pause
  EXPECT_GE(counts[1], 8);   // two starts and two stops of 0.5 s
  EXPECT_EQ(phases.front(), eval::PathPhase::kStanding);  // frame 0 carries no motion
  EXPECT_EQ(phases.back(), eval::PathPhase::kStanding);
}

TEST_F(EvaluateTest, RealColumnEqualsMetricsOfTheDecodedClips) {
  std::vector<eval::MotionPositions> real;
  for (int i : result_->clip_indices)
    real.push_back(eval::motion_positions(data::decode_record(dataset_->info(), dataset_->clips("val").at(i))));
  const auto rows = eval::set_metrics(real);
  for (const auto& m : rows) {
    SCOPED_TRACE(m.key);
    const double v = result_->row(m.key).real;
    if (std::isnan(m.value))
      EXPECT_TRUE(std::isnan(v));
    else
      EXPECT_DOUBLE_EQ(v, m.value);
  }
}

// Per content, the real column is the set metrics of that content's decoded clips alone.
TEST_F(EvaluateTest, PerContentRowsAgainstClipsOfThatContent) {
  const auto& info = dataset_->info();
  std::map<int, std::vector<eval::MotionPositions>> by_content;
  for (int i : result_->clip_indices) {
    const auto& rec = dataset_->clips("val").at(i);
    by_content[rec.content].push_back(eval::motion_positions(data::decode_record(info, rec)));
  }
  ASSERT_FALSE(by_content.empty());
  for (const auto& [content, real] : by_content) {
    if (content < 0) continue;
    const std::string name = info.content_labels.at(static_cast<size_t>(content));
    for (const auto& m : eval::set_metrics(real)) {
      const std::string key = "locomotion." + name + "." + m.key;
      if (m.key.rfind("footsteps.", 0) != 0 && m.key != "foot_skating_ratio" && m.key != "toe_slide_ratio" &&
          m.key != "pelvis_ground_speed_mps") {
        EXPECT_THROW(result_->row(key), Error) << key;  // only footsteps, skating, toe slide and pelvis speed per content
        continue;
      }
      const double v = result_->row(key).real;
      if (std::isnan(m.value)) EXPECT_TRUE(std::isnan(v)) << key;
      else EXPECT_DOUBLE_EQ(v, m.value) << key;
      EXPECT_THAT(result_->row(key).label, HasSubstr("(content " + name + ")"));
    }
  }
}

TEST_F(EvaluateTest, JsonRoundTripAndMarkdown) {
  const eval::EvalResult back = eval::EvalResult::from_json(result_->to_json());
  ASSERT_EQ(back.rows.size(), result_->rows.size());
  for (size_t i = 0; i < back.rows.size(); ++i) {
    EXPECT_EQ(back.rows[i].key, result_->rows[i].key);
    if (std::isfinite(result_->rows[i].model)) {
      EXPECT_DOUBLE_EQ(back.rows[i].model, result_->rows[i].model);
    }
  }
  EXPECT_EQ(back.clips, result_->clips);
  const std::string md = eval::format_markdown(*result_);
  EXPECT_THAT(md, HasSubstr("| metric | model | real data |"));
  EXPECT_THAT(md, HasSubstr("prediction ADE (m)"));
  EXPECT_THAT(md, HasSubstr("n/a"));
  EXPECT_THROW(eval::EvalResult::from_json({{"rows", 3}}), Error);
}

TEST_F(EvaluateTest, SameSeedSameNumbers) {
  eval::EvalOptions e;
  e.num_samples = 2;
  e.max_clips = 2;
  e.prediction = false;
  e.threads = 1;
  const auto a = eval::evaluate((*root_ / "run").string(), *dataset_, e);
  const auto b = eval::evaluate((*root_ / "run").string(), *dataset_, e);
  ASSERT_EQ(a.rows.size(), b.rows.size());
  for (size_t i = 0; i < a.rows.size(); ++i)
    if (std::isfinite(a.rows[i].model)) {
      EXPECT_EQ(a.rows[i].model, b.rows[i].model) << a.rows[i].key;
    }
  EXPECT_THROW(a.row("prediction.ade_m"), Error);  // prediction switched off
}

TEST_F(EvaluateTest, RejectsBadOptions) {
  eval::EvalOptions e;
  e.split = "test";
  EXPECT_THROW(eval::evaluate((*root_ / "run").string(), *dataset_, e), Error);
  e.split = "val";
  e.num_samples = 0;
  EXPECT_THROW(eval::evaluate((*root_ / "run").string(), *dataset_, e), Error);
  e.num_samples = 1;
  e.max_clips = 1;
  e.classifier_dir = (*root_ / "run").string();  // not a classifier
  EXPECT_THROW(eval::evaluate((*root_ / "run").string(), *dataset_, e), Error);
}

// The rows come protocol by protocol, in the order of all_protocols(): set metrics, diversity,
// joint errors, prediction, classifier (what `mosyn eval` always wrote).
TEST_F(EvaluateTest, ProtocolsRunInOrderAndRowsKeepTheirOrder) {
  EXPECT_EQ(result_->protocols,
            (std::vector<std::string>{"locomotion", "diversity", "joint_errors", "prediction", "body_validity",
                                      "recognition"}));
  auto group = [](const std::string& key) {
    for (const auto& [prefix, g] : std::vector<std::pair<std::string, int>>{
             {"diversity.", 1}, {"fse", 1}, {"joint_error.", 2}, {"prediction.", 3}, {"validity.", 4}, {"classifier.", 5}})
      if (key.rfind(prefix, 0) == 0) return g;
    return 0;
  };
  int last = 0;
  for (const auto& r : result_->rows) {
    EXPECT_GE(group(r.key), last) << r.key;
    last = group(r.key);
  }
  EXPECT_EQ(result_->rows.front().key, "motions");
  EXPECT_EQ(result_->rows.back().key, "classifier.fid");
  const std::vector<std::string> tail = {"diversity.apd_m", "diversity.mean_pose_distance_m", "fse",
                                         "joint_error.motion_prior.f20"};
  const auto at = std::find_if(result_->rows.begin(), result_->rows.end(),
                               [](const eval::EvalRow& r) { return r.key == "diversity.apd_m"; });
  ASSERT_NE(at, result_->rows.end());
  for (size_t i = 0; i < tail.size(); ++i) EXPECT_EQ((at + static_cast<long>(i))->key, tail[i]);
}

// A family that generates its root motion and cannot continue motion: no drawn paths, joint
// errors or prediction; the rest as for every family. (The traits are set on a loaded run.)
TEST_F(EvaluateTest, TraitsDecideWhichProtocolsRun) {
  nn::LoadedRun run = nn::load_run((*root_ / "run").string());
  run.traits.control = nn::InputUse::kGenerates;
  run.traits.prefix = false;
  eval::EvalOptions e;
  e.num_samples = 2;
  e.max_clips = 2;
  e.synthetic_paths = true;
  e.threads = 1;
  const auto r = eval::evaluate(run, *dataset_, e);
  EXPECT_EQ(r.protocols, (std::vector<std::string>{"locomotion", "diversity"}));
  EXPECT_NO_THROW(r.row("foot_skating_ratio"));
  EXPECT_NO_THROW(r.row("diversity.apd_m"));
  EXPECT_THROW(r.row("paths.motions"), Error);
  EXPECT_THROW(r.row("joint_error.motion_prior.f70"), Error);
  EXPECT_THROW(r.row("prediction.ade_m"), Error);
  EXPECT_EQ(r.prediction_windows, 0);
}

TEST_F(EvaluateTest, LongHorizonRowsArePerWindowAndFinite) {
  eval::EvalOptions e;
  e.num_samples = 2;
  e.max_clips = 2;
  e.prediction = false;
  e.joint_errors = false;
  e.threads = 1;
  e.long_horizon_s = 4.0;
  e.long_horizon_window_s = 2.0;
  const auto r = eval::evaluate((*root_ / "run").string(), *dataset_, e);
  EXPECT_EQ(r.protocols.back(), "long_horizon");
  for (const char* key : {"long_horizon.bone_length_rmse_cm.w0", "long_horizon.bone_length_rmse_cm.w1",
                          "long_horizon.foot_skating_ratio.w0", "long_horizon.foot_skating_ratio.w1",
                          "long_horizon.body_speed_mps.w0", "long_horizon.body_speed_mps.w1",
                          "long_horizon.body_speed_ratio", "long_horizon.frozen_fraction",
                          "long_horizon.exploded_fraction"}) {
    SCOPED_TRACE(key);
    EXPECT_TRUE(std::isfinite(r.row(key).model));
  }
  EXPECT_THROW(r.row("long_horizon.body_speed_mps.w2"), Error);  // 4 s in 2-s windows
  EXPECT_TRUE(std::isfinite(r.row("long_horizon.body_speed_mps.w0").real));
  EXPECT_GT(r.row("long_horizon.body_speed_mps.w1").model, 0.0);
  EXPECT_THAT(r.row("long_horizon.body_speed_mps.w1").label, HasSubstr("long horizon 2-4 s: body speed"));
  EXPECT_EQ(r.row("long_horizon.exploded_fraction").model, 0.0);
  // Off by default: the rows of the default evaluation do not change.
  EXPECT_THROW(result_->row("long_horizon.frozen_fraction"), Error);
}

// The within-2x rows of a prefix-generation result: the real column is how often the real clips
// themselves pass (a fraction), and each overall fraction, model and real, is the sample-weighted
// mean of its per-content rows, so it lies between the smallest and the largest of them.
void expect_within_2x_rows(const eval::EvalResult& r) {
  for (const std::string key : {"prefix_generation.body_speed_within_2x", "prefix_generation.root_speed_within_2x"}) {
    SCOPED_TRACE(key);
    const eval::EvalRow& overall = r.row(key);
    EXPECT_GE(overall.real, 0.0);
    EXPECT_LE(overall.real, 1.0);
    double lowest[2] = {2, 2}, highest[2] = {-1, -1};
    for (const auto& row : r.rows) {
      if (row.key.rfind(key + ".", 0) != 0) continue;
      EXPECT_THAT(row.label, HasSubstr("prefixes ("));
      const double v[2] = {row.model, row.real};
      for (int k = 0; k < 2; ++k) {
        lowest[k] = std::min(lowest[k], v[k]);
        highest[k] = std::max(highest[k], v[k]);
      }
    }
    ASSERT_LE(highest[0], 1.0);
    EXPECT_GE(lowest[0], 0.0);
    EXPECT_LE(lowest[0], overall.model + 1e-12);
    EXPECT_GE(highest[0], overall.model - 1e-12);
    EXPECT_LE(lowest[1], overall.real + 1e-12);
    EXPECT_GE(highest[1], overall.real - 1e-12);
  }
}

// Generation from held-out prefixes (DFN, Chen et al. 2020): stability rows against the real clips,
// Fig. 9's curves (zero spread over the shared prefix, some after it, the training data's level
// beside them), transitions by the classifier, and the curves through the JSON file.
TEST_F(EvaluateTest, PrefixGenerationRowsAndFig9Curves) {
  eval::EvalOptions e;
  e.num_samples = 3;
  e.max_clips = 4;
  e.prediction = false;
  e.joint_errors = false;
  e.threads = 1;
  e.prefix_generation_s = 4.0;
  e.prefix_generation_frames = 20;
  e.prefix_generation_clips = 2;
  e.long_horizon_window_s = 2.0;
  e.classifier_dir = (*root_ / "classifier").string();  // transitions in its training window (default)
  e.only_protocols = {"prefix_generation"};
  const auto r = eval::evaluate((*root_ / "run").string(), *dataset_, e);
  {
    // The default is the classifier's training window, 30 frames = 1 s: the same counts as 1 s given.
    eval::EvalOptions given = e;
    given.transition_window_s = 1.0;
    const auto g = eval::evaluate((*root_ / "run").string(), *dataset_, given);
    for (const char* key : {"prefix_generation.content_changes_per_min", "prefix_generation.contents_per_sample"}) {
      EXPECT_DOUBLE_EQ(g.row(key).model, r.row(key).model) << key;
      EXPECT_DOUBLE_EQ(g.row(key).real, r.row(key).real) << key;
    }
  }
  EXPECT_EQ(r.protocols, (std::vector<std::string>{"prefix_generation"}));
  for (const char* key : {"prefix_generation.body_speed_mps.last", "prefix_generation.root_speed_mps.last",
                          "prefix_generation.root_height_m", "prefix_generation.content_changes_per_min",
                          "prefix_generation.contents_per_sample"}) {
    SCOPED_TRACE(key);
    EXPECT_TRUE(std::isfinite(r.row(key).model));
    EXPECT_TRUE(std::isfinite(r.row(key).real));
  }
  for (const char* key : {"prefix_generation.body_speed_within_2x", "prefix_generation.root_speed_within_2x",
                          "prefix_generation.root_height_in_range", "prefix_generation.frozen_fraction",
                          "prefix_generation.exploded_fraction"}) {
    SCOPED_TRACE(key);
    EXPECT_GE(r.row(key).model, 0.0);
    EXPECT_LE(r.row(key).model, 1.0);
  }
  EXPECT_GE(r.row("prefix_generation.contents_per_sample").model, 1.0);
  expect_within_2x_rows(r);
  // 20 + 120 frames in windows of 60: three windows, the training level as the real column.
  EXPECT_NO_THROW(r.row("prefix_generation.mean_pose_distance_m.w2"));
  EXPECT_THROW(r.row("prefix_generation.mean_pose_distance_m.w3"), Error);
  ASSERT_EQ(r.curves.size(), 2u);
  for (const auto& c : r.curves) {
    SCOPED_TRACE(c.key);
    ASSERT_EQ(c.mean.size(), 140u);
    ASSERT_EQ(c.spread.size(), 140u);
    EXPECT_DOUBLE_EQ(c.fps, 30.0);
    for (int t = 0; t < 20; ++t) EXPECT_NEAR(c.mean[t], 0.0, 1e-6);  // every sample shares the observed frames
    EXPECT_GT(*std::max_element(c.mean.begin() + 20, c.mean.end()), 1e-3);
    EXPECT_GT(c.reference_mean, 0.0);
    EXPECT_GE(c.reference_spread, 0.0);
    EXPECT_DOUBLE_EQ(r.row("prefix_generation.mean_pose_distance_m.w0").real, c.reference_mean);
  }
  const eval::EvalResult back = eval::EvalResult::from_json(nlohmann::json::parse(r.to_json().dump()));
  ASSERT_EQ(back.curves.size(), r.curves.size());
  EXPECT_EQ(back.curves[1].key, r.curves[1].key);
  EXPECT_EQ(back.curves[1].label, r.curves[1].label);
  for (size_t t = 0; t < r.curves[1].mean.size(); ++t) {
    EXPECT_NEAR(back.curves[1].mean[t], r.curves[1].mean[t], 1e-12);
    EXPECT_NEAR(back.curves[1].spread[t], r.curves[1].spread[t], 1e-12);
  }
  EXPECT_DOUBLE_EQ(back.curves[0].reference_mean, r.curves[0].reference_mean);
  // Off by default, and the JSON of an evaluation without curves has none.
  EXPECT_TRUE(result_->curves.empty());
  EXPECT_FALSE(result_->to_json().contains("curves"));
}

// Generation by label alone (Ghorbani et al. 2020, Table 2): every content x style combination
// sampled K times, IS of both heads, FID overall and per label with the real split-half floor.
TEST_F(EvaluateTest, LabelGenerationScoresEveryCombination) {
  // The tiny MoGlow is not conditioned on labels: it stands in for one that is (labels are passed
  // and ignored), which is all the protocol's bookkeeping needs.
  nn::LoadedRun run = nn::load_run((*root_ / "run").string());
  run.traits.labels = true;
  eval::EvalOptions e;
  e.num_samples = 1;
  e.max_clips = 2;
  e.threads = 1;
  e.label_samples = 3;
  e.label_seconds = 1.0;
  e.classifier_dir = (*root_ / "classifier").string();
  e.only_protocols = {"label_generation"};
  const auto r = eval::evaluate(run, *dataset_, e);
  EXPECT_EQ(r.protocols, (std::vector<std::string>{"label_generation"}));
  EXPECT_EQ(r.row("label_generation.samples").model, 4 * 2 * 3);  // contents x styles x K
  // Real: the original held-out clips in the classifier's windows (30 frames, hop 15; the tail too).
  int real_windows = 0;
  for (const data::ClipRecord& c : dataset_->clips("val")) {
    if (c.mirrored || c.reversed) continue;
    const int frames = c.num_frames;
    real_windows += frames <= 30 ? 1 : (frames - 30) / 15 + 1 + ((frames - 30) % 15 != 0);
  }
  EXPECT_EQ(r.row("label_generation.samples").real, real_windows);
  for (const char* key : {"label_generation.is_content", "label_generation.is_style", "label_generation.fid",
                          "label_generation.content_acc", "label_generation.style_acc"}) {
    SCOPED_TRACE(key);
    EXPECT_TRUE(std::isfinite(r.row(key).model));
  }
  // Inception scores lie in [1, number of classes].
  EXPECT_GE(r.row("label_generation.is_content").model, 1.0 - 1e-9);
  EXPECT_LE(r.row("label_generation.is_content").model, 4.0 + 1e-9);
  EXPECT_LE(r.row("label_generation.is_style").model, 2.0 + 1e-9);
  EXPECT_GE(r.row("label_generation.fid").model, 0.0);
  EXPECT_NO_THROW(r.row("label_generation.fid.content.walk"));
  EXPECT_NO_THROW(r.row("label_generation.fid.style.brisk"));
  // A run without labels has no such protocol; without a classifier it is off.
  run.traits.labels = false;
  EXPECT_TRUE(eval::evaluate(run, *dataset_, e).protocols.empty());
  EXPECT_THROW(result_->row("label_generation.fid"), Error);
}

// A label-conditioned run samples each held-out clip with the clip's own labels, or, with
// EvalOptions::clip_labels off (mosyn eval --no-labels), with none.
TEST_F(EvaluateTest, ClipLabelsGoToLabelledRunsUnlessTurnedOff) {
  nn::LoadedRun run = nn::load_run((*root_ / "run").string());
  eval::EvalOptions e;
  e.max_clips = 3;
  e.threads = 1;
  const eval::EvalContext unlabelled(run, *dataset_, e);
  EXPECT_EQ(unlabelled.clip_labels(0).content, -1);  // the run takes no labels
  run.traits.labels = true;  // the tiny MoGlow stands in for a labelled run, as above
  const eval::EvalContext labelled(run, *dataset_, e);
  e.clip_labels = false;
  const eval::EvalContext turned_off(run, *dataset_, e);
  for (size_t i = 0; i < labelled.num_clips(); ++i) {
    const data::ClipRecord& rec = labelled.clip(i);
    ASSERT_GE(rec.content, 0);
    EXPECT_EQ(labelled.clip_labels(i).content, rec.content);
    EXPECT_EQ(labelled.clip_labels(i).style, rec.style);
    EXPECT_EQ(turned_off.clip_labels(i).content, -1);
    EXPECT_EQ(turned_off.clip_labels(i).style, -1);
  }
}

// Three runs on two datasets: one column per run, one real column per dataset, n/a where a
// protocol does not apply (the run without prefix has no prediction).
TEST_F(EvaluateTest, CompareRunsSideBySide) {
  const nn::LoadedRun moglow = nn::load_run((*root_ / "run").string());
  nn::LoadedRun no_prefix = moglow;
  no_prefix.traits.prefix = false;
  const nn::LoadedRun rvae = nn::load_run((*root_ / "rvae").string());
  eval::CompareOptions o;
  o.eval.num_samples = 2;
  o.eval.max_clips = 2;
  o.eval.prefix_s = 0.5;
  o.eval.horizon_s = 1.0;
  o.eval.error_frames = {20, 60};
  o.eval.warmup_s = 0;
  o.eval.threads = 1;
  o.showcase_samples = 1;
  o.showcase_seconds = 1.0;
  const auto r = eval::compare({{"moglow", &moglow, dataset_, "rot"}, {"noprefix", &no_prefix, dataset_, "rot"},
                                {"rvae", &rvae, positions_, "pos"}},
                               o);
  ASSERT_EQ(r.columns.size(), 5u);
  EXPECT_EQ(r.columns[3].name, "real (rot)");
  EXPECT_EQ(r.columns[4].name, "real (pos)");
  auto row = [&](const std::string& key) -> const eval::CompareRow& {
    for (const auto& x : r.rows)
      if (x.key == key) return x;
    throw Error("no row " + key);
  };
  const auto& ade = row("prediction.ade_m");
  EXPECT_TRUE(std::isfinite(ade.values[0]));
  EXPECT_TRUE(std::isnan(ade.values[1]));  // n/a: no prefix
  EXPECT_TRUE(std::isfinite(ade.values[2]));
  EXPECT_TRUE(std::isnan(ade.values[3]));
  const auto& skating = row("foot_skating_ratio");
  for (double v : skating.values) EXPECT_TRUE(std::isfinite(v));
  // The real columns are the evaluations' real values.
  EXPECT_EQ(row("motions").values[3], 2.0);
  EXPECT_EQ(skating.values[4], r.evaluations[2].row("foot_skating_ratio").real);
  EXPECT_EQ(r.rows.front().key, "motions");
  EXPECT_EQ(r.showcase.size(), 5u);  // one per run, one real clip per dataset
  const std::string md = eval::format_compare_markdown(r);
  EXPECT_THAT(md, HasSubstr("| metric | moglow | noprefix | rvae | real (rot) | real (pos) |"));
  EXPECT_THAT(md, HasSubstr("n/a"));
  const nlohmann::json j = r.to_json();
  EXPECT_EQ(j["format"], "mosyn-compare-1");
  EXPECT_TRUE(j["metrics"]["prediction.ade_m"]["noprefix"].is_null());
  EXPECT_TRUE(j["metrics"]["prediction.ade_m"]["rvae"].is_number());
  EXPECT_EQ(j["runs"][2]["family"], "rvae");
  const std::string html = eval::compare_html(r, "cmp <x>", "<html>viewer</html>", "note");
  EXPECT_THAT(html, HasSubstr("cmp &lt;x&gt;"));
  EXPECT_THAT(html, HasSubstr("<th>real (pos)</th>"));
  EXPECT_THAT(html, HasSubstr("srcdoc=\"&lt;html&gt;viewer"));
  EXPECT_THROW(eval::compare({}, o), Error);
}

// Clips longer than the classifier's training window (its config's train.window, 30 frames) are
// scored in its windows (starts 0, 15, ... and one ending at the last frame), each window one
// entry with the clip's labels.
TEST(ClassifierInputs, LongMotionsAreCutIntoTheClassifiersWindows) {
  const fs::path models = fs::path(MOSYN_SOURCE_DIR) / "tests" / "models";
  const nn::LoadedRun cls = nn::load_run((models / "classifier").string());
  const data::DatasetInfo& info = cls.dataset;
  ASSERT_EQ(eval::detail::training_window(cls), 30);
  ASSERT_EQ(info.window_frames, 40);  // the dataset's windows, not the ones it was trained on
  const int d = info.layout.pose_dim, c = info.layout.control_dim, frames = 80;
  std::vector<float> pose(static_cast<size_t>(frames) * d), control(static_cast<size_t>(frames) * c);
  for (size_t i = 0; i < pose.size(); ++i) pose[i] = static_cast<float>(i / d);  // value = frame index
  for (size_t i = 0; i < control.size(); ++i) control[i] = static_cast<float>(i / c);
  eval::detail::ClassifierInputs set(cls, info);
  EXPECT_EQ(set.add_in_windows(pose, control, "long", 2, 3), 5);  // 0, 15, 30, 45 and 50 (the tail)
  EXPECT_EQ(set.add_in_windows(std::vector<float>(pose.begin(), pose.begin() + 30 * d),
                               std::vector<float>(control.begin(), control.begin() + 30 * c), "one window"),
            1);
  EXPECT_EQ(set.add_in_windows(std::vector<float>(pose.begin(), pose.begin() + 25 * d),
                               std::vector<float>(control.begin(), control.begin() + 25 * c), "short"),
            1);
  ASSERT_EQ(set.poses.size(), 7u);
  const std::vector<int> first_frames = {0, 15, 30, 45, 50, 0, 0};
  for (size_t k = 0; k < set.poses.size(); ++k) {
    const size_t len = set.poses[k].size() / d;
    EXPECT_EQ(len, k < 6 ? 30u : 25u) << k;
    EXPECT_EQ(set.poses[k].front(), static_cast<float>(first_frames[k])) << k;
    EXPECT_EQ(set.poses[k].back(), static_cast<float>(first_frames[k] + len - 1)) << k;
    EXPECT_EQ(set.controls[k].size(), len * c) << k;
    EXPECT_EQ(set.controls[k].front(), static_cast<float>(first_frames[k])) << k;
    EXPECT_EQ(set.content[k], k < 5 ? 2 : -1);
    EXPECT_EQ(set.style[k], k < 5 ? 3 : -1);
  }
  const nn::ClassifierOutputs out = set.classify();
  EXPECT_EQ(out.num_windows, 7);
}

TEST(Report, TrainingCurveSvgAndPage) {
  eval::TrainingCurve c;
  c.step = {1, 2, 3, 4};
  c.loss = {3.0, 2.0, 1.5, 1.2};
  c.val_step = {2, 4};
  c.val_loss = {2.5, 1.4};
  const std::string svg = eval::training_curve_svg(c);
  EXPECT_THAT(svg, HasSubstr("<svg"));
  EXPECT_THAT(svg, HasSubstr("class=\"loss\""));
  EXPECT_THAT(svg, HasSubstr("class=\"val_loss\""));
  EXPECT_THAT(eval::training_curve_svg({}), HasSubstr("no logged steps"));

  eval::ReportInputs in;
  in.title = "run <1>";
  in.config = {{"family", "moglow"}, {"model", {{"hidden", 16}}}};
  in.curve = c;
  eval::EvalResult m;
  m.rows = {{"fse", "FSE (nats)", 0.25, 0.0}, {"diversity.apd_m", "APD", 1.5, std::nan("")}};
  in.metrics = m;
  in.viewer_page = "<html><body>\"viewer\"</body></html>";
  const std::string html = eval::report_html(in);
  EXPECT_THAT(html, HasSubstr("run &lt;1&gt;"));
  EXPECT_THAT(html, HasSubstr("<svg"));
  EXPECT_THAT(html, HasSubstr("<td>FSE (nats)</td><td>0.25</td><td>0</td>"));
  EXPECT_THAT(html, HasSubstr("<td>1.5</td><td>n/a</td>"));
  EXPECT_THAT(html, HasSubstr("srcdoc=\"&lt;html&gt;&lt;body&gt;&quot;viewer&quot;"));
  EXPECT_THAT(html, HasSubstr("&quot;hidden&quot;: 16"));
}

// The recurrent VAE through the same commands as every family: `train rvae` (resume included),
// `sample` along a path of any length, `sample --continue` from observed frames, `eval`.
// Trained on the joint-position form, as the paper, so BVH output goes through IK.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "core/kinematics.h"
#include "data/augment.h"
#include "data/prepare.h"
#include "io/bvh.h"
#include "io/json_file.h"
#include "io/npy.h"

namespace mosyn {
namespace {

using testing::fresh_dir;
using testing::run_mosyn;
using ::testing::HasSubstr;

class CliRvaeTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new std::string(fresh_dir("cli_rvae").string());
    // The committed tiny rvae (4 steps) on joint positions of the synthetic walks.
    data::write_synthetic_source(*root_ + "/source", 2, 90, 3);
    testing::copy_test_model(*root_, "dataset-positions", "dataset");
    testing::copy_test_model(*root_, "rvae", "run");
  }
  static void TearDownTestSuite() { delete root_; }
  static std::string* root_;
};
std::string* CliRvaeTest::root_ = nullptr;

TEST_F(CliRvaeTest, ResumesAndSamplesAPathOfAnyLength) {
  const nlohmann::json config = io::read_json(*root_ + "/run/config.json");
  EXPECT_EQ(config["family"], "rvae");
  EXPECT_EQ(config["model"]["kernel"], 5);
  const auto resumed = run_mosyn("train rvae --data " + *root_ + "/dataset --out " + *root_ + "/run --resume --steps 6 "
                                 "--threads 1");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  // The resumed steps keep the run's own schedule (tiny.json: no warm-up, batch 4), not the flags'
  // defaults (a 1000-step Noam warm-up): the learning rate stays the peak.
  std::ifstream log(*root_ + "/run/log.jsonl");
  std::string line;
  int resumed_lines = 0;
  while (std::getline(log, line)) {
    const nlohmann::json j = nlohmann::json::parse(line);
    if (j["step"].get<int>() <= 4) continue;
    ++resumed_lines;
    EXPECT_DOUBLE_EQ(j["lr"].get<double>(), 1e-3) << line;
  }
  EXPECT_GT(resumed_lines, 0);
  // 7.3 s at 30 fps: 220 frames, neither the training window nor a multiple of the pooling.
  const auto r = run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/path --n 2 --seed 3 --seconds 7.3 "
                           "--path '0,0 0,3 2,5' --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::BvhFile bvh = io::read_bvh(*root_ + "/path/sample_000.bvh");
  EXPECT_EQ(bvh.num_frames, 220);
  const nlohmann::json sidecar = io::read_json(*root_ + "/path/sample_001.json");
  EXPECT_EQ(sidecar["model"]["family"], "rvae");
  EXPECT_EQ(sidecar["model"]["step"], 6);
}

// The observed frames come back unchanged (positions form: IK then FK, exact up to float
// rounding), placed where the file has them; the continuation follows.
TEST_F(CliRvaeTest, ContinuesObservedFrames) {
  const std::string file = *root_ + "/source/data/dataset-9_walk_normal_001.bvh";
  const auto r = run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/cont --n 2 --continue " + file +
                           " --observed-frames 4 --path '0,0 0,2' --positions --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json sidecar = io::read_json(*root_ + "/cont/sample_000.json");
  EXPECT_EQ(sidecar["continued"]["observed_frames"], 4);
  const io::NpyArray out = io::read_npy(*root_ + "/cont/sample_000.npy");  // [T, J, 3] metres
  const std::vector<double> values = out.to_float64();
  const io::BvhFile out_bvh = io::read_bvh(*root_ + "/cont/sample_000.bvh");
  const Clip source = io::to_clip(io::read_bvh(file));
  const WorldPoses truth = forward_kinematics(source.skeleton, source.motion);
  const double m_per_unit = 0.01;  // the synthetic source is in centimetres
  const int joints = static_cast<int>(out.shape[1]);
  const Clip out_clip = io::to_clip(out_bvh);
  int compared = 0;
  for (int j = 0; j < joints; ++j) {
    const std::string& name = out_clip.skeleton.joint_names[j];
    const auto it = std::find(source.skeleton.joint_names.begin(), source.skeleton.joint_names.end(), name);
    ASSERT_NE(it, source.skeleton.joint_names.end()) << name;
    const int sj = static_cast<int>(it - source.skeleton.joint_names.begin());
    for (int t = 0; t < 4; ++t)
      for (int k = 0; k < 3; ++k) {
        const double expected = truth.positions[static_cast<size_t>(t) * source.skeleton.num_joints() + sj][k] * m_per_unit;
        EXPECT_NEAR(values[(static_cast<size_t>(t) * joints + j) * 3 + k], expected, 2e-3) << name << " t " << t;
        ++compared;
      }
  }
  EXPECT_EQ(compared, joints * 12);
  EXPECT_GT(io::read_bvh(*root_ + "/cont/sample_001.bvh").num_frames, 4 + 30);
}

TEST_F(CliRvaeTest, ContinueErrors) {
  const std::string file = *root_ + "/source/data/dataset-9_walk_normal_001.bvh";
  const std::string base = "sample " + *root_ + "/run --out " + *root_ + "/e --threads 1 ";
  EXPECT_EQ(run_mosyn(base + "--continue " + file + " --observed-frames 0").exit_code, 2);
  EXPECT_EQ(run_mosyn(base + "--continue " + file + " --observed -1").exit_code, 2);
  EXPECT_EQ(run_mosyn(base + "--warmup -2").exit_code, 2);
  const auto missing = run_mosyn(base + "--continue /nonexistent/walk.bvh");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("/nonexistent/walk.bvh"));
  const auto too_short = run_mosyn(base + "--continue " + file + " --observed-frames 500");
  EXPECT_EQ(too_short.exit_code, 1);
  EXPECT_THAT(too_short.err, HasSubstr("observed frames"));
  const auto nothing_left = run_mosyn(base + "--continue " + file + " --observed-frames 90");
  EXPECT_EQ(nothing_left.exit_code, 2);
  EXPECT_THAT(nothing_left.err, HasSubstr("--path"));
  // Another skeleton: the synthetic biped without its hands.
  Clip other = io::to_clip(io::read_bvh(file));
  other = data::subset_by_patterns(other, {"Hand_*"}, {});
  io::write_bvh(*root_ + "/handless.bvh", io::from_clip(other));
  const auto wrong = run_mosyn(base + "--continue " + *root_ + "/handless.bvh");
  EXPECT_EQ(wrong.exit_code, 1);
  EXPECT_THAT(wrong.err, HasSubstr("skeleton differs"));
}

TEST_F(CliRvaeTest, EvalReportsThePaperErrors) {
  const std::string args = "eval " + *root_ + "/run --data " + *root_ + "/dataset --n 2 --max-clips 2 "
                           "--prefix 0.5 --horizon 1 --error-frames 20,60,120 --threads 1";
  const auto e = run_mosyn(args);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  // The family's default warm-up is none: the same numbers as --warmup 0, not as --warmup 1.
  EXPECT_EQ(run_mosyn(args + " --warmup 0").out, e.out);
  EXPECT_NE(run_mosyn(args + " --warmup 1").out, e.out);
  EXPECT_EQ(run_mosyn(args + " --warmup -1").exit_code, 2);
  EXPECT_THAT(e.out, HasSubstr("motion error, prior sample at 0.33 s (cm)"));
  EXPECT_THAT(e.out, HasSubstr("pose error (root-relative), 4 initial frames at 2.00 s (cm)"));
  EXPECT_THAT(e.out, HasSubstr("prediction ADE (m)"));
}

}  // namespace
}  // namespace mosyn

// `mosyn data prepare`, `data info`, `train` and `sample` end to end on a small synthetic source.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "core/synthetic.h"
#include "data/prepare.h"
#include "io/atomic_file.h"
#include "io/bvh.h"
#include "io/json_file.h"
#include "io/npy.h"

namespace mosyn {
namespace {

using testing::fresh_dir;
using testing::run_mosyn;
using testing::slurp;
using ::testing::HasSubstr;

// One synthetic source, dataset and tiny run shared by the tests of this file.
class CliModelTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new std::string(fresh_dir("cli_model").string());
    testing::make_tiny_moglow_run(*root_);
  }
  static void TearDownTestSuite() { delete root_; }
  static std::string* root_;
};
std::string* CliModelTest::root_ = nullptr;

TEST_F(CliModelTest, DataInfoDescribesTheDataset) {
  const auto r = run_mosyn("data info " + *root_ + "/dataset");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("rotations"));
  EXPECT_THAT(r.out, HasSubstr("walk-turn-left"));
}

TEST_F(CliModelTest, PrepareRefusesToOverwriteWithoutFlag) {
  const auto r = run_mosyn("data prepare " + *root_ + "/source --out " + *root_ + "/dataset");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr(*root_ + "/dataset"));
}

TEST_F(CliModelTest, PrepareRejectsBadFlagValues) {
  EXPECT_EQ(run_mosyn("data prepare " + *root_ + "/source --out " + *root_ + "/x --form quaternions").exit_code, 2);
  EXPECT_EQ(run_mosyn("data prepare " + *root_ + "/source --out " + *root_ + "/x --val 1.5").exit_code, 2);
  EXPECT_EQ(
      run_mosyn("data prepare " + *root_ + "/source --out " + *root_ + "/x --rest-ends 2 --rest-fraction 0").exit_code,
      2);
  EXPECT_EQ(run_mosyn("data prepare /nonexistent --out " + *root_ + "/x").exit_code, 2);
}

TEST_F(CliModelTest, RunDirectoryIsSelfDescribing) {
  for (const char* f : {"config.json", "stats.json", "checkpoint.pt", "log.jsonl"})
    EXPECT_TRUE(std::filesystem::exists(*root_ + "/run/" + f)) << f;
  const nlohmann::json config = io::read_json(*root_ + "/run/config.json");
  EXPECT_EQ(config["family"], "moglow");
  EXPECT_EQ(config["model"]["num_steps"], 2);
}

TEST_F(CliModelTest, TrainRefusesExistingRunWithoutResumeOrOverwrite) {
  const auto r = run_mosyn("train moglow --data " + *root_ + "/dataset --out " + *root_ + "/run --steps 1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("resume or overwrite"));
}

TEST_F(CliModelTest, TrainRejectsUnknownFamily) {
  const auto r = run_mosyn("train nosuchmodel --data " + *root_ + "/dataset --out " + *root_ + "/run2 --steps 1");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("nosuchmodel"));
}

// --train-preset: its keys over the config file's, the other flags over both; an unknown one is a
// usage error naming the known ones.
TEST_F(CliModelTest, TrainPresetsSitBetweenTheConfigAndTheFlags) {
  const std::string config = *root_ + "/preset-config.json";
  std::ofstream(config) << R"({"model": {"num_steps": 2, "hidden": 16, "tau": 3}, "train": {"batch": 3, "steps": 50, "seed": 4}})";
  const auto r = run_mosyn("train moglow --data " + *root_ + "/dataset --out " + *root_ + "/run-smoke --config " +
                           config + " --train-preset smoke --seed 9 --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json train = io::read_json(*root_ + "/run-smoke/config.json")["train"];
  EXPECT_EQ(train["preset"], "smoke");
  EXPECT_EQ(train["steps"], 2);   // the preset's, over the file's 50
  EXPECT_EQ(train["batch"], 4);   // the preset's, over the file's 3
  EXPECT_EQ(train["seed"], 9);    // the flag's
  const auto bad = run_mosyn("train moglow --data " + *root_ + "/dataset --out " + *root_ + "/run-bad --train-preset fast");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.err, HasSubstr("unknown training preset 'fast' for moglow (known: finetune, smoke, paper, paper-quadruped)"));
}

TEST_F(CliModelTest, SampleWritesBvhNpyAndSidecars) {
  const std::string out = *root_ + "/samples";
  const auto r = run_mosyn("sample " + *root_ + "/run --out " + out +
                           " --n 2 --seed 7 --path '0,0 0,2 2,3' --positions --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (int i = 0; i < 2; ++i) {
    const std::string base = out + "/sample_00" + std::to_string(i);
    const io::BvhFile bvh = io::read_bvh(base + ".bvh");
    EXPECT_GT(bvh.num_frames, 30);
    const io::NpyArray npy = io::read_npy(base + ".npy");
    EXPECT_EQ(npy.shape[0], bvh.num_frames);
    const nlohmann::json sidecar = io::read_json(base + ".json");
    EXPECT_EQ(sidecar["seed"], 7);
    EXPECT_EQ(sidecar["model"]["family"], "moglow");
    EXPECT_EQ(sidecar["control"]["kind"], "path");
  }
}

TEST_F(CliModelTest, SampleFormatGlbWritesEveryMotionAsAnAnimationOfOneFile) {
  const std::string out = *root_ + "/glb";
  const auto r = run_mosyn("sample " + *root_ + "/run --out " + out +
                           " --n 2 --seed 7 --seconds 2 --format glb --prefix walk --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string glb = io::read_file(out + "/walk.glb");
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  EXPECT_NE(glb.find("\"name\":\"walk_000\""), std::string::npos);
  EXPECT_NE(glb.find("\"name\":\"walk_001\""), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(out + "/walk_000.bvh"));  // only the formats asked for
  EXPECT_EQ(io::read_json(out + "/walk_001.json")["gltf"]["animation"], 1);
  EXPECT_EQ(run_mosyn("sample " + *root_ + "/run --out " + out + " --format fbx").exit_code, 2);
}

// --skeleton: the samples written on a rig (here the biped renamed Mixamo-style, 1.2 times as big),
// in its hierarchy and channel layout, BVH and glTF, as `mosyn retarget` writes them.
TEST_F(CliModelTest, SampleSkeletonWritesOnTheRig) {
  const std::string out = *root_ + "/on_rig", rig_path = *root_ + "/rig.bvh";
  Skeleton rig = make_synthetic_biped();
  for (auto& name : rig.joint_names) name = "mixamorig:" + name;
  for (auto& o : rig.offsets) o *= 1.2;
  io::write_bvh(rig_path, io::from_clip(Clip{rig, Motion::rest(rig, 1, 30.0)}));
  const auto r = run_mosyn("sample " + *root_ + "/run --out " + out + " --n 2 --seed 7 --seconds 3 --path '0,0 0,3'" +
                           " --format bvh,glb --skeleton " + rig_path + " --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::BvhFile bvh = io::read_bvh(out + "/sample_001.bvh");
  EXPECT_EQ(bvh.skeleton.joint_names, rig.joint_names);
  EXPECT_EQ(bvh.channels, io::read_bvh(rig_path).channels);
  EXPECT_GT(bvh.num_frames, 30);
  EXPECT_EQ(io::read_file(out + "/sample.glb").substr(0, 4), "glTF");
  const nlohmann::json sidecar = io::read_json(out + "/sample_001.json");
  EXPECT_EQ(sidecar["skeleton"]["file"], rig_path);
  EXPECT_GT(sidecar["skeleton"]["scale"].get<double>(), 0.0);
  const auto bad = run_mosyn("sample " + *root_ + "/run --out " + out + " --skeleton " + *root_ + "/nothing.bvh");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.err, HasSubstr("nothing.bvh"));
}

TEST_F(CliModelTest, SameSeedSameFilesDifferentSeedDifferentFiles) {
  const std::string args = " --n 1 --path '0,0 0,2' --threads 1 --seconds 3";
  ASSERT_EQ(run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/s1 --seed 3" + args).exit_code, 0);
  ASSERT_EQ(run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/s2 --seed 3" + args).exit_code, 0);
  ASSERT_EQ(run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/s3 --seed 4" + args).exit_code, 0);
  const std::string a = slurp(*root_ + "/s1/sample_000.bvh"), b = slurp(*root_ + "/s2/sample_000.bvh"),
                    c = slurp(*root_ + "/s3/sample_000.bvh");
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
}

TEST_F(CliModelTest, SampleFollowsAControlBvh) {
  const auto r = run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/ctl --n 1 --threads 1 --control " + *root_ +
                           "/source/data/dataset-9_walk_normal_001.bvh");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(io::read_bvh(*root_ + "/ctl/sample_000.bvh").num_frames, 90);
}

// A control CSV says its own frame rate (t_s column): written at 15 fps from the same take, it gives
// the BVH control's duration at the run's 30 fps (89 frames for the 44 / 15 s it spans; read as
// frames at 30 fps it would have lasted half as long). --control-fps gives the rate of a CSV without
// times and applies to nothing else.
TEST_F(CliModelTest, SampleReadsAControlCsvAtItsOwnFrameRate) {
  const std::string bvh = *root_ + "/source/data/dataset-9_walk_normal_001.bvh", csv = *root_ + "/ctl15.csv";
  const auto c = run_mosyn("convert " + bvh + " " + csv + " --fps 15 --control");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_EQ(slurp(csv).substr(0, 17), "t_s,dx,dz,dtheta\n");
  const auto r = run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/ctl15 --n 1 --threads 1 --control " + csv);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(io::read_bvh(*root_ + "/ctl15/sample_000.bvh").num_frames, 89);
  const auto both = run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/ctl15b --control " + csv + " --control-fps 15");
  EXPECT_EQ(both.exit_code, 1);
  EXPECT_THAT(both.err, HasSubstr(csv));
  EXPECT_EQ(run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/e --control " + bvh + " --control-fps 15").exit_code, 2);
  EXPECT_EQ(run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/e --control " + csv + " --control-fps -1").exit_code, 2);
}

// `sample --realtime` plays a control through the real-time Generator: with the shipped real-time
// model (which reads the path ahead) two controls equal up to frame t give the same frames up to t.
TEST_F(CliModelTest, RealtimeSampleSeesNoControlAfterAFrame) {
  const std::string model = std::string(MOSYN_SOURCE_DIR) + "/models/moglow-realtime";
  const int frames = 60, t = 30;
  for (const char* name : {"a", "b"}) {
    std::ofstream csv(*root_ + "/rt_" + name + ".csv");
    csv << "t_s,dx,dz,dtheta\n";
    for (int f = 0; f < frames; ++f) {
      const bool turns = name[0] == 'b' && f > t;
      csv << f / 20.0 << ",0," << (f ? 0.065 : 0.0) << "," << (turns ? 0.05 : 0.0) << "\n";
    }
  }
  std::vector<std::vector<double>> positions;
  for (const char* name : {"a", "b"}) {
    const std::string out = *root_ + "/rt_out_" + name;
    const auto r = run_mosyn("sample " + model + " --realtime --control " + *root_ + "/rt_" + name +
                             ".csv --n 1 --seed 5 --positions --threads 1 --warmup 0.5 --out " + out);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const io::NpyArray npy = io::read_npy(out + "/sample_000.npy");
    ASSERT_EQ(npy.shape.at(0), frames);
    positions.push_back(npy.to_float64());
  }
  ASSERT_EQ(positions[0].size(), positions[1].size());
  const size_t per_frame = positions[0].size() / frames;
  for (size_t i = 0; i < (t + 1) * per_frame; ++i)
    ASSERT_EQ(positions[0][i], positions[1][i]) << "frame " << i / per_frame;
  double after = 0;
  for (size_t i = (t + 1) * per_frame; i < positions[0].size(); ++i)
    after = std::max(after, std::abs(positions[0][i] - positions[1][i]));
  EXPECT_GT(after, 1e-3);
}

TEST_F(CliModelTest, SampleErrors) {
  EXPECT_EQ(run_mosyn("sample /nonexistent/run --out " + *root_ + "/e").exit_code, 1);
  EXPECT_EQ(run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/e --path 'a,b'").exit_code, 2);
  EXPECT_EQ(run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/e --n 0").exit_code, 2);
  EXPECT_EQ(run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/e --path '0,0' --control x.csv").exit_code, 2);
  const auto missing = run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/e --control /nonexistent.csv");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("/nonexistent.csv"));
}

// `mosyn export`: weights only, the same motion as the run; --average of a checkpoint with itself
// is that checkpoint; a missing averaged file names itself; an existing --out needs --overwrite.
TEST_F(CliModelTest, ExportShipsTheSameModelAndAveragesCheckpoints) {
  const std::string run = *root_ + "/run", e1 = *root_ + "/export1", e2 = *root_ + "/export2";
  std::filesystem::remove_all(e1);
  std::filesystem::remove_all(e2);
  const auto r = run_mosyn("export " + run + " --checkpoint checkpoint.pt --out " + e1);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LT(std::filesystem::file_size(e1 + "/checkpoint.pt"), std::filesystem::file_size(run + "/checkpoint.pt"));
  const auto avg = run_mosyn("export " + run + " --checkpoint checkpoint.pt --average " + run +
                             "/checkpoint.pt --out " + e2);
  ASSERT_EQ(avg.exit_code, 0) << avg.err;
  EXPECT_THAT(avg.err, HasSubstr("averaged with 1 more checkpoints"));
  const std::string args = " --n 1 --path '0,0 0,2' --threads 1 --seconds 2 --seed 5";
  for (const std::string& dir : {run, e1, e2})
    ASSERT_EQ(run_mosyn("sample " + dir + " --out " + dir + "-s" + args).exit_code, 0) << dir;
  const std::string original = slurp(run + "-s/sample_000.bvh");
  EXPECT_EQ(slurp(e1 + "-s/sample_000.bvh"), original);
  EXPECT_EQ(slurp(e2 + "-s/sample_000.bvh"), original);
  const auto missing = run_mosyn("export " + run + " --checkpoint checkpoint.pt --average /nonexistent.pt --out " +
                                 *root_ + "/export3");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("/nonexistent.pt"));
  EXPECT_EQ(run_mosyn("export " + run + " --checkpoint checkpoint.pt --out " + e1).exit_code, 1);
}

// `export --root-planting`: the section lands in config.json, checked as load_run reads it; a model
// steered by its control ignores it (its sidecar says the root was not planted).
TEST_F(CliModelTest, ExportWritesRootPlanting) {
  const std::string run = *root_ + "/run", out = *root_ + "/export-planted";
  std::filesystem::remove_all(out);
  const auto r = run_mosyn("export " + run + " --checkpoint checkpoint.pt --out " + out +
                           " --root-planting '{\"release_height_m\": 0.08}'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(slurp(out + "/config.json"), HasSubstr("\"release_height_m\": 0.08"));
  ASSERT_EQ(run_mosyn("sample " + out + " --out " + out + "-s --n 1 --seconds 1 --threads 1").exit_code, 0);
  EXPECT_THAT(slurp(out + "-s/sample_000.json"), HasSubstr("\"root_planted\": false"));
  const auto not_json = run_mosyn("export " + run + " --checkpoint checkpoint.pt --out " + out + " --overwrite" +
                                  " --root-planting '{'");
  EXPECT_EQ(not_json.exit_code, 2);
  EXPECT_THAT(not_json.err, HasSubstr("--root-planting"));
  const auto bad = run_mosyn("export " + run + " --checkpoint checkpoint.pt --out " + out + " --overwrite" +
                             " --root-planting '{\"release_height_m\": 0.001}'");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.err, HasSubstr("release_height_m must be above contact_height_m"));
}

TEST_F(CliModelTest, TruncatedCheckpointIsAClearError) {
  const std::string run2 = *root_ + "/run_truncated";
  std::filesystem::remove_all(run2);
  std::filesystem::copy(*root_ + "/run", run2);
  const std::string ckpt = run2 + "/checkpoint.pt";
  std::filesystem::resize_file(ckpt, std::filesystem::file_size(ckpt) / 2);
  const auto r = run_mosyn("sample " + run2 + " --out " + *root_ + "/t --n 1 --threads 1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("checkpoint.pt"));
}

}  // namespace
}  // namespace mosyn

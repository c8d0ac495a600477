// TrainOptions::keep_checkpoints: every checkpoint also kept as checkpoint-<step>.pt.
#include <gtest/gtest.h>

#include <filesystem>

#include "io/json_file.h"
#include "nn/run.h"
#include "nn/training/run_dir.h"
#include "nn/training/train.h"
#include "nn_test_util.h"
#include "training_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;
namespace fs = std::filesystem;
using nn::testing::max_param_diff;
using nn::testing::synthetic_dataset;
using nn::testing::temp_dir;
using nn::testing::tiny_options;

// Checkpoints every 4 steps of 10 (and at the last): 4, 8 and 10 are kept, the last one the same
// state as checkpoint.pt, the first a different one that loads as a run of its own; an overwrite
// clears the kept files of the run it replaces; a run without the option keeps none.
TEST(TrainingCheckpoints, KeptCheckpointsHoldEveryCheckpointedState) {
  const auto ds = synthetic_dataset();
  const auto dir = temp_dir("kept");
  auto o = tiny_options(dir);
  o.steps = 10;
  o.keep_checkpoints = true;
  train(o, ds);
  for (int step : {4, 8, 10}) EXPECT_TRUE(fs::exists(dir / ("checkpoint-" + std::to_string(step) + ".pt"))) << step;
  EXPECT_FALSE(fs::exists(dir / "checkpoint-2.pt"));
  auto last = load_run(dir.string(), {"checkpoint.pt", "cpu", 1});
  auto kept_last = load_run(dir.string(), {"checkpoint-10.pt", "cpu", 1});
  auto kept_first = load_run(dir.string(), {"checkpoint-4.pt", "cpu", 1});
  EXPECT_EQ(kept_last.step, 10);
  EXPECT_EQ(kept_first.step, 4);
  EXPECT_EQ(max_param_diff(*last.model, *kept_last.model), 0.0);
  EXPECT_GT(max_param_diff(*last.model, *kept_first.model), 0.0);
  EXPECT_TRUE(io::read_json((dir / "config.json").string()).at("train").at("keep_checkpoints").get<bool>());

  o.steps = 6;  // replaces the run: checkpoints at 4 and 6 only
  o.overwrite = true;
  train(o, ds);
  EXPECT_TRUE(fs::exists(dir / "checkpoint-4.pt"));
  EXPECT_TRUE(fs::exists(dir / "checkpoint-6.pt"));
  EXPECT_FALSE(fs::exists(dir / "checkpoint-8.pt"));
  EXPECT_FALSE(fs::exists(dir / "checkpoint-10.pt"));

  o.keep_checkpoints = false;
  train(o, ds);
  EXPECT_FALSE(fs::exists(dir / "checkpoint-4.pt"));
  EXPECT_FALSE(fs::exists(dir / "checkpoint-6.pt"));
  EXPECT_FALSE(io::read_json((dir / "config.json").string()).at("train").contains("keep_checkpoints"));
  fs::remove_all(dir);
}

TEST(TrainingCheckpoints, KeptCheckpointNames) {
  using training::RunPaths;
  EXPECT_TRUE(RunPaths::is_kept_checkpoint("checkpoint-300.pt"));
  for (const char* other : {"checkpoint.pt", "checkpoint-.pt", "checkpoint-3a.pt", "checkpoint-300.pt.tmp.1.2",
                            "best.pt", "my-checkpoint-3.pt"})
    EXPECT_FALSE(RunPaths::is_kept_checkpoint(other)) << other;
  EXPECT_EQ(RunPaths("/runs/a").kept_checkpoint(300), "/runs/a/checkpoint-300.pt");
  EXPECT_FALSE(TrainOptions::from_json(nlohmann::json::object()).keep_checkpoints);  // older runs
  EXPECT_TRUE(TrainOptions::from_json({{"keep_checkpoints", true}}).keep_checkpoints);
}

// Training on a user's own data: every registered family learns (its training loss falls) on
// datasets prepared from CMU files as a new user would (`data prepare --fps 30 --drop-fingers
// --mirror`), on one made of a single clip and on one with a single content label. CMU rotations
// hold near-constant dimensions (joints the capture never moves); before they were kept out of the
// models (data::DatasetStats::pose_constant) a default MoGlow diverged on them.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/error.h"
#include "data/dataset.h"
#include "data/prepare.h"
#include "nn/registry.h"
#include "nn/run.h"
#include "nn/sampling.h"
#include "nn/standardiser.h"
#include "nn/training/train.h"

using namespace mosyn;
namespace fs = std::filesystem;

namespace {

const fs::path kCmu = fs::path(MOSYN_DATA_CACHE) / "cmu-mocap-subset";

// A CMU-layout source folder (index.csv + links to the files) holding the given files.
fs::path cmu_source(const std::string& name, const std::vector<std::pair<std::string, std::string>>& files) {
  const fs::path dir = fs::temp_directory_path() / ("mosyn_user_data_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream index(dir / "index.csv");
  index << "file,action\n";
  for (const auto& [file, action] : files) {
    const fs::path target = dir / file;
    fs::create_directories(target.parent_path());
    fs::create_symlink(kCmu / file, target);
    index << file << "," << action << "\n";
  }
  return dir;
}

data::Dataset prepare(const fs::path& source, bool mirror, double val_fraction) {
  data::PrepareOptions o;
  o.input_dirs = {source.string()};
  o.output_dir = (source.string() + "_dataset");
  o.fps = 30;
  o.drop_joint_patterns = {"*Thumb*", "*Index*", "*Middle*", "*Ring*", "*Pinky*", "*HandEnd*", "*Finger*"};  // --drop-fingers
  o.mirror = mirror;
  o.val_fraction = val_fraction;
  o.window_frames = 16;
  o.window_hop = 4;
  o.overwrite = true;
  data::prepare_dataset(o);
  return data::Dataset::open(o.output_dir);
}

// Trains each registered family for a few dozen steps (tiny configs, 96 steps over all of its
// stages) and expects the training loss of its first stage to fall (the mean of the last logged
// third below the mean of the first; single steps are noisy) and no later stage to rise.
void expect_every_family_learns(const data::Dataset& dataset, const std::string& what) {
  for (const std::string& family : nn::model_families()) {
    // Stand-ins registered by other tests of this binary (run whole, not one test per process).
    if (family.rfind("test_", 0) == 0) continue;
    const nn::FamilyInfo info = nn::family_info(family);
    const bool labels_needed = info.kind == nn::FamilyKind::kClassifier;
    if (labels_needed && dataset.info().content_labels.size() < 2) continue;  // one class: nothing to learn
    nn::TrainOptions o;
    o.family = family;
    o.out_dir = (fs::temp_directory_path() / ("mosyn_user_data_run_" + family + "_" + std::to_string(::getpid()))).string();
    o.overwrite = true;
    o.model_config = info.tiny_config;
    o.steps = 96;
    o.batch = 8;
    o.window = 16;
    o.lr = 2e-3;
    o.warmup = 0;
    o.threads = 1;
    o.checkpoint_every = 1000;
    o.validate_every = 0;
    o.log_every = 1;
    o.seed = 7;
    std::map<std::string, std::vector<double>> losses;  // by stage name, in order
    std::vector<std::string> stages;                    // in the order they ran
    nn::TrainCallbacks callbacks;
    callbacks.on_progress = [&](const nn::TrainProgress& p) {
      if (p.has_val) return;
      if (losses.find(p.stage) == losses.end()) stages.push_back(p.stage);
      losses[p.stage].push_back(p.loss);
    };
    try {
      nn::train(o, dataset, callbacks);
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ", " << family << ": " << e.what();
      continue;
    }
    for (const std::string& stage : stages) {
      const std::vector<double>& values = losses[stage];
      ASSERT_GE(values.size(), 8u) << what << ", " << family << " stage " << stage;
      for (double v : values) ASSERT_TRUE(std::isfinite(v)) << what << ", " << family << " stage " << stage;
      const size_t q = values.size() / 3;
      const double first = std::accumulate(values.begin(), values.begin() + q, 0.0) / q;
      const double last = std::accumulate(values.end() - q, values.end(), 0.0) / q;
      // The first stage learns from the data and must fall. Later stages build on it and may trade
      // terms (MoJo's DLow stage: diversity against likelihood, flat over a few dozen steps); they
      // must not diverge.
      if (stage == stages.front())
        EXPECT_LT(last, first) << what << ", " << family << " stage " << stage << ": training loss did not fall";
      else
        EXPECT_LT(last, first + 0.1 * std::abs(first) + 0.1) << what << ", " << family << " stage " << stage << ": training loss rose";
      std::printf("[ info ] %s, %s stage %s: loss %.3f -> %.3f over %zu steps\n", what.c_str(), family.c_str(),
                  stage.c_str(), first, last, values.size());
    }
    fs::remove_all(o.out_dir);
  }
}

TEST(UserDataRealData, EveryFamilyLearnsOnCmuOneClipAndOneContent) {
  if (!fs::exists(kCmu / "index.csv")) GTEST_SKIP() << "no CMU data under " << kCmu;
  const std::vector<std::pair<std::string, std::string>> files = {
      {"bvh/07/07_12.bvh", "walk"}, {"bvh/08/08_10.bvh", "walk"}, {"bvh/02/02_01.bvh", "walk"},
      {"bvh/02/02_03.bvh", "run"},  {"bvh/09/09_01.bvh", "run"},  {"bvh/09/09_05.bvh", "run"}};
  const fs::path source = cmu_source("cmu", files);
  {
    const data::Dataset cmu = prepare(source, /*mirror=*/true, 0.2);
    // Joints CMU never moves give near-constant rotation features; they are recorded, and the
    // standardiser keeps them out of the models and restores them on decoding.
    const std::vector<int>& constant = cmu.stats().pose_constant;
    ASSERT_FALSE(constant.empty());
    const nn::Standardiser st(cmu.stats());
    const auto& clip = cmu.clips("train").front();
    const torch::Tensor raw = torch::from_blob(const_cast<float*>(clip.pose.data()),
                                               {clip.num_frames, cmu.info().layout.pose_dim}).clone();
    const torch::Tensor standardised = st.pose(raw);
    const torch::Tensor decoded = st.unpose(standardised + 5.0);  // whatever a model says there
    for (int k : constant) {
      EXPECT_EQ(standardised.select(1, k).abs().max().item<float>(), 0.0f) << k;
      EXPECT_NEAR(decoded.select(1, k).sub(raw.select(1, k)).abs().max().item<float>(), 0.0f, 3e-3f) << k;
    }
    expect_every_family_learns(cmu, "CMU");
  }
  {
    const fs::path one = cmu_source("one_clip", {files[0]});
    expect_every_family_learns(prepare(one, /*mirror=*/false, 0.0), "one clip");
    fs::remove_all(one);
    fs::remove_all(one.string() + "_dataset");
  }
  {
    const fs::path walks = cmu_source("one_content", {files[0], files[1], files[2]});
    expect_every_family_learns(prepare(walks, /*mirror=*/true, 0.2), "one content");
    fs::remove_all(walks);
    fs::remove_all(walks.string() + "_dataset");
  }
  fs::remove_all(source);
  fs::remove_all(source.string() + "_dataset");
}

}  // namespace

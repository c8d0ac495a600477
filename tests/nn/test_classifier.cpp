// The "classifier" family: trained by the generic trainer on the synthetic labelled walks (four
// contents with different turn rates and speeds, two styles), its loss falls and its accuracy
// rises; classify_windows gives features and probabilities; it refuses to generate.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <torch/utils.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "data/prepare.h"
#include "nn/classifier/classifier.h"
#include "nn/sampling.h"
#include "nn/classifier/classify.h"
#include "nn/model.h"
#include "nn/run.h"
#include "nn/training/train.h"

using namespace mosyn;
using namespace mosyn::nn;
namespace fs = std::filesystem;

namespace {

class ClassifierTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    torch::set_num_threads(1);
    root_ = new fs::path(fs::temp_directory_path() / ("mosyn_classifier_" + std::to_string(::getpid())));
    fs::remove_all(*root_);
    data::write_synthetic_source((*root_ / "source").string(), 2, 90, 3);
    data::PrepareOptions p;
    p.input_dirs = {(*root_ / "source").string()};
    p.output_dir = (*root_ / "dataset").string();
    p.window_frames = 30;
    p.window_hop = 10;
    p.val_fraction = 0.25;
    p.threads = 1;
    data::prepare_dataset(p);
    dataset_ = new data::Dataset(data::Dataset::open(p.output_dir));

    TrainOptions o;
    o.family = "classifier";
    o.out_dir = (*root_ / "run").string();
    o.model_config = {{"channels", 16}, {"features", 16}, {"dropout", 0.0}};
    o.steps = 80;
    o.batch = 16;
    o.window = 30;
    o.lr = 3e-3;
    o.warmup = 0;
    o.threads = 1;
    o.validate_every = 40;
    o.checkpoint_every = 80;
    o.log_every = 1;
    train(o, *dataset_);
  }
  static void TearDownTestSuite() {
    delete dataset_;
    fs::remove_all(*root_);
    delete root_;
  }
  static fs::path* root_;
  static data::Dataset* dataset_;
};
fs::path* ClassifierTest::root_ = nullptr;
data::Dataset* ClassifierTest::dataset_ = nullptr;

std::vector<nlohmann::json> read_log(const fs::path& path) {
  std::vector<nlohmann::json> lines;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

double mean_of(const std::vector<nlohmann::json>& log, size_t from, size_t to, const char* key) {
  double s = 0;
  for (size_t i = from; i < to; ++i) s += log[i].at(key).get<double>();
  return s / (to - from);
}

}  // namespace

TEST_F(ClassifierTest, IsARegisteredFamily) {
  const auto families = model_families();
  EXPECT_NE(std::find(families.begin(), families.end(), "classifier"), families.end());
  EXPECT_NE(std::find(families.begin(), families.end(), "moglow"), families.end());
}

TEST_F(ClassifierTest, LossFallsAndAccuracyRises) {
  const auto log = read_log(*root_ / "run" / "log.jsonl");
  ASSERT_EQ(log.size(), 80u);
  for (const char* key : {"content_ce", "content_acc", "style_ce", "style_acc"}) EXPECT_TRUE(log[0].contains(key)) << key;
  EXPECT_LT(mean_of(log, 70, 80, "loss"), 0.7 * mean_of(log, 0, 10, "loss"));
  EXPECT_GT(mean_of(log, 70, 80, "content_acc"), mean_of(log, 0, 10, "content_acc") + 0.2);
  EXPECT_GT(mean_of(log, 70, 80, "content_acc"), 0.6);  // chance: 0.25
}

TEST_F(ClassifierTest, ClassifiesWholeClipsWithFeaturesAndProbabilities) {
  const LoadedRun run = load_run((*root_ / "run").string(), LoadOptions{"checkpoint.pt", "cpu", 1});
  EXPECT_EQ(run.family, "classifier");
  std::vector<std::vector<float>> poses, controls;
  std::vector<int> labels;
  for (const auto& c : dataset_->clips("train")) {
    poses.push_back(c.pose);
    controls.push_back(c.control);
    labels.push_back(c.content);
  }
  const ClassifierOutputs out = classify_windows(run, poses, controls);
  ASSERT_EQ(out.num_windows, static_cast<int>(poses.size()));
  EXPECT_EQ(out.num_features, 16);
  EXPECT_EQ(out.num_content, 4);
  EXPECT_EQ(out.num_style, 2);
  ASSERT_EQ(out.features.size(), poses.size() * 16);
  ASSERT_EQ(out.style_probabilities.size(), poses.size() * 2);
  int right = 0;
  for (int i = 0; i < out.num_windows; ++i) {
    const float* p = out.content_probabilities.data() + i * 4;
    EXPECT_NEAR(p[0] + p[1] + p[2] + p[3], 1.0, 1e-5);
    right += static_cast<int>(std::max_element(p, p + 4) - p) == labels[i];
  }
  EXPECT_GT(right, out.num_windows / 2);  // chance: a quarter
  // The same windows in another order give the same outputs.
  std::vector<std::vector<float>> two = {poses[1], poses[0]}, two_c = {controls[1], controls[0]};
  const ClassifierOutputs again = classify_windows(run, two, two_c);
  for (int f = 0; f < 16; ++f) EXPECT_NEAR(again.features[16 + f], out.features[f], 1e-4);
}

TEST_F(ClassifierTest, DoesNotGenerateAndNeedsLabels) {
  const LoadedRun run = load_run((*root_ / "run").string(), LoadOptions{"checkpoint.pt", "cpu", 1});
  EXPECT_EQ(run.kind, FamilyKind::kClassifier);
  EXPECT_EQ(run.model, nullptr);  // a trainable model that is not a motion model
  ASSERT_NE(run.trainable, nullptr);
  EXPECT_THROW(sample_motions(run, std::vector<float>(30, 0.0f), 1, 1), Error);
  ModelContext ctx;
  ctx.pose_dim = 10;
  EXPECT_THROW(create_trainable("classifier", nlohmann::json::object(), ctx), Error);
  ctx.num_content = 3;
  EXPECT_NO_THROW(create_trainable("classifier", nlohmann::json::object(), ctx));
  try {
    create_model("classifier", nlohmann::json::object(), ctx);
    FAIL() << "a classifier is not a motion model";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("does not generate motion"));
  }
  EXPECT_THROW(create_trainable("classifier", {{"kernel", 4}}, ctx), Error);
  EXPECT_THROW(create_trainable("classifier", {{"nosuchkey", 1}}, ctx), Error);
}

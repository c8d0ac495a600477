// End to end through the data layer: synthetic BVH source -> prepared dataset -> train from the
// dataset directory -> load_run -> sample -> decode to a clip on the training skeleton.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "core/error.h"
#include "data/prepare.h"
#include "io/bvh.h"
#include "nn/generator.h"
#include "nn/run.h"
#include "nn/sampling.h"
#include "nn/training/train.h"

using namespace mosyn;
namespace fs = std::filesystem;

TEST(Integration, TrainSampleDecodeFromPreparedDataset) {
  const auto root = fs::temp_directory_path() / ("mosyn_nn_e2e_" + std::to_string(::getpid()));
  fs::remove_all(root);
  data::write_synthetic_source((root / "src").string(), 1, 60, 3);
  data::PrepareOptions po;
  po.input_dirs = {(root / "src").string()};
  po.output_dir = (root / "ds").string();
  po.window_frames = 24;
  po.window_hop = 12;
  po.val_fraction = 0.25;
  po.form = data::PoseForm::kRotations;
  data::prepare_dataset(po);

  nn::TrainOptions o;
  o.family = "moglow";
  o.data_dir = po.output_dir;
  o.out_dir = (root / "run").string();
  o.model_config = {{"num_steps", 2}, {"hidden", 16}, {"tau", 4}};
  o.steps = 4;
  o.batch = 4;
  o.threads = 1;
  o.validate_every = 2;
  nn::train(o);

  auto run = nn::load_run(o.out_dir, {"checkpoint.pt", "cpu", 1});
  EXPECT_EQ(run.step, 4);
  EXPECT_EQ(run.context.pose_form, data::PoseForm::kRotations);
  EXPECT_EQ(run.context.pose_dim, run.dataset.layout.pose_dim);
  EXPECT_FALSE(run.dataset.content_labels.empty());
  auto best = nn::load_run(o.out_dir, {"best.pt", "cpu", 1});
  EXPECT_GE(best.step, 2);

  // A straight walk: 1.2 m/s forward at the dataset's frame rate.
  const int t = 30;
  std::vector<float> control;
  for (int f = 0; f < t; ++f) control.insert(control.end(), {0.0f, f == 0 ? 0.0f : float(1.2 / run.dataset.fps), 0.0f});
  auto poses = nn::sample_motions(run, control, 2, 9);
  ASSERT_EQ(poses.size(), 2u);
  for (float v : poses[0].pose) ASSERT_TRUE(std::isfinite(v));
  EXPECT_EQ(poses[0].control, control);  // a family that takes control returns it unchanged
  Clip clip = nn::decode_motion(run, poses[0]);
  EXPECT_EQ(clip.motion.num_frames, t);
  EXPECT_EQ(clip.motion.num_joints, run.dataset.skeleton.num_joints());
  EXPECT_NO_THROW(clip.motion.validate());
  const auto bvh = (root / "sample.bvh").string();
  nn::write_motion_bvh(bvh, run, poses[1]);
  EXPECT_EQ(io::to_clip(io::read_bvh(bvh)).motion.num_frames, t);

  // The warm-up is a lead-in along the control's first step (row 1), dropped: the same frames as
  // sampling that lead-in and the control without a warm-up and cutting the lead-in off, and not
  // those of a standing lead-in (the walk starts at 1.2 m/s).
  const int w = 5;
  nn::SampleExtras lead;
  lead.warmup_frames = w;
  const auto warmed = nn::sample_motions(run, control, 1, 3, 1.0, lead);
  const auto sample_after = [&](const std::vector<float>& lead_row) {
    std::vector<float> full;
    for (int f = 0; f < w; ++f) full.insert(full.end(), lead_row.begin(), lead_row.end());
    full.insert(full.end(), control.begin(), control.end());
    auto p = nn::sample_motions(run, full, 1, 3, 1.0, nn::SampleExtras{}).front().pose;
    return std::vector<float>(p.end() - warmed[0].pose.size(), p.end());
  };
  ASSERT_EQ(warmed[0].pose.size(), static_cast<size_t>(t) * run.context.pose_dim);
  EXPECT_EQ(warmed[0].pose, sample_after({control[3], control[4], control[5]}));
  EXPECT_NE(warmed[0].pose, sample_after({0.0f, 0.0f, 0.0f}));

  nn::GeneratorOptions go;
  go.threads = 1;
  nn::Generator gen(o.out_dir, go);
  for (int f = 0; f < 5; ++f) gen.step({0.0f, 0.04f, 0.0f});
  EXPECT_GT(gen.root(0).position.norm(), 0.0);
  fs::remove_all(root);
}

// Real data (skips unless the shared archives are unpacked; MOSYN_NN_DATA_CACHE overrides the
// location): a small MoGlow on Bandai-Namco walks learns and samples decodable motion.
TEST(RealDataMoGlow, BandaiWalksTrainAndSample) {
  const char* env = std::getenv("MOSYN_NN_DATA_CACHE");
  const std::string cache = env ? env : MOSYN_DATA_CACHE;
  const std::string bandai = cache + "/bandai-namco/Bandai-Namco-Research-Motiondataset-2";
  if (!fs::exists(bandai)) GTEST_SKIP() << "shared data not unpacked";
  const auto root = fs::temp_directory_path() / ("mosyn_nn_real_" + std::to_string(::getpid()));
  fs::remove_all(root);
  data::PrepareOptions po;
  po.input_dirs = {bandai};
  po.output_dir = (root / "ds").string();
  po.contents = {"walk"};
  po.styles = {"normal"};
  po.window_frames = 40;
  po.window_hop = 20;
  po.val_fraction = 0.2;
  data::prepare_dataset(po);

  nn::TrainOptions o;
  o.family = "moglow";
  o.data_dir = po.output_dir;
  o.out_dir = (root / "run").string();
  o.model_config = {{"num_steps", 4}, {"hidden", 64}};
  o.steps = 40;
  o.batch = 12;
  o.warmup = 10;
  o.threads = 1;
  o.validate_every = 20;
  o.log_every = 5;
  std::vector<double> losses;
  nn::TrainCallbacks cb;
  cb.on_progress = [&](const nn::TrainProgress& p) { losses.push_back(p.loss); };
  nn::train(o, cb);
  ASSERT_GE(losses.size(), 4u);
  const double first = (losses[0] + losses[1]) / 2, last = (losses[losses.size() - 1] + losses[losses.size() - 2]) / 2;
  EXPECT_LT(last, first) << "first " << first << " last " << last;

  auto run = nn::load_run(o.out_dir, {"checkpoint.pt", "cpu", 1});
  const auto ds = data::Dataset::open(po.output_dir);
  const auto& clip = ds.clips("val").at(0);
  const int t = std::min(60, clip.num_frames);
  std::vector<float> control(clip.control.begin(), clip.control.begin() + 3 * t);
  auto poses = nn::sample_motions(run, control, 1, 1);
  for (float v : poses[0].pose) ASSERT_TRUE(std::isfinite(v));
  Clip out = nn::decode_motion(run, poses[0]);
  EXPECT_NO_THROW(out.motion.validate());
  fs::remove_all(root);
}

#include "data/prepare.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <tuple>
#include <unistd.h>

#include "core/error.h"
#include "core/kinematics.h"
#include "data/dataset.h"
#include "data/labels.h"
#include "io/atomic_file.h"
#include "io/bvh.h"

namespace mosyn::data {
namespace {
namespace fs = std::filesystem;

fs::path temp_path(const std::string& tag) {
  return fs::temp_directory_path() / ("mosyn_prepare_" + tag + "_" +
                                      ::testing::UnitTest::GetInstance()->current_test_info()->name());
}

// One synthetic source folder shared by the tests of this file (written once per process,
// removed at exit; ctest may run the tests of this file in parallel processes).
struct SyntheticSource {
  SyntheticSource() {
    path = (fs::temp_directory_path() / ("mosyn_prepare_synthetic_source_" + std::to_string(::getpid()))).string();
    fs::remove_all(path);
    write_synthetic_source(path, 2, 90, 1);
  }
  ~SyntheticSource() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string path;
};

const std::string& synthetic_source() {
  static const SyntheticSource source;
  return source.path;
}

PrepareOptions basic_options(const std::string& out) {
  PrepareOptions o;
  o.input_dirs = {synthetic_source()};
  o.output_dir = out;
  o.window_frames = 40;
  o.window_hop = 20;
  o.val_fraction = 0.25;
  o.seed = 7;
  o.threads = 2;
  return o;
}

TEST(Prepare, SyntheticSourceLayout) {
  const SourceListing l = list_source(synthetic_source());
  EXPECT_EQ(l.layout, SourceLayout::kBandaiNamco);
  EXPECT_EQ(l.files.size(), 16u);  // 4 contents x 2 styles x 2 takes
  EXPECT_EQ(l.content_labels.front(), "walk");
  const Clip clip = io::to_clip(io::read_bvh(l.files[0].path));
  EXPECT_EQ(clip.skeleton.joint_names[0], "joint_Root");
}

TEST(Prepare, EndToEndRotations) {
  const fs::path out = temp_path("out");
  fs::remove_all(out);
  PrepareOptions o = basic_options(out.string());
  o.mirror = true;
  o.reverse = true;
  std::vector<PrepareProgress> events;
  const DatasetInfo info = prepare_dataset(o, [&](const PrepareProgress& p) { events.push_back(p); });
  // Progress: 16 parse + 16 encode + 1 write, counts rising to the total.
  ASSERT_EQ(events.size(), 33u);
  EXPECT_EQ(events[15].stage, "parse");
  EXPECT_EQ(events[15].files_done, 16);
  EXPECT_EQ(events[15].files_total, 16);
  EXPECT_EQ(events.back().stage, "write");

  EXPECT_EQ(info.skeleton.joint_names[0], "Hips");  // static joint_Root collapsed
  EXPECT_EQ(info.skeleton.num_joints(), 21);
  EXPECT_EQ(info.layout.pose_dim, 1 + 6 * 21 + 2);  // + the hips' offset from the smoothed root
  EXPECT_DOUBLE_EQ(info.layout.root_smoothing_s, kDefaultRootSmoothingS);
  EXPECT_NEAR(info.skeleton.meters_per_unit, 0.01, 1e-12);
  EXPECT_EQ(info.content_labels, (std::vector<std::string>{"walk", "walk-turn-left", "walk-turn-right", "run"}));
  EXPECT_EQ(info.style_labels, (std::vector<std::string>{"normal", "brisk"}));
  EXPECT_EQ(info.train_files.size(), 12u);
  EXPECT_EQ(info.val_files.size(), 4u);

  const Dataset d = Dataset::open(out.string());
  EXPECT_EQ(d.info().train_files, info.train_files);
  EXPECT_EQ(d.clips("train").size(), 12u * 4);  // original, mirrored, reversed, both
  EXPECT_EQ(d.clips("val").size(), 4u * 4);
  for (const ClipRecord& c : d.clips("val"))
    EXPECT_NE(std::find(info.val_files.begin(), info.val_files.end(), c.source), info.val_files.end());
  // Mirrored turns swap labels; everything else keeps its label.
  const int left = 1, right = 2;
  for (const ClipRecord& c : d.clips("train")) {
    EXPECT_EQ(c.num_frames, 90);
    const bool left_file = c.source.find("walk-turn-left") != std::string::npos;
    if (left_file) {
      EXPECT_EQ(c.content, c.mirrored ? right : left);
    }
  }
  // Stats: finite, floored std.
  for (float s : d.stats().pose_std) EXPECT_GE(s, kStdFloor);
  EXPECT_EQ(d.stats().control_mean.size(), 3u);
  // Windows: 90 frames, window 40, hop 20 -> starts 0, 20, 40.
  EXPECT_EQ(d.windows("train").size(), 12u * 4 * 3);
  EXPECT_EQ(d.windows("val", 90, 5).size(), 4u * 4);
  EXPECT_THROW(d.windows("test"), Error);

  // Decoded clips reproduce the source motion (original, first train clip).
  const ClipRecord& rec = d.clips("train")[0];
  ASSERT_FALSE(rec.mirrored);
  const Clip decoded = decode_record(d.info(), rec);
  Clip source = io::to_clip(io::read_bvh(synthetic_source() + "/" + rec.source));
  const WorldPoses a = forward_kinematics(decoded.skeleton, decoded.motion);
  const WorldPoses b = forward_kinematics(source.skeleton, source.motion);
  // Decoding starts at the origin facing +Z: compare poses relative to the root.
  double worst = 0;
  for (int t = 0; t < rec.num_frames; ++t)
    for (int j = 0; j < 21; ++j) {
      const Eigen::Vector3d pa = a.rotation(t, 0).conjugate() * (a.position(t, j) - a.position(t, 0));
      const Eigen::Vector3d pb = b.rotation(t, 1).conjugate() * (b.position(t, j + 1) - b.position(t, 1));
      worst = std::max(worst, (pa - pb).norm());
    }
  EXPECT_LT(worst, 1e-2);  // centimetres
  const std::string summary = dataset_summary(d);
  EXPECT_NE(summary.find("walk-turn-left"), std::string::npos) << summary;
  EXPECT_NE(summary.find("rotations, pose 129 + control 3"), std::string::npos) << summary;

  // Refuses to overwrite unless asked.
  EXPECT_THROW(prepare_dataset(o), Error);
  o.overwrite = true;
  o.mirror = o.reverse = false;
  EXPECT_NO_THROW(prepare_dataset(o));
  EXPECT_EQ(Dataset::open(out.string()).clips("train").size(), 12u);
  fs::remove_all(out);
}

TEST(Prepare, SplitIsDeterministicAndSeeded) {
  const fs::path out = temp_path("a");
  fs::remove_all(out);
  PrepareOptions o = basic_options(out.string());
  o.overwrite = true;
  const DatasetInfo a = prepare_dataset(o);
  const DatasetInfo b = prepare_dataset(o);
  EXPECT_EQ(a.val_files, b.val_files);
  std::vector<std::string> other_split;
  for (uint64_t seed = 8; seed < 14 && other_split.empty(); ++seed) {
    o.seed = seed;
    const DatasetInfo c = prepare_dataset(o);
    if (c.val_files != a.val_files) other_split = c.val_files;
  }
  EXPECT_FALSE(other_split.empty());
  fs::remove_all(out);
}

// DFN's limited-data runs: the training split cut to a budget of seconds, file by file in order
// (mirrored copies cut with their original), validation untouched, the budget recorded.
TEST(Prepare, MaxTrainSecondsCutsTheTrainingSplit) {
  const fs::path out = temp_path("budget");
  fs::remove_all(out);
  PrepareOptions o = basic_options(out.string());
  o.overwrite = true;
  const DatasetInfo full = prepare_dataset(o);
  ASSERT_EQ(full.train_files.size(), 12u);  // 16 files of 90 frames, a quarter held out
  o.mirror = true;
  o.max_train_seconds = 5.0;  // 150 frames at 30 fps: one file whole, the next cut to 60
  const DatasetInfo cut = prepare_dataset(o);
  EXPECT_EQ(cut.val_files, full.val_files);
  ASSERT_EQ(cut.train_files.size(), 2u);
  EXPECT_EQ(cut.train_files[0], full.train_files[0]);
  EXPECT_EQ(cut.train_files[1], full.train_files[1]);
  const Dataset ds = Dataset::open(out.string());
  EXPECT_DOUBLE_EQ(ds.info().max_train_seconds, 5.0);
  std::vector<int> frames;
  for (const auto& r : ds.clips("train")) frames.push_back(r.num_frames);
  EXPECT_EQ(frames, (std::vector<int>{90, 90, 60, 60}));  // each original beside its mirror
  EXPECT_EQ(ds.clips("train")[2].pose.size(), 60u * ds.info().layout.pose_dim);
  for (const auto& r : ds.clips("val")) EXPECT_EQ(r.num_frames, 90);
  o.max_train_seconds = 0.01;  // not even 2 frames
  EXPECT_THROW(prepare_dataset(o), Error);
  o.max_train_seconds = -1;
  EXPECT_THROW(prepare_dataset(o), Error);
  fs::remove_all(out);
}

// Retimed copies sit after the original and its mirror, flagged, with the frames and root speed
// of the faster playback; evaluation's "take as recorded" skips them; the factors are recorded.
// stats_from standardises with another directory's statistics instead of the dataset's own.
// rest_hold_s: after each clip, a copy starting from rest and one coming to rest, flagged (bit 3,
// read back), labels kept; the held seconds stand still in the control (no root step) and the
// dataset.json records the hold and the ramp.
TEST(Prepare, CopiesStartingFromAndComingToRest) {
  const fs::path out = temp_path("rest");
  fs::remove_all(out);
  PrepareOptions o = basic_options(out.string());
  o.rest_hold_s = 1.0;
  o.rest_ramp_s = 1.0;
  prepare_dataset(o);
  const Dataset ds = Dataset::open(out.string());
  EXPECT_DOUBLE_EQ(ds.info().augment_rest_hold_s, 1.0);
  EXPECT_DOUBLE_EQ(ds.info().augment_rest_ramp_s, 1.0);
  const auto& recs = ds.clips("train");
  ASSERT_EQ(recs.size() % 3, 0u);
  const auto step_m = [](const ClipRecord& r, int t) { return std::hypot(r.control[3 * t], r.control[3 * t + 1]); };
  for (size_t f = 0; f < recs.size(); f += 3) {
    const ClipRecord &orig = recs[f], &start = recs[f + 1], &stop = recs[f + 2];
    EXPECT_FALSE(orig.augmented());
    for (const ClipRecord* r : {&start, &stop}) {
      EXPECT_TRUE(r->at_rest && r->augmented() && !r->mirrored && !r->retimed);
      EXPECT_EQ(r->content, orig.content);
      EXPECT_EQ(r->source, orig.source);
    }
    // Held a second at 30 fps: the stop's last 30 frames and the start's first 30 barely move
    // (the filtered control spreads the ramp a little into them), against a walking step in the middle.
    const double walking = step_m(orig, orig.num_frames / 2);
    EXPECT_GT(walking, 0.01);
    EXPECT_LT(step_m(stop, stop.num_frames - 2), 0.05 * walking);
    EXPECT_LT(step_m(start, 2), 0.05 * walking);
  }
  o.rest_hold_s = -1.0;
  o.overwrite = true;
  EXPECT_THROW(prepare_dataset(o), Error);
}

// rest_fraction keeps a share of the copies at rest, chosen alike on every run: 12 training files
// and their mirrors give 48 candidate copies (two ends each); half of them is kept, the originals
// all, and the same ones again when prepared anew.
TEST(Prepare, KeepsAShareOfTheCopiesAtRestTheSameEachTime) {
  const fs::path full_dir = temp_path("rest_full"), half_dir = temp_path("rest_half"), again_dir = temp_path("rest_again");
  for (const fs::path& d : {full_dir, half_dir, again_dir}) fs::remove_all(d);
  PrepareOptions o = basic_options(full_dir.string());
  o.mirror = true;
  o.rest_hold_s = 1.0;
  prepare_dataset(o);
  o.rest_fraction = 0.5;
  o.output_dir = half_dir.string();
  prepare_dataset(o);
  o.output_dir = again_dir.string();
  prepare_dataset(o);
  const Dataset full = Dataset::open(full_dir.string()), half = Dataset::open(half_dir.string()),
                again = Dataset::open(again_dir.string());
  EXPECT_DOUBLE_EQ(full.info().augment_rest_fraction, 1.0);
  EXPECT_DOUBLE_EQ(half.info().augment_rest_fraction, 0.5);
  const auto at_rest = [](const Dataset& ds) {
    std::vector<std::tuple<std::string, bool, int>> kept;
    for (const ClipRecord& r : ds.clips("train"))
      if (r.at_rest) kept.emplace_back(r.source, r.mirrored, r.num_frames);
    return kept;
  };
  const auto all = at_rest(full), some = at_rest(half);
  EXPECT_EQ(all.size(), 48u);
  EXPECT_GT(some.size(), 12u);
  EXPECT_LT(some.size(), 36u);
  EXPECT_EQ(at_rest(again), some);
  for (const auto& copy : some) EXPECT_NE(std::find(all.begin(), all.end(), copy), all.end());
  EXPECT_EQ(full.clips("train").size() - all.size(), half.clips("train").size() - some.size());
  o.rest_fraction = 0.0;
  o.overwrite = true;
  EXPECT_THROW(prepare_dataset(o), Error);
}

TEST(Prepare, RetimedCopiesAndBorrowedStats) {
  const fs::path out = temp_path("retime"), plain_dir = temp_path("retime_plain");
  fs::remove_all(out);
  fs::remove_all(plain_dir);
  PrepareOptions o = basic_options(plain_dir.string());
  o.mirror = true;
  prepare_dataset(o);
  const Dataset plain = Dataset::open(plain_dir.string());
  o.output_dir = out.string();
  o.retime_factors = {1.5};
  o.stats_from = plain_dir.string();
  prepare_dataset(o);
  const Dataset ds = Dataset::open(out.string());
  EXPECT_EQ(ds.info().augment_retime, std::vector<double>{1.5});
  EXPECT_EQ(ds.info().stats_from, plain_dir.string());
  EXPECT_EQ(ds.stats().pose_mean, plain.stats().pose_mean);
  EXPECT_EQ(ds.stats().control_std, plain.stats().control_std);
  for (const char* split : {"train", "val"}) {
    const auto& recs = ds.clips(split);
    const auto& base = plain.clips(split);
    ASSERT_EQ(recs.size(), 2 * base.size()) << split;
    for (size_t f = 0; f < base.size() / 2; ++f) {  // per file: original, mirror, retimed original, retimed mirror
      const ClipRecord& orig = recs[4 * f];
      const ClipRecord& fast = recs[4 * f + 2];
      EXPECT_FALSE(orig.augmented());
      EXPECT_TRUE(fast.retimed && fast.augmented() && !fast.mirrored);
      EXPECT_TRUE(recs[4 * f + 3].retimed && recs[4 * f + 3].mirrored);
      EXPECT_EQ(orig.num_frames, 90);
      EXPECT_EQ(fast.num_frames, 60);  // 0, 1.5, ..., 88.5
      EXPECT_EQ(fast.content, orig.content);
      // Root speed from the control: dx, dz per frame, summed over the clip.
      auto distance = [](const ClipRecord& r, int frames) {
        double d = 0;
        for (int t = 1; t < frames; ++t) d += std::hypot(r.control[3 * t], r.control[3 * t + 1]);
        return d;
      };
      EXPECT_NEAR(distance(fast, 59) / 58, 1.5 * distance(orig, 88) / 87, 0.05 * distance(orig, 88) / 87);
    }
  }
  o.retime_factors = {1.0};
  EXPECT_THROW(prepare_dataset(o), Error);
  o.retime_factors = {-2};
  EXPECT_THROW(prepare_dataset(o), Error);
  o.retime_factors = {};
  o.stats_from = out.string() + "/nowhere";
  EXPECT_THROW(prepare_dataset(o), Error);
  fs::remove_all(out);
  fs::remove_all(plain_dir);
}

// retime_min/max_speed_mps keep the retimed copies to clips whose mean root speed lies in the band:
// a minimum above every clip's speed adds none, one below every clip's retimes all, a band that
// holds no clip none; the bounds are recorded in dataset.json, and negative or crossed ones refused.
TEST(Prepare, RetimeOnlyClipsInASpeedBand) {
  const fs::path out = temp_path("retime_min");
  fs::remove_all(out);
  PrepareOptions o = basic_options(out.string());
  o.retime_factors = {1.5};
  o.retime_min_speed_mps = 1000.0;
  prepare_dataset(o);
  const Dataset none = Dataset::open(out.string());
  EXPECT_DOUBLE_EQ(none.info().augment_retime_min_speed_mps, 1000.0);
  size_t originals = 0;
  for (const char* split : {"train", "val"})
    for (const ClipRecord& r : none.clips(split)) {
      EXPECT_FALSE(r.retimed);
      ++originals;
    }
  o.retime_min_speed_mps = 1e-6;
  o.overwrite = true;
  prepare_dataset(o);
  const Dataset all = Dataset::open(out.string());
  size_t retimed = 0, total = 0;
  for (const char* split : {"train", "val"})
    for (const ClipRecord& r : all.clips(split)) {
      retimed += r.retimed ? 1 : 0;
      ++total;
    }
  EXPECT_EQ(total, 2 * originals);
  EXPECT_EQ(retimed, originals);
  o.retime_min_speed_mps = 0;
  o.retime_max_speed_mps = 1e-7;  // a band that holds no clip
  prepare_dataset(o);
  for (const char* split : {"train", "val"})
    for (const ClipRecord& r : Dataset::open(out.string()).clips(split)) EXPECT_FALSE(r.retimed);
  o.retime_max_speed_mps = 1000.0;
  prepare_dataset(o);
  EXPECT_DOUBLE_EQ(Dataset::open(out.string()).info().augment_retime_max_speed_mps, 1000.0);
  o.retime_min_speed_mps = -1;
  EXPECT_THROW(prepare_dataset(o), Error);
  o.retime_min_speed_mps = 2.0;
  o.retime_max_speed_mps = 1.0;
  EXPECT_THROW(prepare_dataset(o), Error);
  fs::remove_all(out);
}

// split_from keeps another dataset's split when contents are added: its held-out files stay held
// out and its training files in training, whatever the new seed; the added files are split too.
TEST(Prepare, SplitFromKeepsHeldOutFilesHeldOut) {
  const fs::path small = temp_path("split_small"), grown = temp_path("split_grown");
  fs::remove_all(small);
  fs::remove_all(grown);
  PrepareOptions o = basic_options(small.string());
  o.contents = {"walk", "run"};
  o.val_fraction = 0.5;
  prepare_dataset(o);
  const DatasetInfo before = Dataset::open(small.string()).info();
  ASSERT_EQ(before.val_files.size(), 4u);  // half of 2 contents x 2 styles x 2 takes
  o.output_dir = grown.string();
  o.contents = {};
  o.val_fraction = 0.25;
  o.seed = 99;
  o.split_from = small.string();
  prepare_dataset(o);
  const DatasetInfo after = Dataset::open(grown.string()).info();
  EXPECT_EQ(after.split_from, small.string());
  auto has = [](const std::vector<std::string>& files, const std::string& f) {
    return std::find(files.begin(), files.end(), f) != files.end();
  };
  for (const std::string& f : before.val_files) EXPECT_TRUE(has(after.val_files, f)) << f;
  for (const std::string& f : before.train_files) EXPECT_TRUE(has(after.train_files, f)) << f;
  EXPECT_EQ(after.val_files.size() + after.train_files.size(), 16u);
  EXPECT_GT(after.val_files.size(), before.val_files.size());  // some added files held out as well
  o.split_from = temp_path("split_nowhere").string();
  EXPECT_THROW(prepare_dataset(o), Error);
  fs::remove_all(small);
  fs::remove_all(grown);
}

TEST(Prepare, PositionsFormFiltersJointsAndResample) {
  const fs::path out = temp_path("pos");
  fs::remove_all(out);
  PrepareOptions o = basic_options(out.string());
  o.form = PoseForm::kPositions;
  o.contents = {"walk", "run"};
  o.styles = {"dataset-9_brisk"};
  o.drop_joint_patterns = {"Hand_*", "Toes_?"};
  o.fps = 15;
  o.val_fraction = 0;
  const DatasetInfo info = prepare_dataset(o);
  EXPECT_EQ(info.skeleton.num_joints(), 17);
  EXPECT_EQ(info.layout.pose_dim, 3 * 17);
  EXPECT_EQ(info.content_labels, (std::vector<std::string>{"walk", "run"}));
  EXPECT_EQ(info.style_labels, (std::vector<std::string>{"brisk"}));
  EXPECT_DOUBLE_EQ(info.fps, 15.0);
  EXPECT_EQ(info.train_files.size(), 4u);
  EXPECT_TRUE(info.val_files.empty());
  const Dataset d = Dataset::open(out.string());
  EXPECT_EQ(d.clips("train")[0].num_frames, 45);  // 90 frames at 30 fps: t = 0 .. 89/30 s
  for (const ClipRecord& c : d.clips("train")) EXPECT_EQ(d.info().style_labels[c.style], "brisk");
  o.contents = {"dance"};
  o.overwrite = true;
  EXPECT_THROW(prepare_dataset(o), Error);
  fs::remove_all(out);
}

// One more file encoded for an existing dataset gives exactly its record from prepare time: same
// cleaning (joint patterns, resampling), units and layout.
TEST(Prepare, EncodeClipForDatasetMatchesPreparedRecord) {
  const fs::path out = temp_path("more");
  fs::remove_all(out);
  PrepareOptions o = basic_options(out.string());
  o.form = PoseForm::kPositions;
  o.drop_joint_patterns = {"Hand_*"};
  o.fps = 15;
  prepare_dataset(o);
  const Dataset d = Dataset::open(out.string());
  const ClipRecord& rec = d.clips("train").at(0);
  const std::string file = synthetic_source() + "/" + rec.source;
  std::vector<float> pose, control;
  encode_clip_for_dataset(d.info(), io::to_clip(io::read_bvh(file)), file, &pose, &control);
  ASSERT_EQ(pose.size(), rec.pose.size());
  ASSERT_EQ(control.size(), rec.control.size());
  for (size_t i = 0; i < pose.size(); ++i) ASSERT_FLOAT_EQ(pose[i], rec.pose[i]) << i;
  for (size_t i = 0; i < control.size(); ++i) ASSERT_FLOAT_EQ(control[i], rec.control[i]) << i;
  // Another hierarchy (one toe fewer; the hands are dropped by the dataset's patterns) is refused.
  Clip other = subset_by_patterns(io::to_clip(io::read_bvh(file)), {"Toes_L"}, {});
  try {
    encode_clip_for_dataset(d.info(), other, "other.bvh", &pose, &control);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("other.bvh: skeleton differs"), std::string::npos) << e.what();
  }
  fs::remove_all(out);
}

TEST(Prepare, RejectsMismatchedSkeletonAndBadOptions) {
  const fs::path src = temp_path("src");
  const fs::path out = temp_path("out");
  fs::remove_all(src);
  fs::remove_all(out);
  fs::create_directories(src);
  // Plain folder: two synthetic files, the second with a renamed joint.
  const SourceListing l = list_source(synthetic_source());
  fs::copy_file(l.files[0].path, src / "a.bvh");
  io::BvhFile bvh = io::read_bvh(l.files[1].path);
  bvh.skeleton.joint_names[5] = "Chin";
  io::write_bvh((src / "b.bvh").string(), bvh);
  PrepareOptions o = basic_options(out.string());
  o.input_dirs = {src.string()};
  try {
    prepare_dataset(o);
    FAIL();
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("b.bvh"), std::string::npos) << msg;
    EXPECT_NE(msg.find("Chin"), std::string::npos) << msg;
  }
  // Bone lengths far from the mean.
  bvh = io::read_bvh(l.files[1].path);
  bvh.skeleton.offsets[3] *= 2.5;
  io::write_bvh((src / "b.bvh").string(), bvh);
  try {
    prepare_dataset(o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("% off"), std::string::npos) << e.what();
  }
  // A malformed BVH names the file and line.
  {
    std::ofstream(src / "b.bvh") << "HIERARCHY\nROOT x\n{\n";
  }
  EXPECT_THROW(prepare_dataset(o), ParseError);
  fs::remove(src / "b.bvh");
  EXPECT_NO_THROW(prepare_dataset(o));  // one file: all of it in train
  EXPECT_FALSE(fs::exists(out / "dataset.json.tmp"));
  PrepareOptions bad = o;
  bad.window_frames = 0;
  EXPECT_THROW(prepare_dataset(bad), Error);
  bad = o;
  bad.val_fraction = 1.0;
  EXPECT_THROW(prepare_dataset(bad), Error);
  bad = o;
  bad.input_dirs = {};
  EXPECT_THROW(prepare_dataset(bad), Error);
  fs::remove_all(src);
  fs::remove_all(out);
}

// Real data: a small Bandai-Namco subset (one style of locomotion, dataset 2) and the CMU
// walks, resampled to 30 fps.
std::string data_cache() { return MOSYN_DATA_CACHE; }

TEST(RealDataPrepare, BandaiLocomotionSubsetAndCmuWalks) {
  const std::string bandai = data_cache() + "/bandai-namco/Bandai-Namco-Research-Motiondataset-2";
  const std::string cmu = data_cache() + "/cmu-mocap-subset";
  if (!fs::exists(bandai) || !fs::exists(cmu)) GTEST_SKIP() << "shared data not unpacked";
  const fs::path out = temp_path("bandai");
  fs::remove_all(out);
  PrepareOptions o;
  o.input_dirs = {bandai};
  o.output_dir = out.string();
  o.contents = {"walk", "walk-turn-left", "walk-turn-right", "run"};
  o.styles = {"normal"};
  o.mirror = true;
  o.val_fraction = 0.2;
  const DatasetInfo info = prepare_dataset(o);
  EXPECT_EQ(info.skeleton.joint_names[0], "Hips");
  EXPECT_EQ(info.skeleton.num_joints(), 21);
  EXPECT_EQ(info.layout.pose_dim, 129);
  EXPECT_NEAR(info.skeleton.meters_per_unit, 0.01, 1e-12);
  EXPECT_DOUBLE_EQ(std::round(info.fps), 30.0);
  const Dataset d = Dataset::open(out.string());
  EXPECT_GT(d.windows("train").size(), 100u);
  // Walking forward: mean forward speed per frame about 1 m/s / 30.
  EXPECT_GT(d.stats().control_mean[1], 0.5 / 30);
  EXPECT_LT(d.stats().control_mean[1], 4.0 / 30);
  fs::remove_all(out);

  o.input_dirs = {cmu};
  o.contents = {"walk"};
  o.styles = {};
  o.fps = 30;
  o.form = PoseForm::kPositions;
  o.drop_joint_patterns = {"*Finger*", "*Thumb*", "*Index*"};
  const DatasetInfo c = prepare_dataset(o);
  EXPECT_EQ(c.skeleton.num_joints(), 31 - 6);
  EXPECT_NEAR(c.skeleton.meters_per_unit, 0.056444, 1e-6);
  EXPECT_DOUBLE_EQ(c.fps, 30.0);
  EXPECT_EQ(c.layout.pose_dim, 3 * 25);
  EXPECT_TRUE(c.style_labels.empty());
  EXPECT_EQ(c.content_labels, (std::vector<std::string>{"walk"}));
  const Dataset dc = Dataset::open(out.string());
  // T-pose frame removed: the first frame of every clip is a walking pose with hands below the
  // shoulders... check simply that no clip starts with a large jump in pose.
  for (const ClipRecord& r : dc.clips("train")) {
    ASSERT_GT(r.num_frames, 2);
    double jump = 0;
    for (int k = 0; k < c.layout.pose_dim; ++k) jump = std::max(jump, double(std::abs(r.pose[c.layout.pose_dim + k] - r.pose[k])));
    EXPECT_LT(jump, 0.2) << r.source << " " << r.mirrored;  // metres per frame at 30 fps
  }
  fs::remove_all(out);
}

}  // namespace
}  // namespace mosyn::data

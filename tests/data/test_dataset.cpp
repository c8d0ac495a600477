#include "data/dataset.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/synthetic.h"
#include "io/atomic_file.h"
#include "io/json_file.h"

namespace mosyn::data {
namespace {
namespace fs = std::filesystem;

ClipRecord make_record(const std::string& source, int frames, int pose_dim, float base) {
  ClipRecord r;
  r.source = source;
  r.content = 1;
  r.style = 0;
  r.mirrored = true;
  r.num_frames = frames;
  for (int i = 0; i < frames * pose_dim; ++i) r.pose.push_back(base + 0.5f * i);
  for (int i = 0; i < frames * 3; ++i) r.control.push_back(-base - i);
  return r;
}

DatasetInfo make_info() {
  DatasetInfo info;
  info.skeleton = make_synthetic_biped();
  info.layout = make_layout(info.skeleton, PoseForm::kPositions, 0, Eigen::Vector3d(0, 0, 1));
  info.window_frames = 4;
  info.window_hop = 2;
  info.content_labels = {"walk", "run"};
  info.style_labels = {"normal"};
  info.train_files = {"a.bvh"};
  info.val_files = {"b.bvh"};
  info.source_dir = "/src";
  return info;
}

// A dataset records its control; datasets written before the smoothed control (no
// root_smoothing_s key) read as the raw hip trajectory, with the old pose dimensions.
TEST(Dataset, LayoutRecordsTheControlAndOldDatasetsStillLoad) {
  DatasetInfo info = make_info();
  info.layout = make_layout(info.skeleton, PoseForm::kRotations, 0, Eigen::Vector3d(0, 0, 1), 0.35);
  nlohmann::json j = info_to_json(info);
  EXPECT_DOUBLE_EQ(j["layout"]["root_smoothing_s"].get<double>(), 0.35);
  EXPECT_EQ(info_from_json(j, "d.json").layout.pose_dim, 129);
  DatasetInfo old = make_info();
  old.layout = make_layout(old.skeleton, PoseForm::kRotations, 0, Eigen::Vector3d(0, 0, 1));
  nlohmann::json jo = info_to_json(old);
  jo["layout"].erase("root_smoothing_s");
  const DatasetInfo back = info_from_json(jo, "old.json");
  EXPECT_EQ(back.layout.root_smoothing_s, 0.0);
  EXPECT_EQ(back.layout.pose_dim, 127);
  jo["layout"]["root_smoothing_s"] = -1;
  EXPECT_THROW(info_from_json(jo, "bad.json"), ParseError);
  // A smoothed layout's dims with the key removed no longer fit the skeleton: named error.
  j["layout"].erase("root_smoothing_s");
  EXPECT_THROW(info_from_json(j, "d.json"), ParseError);
}

// Found by fuzz_json_config: an optional key of the wrong type ("source_dirs": [1]) escaped as a
// bare nlohmann exception naming no file. Every optional key is now read like the required ones.
TEST(Dataset, OptionalKeysOfTheWrongTypeNameTheFile) {
  DatasetInfo info = make_info();
  info.layout = make_layout(info.skeleton, PoseForm::kRotations, 0, Eigen::Vector3d(0, 0, 1), 0.35);
  const nlohmann::json good = info_to_json(info);
  for (const auto& [key, value] : std::vector<std::pair<std::string, nlohmann::json>>{
           {"source_dirs", nlohmann::json::array({1})}, {"source_layout", 3}, {"tpose", false},
           {"drop_joint_patterns", "x"}, {"keep_joint_patterns", nlohmann::json::array({nullptr})},
           {"source_joint_names", 1.5}, {"augmentation", 7}, {"max_train_seconds", "many"},
           {"max_train_seconds", -2}}) {
    SCOPED_TRACE(key);
    nlohmann::json j = good;
    j[key] = value;
    try {
      info_from_json(j, "dataset.json");
      ADD_FAILURE() << "accepted " << value.dump();
    } catch (const ParseError& e) {
      EXPECT_EQ(e.file(), "dataset.json");
    }
  }
  nlohmann::json j = good;
  j["augmentation"]["mirror"] = "yes";
  EXPECT_THROW(info_from_json(j, "dataset.json"), ParseError);
  j = good;
  j.erase("source_dirs");  // absent: the old default
  EXPECT_EQ(info_from_json(j, "dataset.json").source_dirs, std::vector<std::string>{"/src"});
}

TEST(Dataset, CacheRoundTripAndCorruption) {
  const int dim = 63;
  std::vector<ClipRecord> clips = {make_record("data/a.bvh", 5, dim, 1.0f), make_record("data/ü.bvh", 0, dim, 2.0f)};
  clips[1].reversed = true;
  clips[1].content = -1;
  const std::string bytes = format_clip_cache(clips, dim, 3);
  const std::vector<ClipRecord> back = parse_clip_cache(bytes, dim, 3, "x.bin");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].source, "data/a.bvh");
  EXPECT_EQ(back[0].pose, clips[0].pose);
  EXPECT_EQ(back[0].control, clips[0].control);
  EXPECT_TRUE(back[0].mirrored);
  EXPECT_FALSE(back[0].reversed);
  EXPECT_TRUE(back[1].reversed);
  EXPECT_EQ(back[1].content, -1);
  EXPECT_EQ(back[1].source, "data/ü.bvh");

  // Truncation anywhere, a flipped byte, wrong dims: clear errors naming the file.
  for (size_t cut : {size_t{3}, size_t{20}, bytes.size() / 2, bytes.size() - 1}) {
    try {
      parse_clip_cache(bytes.substr(0, cut), dim, 3, "x.bin");
      FAIL() << cut;
    } catch (const ParseError& e) {
      EXPECT_EQ(e.file(), "x.bin");
    }
  }
  std::string flipped = bytes;
  flipped[60] ^= 0x10;
  EXPECT_THROW(parse_clip_cache(flipped, dim, 3, "x.bin"), ParseError);
  try {
    parse_clip_cache(bytes, dim + 1, 3, "x.bin");
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("dims"), std::string::npos) << e.what();
  }
  ClipRecord bad = clips[0];
  bad.pose.pop_back();
  EXPECT_THROW(format_clip_cache({bad}, dim, 3), Error);
}

TEST(Dataset, StatsAreFlooredPopulationStd) {
  ClipRecord a;
  a.num_frames = 2;
  a.pose = {1, 5, 3, 5};
  a.control = {0, 0, 0, 2, 0, 0};
  const DatasetStats s = compute_stats({a}, 2, 3);
  EXPECT_FLOAT_EQ(s.pose_mean[0], 2);
  EXPECT_FLOAT_EQ(s.pose_std[0], 1);
  EXPECT_FLOAT_EQ(s.pose_mean[1], 5);
  EXPECT_FLOAT_EQ(s.pose_std[1], kStdFloor);
  EXPECT_FLOAT_EQ(s.control_std[0], 1);
  const DatasetStats empty = compute_stats({}, 2, 3);
  EXPECT_FLOAT_EQ(empty.pose_std[0], 1);
}

TEST(Dataset, WriteOpenAndValidate) {
  const fs::path dir = fs::temp_directory_path() / "mosyn_dataset_write_open";
  fs::remove_all(dir);
  const DatasetInfo info = make_info();
  std::vector<ClipRecord> train = {make_record("a.bvh", 9, 63, 0.f)};
  std::vector<ClipRecord> val = {make_record("b.bvh", 3, 63, 1.f)};
  const DatasetStats stats = compute_stats(train, 63, 3);
  write_dataset(dir.string(), info, stats, train, val, false);
  EXPECT_THROW(write_dataset(dir.string(), info, stats, train, val, false), Error);
  const Dataset d = Dataset::open(dir.string());
  EXPECT_EQ(d.info().layout.pose_names, info.layout.pose_names);
  EXPECT_EQ(d.info().skeleton.joint_names, info.skeleton.joint_names);
  EXPECT_EQ(d.info().skeleton.end_sites.size(), info.skeleton.end_sites.size());
  EXPECT_EQ(d.info().content_labels, info.content_labels);
  EXPECT_EQ(d.clips("train")[0].pose, train[0].pose);
  // 9 frames, window 4, hop 2 -> starts 0, 2, 4; val has 3 frames -> none.
  const std::vector<WindowRef> w = d.windows("train");
  ASSERT_EQ(w.size(), 3u);
  EXPECT_EQ(w[2].start, 4);
  EXPECT_TRUE(d.windows("val").empty());
  EXPECT_EQ(d.windows("val", 3, 1).size(), 1u);
  // Short clips as one padded window, for families that mask padding: at least min frames.
  const std::vector<WindowRef> short_ones = d.windows("val", 4, 2, 2);
  ASSERT_EQ(short_ones.size(), 1u);
  EXPECT_EQ(short_ones[0].start, 0);
  EXPECT_EQ(short_ones[0].frames, 3);
  EXPECT_TRUE(d.windows("val", 4, 2, 4).empty());
  EXPECT_EQ(d.windows("train", 4, 2, 2).size(), 3u);  // long enough: full windows only
  EXPECT_EQ(d.windows("train", 4, 2, 2)[0].frames, 0);

  // Truncated cache.
  const std::string train_path = (dir / "train.bin").string();
  const std::string good = io::read_file(train_path);
  io::write_file_atomically(train_path, good.substr(0, good.size() - 9));
  try {
    Dataset::open(dir.string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("train.bin"), std::string::npos) << e.what();
  }
  io::write_file_atomically(train_path, good);
  // Dims mismatch between dataset.json and the skeleton.
  const std::string info_path = (dir / "dataset.json").string();
  nlohmann::json j = io::read_json(info_path);
  j["layout"]["pose_dim"] = 64;
  io::write_json(info_path, j);
  EXPECT_THROW(Dataset::open(dir.string()), ParseError);
  // Bad JSON.
  io::write_file_atomically(info_path, "{\"version\": 1,\n");
  try {
    Dataset::open(dir.string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("dataset.json"), std::string::npos) << e.what();
  }
  // Missing files.
  fs::remove(info_path);
  EXPECT_THROW(Dataset::open(dir.string()), Error);
  EXPECT_THROW(Dataset::open((dir / "nope").string()), Error);
  fs::remove_all(dir);
}

// Bad numbers are refused with the file named: a NaN or infinity in a cache (which the hash does
// not catch: it was written that way) names the file, clip, frame and dimension; a stats.json
// whose numbers overflow to infinity, or hold a null, names stats.json.
TEST(Dataset, NonFiniteNumbersAreRefusedWithTheFileNamed) {
  const fs::path dir = fs::temp_directory_path() / "mosyn_dataset_non_finite";
  fs::remove_all(dir);
  const DatasetInfo info = make_info();
  std::vector<ClipRecord> train = {make_record("a.bvh", 9, 63, 0.f), make_record("c.bvh", 5, 63, 2.f)};
  std::vector<ClipRecord> val = {make_record("b.bvh", 3, 63, 1.f)};
  const DatasetStats stats = compute_stats(train, 63, 3);
  write_dataset(dir.string(), info, stats, train, val, false);
  const std::string train_path = (dir / "train.bin").string();
  const std::string good = io::read_file(train_path);
  for (const float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    std::vector<ClipRecord> poisoned = train;
    poisoned[1].pose[2 * 63 + 7] = bad;
    io::write_file_atomically(train_path, format_clip_cache(poisoned, 63, 3));
    try {
      Dataset::open(dir.string());
      ADD_FAILURE() << "a non-finite pose value was accepted";
    } catch (const ParseError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("train.bin"), std::string::npos) << what;
      EXPECT_NE(what.find("c.bvh"), std::string::npos) << what;
      EXPECT_NE(what.find("frame 2, dimension 7"), std::string::npos) << what;
    }
  }
  std::vector<ClipRecord> poisoned = train;
  poisoned[0].control[4] = -std::numeric_limits<float>::infinity();
  io::write_file_atomically(train_path, format_clip_cache(poisoned, 63, 3));
  EXPECT_THROW(Dataset::open(dir.string()), ParseError);
  io::write_file_atomically(train_path, good);
  ASSERT_NO_THROW(Dataset::open(dir.string()));

  const std::string stats_path = (dir / "stats.json").string();
  const std::string stats_text = io::read_file(stats_path);
  nlohmann::json j = nlohmann::json::parse(stats_text);
  for (const std::string& replacement : {std::string("1e999"), std::string("null")}) {
    std::string text = j.dump();
    const size_t at = text.find("\"pose_mean\":[") + std::string("\"pose_mean\":[").size();
    const size_t comma = text.find(',', at);
    text = text.substr(0, at) + replacement + text.substr(comma);
    io::write_file_atomically(stats_path, text);
    try {
      Dataset::open(dir.string());
      ADD_FAILURE() << "stats.json with " << replacement << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("stats.json"), std::string::npos) << e.what();
    }
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mosyn::data

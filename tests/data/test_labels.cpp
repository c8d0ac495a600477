#include "data/labels.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"

namespace mosyn::data {
namespace {
namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() / ("mosyn_labels_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
                                         "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string str() const { return path_.string(); }
  void write(const std::string& relative, const std::string& text) const {
    fs::create_directories((path_ / relative).parent_path());
    std::ofstream(path_ / relative) << text;
  }

 private:
  fs::path path_;
};

const char* kBvh = "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n"
                   "End Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.0333333\n0 0 0\n";

TEST(Labels, StripDatasetPrefixAndMirroredLabel) {
  EXPECT_EQ(strip_dataset_prefix("dataset-2_walk"), "walk");
  EXPECT_EQ(strip_dataset_prefix("dataset-12_walk-turn-left"), "walk-turn-left");
  EXPECT_EQ(strip_dataset_prefix("dataset-_walk"), "dataset-_walk");
  EXPECT_EQ(strip_dataset_prefix("walk"), "walk");
  EXPECT_EQ(mirrored_label("walk-turn-left"), "walk-turn-right");
  EXPECT_EQ(mirrored_label("wave-right-hand"), "wave-left-hand");
  EXPECT_EQ(mirrored_label("bright"), "bright");
  EXPECT_EQ(mirrored_label(""), "");
}

TEST(Labels, BandaiLayout) {
  TempDir d;
  d.write("cfg/content_label.txt", "dataset-2_walk\r\ndataset-2_run\r\n");
  d.write("cfg/style_label.txt", "dataset-2_normal\ndataset-2_happy\n");
  d.write("data/dataset-2_run_happy_001.bvh", kBvh);
  d.write("data/dataset-2_run_happy_001.json", R"({"content": 1, "style": 1})");
  d.write("data/dataset-2_walk_normal_001.bvh", kBvh);
  d.write("data/dataset-2_walk_normal_001.json", R"({"content": 0, "style": 0})");
  SourceListing l = list_source(d.str());
  EXPECT_EQ(l.layout, SourceLayout::kBandaiNamco);
  EXPECT_EQ(l.content_labels, (std::vector<std::string>{"walk", "run"}));
  EXPECT_EQ(l.style_labels, (std::vector<std::string>{"normal", "happy"}));
  ASSERT_EQ(l.files.size(), 2u);
  EXPECT_EQ(l.files[0].relative, "data/dataset-2_run_happy_001.bvh");
  EXPECT_EQ(l.files[0].content, "run");
  EXPECT_EQ(l.files[0].style, "happy");
  filter_source(&l, {"dataset-2_walk"}, {});
  ASSERT_EQ(l.files.size(), 1u);
  EXPECT_EQ(l.files[0].content, "walk");
  try {
    filter_source(&l, {"dance"}, {});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("known: walk, run"), std::string::npos) << e.what();
  }
}

TEST(Labels, BandaiMalformedLabels) {
  TempDir d;
  d.write("cfg/content_label.txt", "dataset-2_walk\n\ndataset-2_run\n");
  d.write("cfg/style_label.txt", "dataset-2_normal\n");
  d.write("data/a.bvh", kBvh);
  d.write("data/a.json", R"({"content": 0, "style": 0})");
  try {
    list_source(d.str());
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_NE(e.file().find("content_label.txt"), std::string::npos);
  }
  d.write("cfg/content_label.txt", "dataset-2_walk\n");
  d.write("data/a.json", R"({"content": 3, "style": 0})");
  EXPECT_THROW(list_source(d.str()), ParseError);
  d.write("data/a.json", R"({"content": "walk", "style": 0})");
  EXPECT_THROW(list_source(d.str()), ParseError);
  fs::remove(fs::path(d.str()) / "data/a.json");
  try {
    list_source(d.str());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("a.json"), std::string::npos);
  }
}

TEST(Labels, CmuLayout) {
  TempDir d;
  d.write("index.csv",
          "file,subject,trial,action,description,frames,fps,seconds\n"
          "bvh/01/01_01.bvh,1,1,jump,\"playground - forward jumps, turn around\",2,120,0.01\n"
          "bvh/02/02_01.bvh,2,1,walk,walk,2,120,0.01\n");
  d.write("bvh/01/01_01.bvh", kBvh);
  d.write("bvh/02/02_01.bvh", kBvh);
  const SourceListing l = list_source(d.str());
  EXPECT_EQ(l.layout, SourceLayout::kCmu);
  EXPECT_EQ(l.content_labels, (std::vector<std::string>{"jump", "walk"}));
  EXPECT_TRUE(l.style_labels.empty());
  ASSERT_EQ(l.files.size(), 2u);
  EXPECT_EQ(l.files[1].content, "walk");
  EXPECT_EQ(l.files[1].style, "");
  d.write("index.csv", "file,action\nbvh/01/01_01.bvh,jump\nbvh/02/02_01.bvh\n");
  try {
    list_source(d.str());
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), 3);
  }
  d.write("index.csv", "file,action\nbvh/09/09_01.bvh,jump\n");
  EXPECT_THROW(list_source(d.str()), ParseError);
  d.write("index.csv", "name,action\n");
  EXPECT_THROW(list_source(d.str()), ParseError);
}

TEST(Labels, PlainFolder) {
  TempDir d;
  d.write("b/x.bvh", kBvh);
  d.write("a.BVH", kBvh);
  d.write("notes.txt", "hello");
  SourceListing l = list_source(d.str());
  EXPECT_EQ(l.layout, SourceLayout::kPlain);
  ASSERT_EQ(l.files.size(), 2u);
  EXPECT_EQ(l.files[0].relative, "a.BVH");
  EXPECT_EQ(l.files[1].relative, "b/x.bvh");
  EXPECT_THROW(filter_source(&l, {"walk"}, {}), Error);
  TempDir empty;
  EXPECT_THROW(list_source(empty.str()), Error);
  EXPECT_THROW(list_source(empty.str() + "/missing"), Error);
}

}  // namespace
}  // namespace mosyn::data

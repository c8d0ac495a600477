// The `mosyn` command as a user runs it: exit codes, messages and files for info and convert.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "cli_test_util.h"
#include "core/synthetic.h"
#include "data/control.h"
#include "io/atomic_file.h"
#include "io/bvh.h"
#include "io/npy.h"

namespace mosyn {
namespace {

using testing::fresh_dir;
using testing::run_mosyn;
using ::testing::HasSubstr;

// A synthetic walk written as a BVH file (centimetres, 30 fps, 60 frames).
std::string write_walk_bvh(const std::filesystem::path& dir) {
  Clip clip;
  clip.skeleton = make_synthetic_biped();
  clip.motion = make_synthetic_walk(clip.skeleton, 60, 30.0, SyntheticWalkOptions{});
  const std::string path = (dir / "walk.bvh").string();
  io::write_bvh(path, io::from_clip(clip));
  return path;
}

TEST(CliTest, UsageErrorsExitWithTwo) {
  const auto bare = run_mosyn("");  // prints what mosyn can do, one example per command
  EXPECT_EQ(bare.exit_code, 2);
  for (const char* example : {"mosyn sample models/", "mosyn serve models/", "mosyn convert ", "mosyn train ", "mosyn eval "})
    EXPECT_NE(bare.out.find(example), std::string::npos) << example;
  EXPECT_EQ(run_mosyn("no-such-command").exit_code, 2);
  const auto misspelt = run_mosyn("trian --help");  // not the overview with exit 0
  EXPECT_EQ(misspelt.exit_code, 2);
  EXPECT_NE(misspelt.err.find("unknown command 'trian'"), std::string::npos) << misspelt.err;
  EXPECT_EQ(run_mosyn("info").exit_code, 2);
  EXPECT_EQ(run_mosyn("convert a.bvh b.bvh --no-such-flag").exit_code, 2);
  EXPECT_EQ(run_mosyn("--help").exit_code, 0);
}

TEST(CliTest, InfoDescribesAFile) {
  const auto dir = fresh_dir("info");
  const auto r = run_mosyn("info " + write_walk_bvh(dir));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("frames:    60"));
  EXPECT_THAT(r.out, HasSubstr("fps:       30"));
  EXPECT_THAT(r.out, HasSubstr("centimetres"));
  EXPECT_THAT(r.out, HasSubstr("Hips"));
}

TEST(CliTest, MissingFileNamesTheFile) {
  const auto r = run_mosyn("info /nonexistent/walk.bvh");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("/nonexistent/walk.bvh"));
}

TEST(CliTest, MalformedFileNamesFileAndLine) {
  const auto dir = fresh_dir("malformed");
  const std::string path = (dir / "bad.bvh").string();
  std::ofstream(path) << "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 zero\n  CHANNELS 3 Xrotation Yrotation Zrotation\n}\n";
  const auto r = run_mosyn("info " + path);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr(path + ":4:"));
}

TEST(CliTest, BinaryGarbageIsAnErrorNotACrash) {
  const auto dir = fresh_dir("garbage");
  const std::string path = (dir / "noise.bvh").string();
  std::ofstream out(path, std::ios::binary);
  for (int i = 0; i < 4096; ++i) out.put(static_cast<char>((i * 7919) % 256));
  out.close();
  const auto r = run_mosyn("info " + path);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr(path));
}

TEST(CliTest, ConvertToPositionsNpyHasShapeFramesJointsThree) {
  const auto dir = fresh_dir("npy");
  const std::string npy = (dir / "walk.npy").string();
  const auto r = run_mosyn("convert " + write_walk_bvh(dir) + " " + npy + " --positions");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::NpyArray a = io::read_npy(npy);
  EXPECT_EQ(a.dtype, io::NpyDtype::kFloat32);
  EXPECT_EQ(a.shape, (std::vector<std::int64_t>{60, make_synthetic_biped().num_joints(), 3}));
}

TEST(CliTest, ConvertToCsvHasHeader) {
  const auto dir = fresh_dir("csv");
  const std::string csv = (dir / "walk.csv").string();
  ASSERT_EQ(run_mosyn("convert " + write_walk_bvh(dir) + " " + csv + " --positions").exit_code, 0);
  const std::string text = testing::slurp(csv);
  EXPECT_EQ(text.substr(0, text.find('\n')), "frame,joint,x,y,z");
}

TEST(CliTest, ConvertResamplesAndKeepsJoints) {
  const auto dir = fresh_dir("resample");
  const std::string out = (dir / "walk15.bvh").string();
  ASSERT_EQ(run_mosyn("convert " + write_walk_bvh(dir) + " " + out + " --fps 15").exit_code, 0);
  const io::BvhFile bvh = io::read_bvh(out);
  EXPECT_NEAR(bvh.frame_time_s, 1.0 / 15, 1e-9);
  EXPECT_EQ(bvh.num_frames, 30);  // frames at k/15 s within 59/30 s
  EXPECT_EQ(bvh.skeleton.num_joints(), make_synthetic_biped().num_joints());
}

TEST(CliTest, ConvertJointSubsetKeepsTheRoot) {
  const auto dir = fresh_dir("subset");
  const std::string out = (dir / "legs.bvh").string();
  const auto r = run_mosyn("convert " + write_walk_bvh(dir) + " " + out + " --joints '*Leg*,*Foot*'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::BvhFile bvh = io::read_bvh(out);
  EXPECT_EQ(bvh.skeleton.joint_names[0], "Hips");
  for (const auto& name : bvh.skeleton.joint_names)
    EXPECT_TRUE(name == "Hips" || name.find("Leg") != std::string::npos || name.find("Foot") != std::string::npos)
        << name;
}

// The root control written as CSV is what `data::control_from_clip` computes, and reads back as
// the same numbers at the file's 30 fps (`sample --control file.csv` uses it).
TEST(CliTest, ConvertWritesTheRootControlAsCsv) {
  const auto dir = fresh_dir("control");
  const std::string in = write_walk_bvh(dir), csv = (dir / "walk_control.csv").string();
  const auto r = run_mosyn("convert " + in + " " + csv + " --control");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<float> expected = data::control_from_clip(io::to_clip(io::read_bvh(in)), 30.0);
  const std::vector<float> got = data::control_from_csv(csv, 30.0);
  ASSERT_EQ(got.size(), expected.size());
  for (size_t i = 0; i < got.size(); ++i) EXPECT_NEAR(got[i], expected[i], 1e-6) << i;
  EXPECT_EQ(run_mosyn("convert " + in + " " + (dir / "c.npy").string() + " --control").exit_code, 2);
  EXPECT_EQ(run_mosyn("convert " + in + " " + csv + " --control --positions").exit_code, 2);
}

TEST(CliTest, ConvertRejectsUnknownExtensionAndMissingPositions) {
  const auto dir = fresh_dir("ext");
  const std::string in = write_walk_bvh(dir);
  EXPECT_EQ(run_mosyn("convert " + in + " " + (dir / "walk.txt").string()).exit_code, 2);
  EXPECT_EQ(run_mosyn("convert " + in + " " + (dir / "walk.npy").string()).exit_code, 2);
  EXPECT_FALSE(std::filesystem::exists(dir / "walk.npy"));
}

TEST(CliTest, ConvertWritesGlbAndGltf) {
  const auto dir = fresh_dir("gltf");
  const std::string in = write_walk_bvh(dir), glb = (dir / "walk.glb").string(), gltf = (dir / "walk.gltf").string();
  const auto r = run_mosyn("convert " + in + " " + glb + " --fps 15");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("0.01 m per unit"));
  EXPECT_EQ(io::read_file(glb).substr(0, 4), "glTF");
  ASSERT_EQ(run_mosyn("convert " + in + " " + gltf).exit_code, 0);
  const std::string json = io::read_file(gltf);
  EXPECT_THAT(json, HasSubstr("\"name\":\"walk\""));  // the animation, named as the file
  EXPECT_THAT(json, HasSubstr("\"name\":\"Hips\""));  // joint nodes named as the BVH joints
  EXPECT_EQ(run_mosyn("convert " + in + " " + glb + " --positions").exit_code, 2);
}

}  // namespace
}  // namespace mosyn

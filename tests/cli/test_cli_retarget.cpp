// `mosyn retarget` as a user runs it: files on the rig, exit codes and messages.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "cli_test_util.h"
#include "core/synthetic.h"
#include "io/atomic_file.h"
#include "io/bvh.h"
#include "io/rig.h"

namespace mosyn {
namespace {

using testing::fresh_dir;
using testing::run_mosyn;
using ::testing::HasSubstr;

// The synthetic walk (centimetres) and a rig: the biped with Mixamo-like names, 1.2 times as big.
struct Files {
  std::string walk, rig, bad_rig;
};

Files write_files(const std::filesystem::path& dir) {
  Files f{(dir / "walk.bvh").string(), (dir / "rig.bvh").string(), (dir / "bad_rig.bvh").string()};
  const Skeleton s = make_synthetic_biped();
  io::write_bvh(f.walk, io::from_clip(Clip{s, make_synthetic_walk(s, 60, 30.0)}));
  Skeleton rig = s;
  for (auto& name : rig.joint_names) name = "mixamorig:" + name;
  for (auto& o : rig.offsets) o *= 1.2;
  io::write_bvh(f.rig, io::from_clip(Clip{rig, Motion::rest(rig, 1, 30.0)}));
  rig.joint_names[13] = "Bone13";
  io::write_bvh(f.bad_rig, io::from_clip(Clip{rig, Motion::rest(rig, 1, 30.0)}));
  return f;
}

TEST(CliRetarget, WritesTheMotionOnTheRigAsBvhAndGlb) {
  const auto dir = fresh_dir("retarget");
  const Files f = write_files(dir);
  for (const char* ext : {"bvh", "glb"}) {
    const std::string out = (dir / (std::string("out.") + ext)).string();
    const auto r = run_mosyn("retarget " + f.walk + " --to " + f.rig + " --out " + out);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_THAT(r.err, HasSubstr("scale 1.2"));
    const io::RigFile back = io::read_rig(out);
    EXPECT_EQ(back.rig.skeleton.joint_names[13], "mixamorig:UpperLeg_L");
  }
  const io::BvhFile bvh = io::read_bvh((dir / "out.bvh").string());
  EXPECT_EQ(bvh.num_frames, 60);
  EXPECT_EQ(bvh.channels, io::read_bvh(f.rig).channels);  // the rig's layout
}

TEST(CliRetarget, ErrorsNameWhatIsWrong) {
  const auto dir = fresh_dir("retarget_errors");
  const Files f = write_files(dir);
  const std::string out = (dir / "out.bvh").string();
  auto r = run_mosyn("retarget " + f.walk + " --to " + f.bad_rig + " --out " + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("Bone13"));
  EXPECT_THAT(r.err, HasSubstr("left thigh"));
  const std::string map = (dir / "map.json").string();
  io::write_file_atomically(map, "{\"Bone13\": \"UpperLeg_L\"}");
  r = run_mosyn("retarget " + f.walk + " --to " + f.bad_rig + " --out " + out + " --map " + map);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  io::write_file_atomically(map, "{\"Bone13\": 3}");
  r = run_mosyn("retarget " + f.walk + " --to " + f.bad_rig + " --out " + out + " --map " + map);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("map.json"));
  EXPECT_EQ(run_mosyn("retarget " + f.walk + " --to rig.fbx --out " + out).exit_code, 2);
  EXPECT_EQ(run_mosyn("retarget " + f.walk + " --to " + f.rig + " --out out.npy").exit_code, 2);
  EXPECT_EQ(run_mosyn("retarget " + f.walk + " --out " + out).exit_code, 2);
}

}  // namespace
}  // namespace mosyn

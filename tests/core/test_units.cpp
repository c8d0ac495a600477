#include "core/units.h"

#include <gtest/gtest.h>

#include "core/synthetic.h"
#include "test_bvh_reader.h"

namespace mosyn {
namespace {

Skeleton scaled(Skeleton s, double factor) {
  for (auto& o : s.offsets) o *= factor;
  for (auto& e : s.end_sites) e.offset *= factor;
  return s;
}

TEST(Units, HeightIsLongestLeafToLeafPathOver125) {
  // root -> a (3) -> end site (1); root -> b (2) -> c (2). Longest path: 1 + 3 + 2 + 2 = 8.
  Skeleton s;
  s.joint_names = {"root", "a", "b", "c"};
  s.parents = {-1, 0, 0, 2};
  s.offsets = {{5, 5, 5}, {0, 3, 0}, {2, 0, 0}, {0, 0, -2}};
  s.end_sites = {{1, {0, 1, 0}}};
  EXPECT_NEAR(estimate_height_units(s), 8 / 1.25, 1e-12);
  // The path need not pass through the root.
  s.joint_names.push_back("d");
  s.parents.push_back(3);
  s.offsets.emplace_back(10, 0, 0);
  s.joint_names.push_back("e");
  s.parents.push_back(3);
  s.offsets.emplace_back(0, 9, 0);
  EXPECT_NEAR(estimate_height_units(s), 19 / 1.25, 1e-12);
}

TEST(Units, SyntheticBipedInEveryUnit) {
  const Skeleton s = make_synthetic_biped();
  const UnitsGuess cm = guess_units(s);
  EXPECT_EQ(cm.meters_per_unit, 0.01);
  EXPECT_EQ(cm.name, "centimetres");
  EXPECT_GT(cm.height_m, 1.6);
  EXPECT_LT(cm.height_m, 2.0);
  EXPECT_EQ(guess_meters_per_unit(scaled(s, 0.01)), 1.0);
  EXPECT_EQ(guess_units(scaled(s, 0.01)).name, "metres");
  EXPECT_EQ(guess_meters_per_unit(scaled(s, 10)), 0.001);
  EXPECT_EQ(guess_meters_per_unit(scaled(s, 1 / 2.54)), 0.0254);
  EXPECT_EQ(guess_meters_per_unit(scaled(s, 1 / 30.48)), 0.3048);
  EXPECT_EQ(guess_meters_per_unit(scaled(s, 1 / 5.6444)), 0.056444);
  // A short (1.2 m) or tall (2.3 m) person in centimetres is still centimetres.
  EXPECT_EQ(guess_meters_per_unit(scaled(s, 1.2 / cm.height_m)), 0.01);
  EXPECT_EQ(guess_meters_per_unit(scaled(s, 2.3 / cm.height_m)), 0.01);
}

TEST(Units, NoBonesMeansMetres) {
  Skeleton s;
  s.joint_names = {"root"};
  s.parents = {-1};
  s.offsets = {{0, 0, 0}};
  EXPECT_EQ(estimate_height_units(s), 0.0);
  EXPECT_EQ(guess_meters_per_unit(s), 1.0);
}

TEST(Units, RealDataBandaiIsCentimetresCmuIsCmuUnits) {
  const std::string bandai = testing::data_file(
      "bandai-namco/Bandai-Namco-Research-Motiondataset-2/data/dataset-2_walk_normal_001.bvh");
  const std::string cmu = testing::data_file("cmu-mocap-subset/bvh/02/02_01.bvh");
  if (bandai.empty() || cmu.empty()) GTEST_SKIP() << "data not unpacked";
  const UnitsGuess b = guess_units(testing::read_bvh_for_tests(bandai).skeleton);
  EXPECT_EQ(b.meters_per_unit, 0.01);
  EXPECT_GT(b.height_m, 1.4);
  EXPECT_LT(b.height_m, 2.0);
  for (const char* file : {"bvh/01/01_01.bvh", "bvh/02/02_01.bvh", "bvh/09/09_01.bvh"}) {
    const std::string path = testing::data_file(std::string("cmu-mocap-subset/") + file);
    if (path.empty()) continue;
    const UnitsGuess c = guess_units(testing::read_bvh_for_tests(path).skeleton);
    EXPECT_EQ(c.meters_per_unit, 0.056444) << file;
    EXPECT_GT(c.height_m, 1.4) << file;
    EXPECT_LT(c.height_m, 2.0) << file;
  }
}

}  // namespace
}  // namespace mosyn

TEST(UnitsTest, ResolveMetersPerUnitPrefersRequestThenSkeletonThenGuess) {
  mosyn::Skeleton s = mosyn::make_synthetic_biped();  // centimetres, meters_per_unit 0.01
  EXPECT_DOUBLE_EQ(mosyn::resolve_meters_per_unit(s, 0.5), 0.5);
  EXPECT_DOUBLE_EQ(mosyn::resolve_meters_per_unit(s), 0.01);
  s.meters_per_unit = 1.0;  // as io leaves a parsed file: guessed from the body size
  EXPECT_DOUBLE_EQ(mosyn::resolve_meters_per_unit(s), mosyn::guess_meters_per_unit(s));
  EXPECT_DOUBLE_EQ(mosyn::resolve_meters_per_unit(s), 0.01);
}

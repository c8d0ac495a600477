// Helpers shared by the io tests.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "io/bvh.h"

namespace mosyn::io::testing {

// A fresh empty directory for one test, unique to this process.
inline std::filesystem::path make_temp_dir(const std::string& name) {
  std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mosyn_test_io_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// Same hierarchy, channel layouts, End Sites, offsets (to 1e-6 relative), frame count and time.
inline void expect_same_structure(const BvhFile& a, const BvhFile& b) {
  ASSERT_EQ(a.skeleton.joint_names, b.skeleton.joint_names);
  ASSERT_EQ(a.skeleton.parents, b.skeleton.parents);
  ASSERT_EQ(a.channels, b.channels);
  ASSERT_EQ(a.skeleton.end_sites.size(), b.skeleton.end_sites.size());
  for (size_t e = 0; e < a.skeleton.end_sites.size(); ++e) {
    EXPECT_EQ(a.skeleton.end_sites[e].parent, b.skeleton.end_sites[e].parent);
    EXPECT_LT((a.skeleton.end_sites[e].offset - b.skeleton.end_sites[e].offset).norm(), 1e-9);
  }
  for (int j = 0; j < a.skeleton.num_joints(); ++j)
    EXPECT_LT((a.skeleton.offsets[j] - b.skeleton.offsets[j]).norm(), 1e-6 * (1 + a.skeleton.offsets[j].norm()));
  EXPECT_EQ(a.num_frames, b.num_frames);
  EXPECT_NEAR(a.frame_time_s, b.frame_time_s, 1e-15);
}

}  // namespace mosyn::io::testing

// Every shipped model that walks along a path (models/*/ whose family takes root control) stands
// when told to: with a stopped control (`sample --path "0,0" --seconds 10`) the hips stay within
// 0.25 m of the root over 10 s, offline and, for models that stream, through the real-time
// Generator as the C ABI and `mosyn serve` run it. Models that make their own root motion (DFN,
// MOJO) or only label motion are not asked. A model without its checkpoint (a clone without the
// weights) fails, as every other test of the shipped models does.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "nn/registry.h"
#include "nn/run.h"
#include "nn/sample_job.h"

using namespace mosyn;

namespace {

// Folders under models/ whose config names a motion family (classifiers are left out).
std::vector<std::string> shipped_motion_models() {
  std::vector<std::string> dirs;
  for (const auto& entry : std::filesystem::directory_iterator(MOSYN_SOURCE_DIR "/models")) {
    const auto config = entry.path() / "config.json";
    if (!entry.is_directory() || !std::filesystem::exists(config)) continue;
    std::ifstream in(config);
    const nlohmann::json j = nlohmann::json::parse(in);
    if (nn::family_info(j.at("family").get<std::string>()).kind == nn::FamilyKind::kMotion)
      dirs.push_back(entry.path().string());
  }
  std::sort(dirs.begin(), dirs.end());
  return dirs;
}

// The largest horizontal distance (metres) of any clip's hips (the root joint) from the origin,
// where a stopped control keeps the root.
double worst_hips_from_root_m(const std::vector<nn::SampledClip>& clips) {
  double worst = 0;
  for (const auto& c : clips) {
    const double m_per_unit = c.clip.skeleton.meters_per_unit;
    for (int t = 0; t < c.clip.motion.num_frames; ++t) {
      const Eigen::Vector3d& hips = c.clip.motion.translation(t, 0);
      worst = std::max(worst, std::hypot(hips.x(), hips.z()) * m_per_unit);
    }
  }
  return worst;
}

}  // namespace

TEST(ShippedStanding, EveryPathModelStandsOverItsRootOfflineAndInRealTime) {
  int asked = 0;
  for (const std::string& dir : shipped_motion_models()) {
    const nn::LoadedRun run = nn::load_run(dir, {"checkpoint.pt", "cpu", 1});
    if (run.traits.control != nn::InputUse::kTakes) continue;
    for (const bool realtime : {false, true}) {
      if (realtime && !run.traits.streaming) continue;
      nn::SampleJobOptions o;
      o.path = "0,0";
      o.seconds = 10;
      o.n = 4;
      o.seed = 21;
      o.realtime = realtime;
      o.threads = 1;
      const auto clips = nn::run_sample(run, nn::plan_sample(run, o), o);
      ASSERT_EQ(clips.size(), 4u);
      const double worst = worst_hips_from_root_m(clips);
      EXPECT_LT(worst, 0.25) << dir << (realtime ? " (real time)" : " (offline)") << ": hips " << worst
                             << " m from the root";
      ++asked;
    }
  }
  EXPECT_GE(asked, 5);  // moglow-realtime (both ways), moglow-lookahead, rvae-locomotion, ...
}

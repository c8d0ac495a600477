// Offline sampling from a loaded run, in RAW feature units (the run's stats undo the
// standardisation), and decoding to a clip. No LibTorch in this header.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/skeleton.h"
#include "nn/run.h"

namespace mosyn::nn {

// SampleExtras::warmup_frames value meaning "the family's own": ModelTraits::default_warmup_s
// at the run's frame rate (MoGlow 1 s, rvae none).
constexpr int kFamilyWarmup = -1;

struct SampleExtras {
  std::vector<float> prefix_pose;     // optional raw [P, D]: motion preceding the generated frames
  std::vector<float> prefix_control;  // optional raw [P, C] (empty = mean control)
  int content = -1;                   // label ids, -1 = none
  int style = -1;
  // Frames generated before the requested control and then dropped, along a lead-in that holds
  // the control's first step (its row 1; row 0 is the zero delta into the first frame). Without a
  // prefix a model starts from its initial state (MoGlow: the mean pose as history), which shows
  // as an unnatural first frame; the lead-in lets it settle first into what the control starts
  // with: standing for a drawn path (it starts at rest), walking at the clip's speed for a
  // motion-capture control that starts mid-walk. A standing lead-in there made the first two
  // seconds glide from a standstill to full speed (the MoGlow paper pre-generates a second of
  // preceding motion for the same reason, Sec. 5). 0 = none; kFamilyWarmup = the family's
  // default. Not used with a prefix: real motion already gives the model its start.
  int warmup_frames = 0;
  // Keep the root steps a family makes itself as they are, even when the run plants them
  // (LoadedRun::root_planting): the model's raw output, for comparisons.
  bool raw_root = false;
};

// One generated motion in raw feature units: the poses and the root motion they move along.
struct SampledMotion {
  std::vector<float> pose;     // [T, D] row-major
  std::vector<float> control;  // [T, C] row-major (dx, dz metres, dtheta radians, delta t-1 -> t): the
                               // given control, or the root motion a family generated (ModelTraits)
  bool operator==(const SampledMotion& other) const { return pose == other.pose && control == other.control; }
  bool operator!=(const SampledMotion& other) const { return !(*this == other); }
};

// n random motions of T frames, raw control [T, C] row-major (dx, dz metres, dtheta radians,
// delta t-1 -> t). Families that take control follow it; families that generate their root motion
// read only its length T (zeros will do) and return their own. The n samples are generated as one
// batch from a generator seeded with `seed`: same run + inputs + seed give identical output;
// samples within a call and across seeds differ. temperature scales the latent standard deviation
// (1 = the model's distribution). A family that makes its own root motion has its steps planted
// on its feet (nn/root_planting.h) when the run says so and extras.raw_root is false; the prefix
// shows the planter the feet it starts from. Throws mosyn::Error on size mismatches, labels for a
// model that takes none, and a prefix for a model that cannot continue motion.
std::vector<SampledMotion> sample_motions(const LoadedRun& run, const std::vector<float>& control, int n,
                                          std::uint64_t seed, double temperature = 1.0,
                                          const SampleExtras& extras = {});

// Raw pose [T, D] and control [T, C] to a clip on the run's skeleton (data::decode), starting at
// the origin facing heading 0.
Clip decode_motion(const LoadedRun& run, const std::vector<float>& pose, const std::vector<float>& control);
Clip decode_motion(const LoadedRun& run, const SampledMotion& motion);

// decode_motion written as a BVH file (io::from_clip, CMU-like channel layout) atomically.
void write_motion_bvh(const std::string& path, const LoadedRun& run, const SampledMotion& motion);

}  // namespace mosyn::nn

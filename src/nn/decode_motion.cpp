// Separate from sampling.cpp: no LibTorch, and linked only by users of decode_motion.
#include "core/error.h"
#include "data/representation.h"
#include "io/bvh.h"
#include "nn/sampling.h"

namespace mosyn::nn {

Clip decode_motion(const LoadedRun& run, const std::vector<float>& pose, const std::vector<float>& control) {
  const size_t d = run.context.pose_dim, c = run.context.control_dim;
  if (d == 0 || pose.size() % d != 0) throw Error("decode_motion: pose is not [T, " + std::to_string(d) + "]");
  const size_t t = pose.size() / d;
  if (control.size() != t * c)
    throw Error("decode_motion: control has " + std::to_string(control.size()) + " values, expected " +
                std::to_string(t * c));
  Clip clip;
  clip.skeleton = run.dataset.skeleton;
  clip.motion = data::decode(run.dataset.skeleton, run.dataset.layout, pose.data(), control.data(),
                             static_cast<int>(t), run.dataset.fps);
  return clip;
}

Clip decode_motion(const LoadedRun& run, const SampledMotion& motion) {
  return decode_motion(run, motion.pose, motion.control);
}

void write_motion_bvh(const std::string& path, const LoadedRun& run, const SampledMotion& motion) {
  io::write_bvh(path, io::from_clip(decode_motion(run, motion)));
}

}  // namespace mosyn::nn

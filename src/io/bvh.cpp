// BVH: channel names and the checks shared by the reader, the writer and the clip conversion.
// The reader is bvh_read.cpp, the writer bvh_write.cpp, the conversion to and from Clip bvh_clip.cpp.
#include "io/bvh.h"

#include <cmath>

#include "core/error.h"
#include "io/bvh_detail.h"

namespace mosyn::io {

const char* to_string(BvhChannel channel) {
  switch (channel) {
    case BvhChannel::kXposition: return "Xposition";
    case BvhChannel::kYposition: return "Yposition";
    case BvhChannel::kZposition: return "Zposition";
    case BvhChannel::kXrotation: return "Xrotation";
    case BvhChannel::kYrotation: return "Yrotation";
    case BvhChannel::kZrotation: return "Zrotation";
  }
  return "?";
}

int channel_axis(BvhChannel channel) {
  switch (channel) {
    case BvhChannel::kXposition:
    case BvhChannel::kXrotation: return 0;
    case BvhChannel::kYposition:
    case BvhChannel::kYrotation: return 1;
    case BvhChannel::kZposition:
    case BvhChannel::kZrotation: return 2;
  }
  return 0;
}

bool is_rotation(BvhChannel channel) {
  return channel == BvhChannel::kXrotation || channel == BvhChannel::kYrotation || channel == BvhChannel::kZrotation;
}

int BvhFile::num_channels() const {
  size_t n = 0;
  for (const BvhChannelLayout& c : channels) n += c.size();
  return static_cast<int>(n);
}

int BvhFile::first_channel(int j) const {
  size_t n = 0;
  for (int k = 0; k < j; ++k) n += channels[static_cast<size_t>(k)].size();
  return static_cast<int>(n);
}

namespace detail {

void check_layout(const BvhChannelLayout& layout, const std::string& joint) {
  if (layout.size() > 6) throw Error("BVH joint '" + joint + "' has more than 6 channels");
  for (size_t i = 0; i < layout.size(); ++i)
    for (size_t k = 0; k < i; ++k)
      if (layout[i] == layout[k]) throw Error("BVH joint '" + joint + "' repeats channel " + to_string(layout[i]));
}

// Checks that a BvhFile's arrays agree with each other.
void check_consistent(const BvhFile& bvh) {
  bvh.skeleton.validate();
  const size_t num_joints = static_cast<size_t>(bvh.skeleton.num_joints());
  if (bvh.channels.size() != num_joints)
    throw Error("BVH has " + std::to_string(bvh.channels.size()) + " channel layouts for " +
                std::to_string(num_joints) + " joints");
  for (size_t j = 0; j < num_joints; ++j) check_layout(bvh.channels[j], bvh.skeleton.joint_names[j]);
  if (bvh.num_frames < 0) throw Error("BVH has a negative number of frames");
  if (!(bvh.frame_time_s > 0) || !std::isfinite(bvh.frame_time_s)) throw Error("BVH frame time must be positive");
  const size_t expected = static_cast<size_t>(bvh.num_frames) * static_cast<size_t>(bvh.num_channels());
  if (bvh.values.size() != expected)
    throw Error("BVH has " + std::to_string(bvh.values.size()) + " values; " + std::to_string(bvh.num_frames) +
                " frames x " + std::to_string(bvh.num_channels()) + " channels needs " + std::to_string(expected));
}

}  // namespace detail
}  // namespace mosyn::io

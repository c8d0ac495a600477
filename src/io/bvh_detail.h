// Internal to io's BVH sources (bvh.cpp, bvh_read.cpp, bvh_write.cpp, bvh_clip.cpp): checks
// shared by the writer and the clip conversion. Not part of the public interface.
#pragma once

#include <string>

#include "io/bvh.h"

namespace mosyn::io::detail {

// Throws mosyn::Error naming the joint when a layout has more than 6 channels or repeats one.
void check_layout(const BvhChannelLayout& layout, const std::string& joint);

// Throws mosyn::Error when a BvhFile's arrays disagree with each other (skeleton, layouts,
// frame count, frame time, values).
void check_consistent(const BvhFile& bvh);

}  // namespace mosyn::io::detail

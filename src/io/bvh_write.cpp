// BVH writer: BvhFile to text, written atomically.
#include <charconv>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/bvh.h"
#include "io/bvh_detail.h"

namespace mosyn::io {
namespace {

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

// A name parse_bvh would read back unchanged: not empty, no braces, no whitespace but single
// interior spaces.
bool is_writable_name(const std::string& name) {
  if (name.empty() || name.front() == ' ' || name.back() == ' ') return false;
  for (size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    if (c == '{' || c == '}' || (is_space(c) && c != ' ') || (c == ' ' && name[i - 1] == ' ')) return false;
  }
  return true;
}

void append_number(std::string* out, double value, int significant_digits) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::general, significant_digits);
  out->append(buffer, result.ptr);
}

void append_indent(std::string* out, int depth) { out->append(static_cast<size_t>(depth), '\t'); }

void append_offset(std::string* out, const Eigen::Vector3d& offset, int depth, int significant_digits) {
  if (!offset.allFinite()) throw Error("format_bvh: an OFFSET is not finite");
  append_indent(out, depth);
  *out += "OFFSET";
  for (int i = 0; i < 3; ++i) {
    *out += ' ';
    append_number(out, offset[i], significant_digits);
  }
  *out += '\n';
}

// Joint j's header, OFFSET, CHANNELS and End Sites at `depth`, its block left open.
void append_joint_opening(std::string* out, const BvhFile& bvh, int j, int depth, const std::vector<int>& end_sites,
                          int significant_digits) {
  const Skeleton& sk = bvh.skeleton;
  const std::string& name = sk.joint_names[static_cast<size_t>(j)];
  if (!is_writable_name(name))
    throw Error("format_bvh: joint name '" + name +
                "' cannot be written to BVH (empty, braces, or whitespace other than single spaces)");
  append_indent(out, depth);
  *out += sk.parents[static_cast<size_t>(j)] < 0 ? "ROOT " : "JOINT ";
  *out += name + "\n";
  append_indent(out, depth);
  *out += "{\n";
  append_offset(out, sk.offsets[static_cast<size_t>(j)], depth + 1, significant_digits);
  const BvhChannelLayout& layout = bvh.channels[static_cast<size_t>(j)];
  append_indent(out, depth + 1);
  *out += "CHANNELS " + std::to_string(layout.size());
  for (BvhChannel c : layout) {
    *out += ' ';
    *out += to_string(c);
  }
  *out += '\n';
  for (int e : end_sites) {
    append_indent(out, depth + 1);
    *out += "End Site\n";
    append_indent(out, depth + 1);
    *out += "{\n";
    append_offset(out, sk.end_sites[static_cast<size_t>(e)].offset, depth + 2, significant_digits);
    append_indent(out, depth + 1);
    *out += "}\n";
  }
}

// The HIERARCHY section: joints in depth-first pre-order, each block closed once its subtree ends.
void append_hierarchy(std::string* out, const BvhFile& bvh, int significant_digits) {
  const Skeleton& sk = bvh.skeleton;
  const int num_joints = sk.num_joints();
  std::vector<std::vector<int>> end_sites_of(static_cast<size_t>(num_joints));
  for (size_t e = 0; e < sk.end_sites.size(); ++e)
    end_sites_of[static_cast<size_t>(sk.end_sites[e].parent)].push_back(static_cast<int>(e));
  *out += "HIERARCHY\n";
  std::vector<int> open;  // the path of joints whose blocks are open
  auto close_top = [&]() {
    append_indent(out, static_cast<int>(open.size()) - 1);
    *out += "}\n";
    open.pop_back();
  };
  for (int j = 0; j < num_joints; ++j) {
    const int parent = sk.parents[static_cast<size_t>(j)];
    while (!open.empty() && open.back() != parent) close_top();
    if (parent >= 0 && open.empty())
      throw Error("format_bvh: joints are not in depth-first pre-order (joint '" + sk.joint_names[static_cast<size_t>(j)] +
                  "' does not follow its parent's subtree)");
    append_joint_opening(out, bvh, j, static_cast<int>(open.size()), end_sites_of[static_cast<size_t>(j)],
                         significant_digits);
    open.push_back(j);
  }
  while (!open.empty()) close_top();
}

// The MOTION section: frame count, frame time (exact) and one line of channel values per frame.
void append_motion(std::string* out, const BvhFile& bvh, int significant_digits) {
  *out += "MOTION\nFrames: " + std::to_string(bvh.num_frames) + "\nFrame Time: ";
  append_number(out, bvh.frame_time_s, 17);
  *out += '\n';
  const size_t num_channels = static_cast<size_t>(bvh.num_channels());
  for (size_t t = 0; t < static_cast<size_t>(bvh.num_frames); ++t) {
    const double* row = bvh.values.data() + t * num_channels;
    for (size_t c = 0; c < num_channels; ++c) {
      if (c > 0) *out += ' ';
      append_number(out, row[c], significant_digits);
    }
    *out += '\n';
  }
}

}  // namespace

std::string format_bvh(const BvhFile& bvh, int significant_digits) {
  detail::check_consistent(bvh);
  if (significant_digits < 1 || significant_digits > 17) throw Error("format_bvh: significant_digits must be 1 to 17");
  for (double v : bvh.values)
    if (!std::isfinite(v)) throw Error("format_bvh: a motion value is not finite");
  std::string out;
  out.reserve(bvh.values.size() * 10 + static_cast<size_t>(bvh.skeleton.num_joints()) * 200 + 256);
  append_hierarchy(&out, bvh, significant_digits);
  append_motion(&out, bvh, significant_digits);
  return out;
}

void write_bvh(const std::string& path, const BvhFile& bvh, int significant_digits) {
  write_file_atomically(path, format_bvh(bvh, significant_digits));
}

}  // namespace mosyn::io

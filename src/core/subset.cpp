#include "core/subset.h"

#include <algorithm>

#include "core/error.h"

namespace mosyn {
namespace {

// Sorted, unique kept indices; throws when one is out of range or the root is missing.
std::vector<int> normalized_keep(const Skeleton& skeleton, const std::vector<int>& keep) {
  const int n = skeleton.num_joints();
  std::vector<int> out = keep;
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  for (int j : out)
    if (j < 0 || j >= n) throw Error("joint subset: index " + std::to_string(j) + " is out of range (0.." +
                                     std::to_string(n - 1) + ")");
  if (n == 0 || out.empty() || out[0] != 0)
    throw Error("joint subset: the root joint '" + (n > 0 ? skeleton.joint_names[0] : std::string()) +
                "' must be kept");
  return out;
}

// new_index[j] for kept joints, -1 for dropped ones.
std::vector<int> new_indices(int num_joints, const std::vector<int>& keep) {
  std::vector<int> index(num_joints, -1);
  for (size_t k = 0; k < keep.size(); ++k) index[keep[k]] = static_cast<int>(k);
  return index;
}

}  // namespace

std::vector<int> joint_indices(const Skeleton& skeleton, const std::vector<std::string>& names) {
  std::vector<int> out;
  out.reserve(names.size());
  for (const std::string& name : names) {
    const int j = skeleton.find(name);
    if (j < 0) throw Error("skeleton has no joint named '" + name + "'");
    out.push_back(j);
  }
  return out;
}

bool glob_match(const std::string& pattern, const std::string& name) {
  // Iterative matcher with backtracking to the last '*': linear in practice.
  size_t p = 0, s = 0, star = std::string::npos, mark = 0;
  while (s < name.size()) {
    if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == name[s])) {
      ++p;
      ++s;
    } else if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      mark = s;
    } else if (star != std::string::npos) {
      p = star + 1;
      s = ++mark;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

std::vector<int> joints_matching(const Skeleton& skeleton, const std::vector<std::string>& patterns) {
  std::vector<int> out;
  for (int j = 0; j < skeleton.num_joints(); ++j)
    for (const std::string& pattern : patterns)
      if (glob_match(pattern, skeleton.joint_names[j])) {
        out.push_back(j);
        break;
      }
  return out;
}

std::vector<int> joints_excluding(const Skeleton& skeleton, const std::vector<std::string>& patterns) {
  const std::vector<int> matching = joints_matching(skeleton, patterns);
  std::vector<int> out;
  for (int j = 0; j < skeleton.num_joints(); ++j)
    if (!std::binary_search(matching.begin(), matching.end(), j)) out.push_back(j);
  return out;
}

std::vector<std::string> finger_joint_patterns() {
  return {"*Finger*", "*finger*", "*Thumb*", "*thumb*", "*Index*", "*index*", "*Middle*", "*middle*",
          "*Ring*",   "*ring*",   "*Pinky*", "*pinky*", "*Little*", "*little*"};
}

Skeleton subset_skeleton(const Skeleton& skeleton, const std::vector<int>& keep_in) {
  const std::vector<int> keep = normalized_keep(skeleton, keep_in);
  const std::vector<int> index = new_indices(skeleton.num_joints(), keep);
  Skeleton out;
  out.meters_per_unit = skeleton.meters_per_unit;
  out.up_axis = skeleton.up_axis;
  for (int j : keep) {
    out.joint_names.push_back(skeleton.joint_names[j]);
    Eigen::Vector3d offset = skeleton.offsets[j];
    int a = skeleton.parents[j];
    for (; a >= 0 && index[a] < 0; a = skeleton.parents[a]) offset += skeleton.offsets[a];
    out.parents.push_back(a < 0 ? -1 : index[a]);
    out.offsets.push_back(offset);
  }
  for (const EndSite& e : skeleton.end_sites)
    if (e.parent >= 0 && e.parent < skeleton.num_joints() && index[e.parent] >= 0)
      out.end_sites.push_back({index[e.parent], e.offset});
  return out;
}

Motion subset_motion(const Skeleton& skeleton, const Motion& motion, const std::vector<int>& keep_in) {
  if (motion.num_joints != skeleton.num_joints()) throw Error("joint subset: motion and skeleton joint counts differ");
  const std::vector<int> keep = normalized_keep(skeleton, keep_in);
  const std::vector<int> index = new_indices(skeleton.num_joints(), keep);
  // Dropped chain of every kept joint, nearest the kept ancestor first.
  std::vector<std::vector<int>> chains(keep.size());
  for (size_t k = 0; k < keep.size(); ++k)
    for (int a = skeleton.parents[keep[k]]; a >= 0 && index[a] < 0; a = skeleton.parents[a])
      chains[k].insert(chains[k].begin(), a);

  Motion out;
  out.fps = motion.fps;
  out.num_frames = motion.num_frames;
  out.num_joints = static_cast<int>(keep.size());
  out.rotations.resize(static_cast<size_t>(out.num_frames) * out.num_joints);
  out.translations.resize(out.rotations.size());
  for (int t = 0; t < motion.num_frames; ++t)
    for (size_t k = 0; k < keep.size(); ++k) {
      Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
      Eigen::Vector3d translation = Eigen::Vector3d::Zero();
      for (int d : chains[k]) {
        translation += rotation * motion.translation(t, d);
        rotation = rotation * motion.rotation(t, d);
      }
      translation += rotation * motion.translation(t, keep[k]);
      rotation = rotation * motion.rotation(t, keep[k]);
      out.rotation(t, static_cast<int>(k)) = chains[k].empty() ? rotation : rotation.normalized();
      out.translation(t, static_cast<int>(k)) = translation;
    }
  return out;
}

Clip subset_clip(const Clip& clip, const std::vector<int>& keep) {
  return {subset_skeleton(clip.skeleton, keep), subset_motion(clip.skeleton, clip.motion, keep)};
}

}  // namespace mosyn

#include "core/skeleton.h"

#include <cmath>
#include <set>

#include "core/error.h"

namespace mosyn {

int Skeleton::find(const std::string& name) const {
  for (int j = 0; j < num_joints(); ++j)
    if (joint_names[j] == name) return j;
  return -1;
}

std::vector<int> Skeleton::children(int j) const {
  std::vector<int> out;
  for (int c = 0; c < num_joints(); ++c)
    if (parents[c] == j) out.push_back(c);
  return out;
}

void Skeleton::validate() const {
  const size_t n = joint_names.size();
  if (n == 0) throw Error("skeleton has no joints");
  if (parents.size() != n || offsets.size() != n)
    throw Error("skeleton arrays disagree: " + std::to_string(n) + " names, " +
                std::to_string(parents.size()) + " parents, " + std::to_string(offsets.size()) + " offsets");
  if (parents[0] != -1) throw Error("skeleton joint 0 ('" + joint_names[0] + "') must be the root");
  std::set<std::string> seen;
  for (size_t j = 0; j < n; ++j) {
    if (j > 0 && (parents[j] < 0 || parents[j] >= static_cast<int>(j)))
      throw Error("skeleton joint '" + joint_names[j] + "' has parent " + std::to_string(parents[j]) +
                  "; expected a single root and parents listed before children");
    if (!seen.insert(joint_names[j]).second) throw Error("skeleton joint name repeats: '" + joint_names[j] + "'");
    if (!offsets[j].allFinite()) throw Error("skeleton joint '" + joint_names[j] + "' has a non-finite offset");
  }
  for (const EndSite& e : end_sites)
    if (e.parent < 0 || e.parent >= static_cast<int>(n)) throw Error("end site has an invalid parent joint");
  if (!(meters_per_unit > 0) || !std::isfinite(meters_per_unit)) throw Error("skeleton meters_per_unit must be positive");
  if (up_axis < 0 || up_axis > 2) throw Error("skeleton up_axis must be 0, 1 or 2");
}

Motion Motion::rest(const Skeleton& skeleton, int num_frames, double fps) {
  Motion m;
  m.fps = fps;
  m.num_frames = num_frames;
  m.num_joints = skeleton.num_joints();
  m.rotations.assign(static_cast<size_t>(num_frames) * m.num_joints, Eigen::Quaterniond::Identity());
  m.translations.resize(static_cast<size_t>(num_frames) * m.num_joints);
  for (int t = 0; t < num_frames; ++t)
    for (int j = 0; j < m.num_joints; ++j) m.translation(t, j) = skeleton.offsets[j];
  return m;
}

void Motion::validate() const {
  const size_t n = static_cast<size_t>(num_frames) * num_joints;
  if (num_frames < 0 || num_joints <= 0) throw Error("motion has no joints");
  if (rotations.size() != n || translations.size() != n)
    throw Error("motion arrays do not hold frames x joints entries");
  if (!(fps > 0) || !std::isfinite(fps)) throw Error("motion fps must be positive");
  for (size_t i = 0; i < n; ++i)
    if (!rotations[i].coeffs().allFinite() || !translations[i].allFinite())
      throw Error("motion has a non-finite value at frame " + std::to_string(i / num_joints));
}

}  // namespace mosyn

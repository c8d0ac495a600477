#include "core/kinematics.h"

#include "core/error.h"

namespace mosyn {

WorldPoses forward_kinematics(const Skeleton& skeleton, const Motion& motion) {
  const int num_joints = skeleton.num_joints();
  if (motion.num_joints != num_joints)
    throw Error("forward_kinematics: motion has " + std::to_string(motion.num_joints) + " joints, skeleton " +
                std::to_string(num_joints));
  const size_t n = static_cast<size_t>(motion.num_frames) * num_joints;
  if (motion.rotations.size() != n || motion.translations.size() != n)
    throw Error("forward_kinematics: motion arrays do not hold frames x joints entries");
  WorldPoses poses;
  poses.num_frames = motion.num_frames;
  poses.num_joints = num_joints;
  poses.rotations.resize(n);
  poses.positions.resize(n);
  for (int t = 0; t < motion.num_frames; ++t) {
    const size_t base = static_cast<size_t>(t) * num_joints;
    for (int j = 0; j < num_joints; ++j) {
      const int p = skeleton.parents[j];
      if (p < 0) {
        poses.rotations[base + j] = motion.rotation(t, j);
        poses.positions[base + j] = motion.translation(t, j);
      } else {
        // parents[j] < j, so the parent's world transform is already known.
        const Eigen::Quaterniond& parent_rotation = poses.rotations[base + p];
        poses.rotations[base + j] = parent_rotation * motion.rotation(t, j);
        poses.positions[base + j] = poses.positions[base + p] + parent_rotation * motion.translation(t, j);
      }
    }
  }
  return poses;
}

std::vector<Eigen::Vector3d> end_site_positions(const Skeleton& skeleton, const WorldPoses& poses) {
  const int num_sites = static_cast<int>(skeleton.end_sites.size());
  std::vector<Eigen::Vector3d> out(static_cast<size_t>(poses.num_frames) * num_sites);
  for (const EndSite& e : skeleton.end_sites)
    if (e.parent < 0 || e.parent >= poses.num_joints) throw Error("end_site_positions: end site has an invalid parent");
  for (int t = 0; t < poses.num_frames; ++t)
    for (int e = 0; e < num_sites; ++e) {
      const EndSite& site = skeleton.end_sites[e];
      out[static_cast<size_t>(t) * num_sites + e] =
          poses.position(t, site.parent) + poses.rotation(t, site.parent) * site.offset;
    }
  return out;
}

}  // namespace mosyn

// A minimal BVH reader for core's real-data tests only (core may not depend on io).
#pragma once

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/rotation.h"
#include "core/skeleton.h"

namespace mosyn::testing {

inline Clip read_bvh_for_tests(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  Clip clip;
  Skeleton& s = clip.skeleton;
  s.meters_per_unit = 0.01;
  std::vector<std::vector<std::string>> channels;
  std::vector<int> stack;
  int pending_end = -1;  // parent of an End Site being read
  bool in_end = false;
  std::string tok;
  while (in >> tok) {
    if (tok == "ROOT" || tok == "JOINT") {
      std::string name;
      in >> name;
      s.joint_names.push_back(name);
      s.parents.push_back(stack.empty() ? -1 : stack.back());
      s.offsets.emplace_back(0, 0, 0);
      channels.emplace_back();
    } else if (tok == "End") {
      in >> tok;  // Site
      in_end = true;
      pending_end = stack.back();
    } else if (tok == "{") {
      if (!in_end) stack.push_back(s.num_joints() - 1);
    } else if (tok == "}") {
      if (in_end) in_end = false;
      else stack.pop_back();
    } else if (tok == "OFFSET") {
      Eigen::Vector3d o;
      in >> o.x() >> o.y() >> o.z();
      if (in_end) s.end_sites.push_back({pending_end, o});
      else s.offsets.back() = o;
    } else if (tok == "CHANNELS") {
      int n;
      in >> n;
      for (int i = 0; i < n; ++i) {
        in >> tok;
        channels.back().push_back(tok);
      }
    } else if (tok == "MOTION") {
      break;
    }
  }
  int frames = 0;
  double frame_time = 0;
  in >> tok >> frames >> tok >> tok >> frame_time;  // Frames: N Frame Time: dt
  Motion& m = clip.motion;
  m = Motion::rest(s, frames, 1.0 / frame_time);
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
      for (const std::string& c : channels[j]) {
        double v;
        in >> v;
        const int axis = c[0] - 'X';
        if (c.find("position") != std::string::npos) m.translation(t, j)[axis] = v;
        else q = q * quat_about_axis(axis, v * 3.14159265358979323846 / 180.0);
      }
      m.rotation(t, j) = q.normalized();
    }
  if (!in) throw std::runtime_error("truncated BVH " + path);
  return clip;
}

// MOSYN_DATA_CACHE/<relative> when it exists, else "".
inline std::string data_file(const std::string& relative) {
  const std::string path = std::string(MOSYN_DATA_CACHE) + "/" + relative;
  return std::ifstream(path).good() ? path : std::string();
}

}  // namespace mosyn::testing

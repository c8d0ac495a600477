#include "core/mirror.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/error.h"

namespace mosyn {
namespace {

struct Marker {
  const char* left;
  const char* right;
};

// Whole-word markers first so "LeftArm" is not read as the letter "L" + "eftArm".
constexpr Marker kWordMarkers[] = {{"Left", "Right"}, {"left", "right"}, {"LEFT", "RIGHT"}};
constexpr Marker kLetterMarkers[] = {{"L", "R"}, {"l", "r"}};
constexpr Marker kInfixMarkers[] = {{" L ", " R "}, {"_L_", "_R_"}, {".L.", ".R."}, {" l ", " r "},
                                    {"_l_", "_r_"}, {".l.", ".r."}};

bool starts_with(const std::string& s, const std::string& p) { return s.size() > p.size() && s.compare(0, p.size(), p) == 0; }
bool ends_with(const std::string& s, const std::string& p) {
  return s.size() > p.size() && s.compare(s.size() - p.size(), p.size(), p) == 0;
}

// Candidate partner names with the side they imply for `name` (+1 left, -1 right), most specific
// rule first.
std::vector<std::pair<std::string, int>> partner_candidates(const std::string& name) {
  std::vector<std::pair<std::string, int>> out;
  auto add_affix = [&](const std::string& mine, const std::string& other, int side) {
    if (starts_with(name, mine)) out.emplace_back(other + name.substr(mine.size()), side);
    if (ends_with(name, mine)) out.emplace_back(name.substr(0, name.size() - mine.size()) + other, side);
  };
  for (const Marker& m : kWordMarkers) {
    add_affix(m.left, m.right, +1);
    add_affix(m.right, m.left, -1);
  }
  for (const Marker& m : kInfixMarkers) {
    for (int side : {+1, -1}) {
      const std::string mine = side > 0 ? m.left : m.right, other = side > 0 ? m.right : m.left;
      const size_t pos = name.find(mine);
      if (pos != std::string::npos) out.emplace_back(name.substr(0, pos) + other + name.substr(pos + mine.size()), side);
    }
  }
  for (const Marker& m : kLetterMarkers) {
    add_affix(m.left, m.right, +1);
    add_affix(m.right, m.left, -1);
  }
  return out;
}

// Partner index and side of every joint, before the involution check.
void find_partners(const Skeleton& skeleton, std::vector<int>& partner, std::vector<int>& side) {
  const int n = skeleton.num_joints();
  partner.resize(n);
  side.assign(n, 0);
  for (int j = 0; j < n; ++j) {
    partner[j] = j;
    for (const auto& [other, s] : partner_candidates(skeleton.joint_names[j])) {
      const int k = skeleton.find(other);
      if (k >= 0 && k != j) {
        partner[j] = k;
        side[j] = s;
        break;
      }
    }
  }
  // Keep only mutual pairs with opposite sides; the test is symmetric in j and its candidate, so
  // the result is an involution.
  const std::vector<int> candidate = partner, candidate_side = side;
  for (int j = 0; j < n; ++j) {
    const int k = candidate[j];
    if (k != j && (candidate[k] != j || candidate_side[k] != -candidate_side[j])) {
      partner[j] = j;
      side[j] = 0;
    }
  }
}

Eigen::Vector3d reflect(const Eigen::Vector3d& v, int axis) {
  Eigen::Vector3d r = v;
  r[axis] = -r[axis];
  return r;
}

// S R S for the reflection S of one axis: the rotation axis (a pseudo-vector) maps to -S n.
Eigen::Quaterniond reflect(const Eigen::Quaterniond& q, int axis) {
  Eigen::Quaterniond r(q.w(), -q.x(), -q.y(), -q.z());
  r.coeffs()[axis] = q.coeffs()[axis];  // coeffs() is (x, y, z, w)
  return r;
}

void check_map(const std::vector<int>& map, int num_joints) {
  if (static_cast<int>(map.size()) != num_joints)
    throw Error("mirror map has " + std::to_string(map.size()) + " entries for " + std::to_string(num_joints) + " joints");
  for (int j = 0; j < num_joints; ++j)
    if (map[j] < 0 || map[j] >= num_joints || map[map[j]] != j) throw Error("mirror map is not a left/right involution");
}

}  // namespace

std::vector<int> mirror_map(const Skeleton& skeleton) {
  std::vector<int> partner, side;
  find_partners(skeleton, partner, side);
  return partner;
}

std::vector<int> joint_sides(const Skeleton& skeleton) {
  std::vector<int> partner, side;
  find_partners(skeleton, partner, side);
  return side;
}

int default_mirror_axis(const Skeleton& skeleton) { return (skeleton.up_axis + 2) % 3; }

double mirror_asymmetry(const Skeleton& skeleton, const std::vector<int>& map, int mirror_axis) {
  if (mirror_axis < 0 || mirror_axis > 2) throw Error("mirror axis must be 0, 1 or 2");
  check_map(map, skeleton.num_joints());
  double worst = 0;
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    // The root's offset is its world position, which mirroring moves anyway.
    if (skeleton.parents[j] < 0) continue;
    worst = std::max(worst, (skeleton.offsets[j] - reflect(skeleton.offsets[map[j]], mirror_axis)).norm());
  }
  return worst;
}

Motion mirror_motion(const Skeleton& skeleton, const Motion& motion, const std::vector<int>& map, int mirror_axis) {
  if (mirror_axis < 0 || mirror_axis > 2) throw Error("mirror axis must be 0, 1 or 2");
  const int n = skeleton.num_joints();
  if (motion.num_joints != n) throw Error("mirror_motion: motion and skeleton joint counts differ");
  check_map(map, n);
  Motion out = motion;
  for (int t = 0; t < motion.num_frames; ++t)
    for (int j = 0; j < n; ++j) {
      const int m = map[j];
      out.rotation(t, j) = reflect(motion.rotation(t, m), mirror_axis);
      if (skeleton.parents[j] < 0)
        out.translation(t, j) = reflect(motion.translation(t, m), mirror_axis);
      else
        out.translation(t, j) =
            reflect(motion.translation(t, m) - skeleton.offsets[m], mirror_axis) + skeleton.offsets[j];
    }
  return out;
}

}  // namespace mosyn

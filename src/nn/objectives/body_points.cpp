#include "nn/objectives/body_points.h"

#include <algorithm>
#include <map>

#include "core/error.h"
#include "core/foot_lock.h"
#include "core/markers.h"
#include "nn/kinematics.h"

namespace mosyn::nn {

namespace {

// Rest bones shorter than this (m) are no pair: zero-length joints such as CMU's LHipJoint.
constexpr double kShortestBoneM = 1e-3;

struct Joints {
  std::vector<int> points;  // heels, toes (when found), pelvis
  bool toes = false;
};

// The skeleton joints of the points: find_legs' two ankles, each one's first child, the root joint.
Joints find_point_joints(const ModelContext& context, const std::string& who) {
  const Skeleton& skeleton = context.skeleton;
  Joints out;
  for (const LegChain& leg : find_legs(skeleton)) out.points.push_back(leg.ankle);
  if (out.points.size() != 2)
    throw Error(who + "exactly two legs (ankles named Foot or Ankle); the skeleton has " +
                std::to_string(out.points.size()));
  std::vector<int> toes;
  for (int k = 0; k < 2; ++k) {
    const auto children = skeleton.children(out.points[k]);
    if (!children.empty()) toes.push_back(children.front());
  }
  out.toes = toes.size() == 2;
  if (out.toes) out.points.insert(out.points.end(), toes.begin(), toes.end());
  out.points.push_back(context.layout.root_joint);
  return out;
}

}  // namespace

BodyPoints::BodyPoints(const ModelContext& context, const std::string& family) : form_(context.pose_form) {
  const std::string who = family + ": the foot objectives need ";
  const auto& st = context.stats;
  if (static_cast<int>(st.pose_std.size()) != context.pose_dim ||
      static_cast<int>(st.control_std.size()) != context.control_dim)
    throw Error(who + "the dataset statistics (a model built by mosyn train or load_run)");
  switch (form_) {
    case data::PoseForm::kPositions: init_positions(context, who); break;
    case data::PoseForm::kMarkers: init_markers(context, who); break;
    case data::PoseForm::kRotations: init_rotations(context, who); break;
  }
  num_points_ = form_ == data::PoseForm::kRotations ? static_cast<int>(point_chain_index_.size())
                                                  : static_cast<int>(point_triples_.size());
  pose_mean_ = torch::tensor(st.pose_mean);
  pose_std_ = torch::tensor(st.pose_std);
}

void BodyPoints::init_positions(const ModelContext& context, const std::string& who) {
  const Skeleton& skeleton = context.skeleton;
  const int j = skeleton.num_joints();
  if (j == 0 || j * 3 != context.pose_dim)
    throw Error(who + "the dataset's skeleton (a model built by mosyn train or load_run)");
  const Joints joints = find_point_joints(context, who);
  for (int p : joints.points) point_triples_.push_back({p});
  point_joints_ = joints.points;
  has_toes_ = joints.toes;
  std::vector<double> rest;
  for (int c = 0; c < j; ++c) {
    const double length = skeleton.offsets[c].norm() * skeleton.meters_per_unit;
    if (skeleton.parents[c] < 0 || length < kShortestBoneM) continue;
    pairs_.emplace_back(skeleton.parents[c], c);
    rest.push_back(length);
  }
  rest_lengths_ = torch::tensor(rest, torch::kFloat64);
}

void BodyPoints::init_markers(const ModelContext& context, const std::string& who) {
  const auto& names = cmu41_marker_names();
  if (static_cast<int>(names.size()) * 3 != context.pose_dim) throw Error(who + "the 41 CMU markers");
  auto index = [&](const std::string& name) {
    return static_cast<int64_t>(std::find(names.begin(), names.end(), name) - names.begin());
  };
  point_triples_ = {{index("LHEE")}, {index("RHEE")}, {index("LTOE")}, {index("RTOE")},
                    {index("LFWT"), index("RFWT"), index("LBWT"), index("RBWT")}};
  has_toes_ = true;
  std::vector<double> rest;
  if (context.skeleton.num_joints() > 0) {  // the pairs need the skeleton the markers sit on
    const MarkerSet markers = cmu41_markers(context.skeleton);
    for (int a = 0; a < markers.num_markers(); ++a)
      for (int b = a + 1; b < markers.num_markers(); ++b)
        if (markers.markers[a].joint == markers.markers[b].joint) {
          pairs_.emplace_back(a, b);
          rest.push_back((markers.markers[a].offset - markers.markers[b].offset).norm() *
                         context.skeleton.meters_per_unit);
        }
  }
  rest_lengths_ = torch::tensor(rest, torch::kFloat64);
}

void BodyPoints::init_rotations(const ModelContext& context, const std::string& who) {
  const Skeleton& skeleton = context.skeleton;
  const int j = skeleton.num_joints();
  const bool smoothed = context.layout.smoothed_root();
  if (j == 0 || context.pose_dim != data::expected_pose_dim(form_, j, smoothed) ||
      static_cast<int>(skeleton.parents.size()) != j)
    throw Error(who + "the dataset's skeleton and layout (a model built by mosyn train or load_run)");
  if (skeleton.up_axis != 1) throw Error(who + "a Y-up skeleton in the rotations form");
  const Joints joints = find_point_joints(context, who);
  point_joints_ = joints.points;
  has_toes_ = joints.toes;
  const int root = context.layout.root_joint;
  // The chain: every joint from the root down to a point, in skeleton order (the root first).
  std::vector<int> chain;
  for (int p : joints.points) {
    int k = p;
    for (; k != root && k >= 0; k = skeleton.parents[k]) chain.push_back(k);
    if (k < 0) throw Error(who + "the feet below the layout's root joint");
  }
  chain.push_back(root);
  std::sort(chain.begin(), chain.end());
  chain.erase(std::unique(chain.begin(), chain.end()), chain.end());
  std::map<int, int> at;  // skeleton joint -> chain index
  for (size_t k = 0; k < chain.size(); ++k) at[chain[k]] = static_cast<int>(k);
  auto offsets = torch::zeros({static_cast<int64_t>(chain.size()), 3}, torch::kFloat64);
  for (int k : chain) {
    // Layout: height, the root's 6D at 1, then every other joint's 6D in joint order from 7.
    chain_slots_.push_back(k == root ? 1 : 7 + 6 * (k < root ? k : k - 1));
    chain_parents_.push_back(k == root ? -1 : at.at(skeleton.parents[k]));
    for (int c = 0; c < 3; ++c) offsets[at.at(k)][c] = skeleton.offsets[k][c] * skeleton.meters_per_unit;
  }
  chain_offsets_ = offsets;
  for (int p : joints.points) point_chain_index_.push_back(at.at(p));
  offset_feature_ = smoothed ? context.pose_dim - 2 : -1;
  rest_lengths_ = torch::zeros({0}, torch::kFloat64);
}

torch::Tensor BodyPoints::raw(const torch::Tensor& pose) const {
  const auto opts = pose.options();
  return pose * pose_std_.to(opts) + pose_mean_.to(opts);
}

torch::Tensor BodyPoints::fk_points_m(const torch::Tensor& raw_pose) const {
  const auto lead = raw_pose.sizes().slice(0, raw_pose.dim() - 1).vec();
  const int64_t n = raw_pose.numel() / raw_pose.size(-1);
  const auto flat = raw_pose.reshape({n, 1, raw_pose.size(-1)});
  std::vector<torch::Tensor> locals;
  for (int64_t slot : chain_slots_) locals.push_back(flat.narrow(-1, slot, 6));
  const auto rotations = matrix_from_rot6d(torch::stack(locals, 2));  // [n, 1, K, 3, 3]
  const auto height = flat.narrow(-1, height_feature_, 1);
  const auto zero = torch::zeros_like(height);
  const auto root = offset_feature_ < 0 ? torch::cat({zero, height, zero}, -1)
                                        : torch::cat({flat.narrow(-1, offset_feature_, 1), height,
                                                      flat.narrow(-1, offset_feature_ + 1, 1)},
                                                     -1);
  const auto positions =
      forward_kinematics(rotations, root, chain_offsets_.to(raw_pose.options()), chain_parents_);  // [n, 1, K, 3]
  const auto index = torch::tensor(std::vector<int64_t>(point_chain_index_.begin(), point_chain_index_.end()),
                                   torch::dtype(torch::kInt64).device(raw_pose.device()));
  auto shape = lead;
  shape.push_back(num_points_);
  shape.push_back(3);
  return positions.index_select(2, index).reshape(shape);
}

torch::Tensor BodyPoints::points_m(const torch::Tensor& pose) const {
  if (!valid()) throw Error("BodyPoints: not built from a model context");
  const auto metres = raw(pose);
  if (form_ == data::PoseForm::kRotations) return fk_points_m(metres);
  std::vector<torch::Tensor> points;
  for (const auto& triples : point_triples_) {
    torch::Tensor sum;
    for (int64_t k : triples) {
      const auto p = metres.narrow(-1, 3 * k, 3);
      sum = sum.defined() ? sum + p : p;
    }
    points.push_back(triples.size() == 1 ? sum : sum / static_cast<double>(triples.size()));
  }
  return torch::stack(points, -2);
}

torch::Tensor BodyPoints::pair_lengths_m(const torch::Tensor& pose) const {
  if (!valid()) throw Error("BodyPoints: not built from a model context");
  if (pairs_.empty()) {
    auto shape = pose.sizes().vec();
    shape.back() = 0;
    return torch::zeros(shape, pose.options());
  }
  const auto metres = raw(pose);
  auto shape = metres.sizes().vec();
  shape.back() /= 3;
  shape.push_back(3);
  const auto joints = metres.reshape(shape);  // [..., N, 3]
  std::vector<int64_t> a, b;
  for (const auto& [i, j] : pairs_) {
    a.push_back(i);
    b.push_back(j);
  }
  const auto opts = torch::dtype(torch::kInt64).device(pose.device());
  const auto delta = joints.index_select(-2, torch::tensor(a, opts)) - joints.index_select(-2, torch::tensor(b, opts));
  return (delta.pow(2).sum(-1) + 1e-12).sqrt();
}

}  // namespace mosyn::nn

// Whether predicted bodies stay bodies (MOJO, Zhang et al. 2021, Tables 3, 4 and 6), on the raw
// predicted features of the prediction protocol's windows (same clips, prefix, horizon and seeds,
// so the samples are shared), before decoding through the skeleton makes every body valid:
//   - marker form: deformation of the head, upper-torso and lower-torso markers (Eq. 3) and the
//     foot-skating ratio of the heel markers LHEE / RHEE, beside the real windows';
//   - joint-position form ("MOJO w. J."): the bone deformation (BDF) of the eight limb bones, the
//     standard deviation over time of each bone's length (Eq. 3 on a bone's two joints);
//   - forms decoded through the skeleton (rotations, and markers after the fit) have exact bones:
//     their BDF is measured on the decoded joints.
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/markers.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

namespace {

using detail::mean_finite;
using detail::rows_of;

std::vector<std::string> pose_point_names(const nn::LoadedRun& run) {
  std::vector<std::string> names;
  const auto& pose_names = run.dataset.layout.pose_names;
  for (size_t i = 0; i + 2 < pose_names.size(); i += 3) names.push_back(pose_names[i].substr(0, pose_names[i].rfind('.')));
  return names;
}

int index_of(const std::vector<std::string>& names, const std::string& name) {
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  throw Error("body validity: no point named " + name);
}

// The paper's three rigid parts by CMU marker name.
std::vector<RigidPart> marker_parts(const std::vector<std::string>& names) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> parts = {
      {"head", {"LFHD", "RFHD", "RBHD", "LBHD"}},
      {"upper_torso", {"RSHO", "LSHO", "CLAV", "C7"}},
      {"lower_torso", {"RFWT", "LFWT", "LBWT", "RBWT"}}};
  std::vector<RigidPart> out;
  for (const auto& [part, markers] : parts) {
    RigidPart r{part, {}};
    for (const auto& m : markers) r.joints.push_back(index_of(names, m));
    out.push_back(r);
  }
  return out;
}

// The eight limb bones (upper arm, forearm, thigh, shin; left and right; core/markers.h
// find_body_parts) as two-joint parts indexed into `names`; empty when the skeleton lacks a limb or a
// joint is not among the names.
std::vector<RigidPart> limb_bones(const Skeleton& skeleton, const std::vector<std::string>& names) {
  BodyParts b;
  try {
    b = find_body_parts(skeleton);
  } catch (const Error&) {
    return {};
  }
  std::vector<RigidPart> out;
  auto add = [&](int from, int to) {
    const auto a = std::find(names.begin(), names.end(), skeleton.joint_names.at(from));
    const auto c = std::find(names.begin(), names.end(), skeleton.joint_names.at(to));
    if (a != names.end() && c != names.end())
      out.push_back({"bone", {static_cast<int>(a - names.begin()), static_cast<int>(c - names.begin())}});
  };
  for (int side : {0, 1}) {
    add(b.upper_arm[side], b.forearm[side]);
    add(b.forearm[side], b.hand[side]);
    add(b.thigh[side], b.shin[side]);
    add(b.shin[side], b.foot[side]);
  }
  return out.size() == 8 ? out : std::vector<RigidPart>{};
}

class BodyValidityProtocol : public Protocol {
 public:
  std::string name() const override { return "body_validity"; }
  bool enabled(const EvalOptions& o) const override { return o.prediction; }
  bool applies_to(const nn::ModelTraits& t) const override { return t.prefix; }
  void run(EvalContext& ctx, EvalResult& result) const override;
};

void BodyValidityProtocol::run(EvalContext& ctx, EvalResult& result) const {
  const EvalOptions& o = ctx.options();
  const nn::LoadedRun& run = ctx.run();
  const int d = run.context.pose_dim;
  const double fps = ctx.info().fps;
  const int p = static_cast<int>(std::lround(o.prefix_s * fps));
  const int h = static_cast<int>(std::lround(o.horizon_s * fps));
  const bool markers = run.context.pose_form == data::PoseForm::kMarkers;
  const bool positions = run.context.pose_form == data::PoseForm::kPositions;
  const std::vector<std::string> names = pose_point_names(run);
  const std::vector<RigidPart> parts = markers ? marker_parts(names) : std::vector<RigidPart>{};
  FootJoints heels;
  if (markers) heels.left_heel = index_of(names, "LHEE"), heels.right_heel = index_of(names, "RHEE");
  std::vector<std::vector<double>> deformation(parts.size()), real_deformation(parts.size());
  std::vector<double> skating, real_skating, bdf;
  // BDF on the raw joints of the positions form, else on the joints decoded through the skeleton
  // (named as the decoded real clips are): the limb bones are found once.
  MotionPositions decoded_header;
  if (!positions && !ctx.real().empty()) {
    const MotionPositions& r = ctx.real().front();
    decoded_header = {r.name, r.fps, 0, r.num_joints, r.up_axis, r.joint_names, r.parents, r.bone_lengths_m, {}};
  }
  const std::vector<RigidPart> bones =
      limb_bones(run.dataset.skeleton, positions ? names : decoded_header.joint_names);
  for (size_t i = 0; i < ctx.num_clips(); ++i) {
    const data::ClipRecord& rec = ctx.clip(i);
    if (rec.num_frames < p + h) continue;
    const std::uint64_t seed = o.seed + 1000003 + i;  // the prediction protocol's windows and samples
    const auto& samples = ctx.raw_continuations(i, p, p + h, seed);
    std::vector<MotionPositions> predicted;
    for (const auto& s : samples) predicted.push_back(feature_points_world(s.pose, s.control, d, p, p + h, names, fps));
    if (markers) {
      const MotionPositions real = feature_points_world(rows_of(rec.pose, 0, p + h, d), rows_of(rec.control, 0, p + h, 3), d,
                                                        p, p + h, names, fps);
      real_skating.push_back(foot_skating_ratio(real, heels));
      for (size_t k = 0; k < parts.size(); ++k) real_deformation[k].push_back(rigid_part_deformation_m(real, parts[k]));
      for (const auto& m : predicted) {
        skating.push_back(foot_skating_ratio(m, heels));
        for (size_t k = 0; k < parts.size(); ++k) deformation[k].push_back(rigid_part_deformation_m(m, parts[k]));
      }
    }
    if (bones.empty()) continue;
    std::vector<MotionPositions> joints;
    if (positions) {
      joints = std::move(predicted);
    } else {
      for (const auto& s : ctx.continuations(i, p, p + h, seed)) {
        MotionPositions m = decoded_header;
        m.num_frames = h;
        for (int t = p; t < p + h; ++t)
          for (int j = 0; j < m.num_joints; ++j) m.positions_m.emplace_back(s.row(t).segment<3>(3 * j).transpose());
        joints.push_back(std::move(m));
      }
    }
    for (const auto& m : joints) {
      double sum = 0.0;
      for (const auto& b : bones) sum += rigid_part_deformation_m(m, b);
      bdf.push_back(sum / bones.size());
    }
  }
  for (size_t k = 0; k < parts.size(); ++k)
    result.rows.push_back({"validity.rigid_" + parts[k].name + "_mm", "rigid deformation " + parts[k].name + " (mm)",
                           1e3 * mean_finite(deformation[k]), 1e3 * mean_finite(real_deformation[k])});
  if (markers)
    result.rows.push_back({"validity.heel_skating", "heel-marker foot skating (MOJO)", mean_finite(skating),
                           mean_finite(real_skating)});
  if (!bdf.empty())
    result.rows.push_back({"validity.bdf_m", "limb bone deformation BDF (m)", mean_finite(bdf), 0.0});
}

}  // namespace

std::unique_ptr<Protocol> make_body_validity_protocol() { return std::make_unique<BodyValidityProtocol>(); }

}  // namespace mosyn::eval

#include "core/root_planting.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"
#include "core/foot_lock.h"
#include "core/trajectory.h"

namespace mosyn {

namespace {

// Slides below this (metres per frame) count as still when weighing points and legs: the ratio
// of weight to slide then stays finite for a point that does not move.
constexpr double kStillM = 2e-3;

void require(bool ok, const char* field, const std::string& expected) {
  if (!ok) throw Error(std::string("root planting: ") + field + " " + expected);
}

}  // namespace

void RootPlantingOptions::validate() const {
  require(contact_height_m >= 0 && std::isfinite(contact_height_m), "contact_height_m", "must be >= 0");
  require(release_height_m > contact_height_m && std::isfinite(release_height_m), "release_height_m",
          "must be above contact_height_m");
  require(floor_window_s > 0 && floor_window_s <= 60, "floor_window_s", "must be in (0, 60] seconds");
  require(keep_weight >= 0 && keep_weight <= 1, "keep_weight", "must be in [0, 1]");
  require(switch_ratio >= 1 && std::isfinite(switch_ratio), "switch_ratio", "must be >= 1");
}

std::vector<std::vector<int>> foot_points(const Skeleton& skeleton) {
  std::vector<std::vector<int>> out;
  for (const LegChain& leg : find_legs(skeleton)) {
    std::vector<int> points{leg.ankle};
    for (int j = 0; j < skeleton.num_joints(); ++j)
      if (skeleton.parents[j] == leg.ankle) points.push_back(j);
    out.push_back(points);
  }
  return out;
}

RootPlanter::RootPlanter(const Skeleton& skeleton, double fps, const RootPlantingOptions& options)
    : skeleton_(skeleton), options_(options) {
  options.validate();
  if (!(fps > 0) || !std::isfinite(fps)) throw Error("root planting: fps must be > 0");
  window_frames_ = std::max(1, static_cast<int>(std::lround(options.floor_window_s * fps)));
  for (const auto& points : foot_points(skeleton)) {
    std::vector<Point> leg;
    for (int j : points) leg.push_back(Point{j, Eigen::Vector3d::Zero(), {}});
    legs_.push_back(std::move(leg));
  }
}

void RootPlanter::reset() {
  for (auto& leg : legs_)
    for (auto& p : leg) p.heights_m.clear();
  has_previous_ = false;
  chosen_ = -1;
}

Eigen::Vector2d RootPlanter::step(const std::vector<Eigen::Vector3d>& ground_frame_positions,
                                  const Eigen::Vector2d& step_m, double turn_rad) {
  if (legs_.empty()) return step_m;
  if (static_cast<int>(ground_frame_positions.size()) != skeleton_.num_joints())
    throw Error("root planting: a frame has " + std::to_string(ground_frame_positions.size()) + " joints, the skeleton " +
                std::to_string(skeleton_.num_joints()));
  const double mpu = skeleton_.meters_per_unit > 0 ? skeleton_.meters_per_unit : 1.0;
  const int up = skeleton_.up_axis, fa = forward_axis(skeleton_), sa = sideways_axis(skeleton_);
  const Eigen::Quaterniond turn = heading_rotation(skeleton_, turn_rad);
  const bool first = !has_previous_;
  // Per leg: how firmly it stands (its firmest point's weight), the step that keeps it in place
  // (its points' planted steps, each weighed by how firm and how still it is) and its slide.
  std::vector<double> weight(legs_.size(), 0.0), slide(legs_.size(), 0.0);
  std::vector<Eigen::Vector2d> planted(legs_.size(), step_m);
  for (size_t k = 0; k < legs_.size(); ++k) {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    double total = 0;
    for (Point& p : legs_[k]) {
      const Eigen::Vector3d& q = ground_frame_positions[p.joint];
      p.heights_m.push_back(q[up] * mpu);
      if (static_cast<int>(p.heights_m.size()) > window_frames_) p.heights_m.pop_front();
      if (!first) {
        const double floor_m = *std::min_element(p.heights_m.begin(), p.heights_m.end());
        const double w = std::clamp((options_.release_height_m - (q[up] * mpu - floor_m)) /
                                        (options_.release_height_m - options_.contact_height_m),
                                    0.0, 1.0);
        const Eigen::Vector3d keep = (p.previous - turn * q) * mpu;
        const Eigen::Vector2d point_step(keep[sa], keep[fa]);
        const double a = w / ((step_m - point_step).norm() + kStillM);
        sum += a * point_step;
        total += a;
        weight[k] = std::max(weight[k], w);
      }
      p.previous = q;
    }
    if (total > 0) planted[k] = sum / total;
    slide[k] = (step_m - planted[k]).norm();
  }
  has_previous_ = true;
  if (first) return step_m;
  // The leg that carries the body: the firmest and stillest, kept while it stands so the choice
  // does not flicker between feet within a stance.
  auto score = [&](size_t k) { return weight[k] / (slide[k] + kStillM); };
  size_t best = 0;
  for (size_t k = 1; k < legs_.size(); ++k)
    if (score(k) > score(best)) best = k;
  if (chosen_ < 0 || weight[chosen_] < options_.keep_weight || score(best) > options_.switch_ratio * score(chosen_))
    chosen_ = static_cast<int>(best);
  return step_m + weight[chosen_] * (planted[chosen_] - step_m);
}

}  // namespace mosyn

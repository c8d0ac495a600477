#include "nn/mojo/ceres_fit.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "core/kinematics.h"

namespace mosyn::nn::mojo {
namespace {

// Residuals of one frame's fit. Parameter blocks: [0] the root translation (skeleton units),
// [1 + j] joint j's rotation increment (angle-axis, radians). Constants: the start pose's local
// rotations (w, x, y, z) and translations of frame t.
struct MarkerFitResidual {
  const Skeleton* skeleton;
  const MarkerSet* markers;
  const std::vector<Eigen::Vector3d>* targets;  // skeleton units
  std::vector<Eigen::Quaterniond> start_rotations;
  std::vector<Eigen::Vector3d> translations;
  double sqrt_prior;

  template <typename T>
  bool operator()(T const* const* params, T* residuals) const {
    const int joints = skeleton->num_joints();
    std::vector<T> world_q(4 * static_cast<size_t>(joints)), world_p(3 * static_cast<size_t>(joints));
    for (int j = 0; j < joints; ++j) {
      const Eigen::Quaterniond& s = start_rotations[j];
      const T start[4] = {T(s.w()), T(s.x()), T(s.y()), T(s.z())};
      T step[4], local[4];
      ceres::AngleAxisToQuaternion(params[1 + j], step);
      ceres::QuaternionProduct(start, step, local);
      T* q = &world_q[4 * j];
      T* p = &world_p[3 * j];
      const int parent = skeleton->parents[j];
      if (parent < 0) {
        for (int k = 0; k < 4; ++k) q[k] = local[k];
        for (int k = 0; k < 3; ++k) p[k] = params[0][k];
        continue;
      }
      const T offset[3] = {T(translations[j].x()), T(translations[j].y()), T(translations[j].z())};
      T rotated[3];
      ceres::UnitQuaternionRotatePoint(&world_q[4 * parent], offset, rotated);
      ceres::QuaternionProduct(&world_q[4 * parent], local, q);
      for (int k = 0; k < 3; ++k) p[k] = world_p[3 * parent + k] + rotated[k];
    }
    const double m_per_unit = skeleton->meters_per_unit;
    for (int i = 0; i < markers->num_markers(); ++i) {
      const Marker& marker = markers->markers[i];
      const T offset[3] = {T(marker.offset.x()), T(marker.offset.y()), T(marker.offset.z())};
      T rotated[3];
      ceres::UnitQuaternionRotatePoint(&world_q[4 * marker.joint], offset, rotated);
      for (int k = 0; k < 3; ++k)
        residuals[3 * i + k] = (world_p[3 * marker.joint + k] + rotated[k] - T((*targets)[i][k])) * m_per_unit;
    }
    T* prior = residuals + 3 * markers->num_markers();
    for (int j = 0; j < joints; ++j)
      for (int k = 0; k < 3; ++k) prior[3 * j + k] = sqrt_prior * params[1 + j][k];
    return true;
  }
};

}  // namespace

MarkerFitResult fit_markers_ceres(const Skeleton& skeleton, const MarkerSet& markers,
                                  const std::vector<Eigen::Vector3d>& targets, Motion* motion, int t,
                                  const CeresFitOptions& options) {
  if (static_cast<int>(targets.size()) != markers.num_markers())
    throw Error("mojo fit: " + std::to_string(targets.size()) + " targets for " +
                std::to_string(markers.num_markers()) + " markers");
  for (const auto& target : targets)
    if (!target.allFinite()) throw Error("mojo fit: a target marker position is not finite");
  if (t < 0 || t >= motion->num_frames) throw Error("mojo fit: frame " + std::to_string(t) + " out of range");
  const int joints = skeleton.num_joints();

  auto* residual = new MarkerFitResidual{&skeleton, &markers, &targets, {}, {}, std::sqrt(options.pose_prior)};
  for (int j = 0; j < joints; ++j) {
    residual->start_rotations.push_back(motion->rotation(t, j).normalized());
    residual->translations.push_back(motion->translation(t, j));
  }
  // Stride 9: derivatives in chunks of three joints per pass over the frame's forward kinematics.
  auto* cost = new ceres::DynamicAutoDiffCostFunction<MarkerFitResidual, 9>(residual);
  std::vector<std::vector<double>> blocks(1 + static_cast<size_t>(joints), std::vector<double>(3, 0.0));
  const int root = [&] {
    for (int j = 0; j < joints; ++j)
      if (skeleton.parents[j] < 0) return j;
    return 0;
  }();
  for (int k = 0; k < 3; ++k) blocks[0][k] = motion->translation(t, root)[k];
  std::vector<double*> pointers;
  for (auto& block : blocks) {
    cost->AddParameterBlock(3);
    pointers.push_back(block.data());
  }
  cost->SetNumResiduals(3 * (markers.num_markers() + joints));

  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, pointers);
  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = 1;  // the projection runs samples in parallel, one fit per thread
  solver.logging_type = ceres::SILENT;
  solver.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);

  for (int j = 0; j < joints; ++j) {
    const Eigen::Vector3d d(blocks[1 + j][0], blocks[1 + j][1], blocks[1 + j][2]);
    const double angle = d.norm();
    const Eigen::Quaterniond step =
        angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, d / angle)) : Eigen::Quaterniond::Identity();
    motion->rotation(t, j) = (residual->start_rotations[j] * step).normalized();
  }
  motion->translation(t, root) = Eigen::Vector3d(blocks[0][0], blocks[0][1], blocks[0][2]);

  const WorldPoses world = forward_kinematics(skeleton, *motion);
  MarkerFitResult result;
  result.fitted = marker_positions(markers, world, t);
  double sum = 0.0;
  for (size_t i = 0; i < result.fitted.size(); ++i) sum += (result.fitted[i] - targets[i]).squaredNorm();
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  result.rms_error = std::sqrt(sum / std::max<size_t>(1, result.fitted.size()));
  return result;
}

}  // namespace mosyn::nn::mojo

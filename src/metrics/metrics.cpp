#include "metrics/metrics.h"

#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/FFT>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <complex>
#include <limits>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/mirror.h"
#include "core/units.h"
#include "data/augment.h"
#include "data/control.h"

namespace mosyn::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

Eigen::Vector2d horizontal(const Eigen::Vector3d& v, int up_axis) {
  const int a = (up_axis + 1) % 3, b = (up_axis + 2) % 3;
  return {v[a], v[b]};
}

void check_same_shape(const std::vector<Eigen::MatrixXd>& samples, const Eigen::MatrixXd& like, const char* what) {
  for (const auto& s : samples)
    if (s.rows() != like.rows() || s.cols() != like.cols())
      throw Error(std::string(what) + ": sequences differ in shape (" + std::to_string(s.rows()) + "x" +
                  std::to_string(s.cols()) + " vs " + std::to_string(like.rows()) + "x" +
                  std::to_string(like.cols()) + ")");
}

double mean_of(const std::vector<double>& v) {
  if (v.empty()) return kNaN;
  double s = 0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}

double population_std(const std::vector<double>& v) {
  if (v.empty()) return kNaN;
  const double m = mean_of(v);
  double s = 0;
  for (double x : v) s += (x - m) * (x - m);
  return std::sqrt(s / static_cast<double>(v.size()));
}

}  // namespace

Eigen::MatrixXd MotionPositions::sequence() const {
  Eigen::MatrixXd out(num_frames, num_joints * 3);
  for (int t = 0; t < num_frames; ++t)
    for (int j = 0; j < num_joints; ++j) out.block<1, 3>(t, 3 * j) = position(t, j).transpose();
  return out;
}

MotionPositions motion_positions(const Clip& input, double meters_per_unit, const std::string& name) {
  // A placeholder root (Bandai-Namco's joint_Root) is no body part: its "bone" to Hips would vary.
  const Clip clip = data::collapse_static_root(input);
  const Skeleton& s = clip.skeleton;
  const double mpu = resolve_meters_per_unit(s, meters_per_unit);
  MotionPositions out;
  out.name = name;
  out.fps = clip.motion.fps;
  out.num_frames = clip.motion.num_frames;
  out.num_joints = s.num_joints();
  out.up_axis = s.up_axis;
  out.joint_names = s.joint_names;
  out.parents = s.parents;
  out.bone_lengths_m.resize(s.num_joints());
  for (int j = 0; j < s.num_joints(); ++j) out.bone_lengths_m[j] = s.parents[j] < 0 ? 0.0 : s.offsets[j].norm() * mpu;
  const WorldPoses poses = forward_kinematics(s, clip.motion);
  out.positions_m = poses.positions;
  for (auto& p : out.positions_m) p *= mpu;
  return out;
}

int find_joint_by_patterns(const std::vector<std::string>& joint_names, const std::vector<int>& sides,
                           const std::vector<std::string>& patterns, int side) {
  for (const auto& pattern : patterns) {
    const std::string p = lower(pattern);
    for (size_t j = 0; j < joint_names.size(); ++j)
      if (sides[j] == side && lower(joint_names[j]).find(p) != std::string::npos) return static_cast<int>(j);
  }
  return -1;
}

std::vector<int> joint_sides_of(const MotionPositions& motion) {
  Skeleton s;  // mirror_map only reads names
  s.joint_names = motion.joint_names;
  s.parents = motion.parents;
  s.offsets.assign(motion.joint_names.size(), Eigen::Vector3d::Zero());
  return joint_sides(s);
}

FootJoints find_foot_joints(const MotionPositions& motion, const std::vector<std::string>& overrides) {
  FootJoints f;
  if (!overrides.empty()) {
    if (overrides.size() != 2 && overrides.size() != 4)
      throw Error("foot joints: give 2 names (left and right heel) or 4 (heels, then toes)");
    int* slots[4] = {&f.left_heel, &f.right_heel, &f.left_toe, &f.right_toe};
    for (size_t i = 0; i < overrides.size(); ++i) {
      const auto it = std::find(motion.joint_names.begin(), motion.joint_names.end(), overrides[i]);
      if (it == motion.joint_names.end())
        throw Error("foot joint '" + overrides[i] + "' not found in " + (motion.name.empty() ? "the skeleton" : motion.name));
      *slots[i] = static_cast<int>(it - motion.joint_names.begin());
    }
    return f;
  }
  const std::vector<int> sides = joint_sides_of(motion);
  const std::vector<std::string> heel = {"heel", "foot", "ankle"}, toe = {"toe"};
  // "foot" also matches CMU's LeftFoot before its LeftToeBase; skip toe joints for heels.
  auto find_heel = [&](int side) {
    for (const auto& pattern : heel)
      for (size_t j = 0; j < motion.joint_names.size(); ++j) {
        const std::string n = lower(motion.joint_names[j]);
        if (sides[j] == side && n.find(pattern) != std::string::npos && n.find("toe") == std::string::npos)
          return static_cast<int>(j);
      }
    return -1;
  };
  f.left_heel = find_heel(+1);
  f.right_heel = find_heel(-1);
  f.left_toe = find_joint_by_patterns(motion.joint_names, sides, toe, +1);
  f.right_toe = find_joint_by_patterns(motion.joint_names, sides, toe, -1);
  if (f.left_heel < 0 || f.right_heel < 0)
    throw Error("no left/right foot joints found by name in " + (motion.name.empty() ? "the skeleton" : motion.name) +
                " (looked for *heel*, *foot*, *ankle* with a left/right marker); name them explicitly");
  return f;
}

std::vector<double> horizontal_speed_mps(const MotionPositions& motion, int joint) {
  if (joint < 0 || joint >= motion.num_joints) throw Error("horizontal_speed_mps: joint index out of range");
  std::vector<double> speed;
  for (int t = 0; t + 1 < motion.num_frames; ++t)
    speed.push_back(horizontal(motion.position(t + 1, joint) - motion.position(t, joint), motion.up_axis).norm() *
                    motion.fps);
  return speed;
}

double pelvis_ground_speed_mps(const std::vector<MotionPositions>& motions, double span_s) {
  if (!(span_s > 0)) throw Error("pelvis_ground_speed_mps: the span must be positive");
  double speed_sum = 0;
  long spans = 0;
  for (const MotionPositions& m : motions) {
    if (m.num_frames < 2 || m.num_joints < 1) continue;
    const int n = std::min(m.num_frames - 1, std::max(1, static_cast<int>(std::lround(span_s * m.fps))));
    for (int t = 0; t + n < m.num_frames; ++t, ++spans)
      speed_sum += horizontal(m.position(t + n, 0) - m.position(t, 0), m.up_axis).norm() * m.fps / n;
  }
  return spans > 0 ? speed_sum / spans : std::numeric_limits<double>::quiet_NaN();
}

std::vector<double> footstep_durations_s(const std::vector<double>& speed_mps, double fps, double v_tol_mps) {
  if (!(fps > 0)) throw Error("footstep_durations_s: fps must be positive");
  std::vector<double> out;
  int run = 0;
  for (size_t i = 0; i <= speed_mps.size(); ++i) {
    if (i < speed_mps.size() && speed_mps[i] < v_tol_mps) {
      ++run;
    } else if (run > 0) {
      out.push_back(run / fps);
      run = 0;
    }
  }
  return out;
}

namespace {
using SpeedTrack = std::pair<std::vector<double>, double>;  // horizontal speed (m/s), fps

// Durations (s) of the footsteps of every track at v_tol_mps, runs shorter than min_s left out.
std::vector<double> pooled_footsteps_s(const std::vector<SpeedTrack>& tracks, double v_tol_mps, double min_s) {
  std::vector<double> out;
  for (const auto& [speed, fps] : tracks)
    for (double d : footstep_durations_s(speed, fps, v_tol_mps))
      if (d >= min_s - 1e-9) out.push_back(d);
  return out;
}
}  // namespace

FootstepAnalysis analyse_footsteps(const std::vector<MotionPositions>& motions, const std::vector<FootJoints>& feet,
                                   const FootstepOptions& options) {
  if (motions.size() != feet.size()) throw Error("analyse_footsteps: one FootJoints per motion needed");
  if (!(options.v_tol_step_mps > 0) || !(options.v_tol_max_mps >= options.v_tol_step_mps))
    throw Error("analyse_footsteps: tolerance step and maximum must be positive, step <= maximum");
  if (!(options.fixed_tol_mps > 0)) throw Error("analyse_footsteps: the fixed tolerance must be positive");
  std::vector<SpeedTrack> tracks;
  for (size_t i = 0; i < motions.size(); ++i) {
    const FootJoints& f = feet[i];
    const bool toes = options.use_toes && f.left_toe >= 0 && f.right_toe >= 0;
    for (int j : {toes ? f.left_toe : f.left_heel, toes ? f.right_toe : f.right_heel})
      if (j >= 0) tracks.emplace_back(horizontal_speed_mps(motions[i], j), motions[i].fps);
  }
  FootstepAnalysis a;
  const int k_count = static_cast<int>(std::floor(options.v_tol_max_mps / options.v_tol_step_mps + 1e-9));
  for (int k = 1; k <= k_count; ++k) {
    const double v = k * options.v_tol_step_mps;
    const int count = static_cast<int>(pooled_footsteps_s(tracks, v, options.min_step_duration_s).size());
    a.v_tol_mps.push_back(v);
    a.f_est.push_back(count);
    a.max_steps = std::max(a.max_steps, count);
  }
  const std::vector<double> fixed_durations =
      pooled_footsteps_s(tracks, options.fixed_tol_mps, options.min_step_duration_s);
  double track_s = 0;
  for (const auto& [speed, fps] : tracks) track_s += speed.size() / fps;
  a.contacts_per_foot_s = track_s > 0 ? fixed_durations.size() / track_s : 0.0;
  a.contact_mean_at_fixed_tol_s = mean_of(fixed_durations);
  a.step_duration_mean_s = a.step_duration_std_s = kNaN;
  if (a.max_steps == 0) return a;
  for (size_t k = 0; k < a.f_est.size(); ++k) {
    if (a.f_est[k] >= 0.95 * a.max_steps) {
      a.v_tol95_mps = a.v_tol_mps[k];
      a.steps_at_v_tol95 = a.f_est[k];
      break;
    }
  }
  const std::vector<double> durations = pooled_footsteps_s(tracks, a.v_tol95_mps, options.min_step_duration_s);
  a.step_duration_mean_s = mean_of(durations);
  a.step_duration_std_s = population_std(durations);
  return a;
}

double foot_skating_ratio(const MotionPositions& motion, const FootJoints& feet, const FootSkatingOptions& options) {
  if (motion.num_frames < 2) return 0.0;
  std::vector<int> markers;
  for (int j : {feet.left_heel, feet.right_heel})
    if (j >= 0) markers.push_back(j);
  if (markers.empty()) throw Error("foot_skating_ratio: no foot joints");
  std::vector<double> lowest(markers.size(), std::numeric_limits<double>::infinity());
  for (size_t m = 0; m < markers.size(); ++m)
    for (int t = 0; t < motion.num_frames; ++t)
      lowest[m] = std::min(lowest[m], motion.position(t, markers[m])[motion.up_axis]);
  int skating = 0;
  for (int t = 1; t < motion.num_frames; ++t) {
    int sliding = 0;
    for (size_t m = 0; m < markers.size(); ++m) {
      const Eigen::Vector3d& a = motion.position(t - 1, markers[m]);
      const Eigen::Vector3d& b = motion.position(t, markers[m]);
      const bool low = a[motion.up_axis] - lowest[m] <= options.height_threshold_m &&
                       b[motion.up_axis] - lowest[m] <= options.height_threshold_m;
      const double speed = horizontal(b - a, motion.up_axis).norm() * motion.fps;
      if (low && speed > options.speed_threshold_mps) ++sliding;
    }
    if (options.both_feet ? sliding == static_cast<int>(markers.size()) : sliding > 0) ++skating;
  }
  return static_cast<double>(skating) / (motion.num_frames - 1);
}

namespace {

// The p-th percentile (0..100) of values, linear between order statistics; values not empty.
double percentile(std::vector<double> values, double p) {
  std::sort(values.begin(), values.end());
  const double rank = p / 100.0 * static_cast<double>(values.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(rank));
  const size_t above = std::min(below + 1, values.size() - 1);
  return values[below] + (rank - static_cast<double>(below)) * (values[above] - values[below]);
}

}  // namespace

double toe_slide_ratio(const MotionPositions& motion, const FootJoints& feet, const ToeSlideOptions& options) {
  if (!(options.floor_percentile >= 0 && options.floor_percentile <= 100) || !(options.height_threshold_m > 0) ||
      !(options.speed_threshold_mps > 0))
    throw Error("toe_slide_ratio: floor_percentile in [0, 100] and positive thresholds expected");
  std::vector<int> toes;
  for (int j : {feet.left_toe, feet.right_toe})
    if (j >= 0) toes.push_back(j);
  if (toes.empty()) return std::numeric_limits<double>::quiet_NaN();
  if (motion.num_frames < 2) return 0.0;
  std::vector<double> floor;
  for (int j : toes) {
    std::vector<double> heights(motion.num_frames);
    for (int t = 0; t < motion.num_frames; ++t) heights[t] = motion.position(t, j)[motion.up_axis];
    floor.push_back(percentile(std::move(heights), options.floor_percentile));
  }
  int sliding = 0;
  for (int t = 1; t < motion.num_frames; ++t) {
    bool any = false;
    for (size_t k = 0; k < toes.size() && !any; ++k) {
      const Eigen::Vector3d& a = motion.position(t - 1, toes[k]);
      const double speed = horizontal(motion.position(t, toes[k]) - a, motion.up_axis).norm() * motion.fps;
      any = a[motion.up_axis] - floor[k] < options.height_threshold_m && speed > options.speed_threshold_mps;
    }
    sliding += any ? 1 : 0;
  }
  return static_cast<double>(sliding) / (motion.num_frames - 1);
}

std::vector<double> slower_foot_speed_mps(const MotionPositions& motion, const FootJoints& feet) {
  if (feet.left_heel < 0 || feet.right_heel < 0) throw Error("slower_foot_speed_mps: needs both heel joints");
  std::vector<double> slower = horizontal_speed_mps(motion, feet.left_heel);
  const std::vector<double> right = horizontal_speed_mps(motion, feet.right_heel);
  for (size_t t = 0; t < slower.size(); ++t) slower[t] = std::min(slower[t], right[t]);
  return slower;
}

MotionPositions feature_points_world(const std::vector<float>& pose, const std::vector<float>& control, int dim,
                                     int from, int to, const std::vector<std::string>& names, double fps) {
  const int points = dim / 3;
  const size_t frames = control.size() / 3;
  if (dim < 3 || dim % 3 != 0 || static_cast<int>(names.size()) != points || control.size() % 3 != 0 ||
      pose.size() != frames * dim || from < 0 || to > static_cast<int>(frames) || from >= to)
    throw Error("feature_points_world: pose [T, " + std::to_string(dim) + "], control [T, 3], " +
                std::to_string(points) + " names and frames [from, to) inside [0, T) expected");
  std::vector<double> heading;
  const std::vector<Eigen::Vector3d> floor = data::integrate_control(control, 0.0, &heading);
  MotionPositions m;
  m.fps = fps;
  m.num_frames = to - from;
  m.num_joints = points;
  m.joint_names = names;
  m.parents.assign(points, -1);
  m.bone_lengths_m.assign(points, 0.0);
  for (int t = from; t < to; ++t) {
    const double c = std::cos(heading[t]), s = std::sin(heading[t]);
    for (int i = 0; i < points; ++i) {
      const float* f = &pose[static_cast<size_t>(t) * dim + 3 * i];
      // Heading rotation about +Y: (0, 0, 1) -> (sin h, 0, cos h), (1, 0, 0) -> (cos h, 0, -sin h).
      m.positions_m.emplace_back(floor[t].x() + c * f[0] + s * f[2], f[1], floor[t].z() - s * f[0] + c * f[2]);
    }
  }
  return m;
}

double bone_length_rmse_m(const MotionPositions& motion) {
  double sum = 0;
  long count = 0;
  for (int t = 0; t < motion.num_frames; ++t)
    for (int j = 0; j < motion.num_joints; ++j) {
      const int p = motion.parents[j];
      if (p < 0) continue;
      const double e = (motion.position(t, j) - motion.position(t, p)).norm() - motion.bone_lengths_m[j];
      sum += e * e;
      ++count;
    }
  return count > 0 ? std::sqrt(sum / count) : 0.0;
}

std::vector<RigidPart> default_rigid_parts(const MotionPositions& motion) {
  const std::vector<int> sides = joint_sides_of(motion);
  const auto& names = motion.joint_names;
  auto find0 = [&](const std::vector<std::string>& patterns) { return find_joint_by_patterns(names, sides, patterns, 0); };
  // First joint of a left/right chain below `from`: the shallowest paired descendant on `side`.
  auto first_paired_below = [&](int from, int side) {
    int best = -1, best_depth = 0;
    for (int j = from + 1; j < motion.num_joints; ++j) {
      if (sides[j] != side) continue;
      int depth = 1;
      for (int a = motion.parents[j]; a >= 0; a = motion.parents[a], ++depth)
        if (a == from) {
          if (best < 0 || depth < best_depth) best = j, best_depth = depth;
          break;
        }
    }
    return best;
  };
  std::vector<RigidPart> parts;
  auto add = [&](const std::string& name, std::vector<int> joints) {
    joints.erase(std::remove(joints.begin(), joints.end(), -1), joints.end());
    std::sort(joints.begin(), joints.end());
    joints.erase(std::unique(joints.begin(), joints.end()), joints.end());
    if (joints.size() >= 2) parts.push_back({name, joints});
  };
  const int neck = find0({"neck"});
  const int head = find0({"head"});
  add("head", {neck, head});
  if (neck >= 0) {
    const int chest = motion.parents[neck];
    std::vector<int> upper = {chest, neck};
    if (chest >= 0) {
      upper.push_back(first_paired_below(chest, +1));
      upper.push_back(first_paired_below(chest, -1));
    }
    add("upper torso", upper);
  }
  const int pelvis = find0({"hips", "pelvis", "hip"});
  if (pelvis >= 0) {
    int spine = -1;
    for (int j = pelvis + 1; j < motion.num_joints && spine < 0; ++j)
      if (motion.parents[j] == pelvis && sides[j] == 0) spine = j;
    add("lower torso", {pelvis, spine, first_paired_below(pelvis, +1), first_paired_below(pelvis, -1)});
  }
  return parts;
}

double rigid_part_deformation_m(const MotionPositions& motion, const RigidPart& part) {
  if (part.joints.size() < 2) throw Error("rigid part '" + part.name + "' needs at least 2 joints");
  for (int j : part.joints)
    if (j < 0 || j >= motion.num_joints) throw Error("rigid part '" + part.name + "': joint index out of range");
  if (motion.num_frames == 0) return 0.0;
  double total = 0;
  int pairs = 0;
  for (size_t a = 0; a < part.joints.size(); ++a)
    for (size_t b = a + 1; b < part.joints.size(); ++b) {
      std::vector<double> d(motion.num_frames);
      for (int t = 0; t < motion.num_frames; ++t)
        d[t] = (motion.position(t, part.joints[a]) - motion.position(t, part.joints[b])).norm();
      total += population_std(d);
      ++pairs;
    }
  return total / pairs;
}

double average_pairwise_distance(const std::vector<Eigen::MatrixXd>& samples) {
  if (samples.size() < 2) return 0.0;
  check_same_shape(samples, samples[0], "average_pairwise_distance");
  double sum = 0;
  for (size_t i = 0; i < samples.size(); ++i)
    for (size_t j = i + 1; j < samples.size(); ++j) sum += 2 * (samples[i] - samples[j]).norm();
  const double n = static_cast<double>(samples.size());
  return sum / (n * (n - 1));
}

double average_displacement_error(const std::vector<Eigen::MatrixXd>& samples, const Eigen::MatrixXd& ground_truth) {
  if (samples.empty() || ground_truth.rows() == 0) throw Error("ADE needs samples and a non-empty ground truth");
  check_same_shape(samples, ground_truth, "ADE");
  double best = std::numeric_limits<double>::infinity();
  for (const auto& s : samples) best = std::min(best, (s - ground_truth).rowwise().norm().mean());
  return best;
}

double final_displacement_error(const std::vector<Eigen::MatrixXd>& samples, const Eigen::MatrixXd& ground_truth) {
  if (samples.empty() || ground_truth.rows() == 0) throw Error("FDE needs samples and a non-empty ground truth");
  check_same_shape(samples, ground_truth, "FDE");
  const Eigen::Index last = ground_truth.rows() - 1;
  double best = std::numeric_limits<double>::infinity();
  for (const auto& s : samples) best = std::min(best, (s.row(last) - ground_truth.row(last)).norm());
  return best;
}

std::vector<double> joint_position_errors_m(const Eigen::MatrixXd& sample, const Eigen::MatrixXd& ground_truth,
                                            const std::vector<int>& frames) {
  if (sample.cols() != ground_truth.cols() || sample.cols() % 3 != 0 || sample.cols() == 0)
    throw Error("joint-position error: sequences of " + std::to_string(sample.cols()) + " and " +
                std::to_string(ground_truth.cols()) + " columns; expected equal, non-zero multiples of 3");
  const Eigen::Index joints = sample.cols() / 3;
  std::vector<double> errors;
  for (int f : frames) {
    if (f < 0 || f >= sample.rows() || f >= ground_truth.rows())
      throw Error("joint-position error: frame " + std::to_string(f) + " is outside sequences of " +
                  std::to_string(sample.rows()) + " and " + std::to_string(ground_truth.rows()) + " frames");
    double sum = 0;
    for (Eigen::Index j = 0; j < joints; ++j)
      sum += (sample.row(f).segment(3 * j, 3) - ground_truth.row(f).segment(3 * j, 3)).norm();
    errors.push_back(sum / static_cast<double>(joints));
  }
  return errors;
}

std::vector<std::vector<int>> multimodal_ground_truth(const Eigen::MatrixXd& last_context_poses, double threshold_m) {
  const Eigen::Index n = last_context_poses.rows();
  std::vector<std::vector<int>> out(n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      if ((last_context_poses.row(i) - last_context_poses.row(j)).norm() <= threshold_m)
        out[i].push_back(static_cast<int>(j));
  return out;
}

double multimodal_ade(const std::vector<Eigen::MatrixXd>& samples, const std::vector<Eigen::MatrixXd>& ground_truths) {
  if (ground_truths.empty()) throw Error("MMADE needs at least one ground truth");
  double s = 0;
  for (const auto& g : ground_truths) s += average_displacement_error(samples, g);
  return s / static_cast<double>(ground_truths.size());
}

double multimodal_fde(const std::vector<Eigen::MatrixXd>& samples, const std::vector<Eigen::MatrixXd>& ground_truths) {
  if (ground_truths.empty()) throw Error("MMFDE needs at least one ground truth");
  double s = 0;
  for (const auto& g : ground_truths) s += final_displacement_error(samples, g);
  return s / static_cast<double>(ground_truths.size());
}

double spectral_entropy(const Eigen::MatrixXd& sequence) {
  const Eigen::Index n = sequence.rows();
  const Eigen::Index bins = n / 2;
  if (bins < 1) return 0.0;
  Eigen::FFT<double> fft;
  std::vector<double> x(static_cast<size_t>(n));
  std::vector<std::complex<double>> spectrum;
  double total = 0;
  int columns = 0;
  for (Eigen::Index c = 0; c < sequence.cols(); ++c) {
    const double mean = sequence.col(c).mean();
    double energy = 0;
    for (Eigen::Index t = 0; t < n; ++t) {
      x[t] = sequence(t, c) - mean;
      energy += x[t] * x[t];
    }
    fft.fwd(spectrum, x);
    double sum = 0;
    for (Eigen::Index k = 1; k <= bins; ++k) sum += std::norm(spectrum[k]);
    // Relative threshold: a constant column leaves only rounding noise.
    if (!(sum > 1e-20 * std::max(1.0, energy) && sum > 1e-24)) continue;
    double h = 0;
    for (Eigen::Index k = 1; k <= bins; ++k) {
      const double p = std::norm(spectrum[k]) / sum;
      if (p > 0) h -= p * std::log(p);
    }
    total += h;
    ++columns;
  }
  return columns > 0 ? total / columns : 0.0;
}

double spectral_entropy_difference(const std::vector<Eigen::MatrixXd>& samples,
                                   const std::vector<Eigen::MatrixXd>& ground_truths) {
  if (samples.empty() || ground_truths.empty()) throw Error("FSE needs samples and ground truths");
  double a = 0, b = 0;
  for (const auto& s : samples) a += spectral_entropy(s);
  for (const auto& g : ground_truths) b += spectral_entropy(g);
  return a / static_cast<double>(samples.size()) - b / static_cast<double>(ground_truths.size());
}

PredictionMetrics evaluate_predictions(const std::vector<PredictionWindow>& windows, double multimodal_threshold_m) {
  if (windows.empty()) throw Error("evaluate_predictions needs at least one window");
  const Eigen::Index d = windows[0].last_context_pose.size();
  Eigen::MatrixXd context(static_cast<Eigen::Index>(windows.size()), d);
  for (size_t i = 0; i < windows.size(); ++i) {
    if (windows[i].last_context_pose.size() != d) throw Error("evaluate_predictions: context poses differ in size");
    context.row(static_cast<Eigen::Index>(i)) = windows[i].last_context_pose.transpose();
  }
  const auto groups = multimodal_ground_truth(context, multimodal_threshold_m);
  PredictionMetrics m;
  m.num_windows = static_cast<int>(windows.size());
  std::vector<Eigen::MatrixXd> all_samples, all_truths;
  for (size_t i = 0; i < windows.size(); ++i) {
    const PredictionWindow& w = windows[i];
    m.apd_m += average_pairwise_distance(w.samples);
    m.ade_m += average_displacement_error(w.samples, w.ground_truth);
    m.fde_m += final_displacement_error(w.samples, w.ground_truth);
    std::vector<Eigen::MatrixXd> truths;
    for (int j : groups[i]) truths.push_back(windows[j].ground_truth);
    m.mmade_m += multimodal_ade(w.samples, truths);
    m.mmfde_m += multimodal_fde(w.samples, truths);
    all_samples.insert(all_samples.end(), w.samples.begin(), w.samples.end());
    all_truths.push_back(w.ground_truth);
  }
  const double n = static_cast<double>(windows.size());
  m.apd_m /= n;
  m.ade_m /= n;
  m.fde_m /= n;
  m.mmade_m /= n;
  m.mmfde_m /= n;
  m.fse = spectral_entropy_difference(all_samples, all_truths);
  return m;
}

MeanPoseDistance mean_pose_distance(const std::vector<Eigen::MatrixXd>& samples) {
  if (samples.empty()) throw Error("mean_pose_distance needs at least one sample");
  check_same_shape(samples, samples[0], "mean_pose_distance");
  const Eigen::Index n_frames = samples[0].rows();
  Eigen::MatrixXd mean = Eigen::MatrixXd::Zero(n_frames, samples[0].cols());
  for (const auto& s : samples) mean += s;
  mean /= static_cast<double>(samples.size());
  MeanPoseDistance out;
  out.mean_m.resize(n_frames);
  out.std_m.resize(n_frames);
  for (Eigen::Index t = 0; t < n_frames; ++t) {
    std::vector<double> d;
    for (const auto& s : samples) d.push_back((s.row(t) - mean.row(t)).norm());
    out.mean_m[t] = mean_of(d);
    out.std_m[t] = population_std(d);
  }
  return out;
}

double inception_score(const Eigen::MatrixXd& probabilities) {
  if (probabilities.rows() == 0) throw Error("inception_score needs at least one row");
  if ((probabilities.array() < 0).any()) throw Error("inception_score: negative probability");
  const Eigen::RowVectorXd marginal = probabilities.colwise().mean();
  double kl_sum = 0;
  for (Eigen::Index i = 0; i < probabilities.rows(); ++i)
    for (Eigen::Index c = 0; c < probabilities.cols(); ++c) {
      const double p = probabilities(i, c);
      if (p > 0) kl_sum += p * std::log(p / marginal[c]);
    }
  return std::exp(kl_sum / static_cast<double>(probabilities.rows()));
}

double frechet_distance(const Eigen::VectorXd& mean1, const Eigen::MatrixXd& cov1, const Eigen::VectorXd& mean2,
                        const Eigen::MatrixXd& cov2) {
  const Eigen::Index d = mean1.size();
  if (mean2.size() != d || cov1.rows() != d || cov1.cols() != d || cov2.rows() != d || cov2.cols() != d)
    throw Error("frechet_distance: sizes disagree");
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e1(0.5 * (cov1 + cov1.transpose()));
  const Eigen::VectorXd l1 = e1.eigenvalues().cwiseMax(0.0);
  const Eigen::MatrixXd sqrt1 = e1.eigenvectors() * l1.cwiseSqrt().asDiagonal() * e1.eigenvectors().transpose();
  const Eigen::MatrixXd m = sqrt1 * cov2 * sqrt1;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> em(0.5 * (m + m.transpose()), Eigen::EigenvaluesOnly);
  const double trace_sqrt = em.eigenvalues().cwiseMax(0.0).cwiseSqrt().sum();
  return (mean1 - mean2).squaredNorm() + cov1.trace() + cov2.trace() - 2.0 * trace_sqrt;
}

double frechet_inception_distance(const Eigen::MatrixXd& features1, const Eigen::MatrixXd& features2) {
  if (features1.cols() != features2.cols()) throw Error("FID: feature sets differ in width");
  if (features1.rows() < 2 || features2.rows() < 2) throw Error("FID: each feature set needs at least 2 rows");
  auto stats = [](const Eigen::MatrixXd& f, Eigen::VectorXd* mean, Eigen::MatrixXd* cov) {
    *mean = f.colwise().mean().transpose();
    const Eigen::MatrixXd c = f.rowwise() - mean->transpose();
    *cov = c.transpose() * c / static_cast<double>(f.rows() - 1);
  };
  Eigen::VectorXd m1, m2;
  Eigen::MatrixXd c1, c2;
  stats(features1, &m1, &c1);
  stats(features2, &m2, &c2);
  return frechet_distance(m1, c1, m2, c2);
}

}  // namespace mosyn::eval

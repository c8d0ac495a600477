#include "data/control.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/error.h"
#include "core/trajectory.h"
#include "core/units.h"
#include "data/augment.h"
#include "io/csv.h"

namespace mosyn::data {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A densely sampled ground path: points and cumulative arc length, in metres.
struct DensePath {
  std::vector<Eigen::Vector2d> points;  // (x, z)
  std::vector<double> arc_m;
  std::vector<double> stop_arc_m;       // arc lengths where the walker stops, ascending
  std::vector<double> stop_pause_s;     // pause at each stop

  Eigen::Vector2d at(double s) const {
    if (points.size() == 1 || s <= 0) return points.front();
    if (s >= arc_m.back()) return points.back();
    const size_t i = std::upper_bound(arc_m.begin(), arc_m.end(), s) - arc_m.begin();
    const double seg = arc_m[i] - arc_m[i - 1];
    const double u = seg > 0 ? (s - arc_m[i - 1]) / seg : 0.0;
    return points[i - 1] + u * (points[i] - points[i - 1]);
  }
};

double heading_of_direction(const Eigen::Vector2d& d) { return std::atan2(d.x(), d.y()); }  // 0 = +Z

void append_point(DensePath* path, const Eigen::Vector2d& p) {
  if (!path->points.empty() && (p - path->points.back()).norm() < 1e-9) return;
  path->arc_m.push_back(path->points.empty() ? 0.0 : path->arc_m.back() + (p - path->points.back()).norm());
  path->points.push_back(p);
}

// The polyline with each interior corner replaced by a circular arc tangent to both segments.
DensePath build_path(const std::vector<Waypoint>& waypoints, double corner_radius_m) {
  std::vector<Waypoint> w;
  for (const Waypoint& p : waypoints) {
    if (!w.empty() && std::hypot(p.x_m - w.back().x_m, p.z_m - w.back().z_m) < 1e-6)
      w.back().pause_s += p.pause_s;  // a repeated point only adds its pause
    else
      w.push_back(p);
  }
  DensePath path;
  auto pt = [&](size_t i) { return Eigen::Vector2d(w[i].x_m, w[i].z_m); };
  append_point(&path, pt(0));
  path.stop_arc_m.push_back(0.0);
  path.stop_pause_s.push_back(w[0].pause_s);
  for (size_t i = 1; i < w.size(); ++i) {
    const bool last = i + 1 == w.size();
    const bool stop_here = last || w[i].pause_s > 0;
    if (last || stop_here) {
      // Walkers stop at the exact point; no rounding where the path halts.
      append_point(&path, pt(i));
    } else {
      const Eigen::Vector2d a = pt(i - 1), b = pt(i), c = pt(i + 1);
      const Eigen::Vector2d d1 = (b - a).normalized(), d2 = (c - b).normalized();
      const double turn = std::acos(std::clamp(d1.dot(d2), -1.0, 1.0));
      // Tangent length of an arc of radius r turning by `turn`: r tan(turn / 2), limited so
      // neighbouring arcs never overlap.
      const double max_tangent = 0.5 * std::min((b - a).norm(), (c - b).norm());
      double tangent = corner_radius_m * std::tan(0.5 * turn);
      if (turn < 1e-6 || turn > kPi - 1e-3) tangent = 0;
      tangent = std::min(tangent, max_tangent);
      if (tangent <= 1e-9) {
        append_point(&path, b);
      } else {
        const double radius = tangent / std::tan(0.5 * turn);
        const Eigen::Vector2d start = b - tangent * d1;
        const double side = (d1.x() * d2.y() - d1.y() * d2.x()) > 0 ? 1.0 : -1.0;
        const Eigen::Vector2d normal(-d1.y() * side, d1.x() * side);
        const Eigen::Vector2d centre = start + radius * normal;
        const int steps = std::max(4, static_cast<int>(std::ceil(turn * radius / 0.01)));
        const double a0 = std::atan2(start.y() - centre.y(), start.x() - centre.x());
        for (int k = 0; k <= steps; ++k) {
          const double ang = a0 + side * turn * k / steps;
          append_point(&path, centre + radius * Eigen::Vector2d(std::cos(ang), std::sin(ang)));
        }
      }
    }
    if (stop_here) {
      path.stop_arc_m.push_back(path.arc_m.back());
      path.stop_pause_s.push_back(w[i].pause_s);
    }
  }
  return path;
}

// Distance travelled after t seconds on a leg of length L with a trapezoidal speed profile.
double leg_distance(double t, double length, double speed, double accel_s) {
  const double a = speed / std::max(accel_s, 1e-6);
  double v_peak = speed, t_ramp = accel_s;
  if (speed * accel_s > length) {  // too short to reach full speed: triangular profile
    v_peak = std::sqrt(a * length);
    t_ramp = v_peak / a;
  }
  const double d_ramp = 0.5 * v_peak * t_ramp;
  const double t_cruise = (length - 2 * d_ramp) / v_peak;
  if (t <= 0) return 0;
  if (t < t_ramp) return 0.5 * a * t * t;
  if (t < t_ramp + t_cruise) return d_ramp + v_peak * (t - t_ramp);
  const double td = t - t_ramp - t_cruise;
  if (td < t_ramp) return length - 0.5 * a * (t_ramp - td) * (t_ramp - td);
  return length;
}

double leg_duration(double length, double speed, double accel_s) {
  const double a = speed / std::max(accel_s, 1e-6);
  if (speed * accel_s > length) return 2 * std::sqrt(length / a);
  return length / speed + accel_s;
}

// Per-frame deltas from world ground positions (x, z metres) and headings.
std::vector<float> deltas_from_ground(const std::vector<Eigen::Vector2d>& positions, const std::vector<double>& headings) {
  const size_t n = positions.size();
  std::vector<float> control(3 * n, 0.0f);
  for (size_t t = 1; t < n; ++t) {
    const Eigen::Vector2d d = positions[t] - positions[t - 1];
    const double h = headings[t - 1];
    const Eigen::Vector2d forward(std::sin(h), std::cos(h)), sideways(std::cos(h), -std::sin(h));
    control[3 * t + 0] = static_cast<float>(d.dot(sideways));
    control[3 * t + 1] = static_cast<float>(d.dot(forward));
    control[3 * t + 2] = static_cast<float>(headings[t] - headings[t - 1]);
  }
  return control;
}

}  // namespace

std::vector<Waypoint> parse_path(const std::string& text) {
  std::vector<Waypoint> out;
  std::string normalised = text;
  std::replace(normalised.begin(), normalised.end(), ';', ' ');
  std::istringstream in(normalised);
  std::string token;
  while (in >> token) {
    std::vector<double> v;
    std::string part;
    std::istringstream parts(token);
    while (std::getline(parts, part, ',')) {
      try {
        size_t used = 0;
        const double x = std::stod(part, &used);
        if (used != part.size() || !std::isfinite(x)) throw std::invalid_argument("");
        v.push_back(x);
      } catch (const std::exception&) {
        throw Error("path point '" + token + "': expected numbers 'x,z' or 'x,z,pause_s' (metres, seconds)");
      }
    }
    if (v.size() < 2 || v.size() > 3) throw Error("path point '" + token + "': expected 'x,z' or 'x,z,pause_s'");
    if (v.size() == 3 && v[2] < 0) throw Error("path point '" + token + "': the pause must not be negative");
    out.push_back({v[0], v[1], v.size() == 3 ? v[2] : 0.0});
  }
  if (out.empty()) throw Error("path '" + text + "' has no points; expected 'x,z x,z ...' in metres");
  if (out.size() > 100000) throw Error("path has more than 100000 points");
  return out;
}

std::vector<float> control_from_path(const std::vector<Waypoint>& waypoints, const PathOptions& o,
                                     double* start_heading_rad) {
  if (waypoints.empty()) throw Error("path has no points");
  if (!(o.speed_mps > 0) || !(o.fps > 0) || o.seconds < 0 || o.seconds > 3600)
    throw Error("path: speed and fps must be positive and seconds in [0, 3600]");
  const DensePath path = build_path(waypoints, o.corner_radius_m);
  const double dt = 1.0 / o.fps;

  // Time line: pause at stop 0, leg 0, pause at stop 1, leg 1, ...
  std::vector<Eigen::Vector2d> positions;
  std::vector<double> headings;
  double heading = path.points.size() > 1 ? heading_of_direction(path.points[1] - path.points[0]) : 0.0;
  const double start_heading = heading;
  double total_s = 0;
  for (size_t k = 0; k < path.stop_arc_m.size(); ++k) {
    total_s += path.stop_pause_s[k];
    if (k + 1 < path.stop_arc_m.size())
      total_s += leg_duration(path.stop_arc_m[k + 1] - path.stop_arc_m[k], o.speed_mps, o.accel_s);
  }
  double duration = o.seconds > 0 ? o.seconds : total_s + 1.0;
  if (path.points.size() == 1 && o.seconds <= 0) duration = std::max(o.standing_s, total_s);
  // A path given without a duration lasts as long as walking it takes: bound it like an explicit
  // one (a path of 1000 km asked for 23 million frames; found by fuzz/fuzz_csv).
  if (!(duration <= 3600))
    throw Error("path: walking it takes " + std::to_string(total_s) +
                " s (pauses included), more than the 3600 s a control may last; shorten it or give the seconds");
  const int num_frames = static_cast<int>(std::floor(duration * o.fps + 1e-9)) + 1;

  for (int f = 0; f < num_frames; ++f) {
    double t = f * dt, s = path.stop_arc_m.back();
    for (size_t k = 0; k < path.stop_arc_m.size(); ++k) {
      if (t < path.stop_pause_s[k]) {
        s = path.stop_arc_m[k];
        break;
      }
      t -= path.stop_pause_s[k];
      if (k + 1 == path.stop_arc_m.size()) break;
      const double length = path.stop_arc_m[k + 1] - path.stop_arc_m[k];
      const double leg_s = leg_duration(length, o.speed_mps, o.accel_s);
      if (t < leg_s) {
        s = path.stop_arc_m[k] + leg_distance(t, length, o.speed_mps, o.accel_s);
        break;
      }
      t -= leg_s;
    }
    const Eigen::Vector2d p = path.at(s);
    // Face along the path a few centimetres ahead; keep the last heading while standing.
    const double look = 0.05;
    const Eigen::Vector2d ahead = s + look <= path.arc_m.back() ? path.at(s + look) - p : p - path.at(s - look);
    if (path.points.size() > 1 && ahead.norm() > 1e-6) {
      double h = heading_of_direction(ahead);
      while (h - heading > kPi) h -= 2 * kPi;
      while (h - heading < -kPi) h += 2 * kPi;
      heading = h;
    }
    positions.push_back(p);
    headings.push_back(heading);
  }
  if (start_heading_rad) *start_heading_rad = start_heading;
  // The walker is placed at the first waypoint; heading of frame 0 is start_heading.
  return deltas_from_ground(positions, headings);
}

std::vector<float> control_from_clip(const Clip& clip_in, double fps, double* start_heading_rad) {
  if (!(fps > 0)) throw Error("control: fps must be positive");
  Clip clip = collapse_static_root(clip_in);
  clip.motion = remove_tpose(clip.motion, TposeMode::kAuto);
  if (clip.motion.num_frames < 2) throw Error("control: the clip needs at least 2 frames");
  clip.motion = resample(clip.motion, fps);
  const double mpu = resolve_meters_per_unit(clip.skeleton);
  const Eigen::Vector3d forward = estimate_forward_in_root(clip.skeleton);
  const GroundTrajectory ground = ground_trajectory(clip.skeleton, clip.motion, 0, forward);
  const std::vector<RootDelta> deltas = root_deltas(clip.skeleton, ground);
  std::vector<float> control(3 * deltas.size());
  for (size_t t = 0; t < deltas.size(); ++t) {
    control[3 * t + 0] = static_cast<float>(deltas[t].sideways * mpu);
    control[3 * t + 1] = static_cast<float>(deltas[t].forward * mpu);
    control[3 * t + 2] = static_cast<float>(deltas[t].turn_rad);
  }
  if (start_heading_rad) *start_heading_rad = ground.headings_rad.empty() ? 0.0 : ground.headings_rad[0];
  return control;
}

std::vector<float> control_from_csv(const std::string& path, double fps, double csv_fps) {
  if (!(fps > 0) || csv_fps < 0) throw Error(path + ": the control's frame rates must be positive");
  std::vector<double> times_s;
  const std::vector<Eigen::Vector3d> rows = io::read_control_csv(path, &times_s);
  if (rows.size() < 2) throw Error(path + ": a control needs at least 2 frames");
  if (!times_s.empty() && csv_fps > 0)
    throw Error(path + ": the file gives its frame times (t_s column); a frame rate for it applies only to files without");
  std::vector<float> control;
  control.reserve(rows.size() * 3);
  for (const auto& r : rows)
    for (int k = 0; k < 3; ++k) control.push_back(static_cast<float>(r[k]));
  if (times_s.empty() && csv_fps > 0)
    for (size_t t = 0; t < rows.size(); ++t) times_s.push_back(static_cast<double>(t) / csv_fps);
  return times_s.empty() ? control : resample_control(control, times_s, fps);
}

std::vector<float> resample_control(const std::vector<float>& control, const std::vector<double>& times_s, double fps) {
  const size_t n = times_s.size();
  if (control.size() != 3 * n) throw Error("resample_control: one time per control frame [T, 3] needed");
  if (n < 2) throw Error("resample_control: at least 2 frames needed");
  if (!(fps > 0)) throw Error("resample_control: fps must be positive");
  for (size_t t = 1; t < n; ++t)
    if (!(times_s[t] > times_s[t - 1])) throw Error("resample_control: the times must increase");
  std::vector<double> headings;
  const std::vector<Eigen::Vector3d> points = integrate_control(control, 0.0, &headings);
  const size_t frames = static_cast<size_t>(std::floor((times_s.back() - times_s.front()) * fps + 1e-6)) + 1;
  std::vector<Eigen::Vector2d> positions(frames);
  std::vector<double> new_headings(frames);
  size_t i = 0;  // times_s[i] <= time < times_s[i + 1]
  for (size_t k = 0; k < frames; ++k) {
    const double time = std::min(times_s.front() + static_cast<double>(k) / fps, times_s.back());
    while (i + 2 < n && times_s[i + 1] <= time) ++i;
    const double w = std::clamp((time - times_s[i]) / (times_s[i + 1] - times_s[i]), 0.0, 1.0);
    const Eigen::Vector3d p = (1 - w) * points[i] + w * points[i + 1];
    positions[k] = {p.x(), p.z()};
    new_headings[k] = (1 - w) * headings[i] + w * headings[i + 1];
  }
  return deltas_from_ground(positions, new_headings);
}

std::vector<float> smooth_control(const std::vector<float>& control, double fps, double sigma_s) {
  if (control.size() % 3 != 0) throw Error("smooth_control: the control must hold [T, 3] values");
  if (!(sigma_s > 0)) return control;
  if (!(fps > 0)) throw Error("smooth_control: fps must be positive");
  const Skeleton y_up;  // metres, Y up: the control's own conventions
  const size_t n = control.size() / 3;
  std::vector<RootDelta> deltas(n);
  for (size_t t = 1; t < n; ++t) deltas[t] = {control[3 * t], control[3 * t + 1], control[3 * t + 2]};
  const GroundTrajectory raw = integrate_root_deltas(y_up, deltas, Eigen::Vector3d::Zero(), 0.0);
  const std::vector<RootDelta> smoothed = root_deltas(y_up, smooth_ground_trajectory(raw, sigma_s * fps));
  std::vector<float> out(control.size(), 0.0f);
  for (size_t t = 1; t < n; ++t) {
    out[3 * t + 0] = static_cast<float>(smoothed[t].sideways);
    out[3 * t + 1] = static_cast<float>(smoothed[t].forward);
    out[3 * t + 2] = static_cast<float>(smoothed[t].turn_rad);
  }
  return out;
}

std::vector<Eigen::Vector3d> integrate_control(const std::vector<float>& control, double start_heading_rad,
                                               std::vector<double>* headings_rad) {
  std::vector<Eigen::Vector3d> out;
  if (headings_rad) headings_rad->clear();
  Eigen::Vector2d p(0, 0);
  double h = start_heading_rad;
  for (size_t t = 0; t < control.size() / 3; ++t) {
    if (t > 0) {
      const Eigen::Vector2d forward(std::sin(h), std::cos(h)), sideways(std::cos(h), -std::sin(h));
      p += control[3 * t] * sideways + control[3 * t + 1] * forward;
      h += control[3 * t + 2];
    }
    out.emplace_back(p.x(), 0.0, p.y());
    if (headings_rad) headings_rad->push_back(h);
  }
  return out;
}

}  // namespace mosyn::data

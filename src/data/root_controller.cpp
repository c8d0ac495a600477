#include "data/root_controller.h"

#include <cmath>

namespace mosyn::data {
namespace {

constexpr double kPi = 3.14159265358979323846;

// a - b wrapped into [-pi, pi): the shorter way round.
double angle_difference(double a, double b) {
  const double d = std::fmod(a - b + kPi, 2.0 * kPi);
  return (d < 0 ? d + 2.0 * kPi : d) - kPi;
}

}  // namespace

// Exact discretisation of x'' = w^2 (u - x) - 2 w x' over one frame with u held: for x0 = x - u,
// v0 = x', x(t) = (x0 + (v0 + w x0) t) e^{-w t}.
void RootController::Spring::step(double target, double omega_per_frame) {
  if (omega_per_frame <= 0) {
    value = target;
    rate = 0;
    return;
  }
  const double w = omega_per_frame, e = std::exp(-w);
  const double x0 = value - target, v0 = rate;
  value = target + (x0 + (v0 + w * x0)) * e;
  rate = (v0 - w * (v0 + w * x0)) * e;
}

RootController::RootController(const RootControllerOptions& options) : options_(options) {
  if (options_.smoothing_s > 0 && options_.fps > 0) omega_ = 1.31 / (options_.smoothing_s * options_.fps);
}

void RootController::reset() { *this = RootController(options_); }

RootController::Control RootController::step(const Control& delta) {
  if (mode_ != Mode::kDelta) to_delta_mode();
  for (int i = 0; i < 3; ++i) {
    delta_[i].step(delta[i], omega_);
    last_output_[i] = delta_[i].value;
  }
  last_delta_ = delta;
  heading_rad_ += last_output_[2];
  return last_output_;
}

RootController::Control RootController::step(const StickInput& stick) {
  if (mode_ != Mode::kStick) to_stick_mode();
  const double fps = options_.fps > 0 ? options_.fps : 1.0;
  const double before_x = velocity_[0].value, before_z = velocity_[1].value, theta = heading_rad_;
  velocity_[0].step(stick.velocity_x_mps / fps, omega_);
  velocity_[1].step(stick.velocity_z_mps / fps, omega_);
  heading_.step(heading_.value + angle_difference(stick.facing_rad, heading_.value), omega_);
  // The frame's ground step: the mean of the velocities at its ends, in the previous heading's frame
  // (core/trajectory.h root_deltas).
  const double dx = 0.5 * (before_x + velocity_[0].value), dz = 0.5 * (before_z + velocity_[1].value);
  const double c = std::cos(theta), s = std::sin(theta);
  last_output_ = {c * dx - s * dz, s * dx + c * dz, heading_.value - theta};
  last_stick_ = stick;
  heading_rad_ = heading_.value;
  return last_output_;
}

void RootController::predict(int frames, float* out) const {
  RootController ahead = *this;
  for (int k = 0; k < frames; ++k) {
    const Control c = mode_ == Mode::kStick ? ahead.step(last_stick_) : ahead.step(last_delta_);
    for (int i = 0; i < 3; ++i) out[k * 3 + i] = static_cast<float>(c[i]);
  }
}

// The filtered delta takes over the stick's last step (its rate of change starts at 0).
void RootController::to_delta_mode() {
  for (int i = 0; i < 3; ++i) delta_[i] = Spring{last_output_[i], 0.0};
  last_delta_ = last_output_;
  mode_ = Mode::kDelta;
}

// The world velocity and heading take over the filtered delta's (rates rotated alike).
void RootController::to_stick_mode() {
  const double c = std::cos(heading_rad_), s = std::sin(heading_rad_);
  const auto& side = delta_[0];
  const auto& forward = delta_[1];
  velocity_[0] = Spring{s * forward.value + c * side.value, s * forward.rate + c * side.rate};
  velocity_[1] = Spring{c * forward.value - s * side.value, c * forward.rate - s * side.rate};
  heading_ = Spring{heading_rad_, delta_[2].value};
  const double fps = options_.fps > 0 ? options_.fps : 1.0;
  last_stick_ = StickInput{velocity_[0].value * fps, velocity_[1].value * fps, heading_rad_};
  mode_ = Mode::kStick;
}

}  // namespace mosyn::data

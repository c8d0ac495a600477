// The simulated root of a real-time character: what a game's input at frame t (a stick's desired
// velocity and facing, or a per-frame root delta) makes of the character's root, and where that
// root goes over the next frames if the input stays as it is. A model that reads the path ahead
// (MoGlow with look-ahead) then runs with no algorithmic latency: it reads this prediction, made
// from the input up to t only, instead of the path's real future (as motion matching, Learned
// Motion Matching and CAMDM do).
//
// Both inputs go through critically damped second-order filters (springs) whose 10-90% rise time
// equals that of the Gaussian the training data's root trajectories were smoothed with (2.56
// sigma: natural angular frequency 1.31 / sigma), so the root starts, stops and turns as the
// data's roots do:
//   - a per-frame delta (dx, dz metres in the character's ground frame, dtheta radians; the layout
//     of data/control.h) is filtered channel by channel;
//   - a stick (desired ground velocity in the world, m/s, and desired facing, radians) filters the
//     world velocity towards the desired one and the heading towards the facing.
// No LibTorch, no allocation per step.
#pragma once

#include <array>

namespace mosyn::data {

// A game's input for one frame: the ground velocity the character should reach (world metres per
// second; x sideways, z forward of heading 0, Y up) and the heading it should face (radians; 0 =
// +z, positive turns left towards +x; any multiple of 2 pi, the shorter way round is taken).
struct StickInput {
  double velocity_x_mps = 0;
  double velocity_z_mps = 0;
  double facing_rad = 0;
};

struct RootControllerOptions {
  double fps = 30.0;         // frames per second of the control
  // Gaussian sigma (seconds) of the training data's root smoothing (FeatureLayout::root_smoothing_s)
  // the filters match; 0 = no filtering: a delta passes as given, a stick's velocity and facing are
  // reached at once.
  double smoothing_s = 0.0;
};

// One character's simulated root. Copyable (a prediction runs on a copy).
class RootController {
 public:
  using Control = std::array<double, 3>;  // dx, dz metres, dtheta radians (frame t-1 -> t)

  explicit RootController(const RootControllerOptions& options = {});

  // Back to standing at the origin, facing heading 0.
  void reset();

  // One frame from a per-frame delta: returns the filtered delta the root takes this frame.
  Control step(const Control& delta);
  // One frame from a stick: returns the delta the root takes this frame.
  Control step(const StickInput& stick);

  // The deltas of the next `frames` frames if the last input (delta or stick) stays as it is:
  // out [frames, 3] row-major (float, the model's input type). Before any step: standing still.
  void predict(int frames, float* out) const;

  // Root heading after the frames so far (radians, unwrapped; 0 = +z).
  double heading_rad() const { return heading_rad_; }

 private:
  enum class Mode { kDelta, kStick };
  // State of a critically damped filter: value and its change per frame.
  struct Spring {
    double value = 0, rate = 0;
    void step(double target, double omega_per_frame);
  };
  void to_delta_mode();
  void to_stick_mode();

  RootControllerOptions options_;
  double omega_ = 0;  // natural angular frequency per frame; 0 = no filtering
  Mode mode_ = Mode::kDelta;
  // Delta mode: the filtered delta, channel by channel, and the last input.
  std::array<Spring, 3> delta_;
  Control last_delta_{};
  // Stick mode: world velocity (x, z) in metres per frame and the heading; the last input.
  std::array<Spring, 2> velocity_;
  Spring heading_;
  StickInput last_stick_;
  double heading_rad_ = 0;  // the root's heading (both modes)
  Control last_output_{};   // the delta of the last step
};

}  // namespace mosyn::data

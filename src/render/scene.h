// Stick-figure rendering of motions: skeletons, joints, ground grid and ground paths, seen from a
// chosen camera, into RGB images (canvas.h). No window, no GPU, no torch.
//
// Conventions: positions are world joint positions in metres, row-major [T, J]. Internally every
// motion is turned to +Y up (a rotation for Z-up or X-up skeletons), so the camera presets mean the
// same for all: the floor is XZ, "front" looks from +Z towards -Z, "side" from +X towards -X,
// "top" from above (+Z downwards on screen), "iso" from azimuth 45 degrees, elevation 30 degrees.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/skeleton.h"
#include "render/canvas.h"

namespace mosyn::render {

// One motion to draw.
struct RenderMotion {
  std::string name;
  double fps = 30.0;
  int num_frames = 0;
  int num_joints = 0;
  std::vector<std::string> joint_names;    // [J]
  std::vector<int> parents;                // [J], -1 for the root
  std::vector<Eigen::Vector3d> positions_m;  // [T, J], +Y up (see to_y_up)
  Rgb color{204, 0, 51};

  const Eigen::Vector3d& position(int t, int j) const { return positions_m[static_cast<size_t>(t) * num_joints + j]; }
};

// A point of a skeleton with up axis up_axis (0, 1, 2) expressed with +Y up, by a proper rotation:
// Y-up unchanged; Z-up (x, y, z) -> (x, z, -y); X-up (x, y, z) -> (-y, x, z).
Eigen::Vector3d to_y_up(const Eigen::Vector3d& p, int up_axis);

// A clip's world joint positions in metres (meters_per_unit > 0 as given, else the skeleton's when
// it is not 1, else guessed by core/units.h), turned to +Y up, with the given colour.
RenderMotion render_motion_from_clip(const Clip& clip, Rgb color, double meters_per_unit = 0.0,
                                     const std::string& name = "");

enum class CameraPreset { kSide, kFront, kTop, kIso };
// "side", "front", "top", "iso"; throws mosyn::Error otherwise.
CameraPreset parse_camera_preset(const std::string& text);

struct RenderOptions {
  int width = 640;               // pixels of the whole image
  int height = 480;
  CameraPreset camera = CameraPreset::kIso;
  bool perspective = false;      // orthographic when false
  bool overlay = false;          // all motions in one panel instead of side by side
  bool follow = false;           // camera follows the figures (body-sized view) instead of fitting
                                 // the whole motion
  bool grid = true;              // ground grid (grid_spacing_m squares) under each panel
  double grid_spacing_m = 0.5;
  bool paths = true;             // the root's ground path over the whole motion
  double bone_width_px = 0;      // 0: scaled with the image (about height / 120)
  Rgb background{255, 255, 255};
};

// Renders every motion at time time_s (frame round(time_s * fps), held at the last frame once a
// motion has ended). Side by side: the width is split into equal panels, one per motion, each
// centred on its own motion with one common scale; overlay: one panel centred on all. The view
// fits every frame of the motions, so the scale does not change during an animation; with follow
// it is centred on the figures' current root (mean over the panel's motions) and shows 1.6 times the
// tallest body height, which is also constant. Throws
// mosyn::Error for an empty list or a motion without frames.
Image render_frame(const std::vector<RenderMotion>& motions, double time_s, const RenderOptions& options);

// Seconds of the longest motion: max over motions of (num_frames - 1) / fps.
double longest_duration_s(const std::vector<RenderMotion>& motions);

// Screen position (pixels) of world point p (+Y up) in a panel of size width x height whose view
// is centred on `center` and shows a sphere of radius_m (metres) fully: the projection used by
// render_frame. Returns (x, y, depth); larger depth is nearer the camera.
Eigen::Vector3d project(const Eigen::Vector3d& p, CameraPreset camera, bool perspective, const Eigen::Vector3d& center,
                        double radius_m, int width, int height);

}  // namespace mosyn::render

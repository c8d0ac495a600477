#include "render/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/units.h"
#include "data/augment.h"

namespace mosyn::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct CameraBasis {
  Eigen::Vector3d right, up, back;  // back points from the scene towards the camera
};

CameraBasis basis(CameraPreset preset) {
  double azimuth = 0, elevation = 0;
  switch (preset) {
    case CameraPreset::kFront: break;
    case CameraPreset::kSide: azimuth = kPi / 2; break;
    case CameraPreset::kTop: elevation = kPi / 2; break;
    case CameraPreset::kIso: azimuth = kPi / 4; elevation = kPi / 6; break;
  }
  CameraBasis b;
  b.back = {std::cos(elevation) * std::sin(azimuth), std::sin(elevation), std::cos(elevation) * std::cos(azimuth)};
  b.right = {std::cos(azimuth), 0, -std::sin(azimuth)};
  b.up = b.back.cross(b.right);
  return b;
}

// The joint whose ground path is drawn: the root, or its only child when the root never moves
// (a static placeholder root such as Bandai-Namco's joint_Root).
int path_joint(const RenderMotion& m) {
  if (m.num_joints < 2) return 0;
  for (int t = 1; t < m.num_frames; ++t)
    if ((m.position(t, 0) - m.position(0, 0)).norm() > 1e-6) return 0;
  return 1;
}

struct Box {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  void add(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void add(const Box& b) {
    add(b.lo);
    add(b.hi);
  }
};

Box bounds(const RenderMotion& m) {
  Box b;
  for (const auto& p : m.positions_m) b.add(p);
  // Include the floor, so the grid is inside the view.
  Eigen::Vector3d lo = b.lo;
  lo.y() = std::min(0.0, b.lo.y());
  b.add(lo);
  return b;
}

Rgb lighter(Rgb c, double amount) {
  auto mix = [amount](std::uint8_t v) { return static_cast<std::uint8_t>(std::lround(v + (255 - v) * amount)); };
  return {mix(c.r), mix(c.g), mix(c.b)};
}

void draw_panel(Image* image, int x0, int width, int height, const std::vector<const RenderMotion*>& motions,
                const Box& box, double radius_m, double time_s, const RenderOptions& o) {
  Eigen::Vector3d center = 0.5 * (box.lo + box.hi);
  const double floor_y = std::min(0.0, box.lo.y());
  if (o.follow) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const RenderMotion* m : motions) {
      const int t = std::clamp(static_cast<int>(std::lround(time_s * m->fps)), 0, m->num_frames - 1);
      sum += m->position(t, path_joint(*m));
    }
    center = sum / static_cast<double>(motions.size());
    center.y() = floor_y + 0.5 * radius_m / 0.8;  // radius_m is 0.8 x the tallest body here
  }
  auto proj = [&](const Eigen::Vector3d& p) {
    Eigen::Vector3d s = project(p, o.camera, o.perspective, center, radius_m, width, height);
    s.x() += x0;
    return s;
  };
  const double bone_px = o.bone_width_px > 0 ? o.bone_width_px : std::max(1.5, height / 120.0);

  if (o.grid && o.grid_spacing_m > 0) {
    const double g = o.grid_spacing_m;
    const double xa = std::floor(box.lo.x() / g - 1) * g, xb = std::ceil(box.hi.x() / g + 1) * g;
    const double za = std::floor(box.lo.z() / g - 1) * g, zb = std::ceil(box.hi.z() / g + 1) * g;
    const Rgb grid_color{210, 210, 210};
    if ((xb - xa) / g < 400 && (zb - za) / g < 400) {
      for (double x = xa; x <= xb + 1e-9; x += g) {
        const auto a = proj({x, floor_y, za}), b = proj({x, floor_y, zb});
        image->draw_line(a.x(), a.y(), b.x(), b.y(), 1.0, grid_color);
      }
      for (double z = za; z <= zb + 1e-9; z += g) {
        const auto a = proj({xa, floor_y, z}), b = proj({xb, floor_y, z});
        image->draw_line(a.x(), a.y(), b.x(), b.y(), 1.0, grid_color);
      }
    }
  }
  if (o.paths) {
    for (const RenderMotion* m : motions) {
      const int j = path_joint(*m);
      const Rgb c = lighter(m->color, 0.45);
      for (int t = 1; t < m->num_frames; ++t) {
        Eigen::Vector3d a = m->position(t - 1, j), b = m->position(t, j);
        a.y() = b.y() = floor_y;
        const auto pa = proj(a), pb = proj(b);
        image->draw_line(pa.x(), pa.y(), pb.x(), pb.y(), std::max(1.0, bone_px * 0.6), c);
      }
    }
  }
  // Bones and joints of all motions, far to near (painter's algorithm).
  struct Primitive {
    double depth;
    Eigen::Vector3d a, b;
    double width;
    Rgb color;
  };
  std::vector<Primitive> prims;
  for (const RenderMotion* m : motions) {
    const int t = std::clamp(static_cast<int>(std::lround(time_s * m->fps)), 0, m->num_frames - 1);
    for (int j = 0; j < m->num_joints; ++j) {
      const auto pj = proj(m->position(t, j));
      const int p = m->parents[j];
      if (p >= 0) {
        const auto pp = proj(m->position(t, p));
        prims.push_back({0.5 * (pj.z() + pp.z()), pp, pj, bone_px, m->color});
      }
      prims.push_back({pj.z() + 1e-6, pj, pj, bone_px * 1.8, lighter(m->color, 0.0)});
    }
  }
  std::stable_sort(prims.begin(), prims.end(), [](const Primitive& a, const Primitive& b) { return a.depth < b.depth; });
  for (const auto& q : prims) image->draw_line(q.a.x(), q.a.y(), q.b.x(), q.b.y(), q.width, q.color);
}

}  // namespace

Eigen::Vector3d to_y_up(const Eigen::Vector3d& p, int up_axis) {
  switch (up_axis) {
    case 1: return p;
    case 2: return {p.x(), p.z(), -p.y()};
    case 0: return {-p.y(), p.x(), p.z()};
    default: throw Error("up axis must be 0, 1 or 2");
  }
}

RenderMotion render_motion_from_clip(const Clip& input, Rgb color, double meters_per_unit, const std::string& name) {
  const Clip clip = data::collapse_static_root(input);  // the path then follows the pelvis
  const Skeleton& s = clip.skeleton;
  const double mpu = resolve_meters_per_unit(s, meters_per_unit);
  RenderMotion m;
  m.name = name;
  m.fps = clip.motion.fps;
  m.num_frames = clip.motion.num_frames;
  m.num_joints = s.num_joints();
  m.joint_names = s.joint_names;
  m.parents = s.parents;
  m.color = color;
  const WorldPoses poses = forward_kinematics(s, clip.motion);
  m.positions_m.reserve(poses.positions.size());
  for (const auto& p : poses.positions) m.positions_m.push_back(to_y_up(p * mpu, s.up_axis));
  return m;
}

CameraPreset parse_camera_preset(const std::string& text) {
  if (text == "side") return CameraPreset::kSide;
  if (text == "front") return CameraPreset::kFront;
  if (text == "top") return CameraPreset::kTop;
  if (text == "iso") return CameraPreset::kIso;
  throw Error("camera '" + text + "' is not one of side, front, top, iso");
}

Eigen::Vector3d project(const Eigen::Vector3d& p, CameraPreset camera, bool perspective, const Eigen::Vector3d& center,
                        double radius_m, int width, int height) {
  const CameraBasis b = basis(camera);
  const Eigen::Vector3d q = p - center;
  const double r = std::max(radius_m, 1e-6);
  double scale = 0.45 * std::min(width, height) / r;
  const double depth = q.dot(b.back);
  if (perspective) {
    // Camera 3 radii away; the nearest point of the fitted sphere keeps the orthographic scale.
    const double distance = 3 * r;
    scale *= (distance - r) / std::max(distance - depth, 1e-6);
  }
  return {0.5 * width + q.dot(b.right) * scale, 0.5 * height - q.dot(b.up) * scale, depth};
}

double longest_duration_s(const std::vector<RenderMotion>& motions) {
  double d = 0;
  for (const auto& m : motions) d = std::max(d, m.num_frames > 0 ? (m.num_frames - 1) / m.fps : 0.0);
  return d;
}

Image render_frame(const std::vector<RenderMotion>& motions, double time_s, const RenderOptions& o) {
  if (motions.empty()) throw Error("nothing to render");
  for (const auto& m : motions) {
    if (m.num_frames < 1) throw Error("motion '" + m.name + "' has no frames");
    if (m.positions_m.size() != static_cast<size_t>(m.num_frames) * m.num_joints ||
        m.parents.size() != static_cast<size_t>(m.num_joints) || !(m.fps > 0))
      throw Error("motion '" + m.name + "' is inconsistent");
  }
  Image image(o.width, o.height, o.background);
  double body_radius = 0;  // 0.8 x the tallest body, the view radius when following
  for (const auto& m : motions) {
    const Box b = bounds(m);
    body_radius = std::max(body_radius, 0.8 * (b.hi.y() - b.lo.y()));
  }
  body_radius = std::max(body_radius, 0.1);
  if (o.overlay) {
    Box box;
    std::vector<const RenderMotion*> all;
    for (const auto& m : motions) {
      box.add(bounds(m));
      all.push_back(&m);
    }
    draw_panel(&image, 0, o.width, o.height, all, box, o.follow ? body_radius : 0.5 * (box.hi - box.lo).norm(), time_s,
               o);
    return image;
  }
  const int n = static_cast<int>(motions.size());
  double radius = 0;
  std::vector<Box> boxes;
  for (const auto& m : motions) {
    boxes.push_back(bounds(m));
    radius = std::max(radius, 0.5 * (boxes.back().hi - boxes.back().lo).norm());
  }
  for (int i = 0; i < n; ++i) {
    const int x0 = o.width * i / n, x1 = o.width * (i + 1) / n;
    // Each panel on its own canvas, so nothing spills into a neighbour.
    Image panel(x1 - x0, o.height, o.background);
    draw_panel(&panel, 0, x1 - x0, o.height, {&motions[i]}, boxes[i], o.follow ? body_radius : radius, time_s, o);
    image.paste(panel, x0, 0);
  }
  return image;
}

}  // namespace mosyn::render

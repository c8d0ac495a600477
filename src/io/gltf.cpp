#include "io/gltf.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>

#include "core/error.h"
#include "core/units.h"
#include "io/atomic_file.h"
#include "io/file_name.h"

namespace mosyn::io {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

// The proper rotation that takes the skeleton's up axis to +Y (render/scene.h to_y_up).
Quaterniond up_rotation(int up_axis) {
  switch (up_axis) {
    case 1:
      return Quaterniond::Identity();
    case 2:  // (x, y, z) -> (x, z, -y)
      return Quaterniond(Eigen::AngleAxisd(-M_PI / 2, Vector3d::UnitX()));
    case 0:  // (x, y, z) -> (-y, x, z)
      return Quaterniond(Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitZ()));
    default:
      throw Error("skeleton up_axis must be 0, 1 or 2, not " + std::to_string(up_axis));
  }
}

int accessor_type(int components) {
  switch (components) {
    case 1: return TINYGLTF_TYPE_SCALAR;
    case 2: return TINYGLTF_TYPE_VEC2;
    case 3: return TINYGLTF_TYPE_VEC3;
    case 4: return TINYGLTF_TYPE_VEC4;
    case 16: return TINYGLTF_TYPE_MAT4;
    default: throw Error("no glTF accessor type has " + std::to_string(components) + " components");
  }
}

// Appends typed arrays to the model's single buffer, one buffer view and accessor each, with exact
// per-component min/max.
class BufferBuilder {
 public:
  explicit BufferBuilder(tinygltf::Model& model) : model_(model) { model_.buffers.emplace_back(); }

  // values: [count, components] row-major.
  template <typename T>
  int add(const std::vector<T>& values, int components, int component_type, int target = 0) {
    const size_t count = values.size() / components;
    if (count == 0 || count * components != values.size()) throw Error("glTF accessor with no or partial elements");
    tinygltf::Accessor a;
    a.bufferView = add_view(values.data(), values.size() * sizeof(T), target);
    a.byteOffset = 0;
    a.componentType = component_type;
    a.count = count;
    a.type = accessor_type(components);
    a.minValues.assign(components, std::numeric_limits<double>::infinity());
    a.maxValues.assign(components, -std::numeric_limits<double>::infinity());
    for (size_t i = 0; i < values.size(); ++i) {
      const int c = static_cast<int>(i % components);
      a.minValues[c] = std::min(a.minValues[c], static_cast<double>(values[i]));
      a.maxValues[c] = std::max(a.maxValues[c], static_cast<double>(values[i]));
    }
    model_.accessors.push_back(std::move(a));
    return static_cast<int>(model_.accessors.size()) - 1;
  }

  int add_floats(const std::vector<float>& values, int components, int target = 0) {
    return add(values, components, TINYGLTF_COMPONENT_TYPE_FLOAT, target);
  }

 private:
  int add_view(const void* data, size_t bytes, int target) {
    std::vector<unsigned char>& buffer = model_.buffers[0].data;
    while (buffer.size() % 4 != 0) buffer.push_back(0);  // every component type aligned
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buffer.size();
    view.byteLength = bytes;
    view.target = target;
    buffer.resize(buffer.size() + bytes);
    std::memcpy(buffer.data() + view.byteOffset, data, bytes);
    model_.bufferViews.push_back(view);
    return static_cast<int>(model_.bufferViews.size()) - 1;
  }

  tinygltf::Model& model_;
};

void push(std::vector<float>& out, const Vector3d& v) {
  for (int c = 0; c < 3; ++c) out.push_back(static_cast<float>(v[c]));
}

// glTF stores quaternions as (x, y, z, w).
void push(std::vector<float>& out, const Quaterniond& q) {
  for (double v : {q.x(), q.y(), q.z(), q.w()}) out.push_back(static_cast<float>(v));
}

// The written local transform of joint j at frame t: metres, the up rotation folded into the root.
struct LocalTransform {
  Vector3d translation_m;
  Quaterniond rotation;
};

LocalTransform local_transform(const Motion& motion, int t, int j, double mpu, const Quaterniond& up) {
  LocalTransform l{motion.translation(t, j) * mpu, motion.rotation(t, j).normalized()};
  if (j == 0) {
    l.translation_m = up * l.translation_m;
    l.rotation = (up * l.rotation).normalized();
  }
  return l;
}

struct Geometry {
  std::vector<float> positions, normals, weights;  // [V, 3], [V, 3], [V, 4]
  std::vector<std::uint16_t> joints;               // [V, 4]
  std::vector<std::uint32_t> indices;              // [3 * triangles]
};

// A capsule of radius r around segment a -> b (world, bind pose), every vertex bound to `joint`.
// Rings of `segments` vertices: `rings` + 1 latitudes of the cap at a (south pole first), then
// `rings` + 1 of the cap at b; triangles wound counter-clockwise seen from outside.
void add_capsule(Geometry& g, const Vector3d& a, const Vector3d& b, double r, int joint, int segments, int rings) {
  const Vector3d d = (b - a).normalized();
  const Vector3d u = d.unitOrthogonal(), w = d.cross(u);  // u x w = d
  const auto first = static_cast<std::uint32_t>(g.positions.size() / 3);
  const int num_rings = 2 * (rings + 1);
  for (int i = 0; i < num_rings; ++i) {
    const bool top = i > rings;
    const double phi = top ? (i - rings - 1) * (M_PI / 2) / rings : -M_PI / 2 + i * (M_PI / 2) / rings;
    const Vector3d& centre = top ? b : a;
    for (int s = 0; s < segments; ++s) {
      const double theta = 2 * M_PI * s / segments;
      const Vector3d n = std::cos(phi) * (std::cos(theta) * u + std::sin(theta) * w) + std::sin(phi) * d;
      push(g.positions, centre + r * n);
      push(g.normals, n);
      g.joints.insert(g.joints.end(), {static_cast<std::uint16_t>(joint), 0, 0, 0});
      g.weights.insert(g.weights.end(), {1.0f, 0.0f, 0.0f, 0.0f});
    }
  }
  for (int i = 0; i + 1 < num_rings; ++i)
    for (int s = 0; s < segments; ++s) {
      const std::uint32_t p = first + i * segments + s, q = first + i * segments + (s + 1) % segments;
      const std::uint32_t p_up = p + segments, q_up = q + segments;
      if (i > 0) g.indices.insert(g.indices.end(), {p, q, p_up});  // ring 0 is the pole: degenerate
      if (i + 2 < num_rings) g.indices.insert(g.indices.end(), {q, q_up, p_up});
    }
}

// Bind (rest) pose: identity local rotations, the root at the origin turned by `up`; every joint's
// bind frame has rotation `up`. Returns the joints' bind positions, metres.
std::vector<Vector3d> bind_positions(const Skeleton& s, double mpu, const Quaterniond& up) {
  std::vector<Vector3d> p(s.num_joints(), Vector3d::Zero());
  for (int j = 1; j < s.num_joints(); ++j) p[j] = p[s.parents[j]] + up * (s.offsets[j] * mpu);
  return p;
}

// The body mesh (a capsule per bone, joint or End Site child) and the skin with its inverse bind
// matrices. Joint j is node j.
void add_body(tinygltf::Model& model, BufferBuilder& buffers, const Skeleton& s, double mpu, const Quaterniond& up,
              const GltfOptions& o) {
  const std::vector<Vector3d> bind = bind_positions(s, mpu, up);
  Geometry g;
  auto bone = [&](int parent, const Vector3d& offset) {
    const Vector3d a = bind[parent], b = a + up * (offset * mpu);
    const double length = (b - a).norm();
    if (length < 1e-4) return;  // a placeholder joint on top of its parent
    add_capsule(g, a, b, std::min(o.limb_radius_m, 0.4 * length), parent, o.capsule_segments, o.capsule_rings);
  };
  for (int j = 1; j < s.num_joints(); ++j) bone(s.parents[j], s.offsets[j]);
  for (const EndSite& e : s.end_sites) bone(e.parent, e.offset);
  if (g.indices.empty()) throw Error("glTF export: the skeleton has no bone to draw");

  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.attributes["POSITION"] = buffers.add_floats(g.positions, 3, TINYGLTF_TARGET_ARRAY_BUFFER);
  prim.attributes["NORMAL"] = buffers.add_floats(g.normals, 3, TINYGLTF_TARGET_ARRAY_BUFFER);
  prim.attributes["JOINTS_0"] =
      buffers.add(g.joints, 4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TARGET_ARRAY_BUFFER);
  prim.attributes["WEIGHTS_0"] = buffers.add_floats(g.weights, 4, TINYGLTF_TARGET_ARRAY_BUFFER);
  prim.indices =
      buffers.add(g.indices, 1, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  prim.material = 0;
  tinygltf::Material material;
  material.name = "body";
  material.pbrMetallicRoughness.baseColorFactor = {0.55, 0.62, 0.75, 1.0};
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 0.7;
  model.materials.push_back(material);
  tinygltf::Mesh mesh;
  mesh.name = "body";
  mesh.primitives.push_back(prim);
  model.meshes.push_back(mesh);

  // Inverse of the bind frame [up | p]: [up^T | -up^T p], column-major.
  std::vector<float> inverse_bind;
  const Eigen::Matrix3d rt = up.toRotationMatrix().transpose();
  for (int j = 0; j < s.num_joints(); ++j) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = rt;
    m.topRightCorner<3, 1>() = -rt * bind[j];
    for (int c = 0; c < 16; ++c) inverse_bind.push_back(static_cast<float>(m(c % 4, c / 4)));
  }
  tinygltf::Skin skin;
  skin.name = "skeleton";
  skin.inverseBindMatrices = buffers.add_floats(inverse_bind, 16);
  skin.skeleton = 0;
  for (int j = 0; j < s.num_joints(); ++j) skin.joints.push_back(j);
  model.skins.push_back(skin);
}

// Joint nodes (node j = joint j), posed at the first frame of `first`.
void add_joint_nodes(tinygltf::Model& model, const Skeleton& s, const Motion& first, double mpu,
                     const Quaterniond& up) {
  for (int j = 0; j < s.num_joints(); ++j) {
    tinygltf::Node node;
    node.name = s.joint_names[j];
    const LocalTransform l = local_transform(first, 0, j, mpu, up);
    node.translation = {l.translation_m.x(), l.translation_m.y(), l.translation_m.z()};
    node.rotation = {l.rotation.x(), l.rotation.y(), l.rotation.z(), l.rotation.w()};
    for (int c : s.children(j)) node.children.push_back(c);
    model.nodes.push_back(node);
  }
}

void add_channel(tinygltf::Animation& animation, int node, const char* path, int input, int output) {
  tinygltf::AnimationSampler sampler;
  sampler.input = input;
  sampler.output = output;
  sampler.interpolation = "LINEAR";
  animation.samplers.push_back(sampler);
  tinygltf::AnimationChannel channel;
  channel.sampler = static_cast<int>(animation.samplers.size()) - 1;
  channel.target_node = node;
  channel.target_path = path;
  animation.channels.push_back(channel);
}

// One animation: rotations of every joint, the root's translation, and the translation of any
// other joint whose translation differs from its node's at some frame.
void add_animation(tinygltf::Model& model, BufferBuilder& buffers, const GltfMotion& gm, const std::string& name,
                   double mpu, const Quaterniond& up) {
  const Motion& m = gm.motion;
  tinygltf::Animation animation;
  animation.name = name;
  std::vector<float> times(m.num_frames);
  for (int t = 0; t < m.num_frames; ++t) times[t] = static_cast<float>(t / m.fps);
  const int input = buffers.add_floats(times, 1);
  for (int j = 0; j < m.num_joints; ++j) {
    std::vector<float> rotations, translations;
    Quaterniond previous = Quaterniond::Identity();
    bool moves = j == 0;
    const std::vector<double>& rest = model.nodes[j].translation;
    for (int t = 0; t < m.num_frames; ++t) {
      const LocalTransform l = local_transform(m, t, j, mpu, up);
      Quaterniond q = l.rotation;
      if (t > 0 && q.dot(previous) < 0) q.coeffs() = -q.coeffs();  // shortest arc between keys
      previous = q;
      push(rotations, q);
      push(translations, l.translation_m);
      for (int c = 0; c < 3; ++c) moves = moves || std::abs(l.translation_m[c] - rest[c]) > 1e-9;
    }
    add_channel(animation, j, "rotation", input, buffers.add_floats(rotations, 4));
    if (moves) add_channel(animation, j, "translation", input, buffers.add_floats(translations, 3));
  }
  model.animations.push_back(animation);
}

void check_motions(const Skeleton& skeleton, const std::vector<GltfMotion>& motions) {
  skeleton.validate();
  if (motions.empty()) throw Error("glTF export: no motion");
  for (const GltfMotion& gm : motions) {
    if (gm.motion.num_joints != skeleton.num_joints())
      throw Error("glTF export: motion '" + gm.name + "' has " + std::to_string(gm.motion.num_joints) +
                  " joints, the skeleton " + std::to_string(skeleton.num_joints()));
    if (gm.motion.num_frames < 1) throw Error("glTF export: motion '" + gm.name + "' has no frames");
    gm.motion.validate();
  }
}

}  // namespace

std::string gltf_bytes(const Skeleton& skeleton, const std::vector<GltfMotion>& motions, bool binary,
                       const GltfOptions& options) {
  check_motions(skeleton, motions);
  if (options.capsule_segments < 3 || options.capsule_rings < 1 || !(options.limb_radius_m > 0))
    throw Error("glTF export: capsules need >= 3 segments, >= 1 ring and a positive radius");
  const double mpu = resolve_meters_per_unit(skeleton, options.meters_per_unit);
  const Quaterniond up = up_rotation(skeleton.up_axis);

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "mosyn";
  BufferBuilder buffers(model);
  add_joint_nodes(model, skeleton, motions.front().motion, mpu, up);
  add_body(model, buffers, skeleton, mpu, up, options);
  tinygltf::Node body;
  body.name = "body";
  body.mesh = 0;
  body.skin = 0;
  model.nodes.push_back(body);
  for (size_t i = 0; i < motions.size(); ++i)
    add_animation(model, buffers, motions[i], motions[i].name.empty() ? "motion " + std::to_string(i) : motions[i].name,
                  mpu, up);
  tinygltf::Scene scene;
  scene.name = "mosyn";
  scene.nodes = {0, skeleton.num_joints()};
  model.scenes.push_back(scene);
  model.defaultScene = 0;

  std::ostringstream out;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/false, binary))
    throw Error("glTF export: serialisation failed");
  return out.str();
}

void write_gltf(const std::string& path, const Skeleton& skeleton, const std::vector<GltfMotion>& motions,
                const GltfOptions& options) {
  const std::string ext = extension_of(path);
  if (ext != "glb" && ext != "gltf") throw Error(path + ": a glTF file name ends in .glb or .gltf");
  write_file_atomically(path, gltf_bytes(skeleton, motions, ext == "glb", options));
}

}  // namespace mosyn::io

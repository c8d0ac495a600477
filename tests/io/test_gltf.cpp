// glTF export read back with tinygltf: joint world positions from the file's nodes and animation
// channels equal our forward kinematics at every frame; the skinned body follows the bones; the
// validation rules importers rely on (accessor bounds, unit quaternions, increasing key times).
#include "io/gltf.h"

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <map>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/synthetic.h"
#include "io/atomic_file.h"
#include "io_test_util.h"

namespace mosyn::io {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

tinygltf::Model load(const std::string& bytes, bool binary) {
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  const bool ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn,
                                                       reinterpret_cast<const unsigned char*>(bytes.data()),
                                                       static_cast<unsigned>(bytes.size()))
                         : loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(),
                                                      static_cast<unsigned>(bytes.size()), "");
  EXPECT_TRUE(ok) << err;
  EXPECT_TRUE(warn.empty()) << warn;
  return model;
}

int components(int type) { return tinygltf::GetNumComponentsInType(type); }

// An accessor's elements as doubles, [count * components] (tightly packed views, as written).
std::vector<double> read_accessor(const tinygltf::Model& m, int index) {
  const tinygltf::Accessor& a = m.accessors.at(index);
  const tinygltf::BufferView& v = m.bufferViews.at(a.bufferView);
  const unsigned char* p = m.buffers.at(v.buffer).data.data() + v.byteOffset + a.byteOffset;
  const size_t n = a.count * components(a.type);
  std::vector<double> out(n);
  for (size_t i = 0; i < n; ++i) {
    switch (a.componentType) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: { float f; std::memcpy(&f, p + 4 * i, 4); out[i] = f; break; }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { std::uint16_t u; std::memcpy(&u, p + 2 * i, 2); out[i] = u; break; }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { std::uint32_t u; std::memcpy(&u, p + 4 * i, 4); out[i] = u; break; }
      default: ADD_FAILURE() << "unexpected component type " << a.componentType;
    }
  }
  return out;
}

struct Trs {
  Vector3d t = Vector3d::Zero();
  Quaterniond r = Quaterniond::Identity();
  Eigen::Isometry3d matrix() const {
    Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
    m.translate(t);
    m.rotate(r);
    return m;
  }
};

// World transforms of every node at key k of animation a, from the nodes' TRS and the channels.
std::vector<Eigen::Isometry3d> world_at_key(const tinygltf::Model& m, int a, int k) {
  std::vector<Trs> local(m.nodes.size());
  for (size_t n = 0; n < m.nodes.size(); ++n) {
    const auto& node = m.nodes[n];
    if (node.translation.size() == 3) local[n].t = Vector3d(node.translation[0], node.translation[1], node.translation[2]);
    if (node.rotation.size() == 4)
      local[n].r = Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);
  }
  for (const auto& ch : m.animations[a].channels) {
    const std::vector<double> out = read_accessor(m, m.animations[a].samplers[ch.sampler].output);
    if (ch.target_path == "rotation")
      local[ch.target_node].r = Quaterniond(out[4 * k + 3], out[4 * k], out[4 * k + 1], out[4 * k + 2]);
    else if (ch.target_path == "translation")
      local[ch.target_node].t = Vector3d(out[3 * k], out[3 * k + 1], out[3 * k + 2]);
  }
  std::vector<Eigen::Isometry3d> world(m.nodes.size(), Eigen::Isometry3d::Identity());
  std::function<void(int, const Eigen::Isometry3d&)> visit = [&](int n, const Eigen::Isometry3d& parent) {
    world[n] = parent * local[n].matrix();
    for (int c : m.nodes[n].children) visit(c, world[n]);
  };
  for (int n : m.scenes[0].nodes) visit(n, Eigen::Isometry3d::Identity());
  return world;
}

Clip synthetic_clip(int frames, double turn) {
  Clip clip{make_synthetic_biped(), {}};
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = turn;
  o.noise_rad = 0.05;
  clip.motion = make_synthetic_walk(clip.skeleton, frames, 30.0, o);
  return clip;
}

// Every joint of every frame of every animation lies where our FK puts it (metres, Y-up).
void expect_fk_matches(const tinygltf::Model& model, const Skeleton& s, const std::vector<GltfMotion>& motions,
                       const std::function<Vector3d(const Vector3d&)>& to_gltf) {
  ASSERT_EQ(model.animations.size(), motions.size());
  double worst = 0;
  for (size_t a = 0; a < motions.size(); ++a) {
    const WorldPoses fk = forward_kinematics(s, motions[a].motion);
    for (int k = 0; k < motions[a].motion.num_frames; ++k) {
      const auto world = world_at_key(model, static_cast<int>(a), k);
      for (int j = 0; j < s.num_joints(); ++j)
        worst = std::max(worst, (world[j].translation() - to_gltf(fk.position(k, j))).norm());
    }
  }
  EXPECT_LT(worst, 1e-4) << "largest joint position error, metres";
}

TEST(GltfTest, JointWorldPositionsEqualForwardKinematicsAtEveryFrame) {
  const Clip walk = synthetic_clip(90, 0.0), turn = synthetic_clip(60, 0.8);
  const std::vector<GltfMotion> motions{{"walk", walk.motion}, {"turn", turn.motion}};
  for (bool binary : {true, false}) {
    const tinygltf::Model model = load(gltf_bytes(walk.skeleton, motions, binary), binary);
    ASSERT_EQ(model.skins.size(), 1u);
    ASSERT_EQ(model.skins[0].joints.size(), static_cast<size_t>(walk.skeleton.num_joints()));
    for (int j = 0; j < walk.skeleton.num_joints(); ++j) EXPECT_EQ(model.nodes[j].name, walk.skeleton.joint_names[j]);
    EXPECT_EQ(model.animations[0].name, "walk");
    EXPECT_EQ(model.animations[1].name, "turn");
    expect_fk_matches(model, walk.skeleton, motions, [](const Vector3d& p) { return Vector3d(p * 0.01); });
  }
}

TEST(GltfTest, ZUpSkeletonIsTurnedToYUpAndAnimatedOffsetsAreKept) {
  Clip clip = synthetic_clip(40, 0.5);
  // The same walk expressed with +Z up (inverse of (x, y, z) -> (x, z, -y)) and a stretching spine.
  const Quaterniond to_z_up(Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitX()));
  Clip z = clip;
  z.skeleton.up_axis = 2;
  for (int t = 0; t < z.motion.num_frames; ++t) {
    z.motion.rotation(t, 0) = to_z_up * z.motion.rotation(t, 0);
    z.motion.translation(t, 0) = to_z_up * z.motion.translation(t, 0);
    z.motion.translation(t, 1) *= 1.0 + 0.1 * std::sin(0.3 * t);
    clip.motion.translation(t, 1) = z.motion.translation(t, 1);
  }
  const tinygltf::Model model = load(gltf_bytes(z.skeleton, {{"z", z.motion}}, true), true);
  // Positions equal the Y-up clip's FK: the up rotation is folded into the root exactly.
  expect_fk_matches(model, clip.skeleton, {{"y", clip.motion}}, [](const Vector3d& p) { return Vector3d(p * 0.01); });
  int spine_translation = 0;
  for (const auto& ch : model.animations[0].channels) spine_translation += ch.target_node == 1 && ch.target_path == "translation";
  EXPECT_EQ(spine_translation, 1);
}

// Every skinned body vertex lies within the capsule radius of a bone of its joint at every key:
// the inverse bind matrices and the mesh agree with the animated skeleton.
TEST(GltfTest, SkinnedBodyFollowsTheBones) {
  const Clip clip = synthetic_clip(30, 0.6);
  GltfOptions options;
  const tinygltf::Model model = load(gltf_bytes(clip.skeleton, {{"walk", clip.motion}}, true, options), true);
  const auto& prim = model.meshes.at(0).primitives.at(0);
  const std::vector<double> pos = read_accessor(model, prim.attributes.at("POSITION"));
  const std::vector<double> joints = read_accessor(model, prim.attributes.at("JOINTS_0"));
  const std::vector<double> ibm = read_accessor(model, model.skins[0].inverseBindMatrices);
  const WorldPoses fk = forward_kinematics(clip.skeleton, clip.motion);
  const std::vector<Vector3d> ends = end_site_positions(clip.skeleton, fk);
  double worst = 0;
  for (int k = 0; k < clip.motion.num_frames; k += 7) {
    const auto world = world_at_key(model, 0, k);
    for (size_t v = 0; v < pos.size() / 3; ++v) {
      const int j = static_cast<int>(joints[4 * v]);
      Eigen::Matrix4d inv;
      for (int c = 0; c < 16; ++c) inv(c % 4, c / 4) = ibm[16 * j + c];
      const Vector3d p = (world[j].matrix() * inv * Eigen::Vector4d(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2], 1))
                             .head<3>();
      // Distance to the nearest bone that starts at joint j (to a child joint or an End Site).
      double nearest = 1e9;
      auto segment = [&](const Vector3d& b) {
        const Vector3d a = fk.position(k, j) * 0.01, ab = b * 0.01 - a;
        const double s = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
        nearest = std::min(nearest, (a + s * ab - p).norm());
      };
      for (int c : clip.skeleton.children(j)) segment(fk.position(k, c));
      for (size_t e = 0; e < clip.skeleton.end_sites.size(); ++e)
        if (clip.skeleton.end_sites[e].parent == j) segment(ends[static_cast<size_t>(k) * clip.skeleton.end_sites.size() + e]);
      worst = std::max(worst, nearest);
    }
  }
  EXPECT_LT(worst, options.limb_radius_m + 1e-4);
  EXPECT_GT(worst, 0.5 * options.limb_radius_m);  // the body has thickness
}

TEST(GltfTest, ValidationRulesHold) {
  const Clip a = synthetic_clip(50, 0.0), b = synthetic_clip(20, 1.0);
  const tinygltf::Model m = load(gltf_bytes(a.skeleton, {{"a", a.motion}, {"b", b.motion}}, true), true);
  // Accessor bounds: present on every accessor and equal to the data's own extremes.
  for (size_t i = 0; i < m.accessors.size(); ++i) {
    const auto& acc = m.accessors[i];
    const int nc = components(acc.type);
    ASSERT_EQ(acc.minValues.size(), static_cast<size_t>(nc)) << "accessor " << i;
    ASSERT_EQ(acc.maxValues.size(), static_cast<size_t>(nc)) << "accessor " << i;
    std::vector<double> lo(nc, 1e300), hi(nc, -1e300);
    const std::vector<double> data = read_accessor(m, static_cast<int>(i));
    for (size_t e = 0; e < data.size(); ++e) {
      lo[e % nc] = std::min(lo[e % nc], data[e]);
      hi[e % nc] = std::max(hi[e % nc], data[e]);
    }
    for (int c = 0; c < nc; ++c) {
      EXPECT_EQ(acc.minValues[c], lo[c]) << "accessor " << i;
      EXPECT_EQ(acc.maxValues[c], hi[c]) << "accessor " << i;
    }
    const auto& view = m.bufferViews[acc.bufferView];
    EXPECT_EQ(view.byteOffset % 4, 0u);
    EXPECT_LE(view.byteOffset + view.byteLength, m.buffers[0].data.size());
  }
  for (const auto& anim : m.animations) {
    for (const auto& s : anim.samplers) {
      const std::vector<double> t = read_accessor(m, s.input);
      EXPECT_EQ(t.front(), 0.0);
      for (size_t k = 1; k < t.size(); ++k) ASSERT_GT(t[k], t[k - 1]) << anim.name;  // strictly increasing
      EXPECT_EQ(m.accessors[s.output].count, t.size());
      EXPECT_EQ(s.interpolation, "LINEAR");
    }
    for (const auto& ch : anim.channels) {
      if (ch.target_path != "rotation") continue;
      const std::vector<double> q = read_accessor(m, anim.samplers[ch.sampler].output);
      for (size_t k = 0; k < q.size() / 4; ++k) {
        const double norm = std::sqrt(q[4 * k] * q[4 * k] + q[4 * k + 1] * q[4 * k + 1] + q[4 * k + 2] * q[4 * k + 2] +
                                      q[4 * k + 3] * q[4 * k + 3]);
        ASSERT_NEAR(norm, 1.0, 1e-6) << anim.name << " node " << ch.target_node << " key " << k;
        if (k > 0) {  // consecutive keys in one hemisphere: interpolation takes the short way
          double dot = 0;
          for (int c = 0; c < 4; ++c) dot += q[4 * k + c] * q[4 * (k - 1) + c];
          EXPECT_GE(dot, 0.0);
        }
      }
    }
  }
  const auto& prim = m.meshes[0].primitives[0];
  const std::vector<double> w = read_accessor(m, prim.attributes.at("WEIGHTS_0"));
  for (size_t v = 0; v < w.size() / 4; ++v) EXPECT_DOUBLE_EQ(w[4 * v] + w[4 * v + 1] + w[4 * v + 2] + w[4 * v + 3], 1.0);
  EXPECT_EQ(m.accessors[prim.indices].count % 3, 0u);
  EXPECT_EQ(m.accessors[prim.indices].maxValues[0] + 1, m.accessors[prim.attributes.at("POSITION")].count);
}

TEST(GltfTest, WritesAtomicallyByExtensionAndRefusesBadInput) {
  const auto dir = testing::make_temp_dir("gltf");
  const Clip clip = synthetic_clip(10, 0.0);
  write_gltf((dir / "a.glb").string(), clip.skeleton, {{"a", clip.motion}});
  write_gltf((dir / "a.gltf").string(), clip.skeleton, {{"a", clip.motion}});
  EXPECT_EQ(read_file((dir / "a.glb").string()).substr(0, 4), "glTF");
  const std::string json = read_file((dir / "a.gltf").string());
  EXPECT_NE(json.find("data:application/octet-stream;base64,"), std::string::npos);  // one self-contained file
  load(json, false);
  EXPECT_THROW(write_gltf((dir / "a.obj").string(), clip.skeleton, {{"a", clip.motion}}), Error);
  EXPECT_THROW(gltf_bytes(clip.skeleton, {}, true), Error);
  Motion wrong = clip.motion;
  wrong.num_joints -= 1;
  EXPECT_THROW(gltf_bytes(clip.skeleton, {{"bad", wrong}}, true), Error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mosyn::io

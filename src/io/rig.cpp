#include "io/rig.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "core/error.h"
#include "core/units.h"
#include "io/atomic_file.h"
#include "io/file_name.h"
#include "io/gltf.h"

namespace mosyn::io {
namespace {

using Eigen::Matrix4d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

// Images are irrelevant to a rig: accept them without decoding.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

// A node's local transform (matrix, or T * R * S).
Matrix4d node_matrix(const tinygltf::Node& node) {
  Matrix4d m = Matrix4d::Identity();
  if (node.matrix.size() == 16) {
    for (int c = 0; c < 16; ++c) m(c % 4, c / 4) = node.matrix[static_cast<size_t>(c)];
    return m;
  }
  if (node.rotation.size() == 4)
    m.topLeftCorner<3, 3>() =
        Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]).normalized().toRotationMatrix();
  if (node.scale.size() == 3)
    m.topLeftCorner<3, 3>() *= Eigen::Vector3d(node.scale[0], node.scale[1], node.scale[2]).asDiagonal();
  if (node.translation.size() == 3) m.topRightCorner<3, 1>() = Vector3d(node.translation[0], node.translation[1], node.translation[2]);
  return m;
}

tinygltf::Model load_model(const std::string& bytes, bool binary, const std::string& file) {
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(&skip_image, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  const bool ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn,
                                                       reinterpret_cast<const unsigned char*>(bytes.data()),
                                                       static_cast<unsigned int>(bytes.size()), "")
                         : loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(),
                                                      static_cast<unsigned int>(bytes.size()), "");
  if (!ok) throw ParseError(file, 0, "not a readable glTF file: " + (err.empty() ? std::string("unknown error") : err));
  return model;
}

// World rest transforms of every node (scene graph from every root).
std::vector<Matrix4d> world_matrices(const tinygltf::Model& model, std::vector<int>* node_parent, const std::string& file) {
  const size_t n = model.nodes.size();
  node_parent->assign(n, -1);
  for (size_t i = 0; i < n; ++i)
    for (int c : model.nodes[i].children) {
      if (c < 0 || static_cast<size_t>(c) >= n || (*node_parent)[c] >= 0)
        throw ParseError(file, 0, "node " + std::to_string(i) + " has an invalid or shared child " + std::to_string(c));
      (*node_parent)[c] = static_cast<int>(i);
    }
  std::vector<Matrix4d> world(n);
  std::vector<bool> done(n, false);
  for (size_t i = 0; i < n; ++i) {
    std::vector<int> chain;  // i and its ancestors not yet done
    for (int a = static_cast<int>(i); a >= 0 && !done[a]; a = (*node_parent)[a]) {
      chain.push_back(a);
      if (chain.size() > n) throw ParseError(file, 0, "the node hierarchy has a cycle");
    }
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      const int parent = (*node_parent)[*it];
      world[*it] = (parent >= 0 ? world[parent] : Matrix4d::Identity()) * node_matrix(model.nodes[*it]);
      done[*it] = true;
    }
  }
  return world;
}

// Joint nodes in depth-first order from the single root joint; parents as joint indices.
std::vector<int> joint_order(const tinygltf::Model& model, const std::vector<int>& joints, const std::vector<int>& node_parent,
                             std::vector<int>* parents, const std::string& file) {
  const std::set<int> is_joint(joints.begin(), joints.end());
  auto joint_parent = [&](int node) {
    int a = node_parent[node];
    while (a >= 0 && !is_joint.count(a)) a = node_parent[a];
    return a;
  };
  std::vector<int> roots;
  for (int j : joints)
    if (joint_parent(j) < 0) roots.push_back(j);
  if (roots.size() != 1)
    throw ParseError(file, 0, "the rig's joints form " + std::to_string(roots.size()) + " trees; one root joint is needed");
  std::vector<int> order;
  std::vector<std::pair<int, int>> stack = {{roots[0], -1}};  // (node, parent joint index)
  while (!stack.empty()) {
    const auto [node, parent] = stack.back();
    stack.pop_back();
    const int index = static_cast<int>(order.size());
    order.push_back(node);
    parents->push_back(parent);
    // Children that are joints (through non-joint nodes too), pushed reversed to keep file order.
    std::vector<int> below;
    for (int j : joints)
      if (joint_parent(j) == node) below.push_back(j);
    for (auto it = below.rbegin(); it != below.rend(); ++it) stack.emplace_back(*it, index);
  }
  return order;
}

Quaterniond rotation_of(const Matrix4d& m) {
  Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  for (int c = 0; c < 3; ++c) r.col(c).normalize();  // scale out
  return Quaterniond(r).normalized();
}

}  // namespace

RetargetRig parse_gltf_rig(const std::string& bytes, bool binary, const std::string& file) {
  const tinygltf::Model model = load_model(bytes, binary, file);
  std::vector<int> joints = model.skins.empty() ? std::vector<int>() : model.skins[0].joints;
  if (model.skins.empty())
    for (size_t i = 0; i < model.nodes.size(); ++i)
      if (model.nodes[i].mesh < 0) joints.push_back(static_cast<int>(i));
  if (joints.empty()) throw ParseError(file, 0, "no joints: a rig needs a skin or a node hierarchy");
  for (int j : joints)
    if (j < 0 || static_cast<size_t>(j) >= model.nodes.size()) throw ParseError(file, 0, "a skin joint is not a node");
  std::vector<int> node_parent, parents;
  const std::vector<Matrix4d> world = world_matrices(model, &node_parent, file);
  const std::vector<int> order = joint_order(model, joints, node_parent, &parents, file);
  RetargetRig rig;
  Skeleton& sk = rig.skeleton;
  for (size_t i = 0; i < order.size(); ++i) {
    const Matrix4d& w = world[order[i]];
    if (!w.allFinite()) throw ParseError(file, 0, "joint node " + std::to_string(order[i]) + " has a non-finite transform");
    const std::string& name = model.nodes[order[i]].name;
    sk.joint_names.push_back(name.empty() ? "joint" + std::to_string(order[i]) : name);
    sk.parents.push_back(parents[i]);
    const Quaterniond r = rotation_of(w);
    const Vector3d p = w.topRightCorner<3, 1>();
    if (parents[i] < 0) {
      sk.offsets.push_back(p);
      rig.rest_rotations.push_back(r);
    } else {
      const Matrix4d& pw = world[order[parents[i]]];
      const Quaterniond pr = rotation_of(pw);
      sk.offsets.push_back(pr.conjugate() * (p - Vector3d(pw.topRightCorner<3, 1>())));
      rig.rest_rotations.push_back((pr.conjugate() * r).normalized());
    }
  }
  std::set<std::string> seen;
  for (const std::string& name : sk.joint_names)
    if (!seen.insert(name).second) throw ParseError(file, 0, "joint name '" + name + "' repeats");
  sk.meters_per_unit = 1.0;
  sk.up_axis = 1;
  sk.validate();
  return rig;
}

RigFile read_rig(const std::string& path) {
  const std::string ext = extension_of(path);
  RigFile out;
  if (ext == "bvh") {
    out.bvh = read_bvh(path);
    const Clip clip = to_clip(*out.bvh);
    out.rig.skeleton = clip.skeleton;
    out.rig.frames = clip.motion;
    for (const BvhChannelLayout& layout : out.bvh->channels)
      out.rig.translatable.push_back(std::any_of(layout.begin(), layout.end(), [](BvhChannel c) { return !is_rotation(c); }));
    out.meters_per_unit = resolve_meters_per_unit(out.rig.skeleton);
  } else if (ext == "glb" || ext == "gltf") {
    out.rig = parse_gltf_rig(read_file(path), ext == "glb", path);
    out.meters_per_unit = 1.0;
  } else {
    throw Error(path + ": a rig is a .bvh, .glb or .gltf file");
  }
  return out;
}

void write_on_rig(const std::string& path, const RigFile& rig, const Motion& motion, const std::string& name) {
  const std::string ext = extension_of(path);
  Clip clip{rig.rig.skeleton, motion};
  if (ext == "bvh") {
    write_bvh(path, from_clip(clip, rig.bvh ? &*rig.bvh : nullptr));
  } else if (ext == "glb" || ext == "gltf") {
    GltfOptions options;
    options.meters_per_unit = rig.meters_per_unit;
    write_gltf(path, clip.skeleton, {{name, motion}}, options);
  } else {
    throw Error(path + ": the output is a .bvh, .glb or .gltf file");
  }
}

}  // namespace mosyn::io

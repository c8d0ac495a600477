// `mosyn info` and `mosyn convert`.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli/cli.h"
#include "core/error.h"
#include "core/kinematics.h"
#include "core/markers.h"
#include "core/units.h"
#include "data/augment.h"
#include "data/control.h"
#include "io/bvh.h"
#include "io/csv.h"
#include "io/gltf.h"
#include "io/json_file.h"
#include "io/npy.h"

namespace mosyn::cli {
namespace {

void run_info(const std::string& path) {
  const io::BvhFile bvh = io::read_bvh(path);
  const Skeleton& skeleton = bvh.skeleton;
  const UnitsGuess units = guess_units(skeleton);
  const double fps = 1.0 / bvh.frame_time_s;
  std::printf("file:      %s\n", path.c_str());
  std::printf("joints:    %d (+%zu end sites), root '%s'\n", skeleton.num_joints(), skeleton.end_sites.size(),
              skeleton.joint_names[0].c_str());
  std::printf("channels:  %d per frame\n", bvh.num_channels());
  std::printf("frames:    %d\n", bvh.num_frames);
  std::printf("fps:       %.6g (frame time %.9g s)\n", fps, bvh.frame_time_s);
  std::printf("duration:  %.3f s\n", bvh.num_frames > 0 ? (bvh.num_frames - 1) * bvh.frame_time_s : 0.0);
  std::printf("units:     %s, guessed from an estimated height of %.2f m\n", units.name.c_str(),
              units.height_units * units.meters_per_unit);
  std::printf("hierarchy:\n");
  std::vector<int> depth(skeleton.num_joints(), 0);
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    if (j > 0) depth[j] = depth[skeleton.parents[j]] + 1;
    std::string channels;
    for (io::BvhChannel c : bvh.channels[j]) channels += std::string(channels.empty() ? "" : " ") + io::to_string(c);
    std::printf("  %*s%-*s %s\n", 2 * depth[j], "", 24 - 2 * depth[j] > 1 ? 24 - 2 * depth[j] : 1,
                skeleton.joint_names[j].c_str(), channels.c_str());
  }
}

struct ConvertOptions {
  std::string input, output;
  double fps = 0;
  std::string joints, drop_joints;
  bool positions = false;
  bool markers = false;
  bool metres = false;
  bool control = false;
};

// Throws UsageError when the output's extension and the flags do not go together.
void check_convert_options(const ConvertOptions& o, const std::string& ext) {
  const bool gltf = ext == "glb" || ext == "gltf";
  if (ext != "bvh" && ext != "npy" && ext != "csv" && ext != "json" && !gltf)
    throw UsageError("output '" + o.output + "' must end in .bvh, .glb, .gltf, .npy, .csv or .json");
  if (o.control && (ext != "csv" || o.positions))
    throw UsageError("--control writes the root control as CSV: give an output ending in .csv and no --positions");
  if (o.markers && (o.positions || o.control || (ext != "npy" && ext != "csv")))
    throw UsageError("--markers writes marker positions as .npy or .csv: give such an output and no --positions or --control");
  if (ext == "npy" && !o.positions && !o.markers) throw UsageError(".npy outputs hold world joint positions: add --positions");
  if (ext == "csv" && !o.positions && !o.control && !o.markers)
    throw UsageError(".csv outputs hold world joint positions (--positions) or the root control (--control)");
  if ((ext == "bvh" || gltf) && o.positions) throw UsageError("--positions does not apply to ." + ext + " output");
  if (o.fps < 0) throw UsageError("--fps must be positive");
}

void write_control_of(const ConvertOptions& o, const Clip& clip) {
  const std::vector<float> control = data::control_from_clip(clip, clip.motion.fps);
  std::vector<Eigen::Vector3d> rows(control.size() / 3);
  for (size_t t = 0; t < rows.size(); ++t) rows[t] = {control[3 * t], control[3 * t + 1], control[3 * t + 2]};
  io::write_control_csv(o.output, rows, clip.motion.fps);
  std::fprintf(stderr, "wrote %s: %zu frames of t_s, dx, dz (m) and dtheta (rad) at %g fps\n", o.output.c_str(),
               rows.size(), clip.motion.fps);
}

void write_gltf_of(const ConvertOptions& o, const Clip& clip) {
  io::GltfOptions gltf_options;
  gltf_options.meters_per_unit = resolve_meters_per_unit(clip.skeleton);
  const std::string name = std::filesystem::path(o.input).stem().string();
  io::write_gltf(o.output, clip.skeleton, {{name, clip.motion}}, gltf_options);
  std::fprintf(stderr, "wrote %s: %d joints, %d frames at %g fps, %.4g m per unit, Y up\n", o.output.c_str(),
               clip.skeleton.num_joints(), clip.motion.num_frames, clip.motion.fps, gltf_options.meters_per_unit);
}

// The CMU 41-marker layout rigidly attached to the bones (core/markers.h), as MOJO predicts.
void write_markers_of(const ConvertOptions& o, const Clip& clip, const std::string& ext, double scale) {
  Skeleton placed = clip.skeleton;
  placed.meters_per_unit = resolve_meters_per_unit(clip.skeleton);  // marker offsets are in metres
  const MarkerSet set = cmu41_markers(placed);
  std::vector<Eigen::Vector3d> at = marker_positions(placed, set, clip.motion);
  for (auto& p : at) p *= scale;
  if (ext == "npy")
    io::write_positions_npy(o.output, clip.motion.num_frames, set.num_markers(), at);
  else
    io::write_positions_csv(o.output, cmu41_marker_names(), clip.motion.num_frames, at);
  std::fprintf(stderr, "wrote %s: %d frames x %d CMU markers, positions in %s\n", o.output.c_str(),
               clip.motion.num_frames, set.num_markers(), o.metres ? "metres" : "the file's units");
}

// World joint positions as JSON: skeleton (joints, parents, offsets) and positions [T][J][3].
nlohmann::json positions_json(const ConvertOptions& o, const Clip& clip, const std::vector<Eigen::Vector3d>& positions,
                              double scale) {
  const int num_frames = clip.motion.num_frames, num_joints = clip.skeleton.num_joints();
  nlohmann::json j;
  j["source"] = o.input;
  j["fps"] = clip.motion.fps;
  j["num_frames"] = num_frames;
  j["units"] = o.metres ? "metres" : "file units";
  j["joints"] = clip.skeleton.joint_names;
  j["parents"] = clip.skeleton.parents;
  nlohmann::json offsets = nlohmann::json::array(), frames = nlohmann::json::array();
  for (const auto& v : clip.skeleton.offsets) offsets.push_back({v.x() * scale, v.y() * scale, v.z() * scale});
  j["offsets"] = offsets;
  for (int t = 0; t < num_frames; ++t) {
    nlohmann::json frame = nlohmann::json::array();
    for (int k = 0; k < num_joints; ++k) {
      const auto& p = positions[static_cast<size_t>(t) * num_joints + k];
      frame.push_back({p.x(), p.y(), p.z()});
    }
    frames.push_back(std::move(frame));
  }
  j["positions"] = frames;  // [T][J][3]
  return j;
}

void write_positions_of(const ConvertOptions& o, const Clip& clip, const std::string& ext, double scale) {
  const WorldPoses poses = forward_kinematics(clip.skeleton, clip.motion);
  const int num_frames = clip.motion.num_frames, num_joints = clip.skeleton.num_joints();
  std::vector<Eigen::Vector3d> positions = poses.positions;
  for (auto& p : positions) p *= scale;
  if (ext == "npy")
    io::write_positions_npy(o.output, num_frames, num_joints, positions);
  else if (ext == "csv")
    io::write_positions_csv(o.output, clip.skeleton.joint_names, num_frames, positions);
  else
    io::write_json(o.output, positions_json(o, clip, positions, scale), -1);
  std::fprintf(stderr, "wrote %s: %d frames x %d joints, positions in %s\n", o.output.c_str(), num_frames, num_joints,
               o.metres ? "metres" : "the file's units");
}

void run_convert(const ConvertOptions& o) {
  const std::string ext = extension_of(o.output);
  check_convert_options(o, ext);
  const io::BvhFile bvh = io::read_bvh(o.input);
  Clip clip = io::to_clip(bvh);
  const bool reshaped = !o.joints.empty() || !o.drop_joints.empty();
  if (reshaped) clip = data::subset_by_patterns(clip, split_commas(o.drop_joints), split_commas(o.joints));
  if (o.fps > 0) clip.motion = data::resample(clip.motion, o.fps);

  auto scale = [&] { return o.metres ? resolve_meters_per_unit(clip.skeleton) : 1.0; };  // only where used
  if (o.control)
    write_control_of(o, clip);
  else if (ext == "bvh")
    io::write_bvh(o.output, io::from_clip(clip, reshaped ? nullptr : &bvh));  // the source's channels when unchanged
  else if (ext == "glb" || ext == "gltf")
    write_gltf_of(o, clip);
  else if (o.markers)
    write_markers_of(o, clip, ext, scale());
  else
    write_positions_of(o, clip, ext, scale());
}

}  // namespace

void add_info_command(CLI::App& app, Action* action) {
  auto path = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("info", "Describe a BVH file: joints, channels, frames, fps, duration, units");
  cmd->add_option("file", *path, "BVH file")->required();
  cmd->callback([action, path] { *action = [path] { run_info(*path); }; });
}

void add_convert_command(CLI::App& app, Action* action) {
  auto o = std::make_shared<ConvertOptions>();
  CLI::App* cmd = app.add_subcommand(
      "convert",
      "Convert a BVH file to BVH (resampled / fewer joints), glTF (.glb/.gltf: skinned body and animation, metres, "
      "Y up, for Blender, game engines, three.js), or world joint positions as NPY, CSV or JSON");
  cmd->add_option("input", o->input, "input BVH file")->required();
  cmd->add_option("output", o->output, "output file: .bvh, .glb, .gltf, .npy, .csv or .json")->required();
  cmd->add_option("--fps", o->fps, "resample to this frame rate (slerp)");
  cmd->add_option("--joints", o->joints, "keep only joints matching these comma-separated names/globs (+ the root)");
  cmd->add_option("--drop-joints", o->drop_joints, "drop joints matching these comma-separated globs, e.g. '*Thumb*'");
  cmd->add_flag("--positions", o->positions,
                "write world joint positions: NPY float32 [T,J,3] in BVH joint order (End Sites excluded), "
                "CSV 'frame,joint,x,y,z', or JSON");
  cmd->add_flag("--markers", o->markers,
                "write the 41 CMU surface markers (MOJO's layout, rigidly attached to the bones) instead of joints: "
                "NPY float32 [T,41,3] or CSV 'frame,marker,x,y,z' (Bandai-Namco and CMU joint names)");
  cmd->add_flag("--metres", o->metres, "scale positions to metres (units guessed from the skeleton's size)");
  cmd->add_flag("--control", o->control,
                "write the root control as CSV 't_s,dx,dz,dtheta' per frame (metres, radians; the input of "
                "`mosyn sample --control`)");
  cmd->callback([action, o] { *action = [o] { run_convert(*o); }; });
}

}  // namespace mosyn::cli

// `mosyn retarget`: a BVH motion played on another skeleton (a BVH or glTF rig).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli/cli.h"
#include "core/error.h"
#include "core/retarget.h"
#include "io/bvh.h"
#include "io/json_file.h"
#include "io/rig.h"

namespace mosyn::cli {
namespace {

struct RetargetCommandOptions {
  std::string input, rig, output, map;
  bool no_plant_feet = false;
};

// {"rig joint": "input joint", ...} from a JSON file; ParseError naming the file otherwise.
std::map<std::string, std::string> read_joint_map(const std::string& path) {
  const nlohmann::json j = io::read_json(path);
  if (!j.is_object()) throw ParseError(path, 0, "a joint map is a JSON object {\"rig joint\": \"input joint\", ...}");
  std::map<std::string, std::string> out;
  for (const auto& [key, value] : j.items()) {
    if (!value.is_string())
      throw ParseError(path, 0, "the value for rig joint '" + key + "' must be the name of an input joint (a string)");
    out[key] = value.get<std::string>();
  }
  return out;
}

void run_retarget(const RetargetCommandOptions& o) {
  const std::string in_ext = extension_of(o.input), rig_ext = extension_of(o.rig), out_ext = extension_of(o.output);
  if (in_ext != "bvh") throw UsageError("input '" + o.input + "' must be a .bvh file");
  if (rig_ext != "bvh" && rig_ext != "glb" && rig_ext != "gltf")
    throw UsageError("--to '" + o.rig + "' must be a .bvh, .glb or .gltf rig");
  if (out_ext != "bvh" && out_ext != "glb" && out_ext != "gltf")
    throw UsageError("--out '" + o.output + "' must end in .bvh, .glb or .gltf");
  RetargetOptions options;
  if (!o.map.empty()) options.joint_map = read_joint_map(o.map);
  options.plant_feet = !o.no_plant_feet;
  const Clip clip = io::to_clip(io::read_bvh(o.input));
  const io::RigFile rig = io::read_rig(o.rig);
  RetargetReport report;
  const Motion motion = retarget(clip.skeleton, clip.motion, rig.rig, options, &report);
  io::write_on_rig(o.output, rig, motion, std::filesystem::path(o.input).stem().string());
  std::fprintf(stderr, "wrote %s: %d frames at %g fps on %s (%d joints, %zu driven), scale %.4g (leg lengths), "
                       "lift %.3g, %d foot contacts planted%s%s\n",
               o.output.c_str(), motion.num_frames, motion.fps, o.rig.c_str(), rig.rig.skeleton.num_joints(),
               report.pairs.size(), report.scale, report.lift, report.contacts,
               report.input_rest_reference ? "" : ", input aligned by a standing frame",
               report.rig_rest_reference ? "" : ", rig aligned by a standing frame");
}

}  // namespace

void add_retarget_command(CLI::App& app, Action* action) {
  auto o = std::make_shared<RetargetCommandOptions>();
  CLI::App* cmd = app.add_subcommand(
      "retarget",
      "Play a BVH motion on another skeleton: the rig's joints, offsets and channels, the input's frames; joints "
      "matched by name (Mixamo, Unreal, CMU, Bandai-Namco, Blender) or --map, rest poses aligned in world space, "
      "the path scaled by leg length, feet planted by IK");
  cmd->add_option("input", o->input, "input BVH file")->required();
  cmd->add_option("--to", o->rig, "the rig: a .bvh or .glb/.gltf file with the target skeleton")->required();
  cmd->add_option("--out", o->output, "output file: .bvh (the rig's channel layout) or .glb/.gltf")->required();
  cmd->add_option("--map", o->map, "JSON file {\"rig joint\": \"input joint\", ...} for joints names do not match");
  cmd->add_flag("--no-plant-feet", o->no_plant_feet, "skip the two-bone IK that keeps the feet where the input's stand");
  cmd->callback([action, o] { *action = [o] { run_retarget(*o); }; });
}

}  // namespace mosyn::cli

// The C ABI (include/mosyn.h) over nn::Generator: every entry point catches what the library
// throws and turns it into a status and a thread-local message, so no exception crosses into C.
#define MOSYN_C_BUILD
#include "mosyn.h"

#include <algorithm>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/retarget.h"
#include "io/rig.h"
#include "nn/generator.h"
#include "nn/run.h"

struct mosyn_crowd {
  std::unique_ptr<mosyn::nn::Generator> generator;
  std::uint64_t seed = 0;
  std::vector<mosyn::nn::JointTransforms> poses;  // per slot, cached after each step (on the rig when set)
  std::vector<char> pose_valid;
  std::unique_ptr<mosyn::io::RigFile> rig;                // mosyn_crowd_set_rig, else null
  std::unique_ptr<mosyn::StreamingRetarget> retarget;     // the model's skeleton onto rig
};

namespace {

thread_local std::string last_error;

mosyn_status fail(mosyn_status status, const std::string& message) {
  last_error = message;
  return status;
}

// Runs f, mapping exceptions to statuses; clears the message on success.
template <typename F>
mosyn_status guarded(F&& f) {
  try {
    last_error.clear();
    return f();
  } catch (const mosyn::InvalidArgument& e) {
    return fail(MOSYN_INVALID_ARGUMENT, e.what());
  } catch (const std::bad_alloc&) {
    return fail(MOSYN_OUT_OF_MEMORY, "out of memory");
  } catch (const std::exception& e) {
    return fail(MOSYN_RUNTIME_ERROR, e.what());
  } catch (...) {
    return fail(MOSYN_RUNTIME_ERROR, "unknown error");
  }
}

bool bad_slot(const mosyn_crowd* crowd, int32_t slot) {
  return !crowd || slot < 0 || slot >= crowd->generator->batch();
}

// The skeleton the caller sees: the rig when one is set, else the model's.
const mosyn::Skeleton& skeleton_of(const mosyn_crowd* crowd) {
  return crowd->rig ? crowd->rig->rig.skeleton : crowd->generator->run().dataset.skeleton;
}

bool bad_joint(const mosyn_crowd* crowd, int32_t joint) {
  return !crowd || joint < 0 || joint >= skeleton_of(crowd).num_joints();
}

const mosyn::nn::JointTransforms& pose_of(const mosyn_crowd* crowd, int32_t slot) {
  auto* c = const_cast<mosyn_crowd*>(crowd);
  if (!c->pose_valid[slot]) {
    // On a rig (mosyn_crowd_set_rig): the model's pose retargeted before it is turned to floats.
    c->poses[slot] = c->retarget ? mosyn::nn::joint_transforms_of(c->retarget->apply(c->generator->pose_motion(slot)))
                                 : c->generator->joint_transforms(slot);
    c->pose_valid[slot] = 1;
  }
  return c->poses[slot];
}

}  // namespace

extern "C" {

const char* mosyn_last_error(void) { return last_error.c_str(); }

const char* mosyn_version(void) { return "0.1.0"; }

void mosyn_crowd_options_default(mosyn_crowd_options* options) {
  if (!options) return;
  options->capacity = 16;
  options->threads = 0;
  options->seed = 0;
  options->temperature = 1.0;
  options->warmup_frames = -1;
  options->control_smoothing_s = -1.0;
}

mosyn_status mosyn_crowd_create(const char* model_dir, const mosyn_crowd_options* options, mosyn_crowd** out) {
  if (out) *out = nullptr;
  if (!model_dir || !out) return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_create: model_dir and out must not be NULL");
  mosyn_crowd_options o;
  mosyn_crowd_options_default(&o);
  if (options) o = *options;
  if (o.capacity < 1) return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_create: capacity must be >= 1");
  return guarded([&] {
    auto run = mosyn::nn::load_run(model_dir, {"checkpoint.pt", "cpu", o.threads});
    mosyn::nn::GeneratorOptions g;
    g.batch = o.capacity;
    g.threads = o.threads;
    g.seed = o.seed;
    g.temperature = o.temperature;
    g.control_smoothing_s = o.control_smoothing_s;
    g.warmup_frames = o.warmup_frames >= 0 ? o.warmup_frames
                                           : static_cast<int>(run.traits.default_warmup_s * run.dataset.fps + 0.5);
    auto crowd = std::make_unique<mosyn_crowd>();
    crowd->seed = o.seed;
    crowd->generator = std::make_unique<mosyn::nn::Generator>(std::move(run), g);
    for (int k = 0; k < o.capacity; ++k) crowd->generator->remove(k);  // slots start empty
    crowd->poses.resize(o.capacity);
    crowd->pose_valid.assign(o.capacity, 0);
    *out = crowd.release();
    return MOSYN_OK;
  });
}

void mosyn_crowd_destroy(mosyn_crowd* crowd) { delete crowd; }

int32_t mosyn_crowd_capacity(const mosyn_crowd* crowd) { return crowd ? crowd->generator->batch() : -1; }

int32_t mosyn_crowd_joint_count(const mosyn_crowd* crowd) { return crowd ? skeleton_of(crowd).num_joints() : -1; }

const char* mosyn_crowd_joint_name(const mosyn_crowd* crowd, int32_t joint) {
  return bad_joint(crowd, joint) ? nullptr : skeleton_of(crowd).joint_names[joint].c_str();
}

int32_t mosyn_crowd_joint_parent(const mosyn_crowd* crowd, int32_t joint) {
  return bad_joint(crowd, joint) ? -1 : skeleton_of(crowd).parents[joint];
}

mosyn_status mosyn_crowd_joint_offset(const mosyn_crowd* crowd, int32_t joint, float* out_xyz) {
  if (bad_joint(crowd, joint) || !out_xyz) return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_joint_offset: bad crowd, joint or pointer");
  const auto& v = skeleton_of(crowd).offsets[joint];
  for (int i = 0; i < 3; ++i) out_xyz[i] = static_cast<float>(v[i]);
  return MOSYN_OK;
}

double mosyn_crowd_fps(const mosyn_crowd* crowd) { return crowd ? crowd->generator->run().dataset.fps : 0.0; }

double mosyn_crowd_meters_per_unit(const mosyn_crowd* crowd) {
  if (!crowd) return 0.0;
  return crowd->rig ? crowd->rig->meters_per_unit : crowd->generator->run().dataset.skeleton.meters_per_unit;
}

mosyn_status mosyn_crowd_set_rig(mosyn_crowd* crowd, const char* rig_path) {
  if (!crowd) return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_set_rig: crowd must not be NULL");
  return guarded([&] {
    std::fill(crowd->pose_valid.begin(), crowd->pose_valid.end(), 0);
    crowd->retarget.reset();
    crowd->rig.reset();
    if (!rig_path) return MOSYN_OK;
    int slot = 0;
    while (slot < crowd->generator->batch() && !crowd->generator->active(slot)) ++slot;
    if (slot == crowd->generator->batch())
      return fail(MOSYN_INVALID_ARGUMENT,
                  "mosyn_crowd_set_rig: add a character first: its pose aligns the model's skeleton with the rig");
    auto rig = std::make_unique<mosyn::io::RigFile>(mosyn::io::read_rig(rig_path));
    // Only the root's translation reaches the caller (mosyn_crowd_root): the path goes there.
    rig->rig.translatable.assign(static_cast<size_t>(rig->rig.skeleton.num_joints()), false);
    rig->rig.translatable[0] = true;
    crowd->retarget = std::make_unique<mosyn::StreamingRetarget>(crowd->generator->run().dataset.skeleton,
                                                                 crowd->generator->pose_motion(slot), rig->rig);
    crowd->rig = std::move(rig);
    return MOSYN_OK;
  });
}

int32_t mosyn_crowd_label(const mosyn_crowd* crowd, const char* kind, const char* name) {
  if (!crowd || !kind || !name || !crowd->generator->run().traits.labels) return -1;
  const auto& info = crowd->generator->run().dataset;
  const std::vector<std::string>* vocabulary = nullptr;
  if (std::strcmp(kind, "content") == 0) vocabulary = &info.content_labels;
  if (std::strcmp(kind, "style") == 0) vocabulary = &info.style_labels;
  if (!vocabulary) return -1;
  const auto it = std::find(vocabulary->begin(), vocabulary->end(), name);
  return it == vocabulary->end() ? -1 : static_cast<int32_t>(it - vocabulary->begin());
}

mosyn_status mosyn_crowd_add(mosyn_crowd* crowd, int32_t slot, const mosyn_character* character) {
  if (bad_slot(crowd, slot)) return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_add: bad crowd or slot");
  return guarded([&] {
    mosyn::nn::CharacterOptions c;
    c.seed = character ? character->seed : crowd->seed;
    c.content = character ? character->content : -1;
    c.style = character ? character->style : -1;
    crowd->generator->add(slot, c);
    crowd->pose_valid[slot] = 0;
    return MOSYN_OK;
  });
}

mosyn_status mosyn_crowd_remove(mosyn_crowd* crowd, int32_t slot) {
  if (bad_slot(crowd, slot)) return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_remove: bad crowd or slot");
  return guarded([&] {
    crowd->generator->remove(slot);
    crowd->pose_valid[slot] = 0;
    return MOSYN_OK;
  });
}

int32_t mosyn_crowd_active(const mosyn_crowd* crowd, int32_t slot) {
  return bad_slot(crowd, slot) ? -1 : (crowd->generator->active(slot) ? 1 : 0);
}

mosyn_status mosyn_crowd_step(mosyn_crowd* crowd, const float* controls, size_t count) {
  if (!crowd || !controls) return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_step: crowd and controls must not be NULL");
  const size_t want = static_cast<size_t>(crowd->generator->batch()) * crowd->generator->control_dim();
  if (count != want)
    return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_step: controls must hold capacity x " +
                                            std::to_string(crowd->generator->control_dim()) + " = " +
                                            std::to_string(want) + " floats, got " + std::to_string(count));
  return guarded([&] {
    crowd->generator->step(std::vector<float>(controls, controls + count));
    std::fill(crowd->pose_valid.begin(), crowd->pose_valid.end(), 0);
    return MOSYN_OK;
  });
}

mosyn_status mosyn_crowd_step_stick(mosyn_crowd* crowd, const float* sticks, size_t count) {
  if (!crowd || !sticks) return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_step_stick: crowd and sticks must not be NULL");
  const size_t want = static_cast<size_t>(crowd->generator->batch()) * 3;
  if (count != want)
    return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_step_stick: sticks must hold capacity x 3 = " +
                                            std::to_string(want) + " floats, got " + std::to_string(count));
  return guarded([&] {
    crowd->generator->step_stick(std::vector<float>(sticks, sticks + count));
    std::fill(crowd->pose_valid.begin(), crowd->pose_valid.end(), 0);
    return MOSYN_OK;
  });
}

mosyn_status mosyn_crowd_joint_rotations(const mosyn_crowd* crowd, int32_t slot, float* out_wxyz, size_t count) {
  if (bad_slot(crowd, slot) || !out_wxyz)
    return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_joint_rotations: bad crowd, slot or pointer");
  const size_t want = 4 * static_cast<size_t>(skeleton_of(crowd).num_joints());
  if (count < want)
    return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_joint_rotations: out_wxyz must hold " + std::to_string(want) +
                                            " floats, got " + std::to_string(count));
  return guarded([&] {
    const auto& pose = pose_of(crowd, slot);
    std::copy(pose.rotations_wxyz.begin(), pose.rotations_wxyz.end(), out_wxyz);
    return MOSYN_OK;
  });
}

mosyn_status mosyn_crowd_root(const mosyn_crowd* crowd, int32_t slot, float* out_translation, float* out_floor,
                              float* out_heading_rad) {
  if (bad_slot(crowd, slot)) return fail(MOSYN_INVALID_ARGUMENT, "mosyn_crowd_root: bad crowd or slot");
  return guarded([&] {
    const auto& pose = pose_of(crowd, slot);
    const auto& root = crowd->generator->root(slot);
    const double scale = crowd->retarget ? crowd->retarget->scale() : 1.0;  // model units -> rig units
    for (int i = 0; i < 3; ++i) {
      if (out_translation) out_translation[i] = static_cast<float>(pose.root_translation[i]);
      if (out_floor) out_floor[i] = static_cast<float>(scale * root.position[i]);
    }
    if (out_heading_rad) *out_heading_rad = static_cast<float>(root.heading_rad);
    return MOSYN_OK;
  });
}

}  // extern "C"

#include "nn/sample_job.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/parallel.h"
#include "data/control.h"
#include "data/dataset.h"
#include "data/prepare.h"
#include "io/bvh.h"
#include "io/file_name.h"
#include "nn/generator.h"

namespace mosyn::nn {

namespace {

void check_ranges(const SampleJobOptions& o) {
  const int sources = !o.path.empty() + !o.control_file.empty() + !o.data_dir.empty();
  if (sources > 1) throw InvalidArgument("give at most one of --path, --control and --data");
  if (o.n < 1 || o.n > 10000) throw InvalidArgument("--n must be in [1, 10000]");
  if (!(o.seconds >= 0 && o.seconds <= 3600)) throw InvalidArgument("--seconds must be in [0, 3600]");
  if (!(o.temperature >= 0)) throw InvalidArgument("--temperature must not be negative");
  if (!(o.speed_mps > 0)) throw InvalidArgument("--speed must be positive");
  if (!(o.observed_s > 0) || o.observed_s > 3600) throw InvalidArgument("--observed must be in (0, 3600] seconds");
  if (o.observed_frames == 0 || o.observed_frames < -1) throw InvalidArgument("--observed-frames must be >= 1");
  if (o.warmup_s > 60) throw InvalidArgument("--warmup must be at most 60 seconds");
  if (!(o.control_fps >= 0 && o.control_fps <= 10000)) throw InvalidArgument("--control-fps must be in (0, 10000]");
  if (o.control_fps > 0 && io::extension_of(o.control_file) != "csv")
    throw InvalidArgument("--control-fps is the frame rate of a CSV --control (a BVH gives its own)");
}

// continue_file's observed frames as the plan's prefix; returns the rest of its root motion.
std::vector<float> observe(const LoadedRun& run, const SampleJobOptions& o, SamplePlan& plan) {
  if (!run.traits.prefix)
    throw InvalidArgument(run.run_dir + ": this " + run.family + " model cannot continue a given motion");
  const Clip clip = io::to_clip(io::read_bvh(o.continue_file));
  std::vector<float> pose, control;
  // Output in the file's own world placement: where and facing where its motion starts.
  data::encode_clip_for_dataset(run.dataset, clip, o.continue_file, &pose, &control, &plan.start_position,
                                &plan.start_heading_rad);
  const size_t c = static_cast<size_t>(run.context.control_dim), d = static_cast<size_t>(run.context.pose_dim);
  const int frames = static_cast<int>(control.size() / c);
  const double fps = run.dataset.fps;
  int observed = o.observed_frames > 0 ? o.observed_frames : static_cast<int>(std::lround(o.observed_s * fps));
  observed = std::max(observed, 1);
  if (observed > frames)
    throw Error(o.continue_file + ": " + std::to_string(frames) + " frames at the model's " + std::to_string(fps) +
                " fps, fewer than the " + std::to_string(observed) + " observed frames asked for");
  plan.observed_frames = observed;
  plan.extras.prefix_pose.assign(pose.begin(), pose.begin() + observed * d);
  plan.extras.prefix_control.assign(control.begin(), control.begin() + observed * c);
  return std::vector<float>(control.begin() + observed * c, control.end());
}

// The control of the generated frames, raw [T, C], for a family that takes control.
std::vector<float> given_control(const LoadedRun& run, const SampleJobOptions& o, const std::vector<float>& rest,
                                 SamplePlan& plan) {
  const double fps = run.dataset.fps;
  std::vector<float> control;
  bool from_dataset = false;  // a dataset clip's or the continued file's own (already smoothed) control
  if (!o.control_file.empty()) {
    double heading = 0;
    if (io::extension_of(o.control_file) == "csv")
      control = data::control_from_csv(o.control_file, fps, o.control_fps);
    else
      control = data::control_from_clip(io::to_clip(io::read_bvh(o.control_file)), fps, &heading);
    if (o.continue_file.empty()) plan.start_heading_rad = heading;
    plan.control_description = {{"kind", "file"}, {"file", o.control_file}};
  } else if (!o.data_dir.empty()) {
    const data::Dataset dataset = data::Dataset::open(o.data_dir);
    const auto& clips = dataset.clips(o.split);
    if (o.clip < 0 || o.clip >= static_cast<int>(clips.size()))
      throw InvalidArgument("--clip must be in [0, " + std::to_string(clips.size()) + ") for split '" + o.split + "'");
    control = clips[o.clip].control;
    from_dataset = true;
    plan.control_description = {{"kind", "dataset"}, {"dataset", o.data_dir}, {"split", o.split},
                                {"clip", o.clip},    {"source", clips[o.clip].source}};
  } else if (!o.continue_file.empty() && o.path.empty()) {
    control = rest;  // the rest of the observed file's own root motion
    from_dataset = true;
    plan.control_description = {{"kind", "file"}, {"file", o.continue_file}, {"from_frame", plan.observed_frames}};
    if (control.size() < 2 * static_cast<size_t>(run.context.control_dim) && o.seconds <= 0)
      throw InvalidArgument(o.continue_file + " has no frames after the " + std::to_string(plan.observed_frames) +
                            " observed ones: give --path, --control or --seconds for the continuation");
  } else {
    data::PathOptions po;
    po.speed_mps = o.speed_mps;
    po.fps = fps;
    po.seconds = o.seconds;
    const std::string text = o.path.empty() ? kDefaultSamplePath : o.path;
    std::vector<data::Waypoint> path;
    try {
      path = data::parse_path(text);
    } catch (const Error& e) {
      throw InvalidArgument(std::string("--path: ") + e.what());
    }
    double heading = 0;
    control = data::control_from_path(path, po, &heading);
    // In real time the root trails the path by the controller's delay (about 1 s): 2 s more of
    // standing, unless a duration is given, let it arrive.
    if (o.realtime && o.seconds <= 0) control.resize(control.size() + 3 * static_cast<size_t>(2 * fps), 0.0f);
    if (o.continue_file.empty()) plan.start_heading_rad = heading;
    plan.control_description = {{"kind", "path"}, {"path", text}, {"speed_mps", o.speed_mps}};
  }
  // Paths and files shaped like the run's training controls (its dataset's root smoothing).
  // Not in real time: there the Generator's controller shapes every control causally as it plays.
  if (!from_dataset && !o.realtime) control = data::smooth_control(control, fps, run.dataset.layout.root_smoothing_s);
  return control;
}

}  // namespace

int label_index(const std::vector<std::string>& vocabulary, const std::string& name, const std::string& what) {
  if (name.empty()) return -1;
  for (size_t i = 0; i < vocabulary.size(); ++i)
    if (vocabulary[i] == name) return static_cast<int>(i);
  std::string known;
  for (const auto& v : vocabulary) known += (known.empty() ? "" : ", ") + v;
  throw InvalidArgument("unknown " + what + " '" + name + "'; the run knows: " + (known.empty() ? "none" : known));
}

int translate_label(int id, const std::vector<std::string>& from, const std::vector<std::string>& to) {
  if (id < 0 || id >= static_cast<int>(from.size())) return -1;
  const auto it = std::find(to.begin(), to.end(), from[id]);
  return it == to.end() ? -1 : static_cast<int>(it - to.begin());
}

int warmup_frames(const LoadedRun& run, double warmup_s) {
  return warmup_s >= 0 ? static_cast<int>(std::lround(warmup_s * run.dataset.fps)) : kFamilyWarmup;
}

SamplePlan plan_sample(const LoadedRun& run, const SampleJobOptions& o) {
  if (!run.model)
    throw InvalidArgument(run.run_dir + ": the " + run.family + " family does not generate motion");
  check_ranges(o);
  SamplePlan plan;
  std::vector<float> rest;
  if (!o.continue_file.empty()) rest = observe(run, o, plan);
  const size_t c = static_cast<size_t>(run.context.control_dim);
  const double fps = run.dataset.fps;
  switch (run.traits.control) {
    case InputUse::kTakes:
      plan.control = given_control(run, o, rest, plan);
      // --seconds cuts or extends (standing still) controls from files and datasets too.
      if (o.seconds > 0) plan.control.resize(c * (static_cast<size_t>(o.seconds * fps) + 1), 0.0f);
      break;
    case InputUse::kGenerates:
    case InputUse::kIgnores: {
      if (!o.path.empty() || !o.control_file.empty() || !o.data_dir.empty())
        throw InvalidArgument(run.run_dir + ": the " + run.family +
                              " family makes its own root motion: give --seconds instead of a path or control");
      const double seconds = o.seconds > 0 ? o.seconds : kDefaultGeneratedSeconds;
      plan.control.assign(c * (static_cast<size_t>(seconds * fps) + 1), 0.0f);
      plan.control_description = {{"kind", "generated"}, {"seconds", seconds}};
      break;
    }
  }
  if (plan.control.size() < 2 * c) throw Error("the control has fewer than 2 frames");
  plan.extras.content = label_index(run.dataset.content_labels, o.content, "content label");
  plan.extras.style = label_index(run.dataset.style_labels, o.style, "style label");
  if ((plan.extras.content >= 0 || plan.extras.style >= 0) && !run.traits.labels)
    throw InvalidArgument(run.run_dir + ": this " + run.family +
                          " model was trained without labels; --content and --style need one trained with labels");
  plan.extras.warmup_frames = warmup_frames(run, o.warmup_s);
  plan.extras.raw_root = o.raw_root;
  return plan;
}

std::vector<SampledClip> run_sample(const LoadedRun& run, const SamplePlan& plan, const SampleJobOptions& o) {
  std::vector<SampledMotion> motions =
      o.realtime ? stream_motions(run, plan.control, o.n, o.seed, o.temperature, plan.extras, o.foot_lock)
                 : sample_motions(run, plan.control, o.n, o.seed, o.temperature, plan.extras);
  std::vector<SampledClip> out(motions.size());
  // Decoding (positions to rotations, foot locking) is per motion: spread over the cores.
  parallel_for(static_cast<int>(motions.size()), o.threads > 0 ? o.threads : hardware_threads(), [&](int i) {
    SampledMotion& m = motions[i];
    SampledClip& s = out[i];
    if (plan.observed_frames > 0) {  // observed + continuation
      m.pose.insert(m.pose.begin(), plan.extras.prefix_pose.begin(), plan.extras.prefix_pose.end());
      m.control.insert(m.control.begin(), plan.extras.prefix_control.begin(), plan.extras.prefix_control.end());
    }
    const int frames = static_cast<int>(m.control.size() / run.context.control_dim);
    s.clip = data::decode_features(run.dataset, m.pose.data(), m.control.data(), frames, plan.start_position,
                                   plan.start_heading_rad);
    if (o.foot_lock && !o.realtime) s.clip.motion = foot_lock(s.clip.skeleton, s.clip.motion, {}, &s.foot_lock);
    s.features = std::move(m);
  });
  return out;
}

}  // namespace mosyn::nn

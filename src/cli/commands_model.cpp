// `mosyn train FAMILY` and `mosyn sample RUN_DIR`.
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "cli/cli.h"
#include "core/error.h"
#include "core/foot_lock.h"
#include "core/kinematics.h"
#include "core/parallel.h"
#include "data/control.h"
#include "data/dataset.h"
#include "data/prepare.h"
#include "io/atomic_file.h"
#include "io/bvh.h"
#include "io/gltf.h"
#include "io/json_file.h"
#include "io/npy.h"
#include "io/rig.h"
#include "nn/checkpoint.h"
#include "nn/model.h"
#include "nn/root_planting.h"
#include "nn/run.h"
#include "nn/sample_job.h"
#include "nn/sampling.h"
#include "nn/training/train.h"

namespace mosyn::cli {
namespace {

std::atomic<bool> g_interrupted{false};

extern "C" void on_interrupt(int) { g_interrupted = true; }

struct TrainArgs {
  std::string family;
  std::string config_file;
  std::string preset;
  std::string train_preset;
  nn::TrainOptions options;
  CLI::App* cmd = nullptr;
};

// --train-preset's help: the generic presets and every family's own.
std::string train_preset_help() {
  const std::vector<std::string> generic_names = nn::train_preset_names("");
  std::string text = "named training settings, over --config's and under the other flags: ";
  for (const std::string& name : generic_names) text += name + ", ";
  text += "or a family's own (";
  bool first = true;
  const size_t generic = generic_names.size();
  for (const std::string& family : nn::model_families()) {
    const std::vector<std::string> names = nn::train_preset_names(family);
    if (names.size() == generic) continue;
    text += (first ? "" : "; ") + family + ":";
    first = false;
    for (size_t i = generic; i < names.size(); ++i) text += " " + names[i];
  }
  return text + "); docs/training.md";
}

// The options of a train command: the resumed run's own (with --resume), then the config file
// ({"model": {...}, "train": {...}}; a "preset" there starts its section from that preset), then
// --train-preset's keys, then the other flags given on the command line.
nn::TrainOptions resolve_train_options(const TrainArgs& a) {
  nn::TrainOptions o;
  if (a.options.resume && a.config_file.empty()) {
    // Resuming continues the run's own schedule (steps, lr, warm-up, batch...) unless flags say otherwise.
    const std::string saved = (std::filesystem::path(a.options.out_dir) / "config.json").string();
    if (std::filesystem::exists(saved)) {
      const nlohmann::json run = io::read_json(saved);
      if (run.contains("train")) {
        try {
          o = nn::TrainOptions::from_json(run["train"]);
        } catch (const Error& e) {
          throw Error(saved + ": " + e.what());
        }
        o.init_from.clear();  // the warm start happened when the run began
      }
    }
  }
  if (!a.config_file.empty()) {
    const nlohmann::json file = io::read_json(a.config_file);
    for (const auto& [key, value] : file.items())
      if (key != "model" && key != "train")
        throw Error(a.config_file + ": unknown key '" + key + "'; expected \"model\" and/or \"train\"");
    if (file.contains("train")) {
      const bool preset = file["train"].is_object() && file["train"].contains("preset");
      nlohmann::json merged = preset ? nlohmann::json::object() : o.to_json();
      merged["family"] = a.family;  // whose presets
      merged.update(file["train"]);
      try {
        o = nn::TrainOptions::from_json(merged);
      } catch (const Error& e) {
        throw Error(a.config_file + ": " + e.what());
      }
    }
    if (file.contains("model")) o.model_config = file["model"];
  }
  if (!a.train_preset.empty()) {
    nlohmann::json merged = o.to_json();
    merged.erase("preset");
    merged["family"] = a.family;
    try {
      merged.update(nn::train_preset(a.family, a.train_preset));
    } catch (const Error& e) {
      throw UsageError(std::string("--train-preset: ") + e.what());
    }
    o = nn::TrainOptions::from_json(merged);
    o.preset = a.train_preset;
  }
  const nn::TrainOptions& flags = a.options;
  auto given = [&](const char* name) { return a.cmd->count(name) > 0; };
  o.family = a.family;
  o.data_dir = flags.data_dir;
  o.out_dir = flags.out_dir;
  if (given("--steps")) o.steps = flags.steps;
  if (given("--batch")) o.batch = flags.batch;
  if (given("--window")) o.window = flags.window;
  if (given("--window-sampling")) o.window_sampling = flags.window_sampling;
  if (given("--lr")) o.lr = flags.lr;
  if (given("--warmup")) o.warmup = flags.warmup;
  if (given("--seed")) o.seed = flags.seed;
  if (given("--threads")) o.threads = flags.threads;
  if (given("--device")) o.device = flags.device;
  if (given("--checkpoint-every")) o.checkpoint_every = flags.checkpoint_every;
  if (given("--keep-checkpoints")) o.keep_checkpoints = true;
  if (given("--validate-every")) o.validate_every = flags.validate_every;
  if (given("--init-from")) o.init_from = flags.init_from;
  o.resume = flags.resume;
  o.overwrite = flags.overwrite;
  // One of N processes when a launcher (torchrun, srun, or by hand) set RANK, WORLD_SIZE, ...
  o.distributed = nn::distributed_from_environment();
  if (!a.preset.empty()) o.model_config["preset"] = a.preset;
  if (o.resume && o.overwrite) throw UsageError("--resume and --overwrite exclude each other");
  if (o.resume && !o.init_from.empty()) throw UsageError("--resume and --init-from exclude each other");
  if (o.steps < 1 || o.batch < 1) throw UsageError("--steps and --batch must be at least 1");
  if (!(o.lr > 0)) throw UsageError("--lr must be positive");
  return o;
}

// One progress line: "[stage 2/3 prior 120/500  ]step 620/1500  loss ... lr ... step/s ETA ...".
std::string format_train_progress(const nn::TrainProgress& p) {
  char line[320];
  std::string extra;
  for (const auto& [k, v] : p.metrics) {
    char buf[64];
    std::snprintf(buf, sizeof buf, " %s %.4g", k.c_str(), v);
    extra += buf;
  }
  std::string stage;  // runs of several stages say which one
  if (p.num_stages > 1)
    stage = "stage " + std::to_string(p.stage_index + 1) + "/" + std::to_string(p.num_stages) + " " + p.stage + " " +
            std::to_string(p.stage_step) + "/" + std::to_string(p.stage_steps) + "  ";
  std::snprintf(line, sizeof line, "%sstep %d/%d  loss %.4f%s%s  lr %.2e  %.2f step/s  ETA %s", stage.c_str(), p.step,
                p.total_steps, p.loss, extra.c_str(), p.has_val ? ("  val " + std::to_string(p.val_loss)).c_str() : "",
                p.lr, p.steps_per_s, format_duration(p.eta_s).c_str());
  return line;
}

void run_train(const TrainArgs& a) {
  const nn::TrainOptions o = resolve_train_options(a);
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  ProgressLine progress;
  nn::TrainCallbacks callbacks;
  callbacks.on_message = [&](const std::string& m) {
    progress.finish();
    std::fprintf(stderr, "%s\n", m.c_str());
  };
  callbacks.on_progress = [&](const nn::TrainProgress& p) {
    progress.update(format_train_progress(p), p.has_val || p.stage_step == p.stage_steps);  // kept: validations, stage ends
  };
  callbacks.should_stop = [] { return g_interrupted.load(); };
  const nn::TrainResult r = nn::train(o, callbacks);
  progress.finish();
  if (o.distributed.rank != 0) return;  // rank 0 reports for the group
  if (r.stopped_early)
    std::fprintf(stderr, "interrupted: checkpoint at step %d saved in %s (continue with --resume)\n", r.step,
                 r.run_dir.c_str());
  else
    std::fprintf(stderr, "trained %d steps: last loss %.4f%s; run in %s\n", r.step, r.last_loss,
                 std::isfinite(r.best_val_loss) ? (", best validation loss " + std::to_string(r.best_val_loss)).c_str()
                                                : "",
                 r.run_dir.c_str());
}

struct SampleArgs {
  std::string run_dir, out_dir;
  int n = 4;
  std::uint64_t seed = 0;
  double seconds = 0;
  double temperature = 1.0;
  bool positions = false;
  std::string path, control_file, data_dir, split = "val", checkpoint = "checkpoint.pt", prefix = "sample";
  double control_fps = 0;  // frame rate of a CSV --control without times (0: the run's)
  int clip = -1;
  double speed_mps = 1.3;
  double warmup_s = -1.0;  // < 0: the family's default
  int threads = 0;
  std::string content, style;
  std::string continue_file;  // --continue: observed motion to continue
  double observed_s = 1.0;
  int observed_frames = -1;
  bool foot_lock = false;
  bool raw_root = false;
  bool realtime = false;
  std::string format = "bvh";  // comma-separated: bvh, glb, gltf
  std::string skeleton;        // --skeleton: a rig (BVH or glTF) to write the motions on
};

nn::SampleJobOptions job_options(const SampleArgs& a) {
  nn::SampleJobOptions o;
  o.path = a.path;
  o.speed_mps = a.speed_mps;
  o.control_file = a.control_file;
  o.control_fps = a.control_fps;
  o.data_dir = a.data_dir;
  o.split = a.split;
  o.clip = a.clip;
  o.continue_file = a.continue_file;
  o.observed_s = a.observed_s;
  o.observed_frames = a.observed_frames;
  o.seconds = a.seconds;
  o.content = a.content;
  o.style = a.style;
  o.warmup_s = a.warmup_s;
  o.n = a.n;
  o.seed = a.seed;
  o.temperature = a.temperature;
  o.foot_lock = a.foot_lock;
  o.raw_root = a.raw_root;
  o.realtime = a.realtime;
  o.threads = a.threads;
  return o;
}

struct SampleFormats {
  bool bvh = false;
  std::string gltf_ext;  // "glb", "gltf" or "" for none
};

// --format "bvh,glb": BVH files, and/or one glTF file holding every motion as an animation.
SampleFormats parse_sample_formats(const std::string& text) {
  SampleFormats f;
  for (const std::string& item : split_commas(text)) {
    if (item == "bvh") {
      f.bvh = true;
    } else if (item == "glb" || item == "gltf") {
      if (!f.gltf_ext.empty() && f.gltf_ext != item) throw UsageError("--format: give glb or gltf, not both");
      f.gltf_ext = item;
    } else {
      throw UsageError("--format: unknown format '" + item + "' (bvh, glb, gltf)");
    }
  }
  if (!f.bvh && f.gltf_ext.empty()) throw UsageError("--format: give at least one of bvh, glb, gltf");
  return f;
}

void write_sample_gltf(const std::string& path, const std::vector<const Clip*>& clips, const std::string& prefix,
                       double meters_per_unit) {
  std::vector<io::GltfMotion> motions;
  for (size_t i = 0; i < clips.size(); ++i) {
    char name[64];
    std::snprintf(name, sizeof name, "%s_%03zu", prefix.c_str(), i);
    motions.push_back({name, clips[i]->motion});
  }
  io::GltfOptions options;
  options.meters_per_unit = meters_per_unit;
  io::write_gltf(path, clips.front()->skeleton, motions, options);
}

// The motions to write: the model's own (no copy: 512 characters' clips take a third of a second
// to copy), or with --skeleton each retargeted onto the rig (core/retarget.h, as `mosyn retarget`
// does) and kept in *retargeted; *scale gets the rig's units per model unit.
std::vector<const Clip*> output_clips(const std::vector<nn::SampledClip>& sampled, const io::RigFile* rig,
                                      std::vector<Clip>* retargeted, double* scale) {
  std::vector<const Clip*> out;
  if (rig != nullptr) {
    retargeted->reserve(sampled.size());
    for (const nn::SampledClip& s : sampled) {
      RetargetReport report;
      retargeted->push_back({rig->rig.skeleton, retarget(s.clip.skeleton, s.clip.motion, rig->rig, {}, &report)});
      retargeted->back().skeleton.meters_per_unit = rig->meters_per_unit;
      *scale = report.scale;
    }
    for (const Clip& c : *retargeted) out.push_back(&c);
  } else {
    for (const nn::SampledClip& s : sampled) out.push_back(&s.clip);
  }
  return out;
}

void run_sample(const SampleArgs& a) {
  const SampleFormats formats = parse_sample_formats(a.format);  // usage errors before the model loads
  std::optional<io::RigFile> rig;
  if (!a.skeleton.empty()) rig = io::read_rig(a.skeleton);  // input errors before the model loads, too
  const nn::SampleJobOptions options = job_options(a);
  nn::LoadOptions load;
  load.checkpoint = a.checkpoint;
  load.threads = a.threads;
  const nn::LoadedRun run = nn::load_run(a.run_dir, load);
  const nn::SamplePlan plan = nn::plan_sample(run, options);
  const std::vector<nn::SampledClip> sampled = nn::run_sample(run, plan, options);
  double rig_scale = 1;
  std::vector<Clip> retargeted;
  const std::vector<const Clip*> clips = output_clips(sampled, rig ? &*rig : nullptr, &retargeted, &rig_scale);
  const double fps = run.dataset.fps;
  const int total_frames = sampled.front().clip.motion.num_frames;
  std::filesystem::create_directories(a.out_dir);
  const std::string gltf_name = formats.gltf_ext.empty() ? "" : a.prefix + "." + formats.gltf_ext;
  // Every motion's files apart from the others': written on the cores --threads allows. Each file
  // is synced to disk before it replaces its name (io/atomic_file.h), which waits on the disk, not
  // the cores: with all cores allowed, four writers per core keep the cores busy through the
  // waits (a 512-crowd's 1,024 files: 0.3 s sooner, of 7.6).
  constexpr int kWritersPerCore = 4;
  parallel_for(a.n, a.threads > 0 ? a.threads : kWritersPerCore * hardware_threads(), [&](int i) {
    char name[64];
    std::snprintf(name, sizeof name, "%s_%03d", a.prefix.c_str(), i);
    const std::string base = (std::filesystem::path(a.out_dir) / name).string();
    const Clip& clip = *clips[i];
    const FootLockReport& lock = sampled[i].foot_lock;
    if (formats.bvh) io::write_bvh(base + ".bvh", io::from_clip(clip, rig && rig->bvh ? &*rig->bvh : nullptr));
    if (a.positions) {
      io::write_positions_npy(base + ".npy", total_frames, clip.skeleton.num_joints(),
                              forward_kinematics(clip.skeleton, clip.motion).positions, clip.skeleton.meters_per_unit);
    }
    nlohmann::json sidecar = {{"model", {{"run_dir", a.run_dir}, {"family", run.family}, {"step", run.step},
                                         {"checkpoint", a.checkpoint}}},
                              {"seed", a.seed},
                              {"sample_index", i},
                              {"num_samples", a.n},
                              {"temperature", a.temperature},
                              {"fps", fps},
                              {"frames", total_frames},
                              {"control", plan.control_description},
                              {"continued", a.continue_file.empty()
                                                ? nlohmann::json(nullptr)
                                                : nlohmann::json{{"file", a.continue_file},
                                                                 {"observed_frames", plan.observed_frames}}},
                              {"content", a.content},
                              {"style", a.style},
                              {"root_planted", nn::plants_root(run, a.raw_root)},
                              {"foot_lock", a.foot_lock ? nlohmann::json{{"contacts", lock.contacts},
                                                                         {"max_correction_m", lock.max_correction_m}}
                                                        : nlohmann::json(nullptr)},
                              {"positions_npy", a.positions ? name + std::string(".npy") : ""}};
    if (!gltf_name.empty()) sidecar["gltf"] = {{"file", gltf_name}, {"animation", i}};
    if (rig) sidecar["skeleton"] = {{"file", a.skeleton}, {"scale", rig_scale}};
    io::write_json(base + ".json", sidecar);
  });
  if (!gltf_name.empty())
    write_sample_gltf((std::filesystem::path(a.out_dir) / gltf_name).string(), clips, a.prefix,
                      rig ? rig->meters_per_unit : 0.0);
  for (const nn::SampleStageTiming& stage : run.model->last_sample_timings())
    if (stage.steps > 0 && stage.rows > 0)
      std::fprintf(stderr, "%s: %.1f ms per predicted frame (%ld samples together), %.2f ms per sample-frame, %.2f s in all\n",
                   stage.stage.c_str(), 1e3 * stage.seconds / stage.steps, stage.rows / stage.steps,
                   1e3 * stage.seconds / stage.rows, stage.seconds);
  const int observed = plan.observed_frames;
  std::fprintf(stderr, "wrote %d motions of %d frames (%.1f s%s) to %s\n", a.n, total_frames, (total_frames - 1) / fps,
               observed > 0 ? (", the first " + std::to_string(observed) + " observed").c_str() : "", a.out_dir.c_str());
}

struct ExportArgs {
  std::string run_dir, out_dir, checkpoint = "best.pt";
  bool overwrite = false;
  bool half = false;
  std::vector<std::string> average;
  std::string root_planting;  // JSON object for config.json's "root_planting" ("" = as the run's)
};

// The run's config with --root-planting's section (checked as load_run reads it).
nlohmann::json with_root_planting(nlohmann::json config, const std::string& root_planting) {
  try {
    config["root_planting"] = nlohmann::json::parse(root_planting);
  } catch (const std::exception& e) {
    throw UsageError(std::string("--root-planting: not JSON (") + e.what() + "); e.g. '{}' for the defaults");
  }
  nn::root_planting_from_config(config, "--root-planting");
  return config;
}

// A run directory without optimiser state: what ships under models/.
void run_export(const ExportArgs& e) {
  namespace fs = std::filesystem;
  if (fs::exists(e.out_dir) && !fs::is_empty(e.out_dir) && !e.overwrite)
    throw Error(e.out_dir + ": already exists and is not empty (add --overwrite to replace its model files)");
  nn::LoadOptions load;
  load.checkpoint = e.checkpoint;
  const nn::LoadedRun run = nn::load_run(e.run_dir, load);
  const std::optional<nlohmann::json> config =
      e.root_planting.empty() ? std::nullopt : std::optional(with_root_planting(run.config, e.root_planting));
  // Stochastic weight averaging: the mean of --checkpoint's weights and each averaged file's, all
  // loaded into this run's model (so of its family and config).
  for (size_t k = 0; k < e.average.size(); ++k) {
    nn::LoadOptions other_load;
    other_load.checkpoint = fs::absolute(e.average[k]).string();
    const nn::LoadedRun other = nn::load_run(e.run_dir, other_load);
    nn::fold_into_mean(*run.trainable, *other.trainable, static_cast<int>(k) + 1);
  }
  fs::create_directories(e.out_dir);
  for (const char* name : {"config.json", "stats.json", "log.jsonl"}) {
    const fs::path from = fs::path(e.run_dir) / name, to = fs::path(e.out_dir) / name;
    if (config && from.filename() == "config.json") io::write_json(to.string(), *config);
    else if (fs::exists(from)) io::write_file_atomically(to.string(), io::read_file(from.string()));
  }
  nn::CheckpointState state;
  state.step = run.step;
  if (e.half) nn::narrow_to_half(*run.trainable);
  nn::save_checkpoint((fs::path(e.out_dir) / "checkpoint.pt").string(), *run.trainable, nullptr, state);
  const std::string averaged =
      e.average.empty() ? "" : ", averaged with " + std::to_string(e.average.size()) + " more checkpoints";
  std::fprintf(stderr, "exported step %d of %s (%s) to %s/checkpoint.pt (weights only%s%s)\n", run.step,
               e.run_dir.c_str(), e.checkpoint.c_str(), e.out_dir.c_str(), e.half ? ", float16" : "", averaged.c_str());
}


void add_train_command(CLI::App& app, Action* action) {
  auto t = std::make_shared<TrainArgs>();
  CLI::App* train = app.add_subcommand("train", "Train a model family on a prepared dataset into a run directory");
  t->cmd = train;
  nn::TrainOptions& o = t->options;
  train->add_option("family", t->family, "model family: " + [] {
    std::string s;
    for (const auto& f : nn::model_families()) s += (s.empty() ? "" : ", ") + f;
    return s;
  }())->required();
  train->add_option("--data", o.data_dir, "prepared dataset directory (mosyn data prepare)")->required();
  train->add_option("--out,-o", o.out_dir, "run directory to create (or continue with --resume)")->required();
  train->add_option("--config", t->config_file, "JSON file {\"model\": {...}, \"train\": {...}}; flags override it");
  train->add_option("--preset", t->preset, "named model preset, e.g. 'paper' for MoGlow's published size");
  train->add_option("--train-preset", t->train_preset, train_preset_help());
  train->add_option("--steps", o.steps, "total optimiser steps")->capture_default_str();
  train->add_option("--batch", o.batch, "windows per batch (global: shared by the processes of a data-parallel run)")
      ->capture_default_str();
  train->add_option("--window", o.window, "frames per training window (0: the dataset's)");
  train->add_option("--window-sampling", o.window_sampling,
                    "how windows are drawn: 'windows' (all alike: long clips weigh more) or 'frames' (each clip "
                    "in proportion to its frames)")
      ->check(CLI::IsMember({"windows", "frames"}))
      ->capture_default_str();
  train->add_option("--lr", o.lr, "peak learning rate (Adam)")->capture_default_str();
  train->add_option("--warmup", o.warmup, "Noam warm-up steps (0: constant learning rate)")->capture_default_str();
  train->add_option("--seed", o.seed, "seed of initialisation, data order and dropout")->capture_default_str();
  train->add_option("--threads", o.threads, "CPU threads (default: all cores)");
  train->add_option("--device", o.device, "cpu or cuda")->capture_default_str();
  train->add_option("--checkpoint-every", o.checkpoint_every, "steps between checkpoints")->capture_default_str();
  train->add_flag("--keep-checkpoints", o.keep_checkpoints,
                  "also keep every checkpoint as checkpoint-STEP.pt, to export or average any of them later");
  train->add_option("--validate-every", o.validate_every, "steps between validations")->capture_default_str();
  train->add_flag("--resume", o.resume, "continue the run in --out exactly where it stopped");
  train->add_option("--init-from", o.init_from,
                    "warm start from a run or shipped model directory of the same family: its weights and model "
                    "config (overridden by --config/--preset), a fresh optimiser and step count")
      ->check(CLI::ExistingDirectory);
  train->add_flag("--overwrite", o.overwrite, "replace an existing run in --out");
  train->footer(
      "Data-parallel: run N copies with RANK, WORLD_SIZE, MASTER_ADDR, MASTER_PORT set (torchrun --no-python, srun, "
      "or by hand); --batch is the global batch, rank 0 writes the run (docs/training.md: Training on several processes or machines).");
  train->callback([action, t] { *action = [t] { run_train(*t); }; });
}

void add_sample_command(CLI::App& app, Action* action) {
  auto s = std::make_shared<SampleArgs>();
  CLI::App* sample = app.add_subcommand(
      "sample", "Draw N different motions from a trained run along a path, a control file or a dataset clip");
  sample->add_option("run_dir", s->run_dir, "run directory (mosyn train) or a shipped model under models/")->required();
  sample->add_option("--out,-o", s->out_dir, "folder for the BVH (+ NPY) files and their JSON sidecars")->required();
  sample->add_option("--n", s->n, "number of motions")->capture_default_str();
  sample->add_option("--seed", s->seed, "random seed: the same seed and inputs give identical files")
      ->capture_default_str();
  sample->add_option("--seconds", s->seconds, "duration in seconds (default: as long as the control)");
  sample->add_option("--temperature", s->temperature, "latent noise scale (1: the model's distribution)")
      ->capture_default_str();
  sample->add_flag("--positions", s->positions, "also write world joint positions in metres as NPY [T,J,3]");
  sample->add_option("--path", s->path,
                     "ground path 'x,z x,z ...' in metres (a third number 'x,z,s' stands s seconds there; "
                     "one point stands still); default '0,0 0,4 3,7'");
  sample->add_option("--speed", s->speed_mps, "walking speed along --path, m/s")->capture_default_str();
  sample->add_option("--control", s->control_file,
                     "BVH whose root motion is reused, or CSV of dx,dz,dtheta per frame (with a t_s column of "
                     "frame times it is resampled to the model's rate; `mosyn convert --control` writes one)");
  sample->add_option("--control-fps", s->control_fps,
                     "frame rate of a CSV --control without a t_s column (default: the model's)");
  sample->add_option("--data", s->data_dir, "take the control of a dataset clip (with --clip, --split)");
  sample->add_option("--split", s->split, "dataset split for --data")->capture_default_str();
  sample->add_option("--clip", s->clip, "clip index in the split for --data");
  sample->add_option("--warmup", s->warmup_s,
                     "seconds generated first along the control's first step and dropped, so motion starts from a "
                     "natural pose already doing what the control starts with (walking for a clip's control and "
                     "for a --path, whose filtered start moves at about half its speed); default: the run's: moglow its lead_in_s, 1 unless its config sets one; 0 for rvae")
      ->check(CLI::Range(0.0, 60.0));
  sample->add_option("--content", s->content, "content label, for label-conditioned families");
  sample->add_option("--style", s->style, "style label, for label-conditioned families");
  sample->add_option("--checkpoint", s->checkpoint, "checkpoint file in the run directory (e.g. best.pt)")
      ->capture_default_str();
  sample->add_option("--continue", s->continue_file,
                     "BVH on the run's skeleton to continue: its first --observed seconds are kept and the motion "
                     "goes on along --path/--control (default: the rest of the file's own root motion)");
  sample->add_option("--observed", s->observed_s, "--continue: seconds of the file observed")->capture_default_str();
  sample->add_option("--observed-frames", s->observed_frames,
                     "--continue: frames of the file observed (overrides --observed; e.g. 4 as Habibie et al.)");
  sample->add_option("--prefix", s->prefix, "output file name prefix")->capture_default_str();
  sample->add_option("--format", s->format,
                     "comma-separated: bvh (PREFIX_000.bvh ...), glb or gltf (one PREFIX.glb with every motion as an "
                     "animation of a skinned body, metres, Y up)")
      ->capture_default_str();
  sample->add_option("--skeleton", s->skeleton,
                     "write the motions on this rig (.bvh or .glb/.gltf) instead of the model's skeleton, as "
                     "`mosyn retarget` does: its joints, offsets and channels; path scaled by leg length, feet planted");
  sample->add_flag("--foot-lock", s->foot_lock,
                   "post-process: pin each foot contact to one floor position by two-bone IK (off: the model's raw "
                   "motion)");
  sample->add_flag("--raw-root", s->raw_root,
                   "keep the root steps a model makes itself as it makes them, where its run plants them on the "
                   "feet (config.json's root_planting; for comparisons)");
  sample->add_flag("--realtime", s->realtime,
                   "play the control frame by frame through the real-time Generator (as the C ABI and serve): frame "
                   "t sees the control up to t only, a path is shaped causally as it plays");
  sample->add_option("--threads", s->threads, "CPU threads (default: all cores)");
  sample->callback([action, s] { *action = [s] { run_sample(*s); }; });
}

void add_export_command(CLI::App& app, Action* action) {
  auto e = std::make_shared<ExportArgs>();
  CLI::App* exp = app.add_subcommand(
      "export", "Copy a run's config, statistics, log and weights (no optimiser state) to a model directory to ship");
  exp->add_option("run_dir", e->run_dir, "trained run directory")->required();
  exp->add_option("--out,-o", e->out_dir, "model directory to write (usable as RUN_DIR of sample)")->required();
  exp->add_option("--checkpoint", e->checkpoint, "checkpoint to export")->capture_default_str();
  exp->add_flag("--overwrite", e->overwrite, "replace the model files in an existing --out");
  exp->add_flag("--half", e->half, "store weights as float16 (half the size; computed in float32 when loaded)");
  exp->add_option("--average", e->average,
                  "checkpoint files of this run's config whose weights are averaged with --checkpoint's "
                  "(stochastic weight averaging)");
  exp->add_option("--root-planting", e->root_planting,
                  "JSON object written as config.json's root_planting ('{}' for the defaults): sampling takes the "
                  "root steps of a family that makes its own root motion from its planted feet (nn/root_planting.h)");
  exp->callback([action, e] { *action = [e] { run_export(*e); }; });
}

}  // namespace

void add_model_commands(CLI::App& app, Action* action) {
  add_train_command(app, action);
  add_sample_command(app, action);
  add_export_command(app, action);
}

}  // namespace mosyn::cli

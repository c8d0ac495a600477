// `mosyn data prepare` and `mosyn data info`.
#include <chrono>
#include <cstdio>
#include <memory>

#include "cli/cli.h"
#include "data/dataset.h"
#include "data/prepare.h"

namespace mosyn::cli {
namespace {

struct PrepareArgs {
  data::PrepareOptions options;
  std::string form = "rotations";
  std::string tpose = "auto";
  std::string contents, styles, drop_joints, joints;
  bool drop_fingers = false;
};

void run_prepare(PrepareArgs& a) {
  data::PrepareOptions& o = a.options;
  try {
    o.form = data::parse_pose_form(a.form);
    o.tpose = data::parse_tpose_mode(a.tpose);
  } catch (const std::exception& e) {
    throw UsageError(e.what());
  }
  if (o.window_frames < 2) throw UsageError("--window must be at least 2 frames");
  if (o.window_hop < 1) throw UsageError("--hop must be at least 1 frame");
  if (o.val_fraction < 0 || o.val_fraction >= 1) throw UsageError("--val must be in [0, 1)");
  if (o.threads < 1) throw UsageError("--threads must be at least 1");
  if (o.fps < 0) throw UsageError("--fps must be positive");
  o.contents = split_commas(a.contents);
  o.styles = split_commas(a.styles);
  o.drop_joint_patterns = split_commas(a.drop_joints);
  o.keep_joint_patterns = split_commas(a.joints);
  if (a.drop_fingers)
    for (const char* p : {"*Thumb*", "*Index*", "*Middle*", "*Ring*", "*Pinky*", "*HandEnd*", "*Finger*"})
      o.drop_joint_patterns.push_back(p);

  ProgressLine progress;
  const auto start = std::chrono::steady_clock::now();
  const data::DatasetInfo info = data::prepare_dataset(o, [&](const data::PrepareProgress& p) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char line[256];
    std::snprintf(line, sizeof line, "%-6s %d/%d files  %s", p.stage.c_str(), p.files_done, p.files_total,
                  format_duration(elapsed).c_str());
    progress.update(line, p.files_done == p.files_total);
  });
  progress.finish();
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "prepared %s in %s: %zu train files, %zu validation files\n", o.output_dir.c_str(),
               format_duration(elapsed).c_str(), info.train_files.size(), info.val_files.size());
  std::printf("%s", data::dataset_summary(data::Dataset::open(o.output_dir)).c_str());
}


// `data prepare`'s augmentation flags (PrepareOptions: mirror, reverse, retime, rest ends).
void add_augmentation_options(CLI::App* prep, data::PrepareOptions* o) {
  prep->add_flag("--mirror", o->mirror, "add left/right mirrored copies (labels swapped accordingly)");
  prep->add_flag("--reverse", o->reverse, "add time-reversed copies");
  prep->add_option("--retime", o->retime_factors,
                   "add copies of every clip played this many times as fast, comma-separated (e.g. 1.2,1.4: walks "
                   "faster than the takes; cadence scales, feet stay planted)")
      ->delimiter(',');
  prep->add_option("--retime-min-speed", o->retime_min_speed_mps,
                   "retime only clips whose mean root speed is at least this many m/s (0 = no bound): the fastest "
                   "walks played faster widen the speeds without a second cadence at speeds the takes cover")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  prep->add_option("--retime-max-speed", o->retime_max_speed_mps,
                   "retime only clips whose mean root speed is at most this many m/s (0 = no bound), e.g. to leave "
                   "runs out")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  prep->add_option("--rest-ends", o->rest_hold_s,
                   "add two copies of every clip, one starting from rest and one coming to rest at its "
                   "double-support frame, the still pose held this many seconds (0 = none): takes that begin and "
                   "end in stride teach no stop")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 60.0));
  prep->add_option("--rest-fraction", o->rest_fraction,
                   "--rest-ends: the share of those copies kept (each clip copy and end chosen by a hash of its "
                   "file, the same on every run)")
      ->capture_default_str()
      ->check(CLI::Validator(
          [](std::string& value) {
            double f = 0;
            const bool number = CLI::detail::lexical_cast(value, f);
            return number && f > 0 && f <= 1 ? std::string() : "must lie in (0, 1], got " + value;
          },
          "(0, 1]"));
  prep->add_option("--rest-ramp", o->rest_ramp_s,
                   "--rest-ends: seconds over which the speed falls to rest (rises from it), linearly")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10.0));
}

// `data prepare`: every PrepareOptions field as a flag.
void add_prepare_command(CLI::App* data_cmd, Action* action) {
  auto a = std::make_shared<PrepareArgs>();
  data::PrepareOptions& o = a->options;
  o.threads = default_threads();
  CLI::App* prep = data_cmd->add_subcommand(
      "prepare",
      "BVH folder(s) -> dataset directory: resampling, T-pose removal, joint subset, windows, augmentation, "
      "statistics, label vocabularies, train/validation split by file, binary cache");
  prep->add_option("input", o.input_dirs,
                   "source folder(s): Bandai-Namco layout (cfg/ + data/*.bvh + .json labels), CMU subset layout "
                   "(index.csv + bvh/), or a plain folder of BVH")
      ->required()
      ->check(CLI::ExistingDirectory);
  prep->add_option("--out,-o", o.output_dir, "dataset directory to write")->required();
  prep->add_option("--form", a->form, "pose form: rotations (joint rotations, writes BVH), positions (joint positions) or markers (41 CMU surface markers, MOJO)")
      ->capture_default_str();
  prep->add_option("--fps", o.fps, "target frame rate (default: keep the files' own)");
  prep->add_option("--root-smoothing", o.root_smoothing_s,
                   "standard deviation in seconds of the Gaussian filter on the hip trajectory that becomes the "
                   "control (MoGlow Sec. 4.1); 0 = raw hip motion, whose gait rhythm models then read from the control")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10.0));
  prep->add_option("--window", o.window_frames, "training window length in frames")->capture_default_str();
  prep->add_option("--hop", o.window_hop, "frames between window starts (overlap = window - hop)")
      ->capture_default_str();
  add_augmentation_options(prep, &o);
  prep->add_option("--stats-from", o.stats_from,
                   "standardise with the stats.json of this dataset or run directory instead of this dataset's own "
                   "(same features), so a model warm-started from that run keeps its input units")
      ->check(CLI::ExistingDirectory);
  prep->add_option("--split-from", o.split_from,
                   "keep the file split of this dataset or run directory: its held-out files stay held out, its "
                   "training files in training (new files are split by --val and --seed)")
      ->check(CLI::ExistingDirectory);
  prep->add_option("--val", o.val_fraction, "fraction of files held out for validation")->capture_default_str();
  prep->add_option("--seed", o.seed, "seed of the train/validation split")->capture_default_str();
  prep->add_option("--contents", a->contents, "keep only these content labels, comma-separated (e.g. walk,run)");
  prep->add_option("--styles", a->styles, "keep only these style labels, comma-separated");
  prep->add_option("--joints", a->joints, "keep only joints matching these comma-separated globs (+ the root)");
  prep->add_option("--drop-joints", a->drop_joints, "drop joints matching these comma-separated globs");
  prep->add_flag("--drop-fingers", a->drop_fingers, "drop finger and thumb joints");
  prep->add_option("--tpose", a->tpose, "drop a converter T-pose in frame 0: auto, on or off")->capture_default_str();
  prep->add_option("--units-m", o.meters_per_unit, "metres per file unit (default: guessed from body size)");
  prep->add_option("--max-train-seconds", o.max_train_seconds,
                   "keep at most this much original training motion (files in order, the last cut; DFN's "
                   "limited-data runs)");
  prep->add_option("--threads", o.threads, "parsing threads (default: all cores)");
  prep->add_flag("--overwrite", o.overwrite, "replace an existing dataset in --out");
  prep->callback([action, a] { *action = [a] { run_prepare(*a); }; });
}

// `data info` and `data synth`.
void add_info_and_synth_commands(CLI::App* data_cmd, Action* action) {
  auto dir = std::make_shared<std::string>();
  CLI::App* info = data_cmd->add_subcommand("info", "Print a dataset's size, feature dimensions and labels");
  info->add_option("dataset", *dir, "dataset directory")->required();
  info->callback([action, dir] {
    *action = [dir] { std::printf("%s", data::dataset_summary(data::Dataset::open(*dir)).c_str()); };
  });

  struct SynthArgs {
    std::string out;
    int takes = 2, frames = 90;
    std::uint64_t seed = 1;
  };
  auto sy = std::make_shared<SynthArgs>();
  CLI::App* synth = data_cmd->add_subcommand(
      "synth", "Write a small Bandai-Namco-like folder of synthetic labelled walks (BVH + labels), for tests and trials");
  synth->add_option("out", sy->out, "folder to write")->required();
  synth->add_option("--takes", sy->takes, "takes per (content, style) pair")->capture_default_str()->check(
      CLI::Range(1, 100));
  synth->add_option("--frames", sy->frames, "frames per take at 30 fps")->capture_default_str()->check(
      CLI::Range(2, 100000));
  synth->add_option("--seed", sy->seed, "random seed")->capture_default_str();
  synth->callback([action, sy] {
    *action = [sy] {
      data::write_synthetic_source(sy->out, sy->takes, sy->frames, sy->seed);
      std::fprintf(stderr, "wrote synthetic takes to %s\n", sy->out.c_str());
    };
  });
}

}  // namespace

void add_data_commands(CLI::App& app, Action* action) {
  CLI::App* data_cmd = app.add_subcommand("data", "Prepare and inspect training datasets");
  data_cmd->require_subcommand(1);
  add_prepare_command(data_cmd, action);
  add_info_and_synth_commands(data_cmd, action);
}

}  // namespace mosyn::cli

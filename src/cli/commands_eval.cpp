// `mosyn eval` and `mosyn report`: a trained run scored against held-out data, and its HTML page;
// `mosyn compare` (commands_compare.cpp) is registered here too.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli/cli.h"
#include "core/error.h"
#include "data/control.h"
#include "data/dataset.h"
#include "eval/evaluate.h"
#include "eval/report.h"
#include "io/atomic_file.h"
#include "io/json_file.h"
#include "nn/run.h"
#include "nn/sampling.h"
#include "render/image_io.h"
#include "render/plot.h"
#include "render/scene.h"
#include "render/view.h"

namespace mosyn::cli {
namespace {

struct EvalArgs {
  std::string run_dir, data_dir, out, classifier;
  eval::EvalOptions options;
  std::string foot_joints, protocols;
  bool no_prediction = false;
  bool no_labels = false;
  bool no_joint_errors = false;
  std::string plot;  // PNG of the curves
};

// DFN's Fig. 9 from the evaluation's curves: each prefix's distance to the per-frame mean pose over
// time (s, x axis; metres, y axis) with its spread, over the training data's level as a band.
void write_curves_plot(const eval::EvalResult& r, const std::string& path) {
  if (r.curves.empty()) throw Error(path + ": the evaluation made no curve to plot (no prefix generation ran)");
  std::vector<render::PlotSeries> series;
  std::vector<render::PlotBand> bands;
  for (size_t k = 0; k < r.curves.size(); ++k) {
    const eval::EvalCurve& c = r.curves[k];
    render::PlotSeries s;
    for (size_t t = 0; t < c.mean.size(); ++t) s.x.push_back(t / c.fps);
    s.y = c.mean;
    s.spread = c.spread;
    s.color = render::motion_color(static_cast<int>(k));
    s.spread_alpha = 0.12;
    series.push_back(std::move(s));
  }
  if (std::isfinite(r.curves[0].reference_mean))
    bands.push_back({r.curves[0].reference_mean, r.curves[0].reference_spread});
  render::write_png(path, render::plot_series(series, bands));
  std::fprintf(stderr,
               "wrote %s (x: seconds from the first observed frame; y: metres; grey band: training data, "
               "mean +- std)\n",
               path.c_str());
}

void run_eval(EvalArgs a) {
  eval::EvalOptions& o = a.options;
  if (o.split != "val" && o.split != "train") throw UsageError("--split must be val or train");
  if (o.num_samples < 1 || o.num_samples > 1000) throw UsageError("--n must be in [1, 1000]");
  if (o.max_clips < 0) throw UsageError("--max-clips must not be negative");
  if (!(o.temperature >= 0)) throw UsageError("--temperature must not be negative");
  if (!(o.prefix_s > 0) || !(o.horizon_s > 0)) throw UsageError("--prefix and --horizon must be positive");
  const std::vector<std::string> feet = split_commas(a.foot_joints);
  if (!feet.empty() && feet.size() != 2 && feet.size() != 4)
    throw UsageError("--foot-joints takes 2 names (left, right heel) or 4 (heels, then toes)");
  o.metrics.foot_joints = feet;
  o.only_protocols = split_commas(a.protocols);
  o.prediction = !a.no_prediction;
  o.clip_labels = !a.no_labels;
  o.joint_errors = !a.no_joint_errors;
  if (!(o.error_frames_fps > 0)) throw UsageError("--error-fps must be positive");
  if (o.initial_frames < 1) throw UsageError("--initial-frames must be >= 1");
  if (!(o.long_horizon_s >= 0) || !(o.long_horizon_window_s > 0))
    throw UsageError("--long-horizon must not be negative and --long-horizon-window must be positive");
  if (!(o.prefix_generation_s >= 0) || o.prefix_generation_frames < 1 || o.prefix_generation_clips < 1 ||
      !(o.transition_window_s >= 0))
    throw UsageError("--prefix-generation must not be negative; --prefix-frames and --prefix-clips must be >= 1; "
                     "--transition-window must not be negative");
  if (o.label_samples < 0 || o.label_samples > 100000 || !(o.label_seconds >= 0) || o.label_seconds > 3600)
    throw UsageError("--label-samples must be in [0, 100000] and --label-seconds in [0, 3600]");
  if (o.label_samples > 0 && a.classifier.empty())
    throw UsageError("--label-samples needs --classifier (an evaluation classifier run)");
  if (!a.plot.empty() && !(o.prefix_generation_s > 0))
    throw UsageError("--plot draws the curves of --prefix-generation: give it too");
  o.classifier_dir = a.classifier;
  const data::Dataset dataset = data::Dataset::open(a.data_dir);
  ProgressLine progress;
  const eval::EvalResult r = eval::evaluate(a.run_dir, dataset, o, [&](const eval::EvalProgress& p) {
    progress.update(p.stage + " " + std::to_string(p.done) + "/" + std::to_string(p.total), p.done == p.total);
  });
  progress.finish();
  std::printf("%s", eval::format_markdown(r).c_str());
  if (!a.out.empty()) {
    nlohmann::json j = r.to_json();
    j["data"] = a.data_dir;
    if (!a.classifier.empty()) j["classifier"] = a.classifier;
    io::write_json(a.out, j);
    std::fprintf(stderr, "wrote %s\n", a.out.c_str());
  }
  if (!a.plot.empty()) write_curves_plot(r, a.plot);
}

// ---------------------------------------------------------------------------------------------
// report

struct ReportArgs {
  std::string run_dir, metrics, samples, out;
  int threads = 0;
};

void run_report(const ReportArgs& a) {
  namespace fs = std::filesystem;
  const std::string ext = extension_of(a.out);
  if (ext != "html" && ext != "htm") throw UsageError("--out must end in .html");
  const fs::path run(a.run_dir);
  if (!fs::exists(run / "config.json")) throw Error(a.run_dir + ": not a run directory (no config.json): give the --out folder of `mosyn train`, or a model "
                "of models/ (models/README.md)");
  eval::ReportInputs in;
  in.title = "mosyn run " + fs::absolute(run).lexically_normal().string();
  in.config = io::read_json((run / "config.json").string());
  if (fs::exists(run / "log.jsonl")) in.curve = eval::read_training_log((run / "log.jsonl").string());
  const std::string metrics_path =
      !a.metrics.empty() ? a.metrics : fs::exists(run / "metrics.json") ? (run / "metrics.json").string() : "";
  if (!metrics_path.empty()) in.metrics = eval::EvalResult::from_json(io::read_json(metrics_path));

  std::vector<render::RenderMotion> motions;
  if (!a.samples.empty()) {
    if (!fs::is_directory(a.samples)) throw UsageError("--samples must be a folder of BVH files");
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(a.samples))
      if (e.is_regular_file() && extension_of(e.path().string()) == "bvh") files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    if (files.empty()) throw UsageError("--samples: no .bvh file in " + a.samples);
    const auto clips = read_clips(files);
    for (size_t i = 0; i < clips.size(); ++i)
      motions.push_back(render::render_motion_from_clip(clips[i], render::motion_color(static_cast<int>(i)), 0.0,
                                                        base_name(files[i])));
  } else {
    // Three short motions along a gentle curve, sampled here. A classifier run does not generate
    // motion, and the page says so instead.
    nn::LoadOptions load;
    load.threads = a.threads;
    const nn::LoadedRun loaded = nn::load_run(a.run_dir, load);
    data::PathOptions po;
    po.fps = loaded.dataset.fps;
    po.seconds = 4.0;
    const auto control = data::control_from_path(data::parse_path("0,0 0,2 1.5,4"), po);
    if (!loaded.model) {
      in.viewer_note = "No samples: the " + loaded.family + " family does not generate motion.";
    } else {
      const auto motions_made = nn::sample_motions(loaded, control, 3, 1);
      for (size_t i = 0; i < motions_made.size(); ++i)
        motions.push_back(render::render_motion_from_clip(nn::decode_motion(loaded, motions_made[i]),
                                                          render::motion_color(static_cast<int>(i)), 0.0,
                                                          "sample " + std::to_string(i + 1)));
    }
  }
  if (!motions.empty()) {
    if (render::viewer_available()) {
      in.viewer_page = render::viewer_page(motions, "samples");
      in.viewer_note = std::to_string(motions.size()) + " motions; drag to orbit the camera.";
    } else {
      in.viewer_note = "The browser viewer is not available: mosyn was built without npm/node.";
    }
  }
  io::write_file_atomically(a.out, eval::report_html(in));
  std::fprintf(stderr, "wrote %s: open file://%s in a browser\n", a.out.c_str(),
               fs::absolute(a.out).lexically_normal().c_str());
}


}  // namespace

// `mosyn compare` (commands_compare.cpp), registered with the other eval commands.
void add_compare_command(CLI::App& app, Action* action);

namespace {

void add_eval_command(CLI::App& app, Action* action) {
  auto a = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand(
      "eval",
      "Score a trained run on held-out data: N samples per held-out control, every metric on the samples and on "
      "the real clips (footsteps, skating, bone lengths, diversity, prediction ADE/FDE, IS/FID); Markdown table");
  cmd->add_option("run", a->run_dir, "run directory (mosyn train --out); a classifier run is scored on the held-out clips")->required();
  cmd->add_option("--data", a->data_dir, "prepared dataset directory")->required();
  cmd->add_option("--split", a->options.split, "split of the held-out clips: val or train (default val)");
  cmd->add_option("--n", a->options.num_samples, "samples per control (default 10)");
  cmd->add_option("--seed", a->options.seed, "random seed (default 1)");
  cmd->add_option("--max-clips", a->options.max_clips, "evaluate at most this many clips, evenly spread (default all)");
  cmd->add_option("--out", a->out, "also write every value to this JSON file (e.g. RUN/metrics.json)");
  cmd->add_option("--checkpoint", a->options.checkpoint, "checkpoint file of the run (default checkpoint.pt; e.g. best.pt)");
  cmd->add_option("--classifier", a->classifier, "a classifier run (mosyn train classifier): adds accuracy, IS, FID");
  cmd->add_option("--temperature", a->options.temperature, "latent standard-deviation multiplier (default 1)");
  cmd->add_option("--warmup", a->options.warmup_s,
                  "seconds generated before each synthesised clip along its control's first step and dropped "
                  "(default: the run's: moglow its lead_in_s, 1 unless its config sets one; 0 for rvae)")
      ->check(CLI::Range(0.0, 60.0));
  cmd->add_option("--prefix", a->options.prefix_s, "prediction: seconds of real motion observed (default 1)");
  cmd->add_option("--horizon", a->options.horizon_s, "prediction: seconds predicted (default 2)");
  cmd->add_option("--mm-threshold", a->options.multimodal_threshold_m,
                  "prediction: MMADE/MMFDE grouping distance of last observed poses, m (default 0.5)");
  cmd->add_flag("--no-prediction", a->no_prediction, "skip the stochastic-prediction metrics");
  cmd->add_flag("--no-labels", a->no_labels,
                "label-conditioned models: sample the held-out clips' controls and prefixes with no label");
  cmd->add_option("--protocols", a->protocols,
                  "run only these comma-separated protocols, e.g. prediction,body_validity (default: all that apply: "
                  "locomotion, paths, diversity, joint_errors, prediction, body_validity, recognition, "
                  "label_generation, long_horizon, prefix_generation)");
  cmd->add_option("--error-frames", a->options.error_frames,
                  "joint-position errors at these comma-separated frames (default 70,90,120,160,210: Habibie et al.)")
      ->delimiter(',')
      ->check(CLI::Range(0, 1000000));
  cmd->add_option("--error-fps", a->options.error_frames_fps,
                  "frame rate the --error-frames are counted at; converted by time (default 60, the paper's)");
  cmd->add_option("--initial-frames", a->options.initial_frames,
                  "joint errors: real frames observed before the continuation (default 4, the paper's)");
  cmd->add_flag("--no-joint-errors", a->no_joint_errors, "skip the joint-position errors");
  cmd->add_flag("--paths", a->options.synthetic_paths,
                "also walk N samples along drawn paths (curve, zigzag, stop-and-go, straight at 0.8/1.3/1.8 m/s) and "
                "score them against the real clips (rows paths.*)");
  cmd->add_flag("--foot-lock", a->options.foot_lock,
                "also score the samples after the foot-lock post-process (rows foot_locked.*; the raw rows stay)");
  cmd->add_flag("--raw-root", a->options.raw_root,
                "sample with the model's own root steps where its run plants them on the feet (config.json's "
                "root_planting)");
  cmd->add_option("--long-horizon", a->options.long_horizon_s,
                  "also sample this many seconds (a meandering walk, or free generation) and score stability per "
                  "window: bone lengths, skating, body speed, freezing, exploding (rows long_horizon.*; default off)");
  cmd->add_option("--long-horizon-window", a->options.long_horizon_window_s,
                  "long horizon: window length, s (default 10)");
  cmd->add_option("--label-samples", a->options.label_samples,
                  "with --classifier, families conditioned on labels: K samples of every content x style "
                  "combination, scored like the paper's Table 2 (rows label_generation.*; default off)");
  cmd->add_option("--label-seconds", a->options.label_seconds,
                  "label generation: seconds per sample (default: the dataset's window)");
  cmd->add_option("--prefix-generation", a->options.prefix_generation_s,
                  "families that continue a prefix: N samples of SECONDS after the first --prefix-frames of "
                  "--prefix-clips held-out clips (along the long-horizon meander for families that take control); "
                  "stability, Fig. 9, transitions (rows prefix_generation.*; default off)");
  cmd->add_option("--prefix-frames", a->options.prefix_generation_frames,
                  "prefix generation: real frames observed (default 20)");
  cmd->add_option("--prefix-clips", a->options.prefix_generation_clips,
                  "prefix generation: held-out clips whose starts are continued (default 4)");
  cmd->add_option("--transition-window", a->options.transition_window_s,
                  "prefix generation with --classifier: seconds per recognised window (default: the "
                  "classifier's training window)");
  cmd->add_option("--plot", a->plot, "write the prefix generation's curves (DFN Fig. 9) as a PNG");
  cmd->add_option("--foot-joints", a->foot_joints,
                  "comma-separated left,right heel joints [,left,right toe] (default: found by name)");
  cmd->add_option("--threads", a->options.threads, "CPU threads (default: all cores)");
  cmd->callback([action, a] { *action = [a] { run_eval(*a); }; });
}

void add_report_command(CLI::App& app, Action* action) {
  auto a = std::make_shared<ReportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "report", "One self-contained HTML page about a run: config, training curves, metrics beside real data, "
                "sample motions in the browser viewer");
  cmd->add_option("run", a->run_dir, "run directory")->required();
  cmd->add_option("--metrics", a->metrics, "mosyn eval --out JSON (default: RUN/metrics.json when present)");
  cmd->add_option("--samples", a->samples, "folder of BVH samples to show (default: sample 3 short motions)");
  cmd->add_option("--out", a->out, "output .html page")->required();
  cmd->add_option("--threads", a->threads, "CPU threads (default: all cores)");
  cmd->callback([action, a] { *action = [a] { run_report(*a); }; });
}


}  // namespace

void add_eval_commands(CLI::App& app, Action* action) {
  add_eval_command(app, action);
  add_report_command(app, action);
  add_compare_command(app, action);
}

}  // namespace mosyn::cli

// `mosyn compare`: several runs scored with the same protocols beside the real clips of their
// datasets; one table (Markdown, JSON) and an HTML page with the viewer. The logic lives in
// eval/compare.h; this file parses flags and writes files.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "cli/cli.h"
#include "core/error.h"
#include "eval/compare.h"
#include "io/atomic_file.h"
#include "io/json_file.h"
#include "render/scene.h"
#include "render/view.h"

namespace mosyn::cli {
namespace {

struct CompareArgs {
  std::vector<std::string> runs, data;
  std::string out, classifier;
  eval::CompareOptions options;
};

void check_args(const CompareArgs& a) {
  const eval::EvalOptions& o = a.options.eval;
  if (a.runs.empty()) throw UsageError("give at least one run directory");
  if (a.data.size() != 1 && a.data.size() != a.runs.size())
    throw UsageError("give one --data for all runs or one per run (" + std::to_string(a.runs.size()) + " runs, " +
                     std::to_string(a.data.size()) + " --data)");
  if (o.split != "val" && o.split != "train") throw UsageError("--split must be val or train");
  if (o.num_samples < 1 || o.num_samples > 1000) throw UsageError("--n must be in [1, 1000]");
  if (o.max_clips < 0) throw UsageError("--max-clips must not be negative");
  if (!(o.long_horizon_s >= 0) || !(o.long_horizon_window_s > 0))
    throw UsageError("--long-horizon must not be negative and --long-horizon-window must be positive");
  if (a.options.showcase_samples < 0 || a.options.showcase_samples > 10) throw UsageError("--show must be in [0, 10]");
}

// The showcase motions as a viewer page, or why there is none (note).
std::string viewer_of(const eval::CompareResult& r, std::string* note) {
  if (r.showcase.empty()) return "";
  if (!render::viewer_available()) {
    *note = "The browser viewer is not available: mosyn was built without npm/node.";
    return "";
  }
  std::vector<render::RenderMotion> motions;
  for (const auto& m : r.showcase)
    motions.push_back(render::render_motion_from_clip(m.clip, render::motion_color(m.column), 0.0, m.name));
  *note = std::to_string(motions.size()) + " motions, one colour per column; drag to orbit the camera.";
  return render::viewer_page(motions, "compare");
}

void run_compare(CompareArgs a) {
  check_args(a);
  a.options.eval.classifier_dir = a.classifier;
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(a.out, ec);
  if (ec) throw Error(a.out + ": cannot create the output folder: " + ec.message());
  ProgressLine progress;
  const eval::CompareResult r = eval::compare(a.runs, a.data, a.options, [&](const std::string& column, const eval::EvalProgress& p) {
    progress.update(column + ": " + p.stage + " " + std::to_string(p.done) + "/" + std::to_string(p.total),
                    p.done == p.total);
  });
  progress.finish();
  const std::string md = eval::format_compare_markdown(r);
  std::printf("%s", md.c_str());
  const fs::path dir(a.out);
  io::write_file_atomically((dir / "compare.md").string(), md);
  nlohmann::json j = r.to_json();
  j["data"] = a.data;
  j["options"] = {{"split", a.options.eval.split}, {"n", a.options.eval.num_samples}, {"seed", a.options.eval.seed},
                  {"max_clips", a.options.eval.max_clips}, {"paths", a.options.eval.synthetic_paths},
                  {"long_horizon_s", a.options.eval.long_horizon_s}};
  if (!a.classifier.empty()) j["classifier"] = a.classifier;
  io::write_json((dir / "compare.json").string(), j);
  std::string note;
  const std::string viewer = viewer_of(r, &note);
  std::string title = "mosyn compare:";
  for (const auto& c : r.columns)
    if (!c.real) title += " " + c.name;
  io::write_file_atomically((dir / "compare.html").string(), eval::compare_html(r, title, viewer, note));
  std::fprintf(stderr, "wrote %s/compare.{md,json,html}\n", a.out.c_str());
}

}  // namespace

void add_compare_command(CLI::App& app, Action* action) {
  auto a = std::make_shared<CompareArgs>();
  eval::EvalOptions& o = a->options.eval;
  CLI::App* cmd = app.add_subcommand(
      "compare",
      "Score several runs with every applicable eval protocol beside the real clips of their datasets: one table "
      "(DIR/compare.md, compare.json) and a page with samples of each run in the viewer (compare.html)");
  cmd->add_option("runs", a->runs, "run directories (mosyn train --out)")->required();
  cmd->add_option("--data", a->data, "prepared dataset: once for all runs, or once per run in the same order")
      ->required();
  cmd->add_option("--out", a->out, "output folder for compare.md, compare.json and compare.html")->required();
  cmd->add_option("--split", o.split, "split of the held-out clips: val or train (default val)");
  cmd->add_option("--n", o.num_samples, "samples per control (default 10)");
  cmd->add_option("--seed", o.seed, "random seed (default 1)");
  cmd->add_option("--max-clips", o.max_clips, "evaluate at most this many clips, evenly spread (default all)");
  cmd->add_option("--checkpoint", o.checkpoint, "checkpoint file of every run (default checkpoint.pt)");
  cmd->add_option("--classifier", a->classifier, "a classifier run (mosyn train classifier): adds accuracy, IS, FID");
  cmd->add_flag("--paths", o.synthetic_paths, "also walk N samples along the drawn paths (rows paths.*)");
  cmd->add_flag("--foot-lock", o.foot_lock, "also score the foot-locked samples (rows foot_locked.*)");
  cmd->add_flag("--raw-root", o.raw_root, "sample every run with its model's own root steps (no root_planting)");
  cmd->add_option("--long-horizon", o.long_horizon_s,
                  "also sample this many seconds and score stability per window (rows long_horizon.*; default off)");
  cmd->add_option("--long-horizon-window", o.long_horizon_window_s, "long horizon: window length, s (default 10)");
  cmd->add_option("--show", a->options.showcase_samples, "sample motions of each run in the viewer (default 2)");
  cmd->add_option("--threads", o.threads, "CPU threads (default: all cores)");
  cmd->callback([action, a] { *action = [a] { run_compare(*a); }; });
}

}  // namespace mosyn::cli

// `mosyn metrics`, `mosyn render` and `mosyn view`: metrics and pictures of any BVH files. These
// link no LibTorch (metrics, render, io), so the light `mosyn` binary runs them itself.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli/cli.h"
#include "core/error.h"
#include "io/atomic_file.h"
#include "io/bvh.h"
#include "io/json_file.h"
#include "metrics/metrics.h"
#include "metrics/set_metrics.h"
#include "render/image_io.h"
#include "render/scene.h"
#include "render/view.h"

namespace mosyn::cli {

std::string base_name(const std::string& path) { return std::filesystem::path(path).filename().string(); }

std::vector<Clip> read_clips(const std::vector<std::string>& paths) {
  std::vector<Clip> clips;
  ProgressLine progress;
  for (size_t i = 0; i < paths.size(); ++i) {
    if (paths.size() > 20) progress.update("reading " + std::to_string(i + 1) + "/" + std::to_string(paths.size()));
    clips.push_back(io::to_clip(io::read_bvh(paths[i])));
  }
  progress.finish();
  return clips;
}

namespace {


// ---------------------------------------------------------------------------------------------
// metrics

struct MetricsArgs {
  std::vector<std::string> files, reference;
  std::string json_out;
  std::string foot_joints;
  double units_m = 0;
  double v_tol_step_cmps = 1.0, v_tol_max_cmps = 100.0;
  bool toes = false;
  bool skate_any_foot = false;
  double min_step_s = 0.1;
  double contact_tol_cmps = 15.0;
  eval::FootSkatingOptions skating;
};

std::vector<eval::MotionPositions> positions_of(const std::vector<std::string>& paths, double units_m) {
  const std::vector<Clip> clips = read_clips(paths);
  std::vector<eval::MotionPositions> out;
  for (size_t i = 0; i < clips.size(); ++i) out.push_back(eval::motion_positions(clips[i], units_m, paths[i]));
  return out;
}

// The set-metric options of the command line; throws UsageError on values out of range.
eval::SetMetricsOptions set_metrics_options(const MetricsArgs& a) {
  if (a.units_m < 0) throw UsageError("--units-m must be positive");
  if (!(a.v_tol_step_cmps > 0) || !(a.v_tol_max_cmps >= a.v_tol_step_cmps))
    throw UsageError("--v-tol-step and --v-tol-max must be positive, step <= max");
  if (!(a.min_step_s >= 0)) throw UsageError("--min-step must not be negative");
  if (!(a.contact_tol_cmps > 0)) throw UsageError("--contact-tol must be positive");
  if (!(a.skating.height_threshold_m >= 0) || !(a.skating.speed_threshold_mps >= 0))
    throw UsageError("skating thresholds must not be negative");
  const std::vector<std::string> feet = split_commas(a.foot_joints);
  if (!feet.empty() && feet.size() != 2 && feet.size() != 4)
    throw UsageError("--foot-joints takes 2 names (left, right heel) or 4 (heels, then toes)");
  eval::SetMetricsOptions o;
  o.footsteps.v_tol_step_mps = a.v_tol_step_cmps / 100;
  o.footsteps.v_tol_max_mps = a.v_tol_max_cmps / 100;
  o.footsteps.use_toes = a.toes;
  o.skating = a.skating;
  o.skating.both_feet = !a.skate_any_foot;
  o.footsteps.min_step_duration_s = a.min_step_s;
  o.footsteps.fixed_tol_mps = a.contact_tol_cmps / 100;
  o.foot_joints = feet;
  return o;
}

// One Markdown row per metric, with the reference's column when there is one.
void print_metrics_table(const std::vector<eval::MetricValue>& rows, const std::vector<eval::MetricValue>& ref_rows,
                         double fse) {
  const bool with_ref = !ref_rows.empty();
  std::printf("| metric | files |%s\n", with_ref ? " reference |" : "");
  std::printf("|---|---|%s\n", with_ref ? "---|" : "");
  for (size_t i = 0; i < rows.size(); ++i) {
    std::printf("| %s | %s |", rows[i].label.c_str(), eval::format_metric_value(rows[i].value).c_str());
    if (with_ref) std::printf(" %s |", eval::format_metric_value(ref_rows[i].value).c_str());
    std::printf("\n");
  }
  if (with_ref)
    std::printf("| FSE: spectral entropy minus reference's (nats) | %s | 0 |\n", eval::format_metric_value(fse).c_str());
}

// DFN section 6.3: distance to the per-frame mean pose over time ({fps, mean_m, std_m}), or null
// for fewer than two motions or motions of different skeletons.
nlohmann::json spread_curve(const std::vector<eval::MotionPositions>& set) {
  if (set.size() < 2) return nullptr;
  int shortest = set[0].num_frames;
  for (const auto& m : set) {
    if (m.num_joints != set[0].num_joints) return nullptr;
    shortest = std::min(shortest, m.num_frames);
  }
  if (shortest < 1) return nullptr;
  std::vector<Eigen::MatrixXd> seqs;
  for (const auto& m : set) seqs.push_back(m.sequence().topRows(shortest));
  const eval::MeanPoseDistance d = eval::mean_pose_distance(seqs);
  return {{"fps", set[0].fps},
          {"mean_m", std::vector<double>(d.mean_m.data(), d.mean_m.data() + d.mean_m.size())},
          {"std_m", std::vector<double>(d.std_m.data(), d.std_m.data() + d.std_m.size())}};
}

// The footstep curve (steps over v_tol) of a set of motions, feet found as the options say.
eval::FootstepAnalysis footstep_curve(const std::vector<eval::MotionPositions>& motions,
                                      const eval::SetMetricsOptions& o) {
  std::vector<eval::FootJoints> feet;
  for (const auto& m : motions) feet.push_back(eval::find_foot_joints(m, o.foot_joints));
  return eval::analyse_footsteps(motions, feet, o.footsteps);
}

// Everything `mosyn metrics --json` writes: metrics, footstep curves, spread curves, options.
nlohmann::json metrics_json(const MetricsArgs& a, const eval::SetMetricsOptions& o,
                            const std::vector<eval::MotionPositions>& motions, const std::vector<eval::MetricValue>& rows,
                            const std::vector<eval::MotionPositions>& ref_motions,
                            const std::vector<eval::MetricValue>& ref_rows, double fse) {
  nlohmann::json j;
  j["files"] = a.files;
  j["metrics"] = eval::metrics_to_json(rows);
  const auto curve = footstep_curve(motions, o);
  nlohmann::json steps;
  std::vector<double> v_cmps;
  for (double v : curve.v_tol_mps) v_cmps.push_back(std::round(v * 1e6) / 1e4);
  steps["v_tol_cmps"] = v_cmps;
  steps["f_est"] = curve.f_est;
  const bool with_ref = !ref_rows.empty();
  if (with_ref) {
    j["reference"] = a.reference;
    j["reference_metrics"] = eval::metrics_to_json(ref_rows);
    steps["reference_f_est"] = footstep_curve(ref_motions, o).f_est;
    j["fse_difference"] = std::isfinite(fse) ? nlohmann::json(fse) : nlohmann::json(nullptr);
  }
  j["footstep_curve"] = steps;
  j["mean_pose_distance_curve"] = spread_curve(motions);
  if (with_ref) j["reference_mean_pose_distance_curve"] = spread_curve(ref_motions);
  j["options"] = {{"v_tol_step_cmps", a.v_tol_step_cmps},
                  {"v_tol_max_cmps", a.v_tol_max_cmps},
                  {"toes", a.toes},
                  {"skate_height_m", a.skating.height_threshold_m},
                  {"skate_speed_mps", a.skating.speed_threshold_mps},
                  {"skate_both_feet", !a.skate_any_foot},
                  {"min_step_s", a.min_step_s},
                  {"contact_tol_cmps", a.contact_tol_cmps},
                  {"foot_joints", o.foot_joints}};
  return j;
}

void run_metrics(const MetricsArgs& a) {
  const eval::SetMetricsOptions o = set_metrics_options(a);
  const auto motions = positions_of(a.files, a.units_m);
  const auto rows = eval::set_metrics(motions, o);
  std::vector<eval::MetricValue> ref_rows;
  std::vector<eval::MotionPositions> ref_motions;
  double fse = NAN;
  if (!a.reference.empty()) {
    ref_motions = positions_of(a.reference, a.units_m);
    ref_rows = eval::set_metrics(ref_motions, o);
    std::vector<Eigen::MatrixXd> seqs, ref_seqs;
    for (const auto& m : motions) seqs.push_back(m.sequence());
    for (const auto& m : ref_motions) ref_seqs.push_back(m.sequence());
    fse = eval::spectral_entropy_difference(seqs, ref_seqs);
  }
  print_metrics_table(rows, ref_rows, fse);
  if (!a.json_out.empty()) {
    io::write_json(a.json_out, metrics_json(a, o, motions, rows, ref_motions, ref_rows, fse));
    std::fprintf(stderr, "wrote %s\n", a.json_out.c_str());
  }
}

// ---------------------------------------------------------------------------------------------
// render and view

struct PictureArgs {
  std::vector<std::string> files;
  std::string out;
  std::string camera = "iso";
  std::string colors;
  std::string title;
  int width = 640, height = 480;
  double fps = 0;
  int frame = -1;
  double time_s = -1;
  int filmstrip = 0;
  double units_m = 0;
  bool overlay = false, perspective = false, no_grid = false, no_paths = false, follow = false;
};

std::vector<render::RenderMotion> render_motions(const PictureArgs& a) {
  if (a.units_m < 0) throw UsageError("--units-m must be positive");
  const std::vector<std::string> colors = split_commas(a.colors);
  if (!colors.empty() && colors.size() != a.files.size())
    throw UsageError("--colors needs one #rrggbb per file (" + std::to_string(a.files.size()) + ")");
  std::vector<render::Rgb> rgb;
  for (const auto& c : colors) {
    try {
      rgb.push_back(render::parse_color(c));
    } catch (const Error& e) {
      throw UsageError(e.what());
    }
  }
  const std::vector<Clip> clips = read_clips(a.files);
  std::vector<render::RenderMotion> motions;
  for (size_t i = 0; i < clips.size(); ++i)
    motions.push_back(render::render_motion_from_clip(
        clips[i], rgb.empty() ? render::motion_color(static_cast<int>(i)) : rgb[i], a.units_m, base_name(a.files[i])));
  return motions;
}

void run_render(const PictureArgs& a) {
  const std::string ext = extension_of(a.out);
  if (ext != "png" && ext != "gif" && ext != "mp4") throw UsageError("--out must end in .png, .gif or .mp4");
  if (a.width < 16 || a.height < 16 || a.width > 8192 || a.height > 8192)
    throw UsageError("--width and --height must be in 16..8192");
  if (a.fps < 0) throw UsageError("--fps must be positive");
  if (ext != "png" && (a.frame >= 0 || a.time_s >= 0 || a.filmstrip > 0))
    throw UsageError("--frame, --time and --filmstrip apply to .png output");
  if ((a.frame >= 0) + (a.time_s >= 0) + (a.filmstrip > 0) > 1)
    throw UsageError("give at most one of --frame, --time, --filmstrip");
  if (a.filmstrip < 0 || a.filmstrip > 64) throw UsageError("--filmstrip must be in 1..64");
  render::RenderOptions o;
  try {
    o.camera = render::parse_camera_preset(a.camera);
  } catch (const Error& e) {
    throw UsageError(e.what());
  }
  o.width = a.width;
  o.height = a.height;
  o.overlay = a.overlay;
  o.follow = a.follow;
  o.perspective = a.perspective;
  o.grid = !a.no_grid;
  o.paths = !a.no_paths;
  if (ext == "mp4" && render::find_on_path("ffmpeg").empty())
    throw Error("writing " + a.out +
                " needs ffmpeg, which is not on PATH: install it (e.g. apt-get install ffmpeg), or write .gif or .png");

  const auto motions = render_motions(a);
  const double duration = render::longest_duration_s(motions);
  if (ext == "png") {
    if (a.filmstrip > 0) {
      render::Image strip(o.width * a.filmstrip, o.height, o.background);
      for (int k = 0; k < a.filmstrip; ++k) {
        const double t = a.filmstrip > 1 ? duration * k / (a.filmstrip - 1) : 0.0;
        strip.paste(render::render_frame(motions, t, o), k * o.width, 0);
      }
      render::write_png(a.out, strip);
    } else {
      const double t = a.frame >= 0 ? a.frame / motions[0].fps : a.time_s >= 0 ? a.time_s : 0.5 * duration;
      render::write_png(a.out, render::render_frame(motions, t, o));
    }
    std::fprintf(stderr, "wrote %s\n", a.out.c_str());
    return;
  }
  // GIF delays are whole hundredths of a second: 25 fps (4 cs) by default.
  const double fps = a.fps > 0 ? a.fps : ext == "gif" ? 25.0 : motions[0].fps;
  const int delay_cs = std::max(2, static_cast<int>(std::lround(100.0 / fps)));
  const double step_s = ext == "gif" ? delay_cs / 100.0 : 1.0 / fps;
  const int num_frames = static_cast<int>(std::floor(duration / step_s + 1e-9)) + 1;
  if (num_frames > 20000) throw UsageError("more than 20000 frames: lower --fps");
  std::vector<render::Image> frames;
  ProgressLine progress;
  for (int k = 0; k < num_frames; ++k) {
    progress.update("rendering frame " + std::to_string(k + 1) + "/" + std::to_string(num_frames), k + 1 == num_frames);
    frames.push_back(render::render_frame(motions, k * step_s, o));
  }
  progress.finish();
  if (ext == "gif")
    render::write_gif(a.out, frames, delay_cs);
  else
    render::write_mp4(a.out, frames, fps);
  std::fprintf(stderr, "wrote %s: %d frames\n", a.out.c_str(), num_frames);
}

void run_view(const PictureArgs& a) {
  if (extension_of(a.out) != "html" && extension_of(a.out) != "htm") throw UsageError("--out must end in .html");
  if (!render::viewer_available())
    throw Error("the browser viewer is not available: mosyn was built without npm/node, which bundle three.js at "
                "build time (install npm and rebuild)");
  const auto motions = render_motions(a);
  std::string title = a.title;
  if (title.empty()) {
    for (const auto& m : motions) title += (title.empty() ? "" : ", ") + m.name;
    title = "mosyn: " + title;
  }
  render::write_viewer_page(a.out, motions, title);
  std::fprintf(stderr, "wrote %s: open file://%s in a browser\n", a.out.c_str(),
               std::filesystem::absolute(a.out).lexically_normal().c_str());
}

// ---------------------------------------------------------------------------------------------
// eval


void add_picture_options(CLI::App* cmd, PictureArgs* a) {
  cmd->add_option("files", a->files, "BVH files")->required();
  cmd->add_option("--colors", a->colors, "comma-separated #rrggbb, one per file (default: a fixed cycle)");
  cmd->add_option("--units-m", a->units_m, "metres per file unit (default: guessed from the skeleton size)");
}

void add_metrics_command(CLI::App& app, Action* action) {
  auto a = std::make_shared<MetricsArgs>();
  CLI::App* cmd = app.add_subcommand(
      "metrics",
      "Motion metrics of BVH files (footsteps, foot skating, bone lengths, rigid-part deformation, diversity, "
      "spectral entropy), optionally beside a reference set; a Markdown table on stdout");
  cmd->add_option("files", a->files, "BVH files")->required();
  cmd->add_option("--reference", a->reference, "BVH files of the reference set (e.g. held-out data)");
  cmd->add_option("--json", a->json_out, "also write all values (and the footstep curve) to this JSON file");
  cmd->add_option("--foot-joints", a->foot_joints,
                  "comma-separated left,right heel joints [,left,right toe] (default: found by name)");
  cmd->add_option("--units-m", a->units_m, "metres per file unit (default: guessed from the skeleton size)");
  cmd->add_option("--v-tol-step", a->v_tol_step_cmps, "footstep tolerance increment, cm/s (default 1)");
  cmd->add_option("--v-tol-max", a->v_tol_max_cmps, "largest footstep tolerance, cm/s (default 100)");
  cmd->add_option("--min-step", a->min_step_s, "shortest footstep counted, s (default 0.1)");
  cmd->add_option("--contact-tol", a->contact_tol_cmps,
                  "one tolerance for every set's contact rate and length, cm/s (default 15)");
  cmd->add_flag("--toes", a->toes, "footsteps from toe joints instead of heels (quadrupeds)");
  cmd->add_option("--skate-height", a->skating.height_threshold_m,
                  "foot skating: height above the foot's lowest point counted as ground contact, m (default 0.05)");
  cmd->add_option("--skate-speed", a->skating.speed_threshold_mps,
                  "foot skating: horizontal speed limit, m/s (default 0.075)");
  cmd->add_flag("--skate-any-foot", a->skate_any_foot,
                "foot skating when either foot slides (default: both at once, as MOJO)");
  cmd->callback([action, a] { *action = [a] { run_metrics(*a); }; });
}

void add_render_command(CLI::App& app, Action* action) {
  auto a = std::make_shared<PictureArgs>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Stick figures of BVH motions side by side (or overlaid) with ground paths: PNG, animated GIF, MP4");
  add_picture_options(cmd, a.get());
  cmd->add_option("--out", a->out, "output .png (one frame or a filmstrip), .gif or .mp4 (needs ffmpeg)")
      ->required();
  cmd->add_option("--camera", a->camera, "side, front, top or iso (default iso)");
  cmd->add_option("--width", a->width, "pixels (default 640; of each filmstrip frame)");
  cmd->add_option("--height", a->height, "pixels (default 480)");
  cmd->add_option("--fps", a->fps, "frame rate of GIF/MP4 (default 25 for GIF, the motion's for MP4)");
  cmd->add_option("--frame", a->frame, "PNG: frame index (at the first file's frame rate; default: mid-motion)");
  cmd->add_option("--time", a->time_s, "PNG: time in seconds");
  cmd->add_option("--filmstrip", a->filmstrip, "PNG: N frames evenly spaced over the motion, side by side");
  cmd->add_flag("--overlay", a->overlay, "draw all motions in one panel");
  cmd->add_flag("--follow", a->follow, "camera follows the figures (body-sized view) instead of fitting whole paths");
  cmd->add_flag("--perspective", a->perspective, "perspective camera (default orthographic)");
  cmd->add_flag("--no-grid", a->no_grid, "no ground grid");
  cmd->add_flag("--no-paths", a->no_paths, "no ground paths");
  cmd->callback([action, a] { *action = [a] { run_render(*a); }; });
}

void add_view_command(CLI::App& app, Action* action) {
  auto a = std::make_shared<PictureArgs>();
  CLI::App* cmd = app.add_subcommand(
      "view", "A self-contained HTML page that plays BVH motions in the browser (three.js; works offline)");
  add_picture_options(cmd, a.get());
  cmd->add_option("--out", a->out, "output .html page")->required();
  cmd->add_option("--title", a->title, "page title (default: the file names)");
  cmd->callback([action, a] { *action = [a] { run_view(*a); }; });
}


}  // namespace

void add_view_commands(CLI::App& app, Action* action) {
  add_metrics_command(app, action);
  add_render_command(app, action);
  add_view_command(app, action);
}

}  // namespace mosyn::cli

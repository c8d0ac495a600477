// Long generation from held-out prefixes (Dynamic Future Net, Chen et al. 2020): N samples of
// prefix_generation_s seconds after the first prefix_generation_frames frames of a few held-out
// clips, open loop (families that take control follow the long-horizon meander after the prefix;
// the others make their own root motion). Scored three ways:
// - stability (section 6.2): body speed (joints relative to the pelvis) and root speed over the
//   last window against the real clips of the prefix's content, root height against their range,
//   frozen and exploded samples;
// - distribution over time (section 6.3, Fig. 9): per frame, the distance of each sample's pose to
//   the mean pose of the N samples, beside the same distance over the training data (every frame
//   to the training data's mean pose). Poses are joint positions relative to the pelvis in the
//   root's heading frame (each frame turned back by the root's heading), so facing does not count;
// - transitions (section 6.2), with a classifier: each sample's content recognised in windows of
//   transition_window_s seconds; changes per minute and contents per sample beside the same counts
//   on the real held-out clips (a floor of the classifier's own flicker).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>

#include "core/error.h"
#include "core/trajectory.h"
#include "data/control.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

namespace {

using detail::body_speed_mps;
using detail::kNaN;
using detail::mean_finite;
using detail::slice;

using detail::kExplodedExtent;
using detail::kFrozenFraction;

// Mean horizontal speed (m/s) of the pelvis (joint 0) over frames [from, to).
double root_speed_mps(const MotionPositions& m, int from, int to) {
  if (to - from < 2) return kNaN;
  double sum = 0;
  for (int t = from + 1; t < to; ++t) {
    Eigen::Vector3d d = m.position(t, 0) - m.position(t - 1, 0);
    d[m.up_axis] = 0;
    sum += d.norm();
  }
  return sum * m.fps / (to - from - 1.0);
}

// 1 when `speed` is within a factor of two of `real` (either way), else 0.
double within_2x(double speed, double real) { return speed >= 0.5 * real && speed <= 2.0 * real ? 1.0 : 0.0; }

// Fraction of `speeds` within a factor of two of their own mean: how often a real clip itself would
// pass the test the samples face, the floor a standing content's scattered weight shifts set.
double fraction_within_2x_of_mean(const std::vector<double>& speeds) {
  const double mean = mean_finite(speeds);
  std::vector<double> within;
  for (double s : speeds)
    if (std::isfinite(s)) within.push_back(within_2x(s, mean));
  return mean_finite(within);
}

// What the real clips of one content do, each clip whole.
struct ContentReference {
  std::vector<double> body_speed, root_speed;
  double body_within = kNaN, root_within = kNaN;  // fraction_within_2x_of_mean of the two above
  double height_min = std::numeric_limits<double>::infinity(), height_max = -std::numeric_limits<double>::infinity();
  double height_sum = 0;
  int height_frames = 0;
  double extent = 0;
};

std::map<int, ContentReference> content_references(const EvalContext& ctx) {
  std::map<int, ContentReference> refs;
  for (size_t i = 0; i < ctx.num_clips(); ++i) {
    const MotionPositions& m = ctx.real()[i];
    for (int content : {ctx.clip(i).content, -2}) {  // -2: every content together
      ContentReference& r = refs[content];
      r.body_speed.push_back(body_speed_mps(m));
      r.root_speed.push_back(root_speed_mps(m, 0, m.num_frames));
      for (int t = 0; t < m.num_frames; ++t) {
        r.height_min = std::min(r.height_min, m.position(t, 0)[m.up_axis]);
        r.height_max = std::max(r.height_max, m.position(t, 0)[m.up_axis]);
        r.height_sum += m.position(t, 0)[m.up_axis];
        ++r.height_frames;
      }
      r.extent = std::max(r.extent, detail::largest_extent_m(m));
    }
  }
  for (auto& [content, r] : refs) {
    r.body_within = fraction_within_2x_of_mean(r.body_speed);
    r.root_within = fraction_within_2x_of_mean(r.root_speed);
  }
  return refs;
}

// Joint positions relative to the pelvis in the root's heading frame [T, J * 3], so only the body's
// own pose counts: a decoded world motion turned back, frame by frame, by the heading of the
// control it was placed on (decode_motion starts at heading 0).
Eigen::MatrixXd heading_frame_pose(const nn::LoadedRun& run, const MotionPositions& world,
                                   const std::vector<float>& control) {
  std::vector<double> headings;
  data::integrate_control(control, 0.0, &headings);
  Eigen::MatrixXd out(world.num_frames, 3 * world.num_joints);
  for (int t = 0; t < world.num_frames; ++t) {
    const Eigen::Matrix3d back = heading_rotation(run.dataset.skeleton, -headings[t]).toRotationMatrix();
    for (int j = 0; j < world.num_joints; ++j)
      out.block<1, 3>(t, 3 * j) = (back * (world.position(t, j) - world.position(t, 0))).transpose();
  }
  return out;
}

// Mean and population std of every training frame's distance to the training mean pose, over
// up to max_clips training clips evenly spread.
std::pair<double, double> training_spread(const EvalContext& ctx, int max_clips) {
  const auto& clips = ctx.dataset().clips("train");
  if (clips.empty()) return {kNaN, kNaN};
  const size_t n = std::min(clips.size(), static_cast<size_t>(std::max(1, max_clips)));
  std::vector<Eigen::MatrixXd> poses;
  Eigen::Index rows = 0;
  for (size_t k = 0; k < n; ++k) {
    const data::ClipRecord& rec = clips[k * clips.size() / n];
    poses.push_back(heading_frame_pose(ctx.run(), motion_positions(nn::decode_motion(ctx.run(), rec.pose, rec.control)),
                                       rec.control));
    rows += poses.back().rows();
  }
  Eigen::MatrixXd all(rows, poses[0].cols());
  rows = 0;
  for (const auto& p : poses) {
    all.middleRows(rows, p.rows()) = p;
    rows += p.rows();
  }
  const Eigen::RowVectorXd mean = all.colwise().mean();
  const Eigen::VectorXd d = (all.rowwise() - mean).rowwise().norm();
  return {d.mean(), std::sqrt((d.array() - d.mean()).square().mean())};
}

// Content ids recognised in consecutive windows of `window` frames of a raw motion (at least one).
std::vector<int> recognised_contents(const EvalContext& ctx, const nn::LoadedRun& cls, const std::vector<float>& pose,
                                     const std::vector<float>& control, int window, const std::string& name) {
  const int d = ctx.run().context.pose_dim, c = ctx.run().context.control_dim;
  const int frames = static_cast<int>(pose.size()) / d;
  detail::ClassifierInputs windows(cls, ctx.info());
  for (int from = 0; from == 0 || from + window <= frames; from += window) {  // full windows, at least one
    const int to = std::min(frames, from + window);
    windows.add(detail::rows_of(pose, from, to, d), detail::rows_of(control, from, to, c), name);
  }
  const nn::ClassifierOutputs out = windows.classify();
  std::vector<int> ids;
  for (int w = 0; w < out.num_windows; ++w) ids.push_back(detail::arg_max(out.content_probabilities, out.num_content, w));
  return ids;
}

// Content changes per minute and distinct contents of a sequence of recognised ids.
std::pair<double, double> transition_counts(const std::vector<int>& ids, double window_s) {
  int changes = 0;
  for (size_t w = 1; w < ids.size(); ++w) changes += ids[w] != ids[w - 1];
  const double minutes = ids.size() * window_s / 60.0;
  return {minutes > 0 ? changes / minutes : kNaN, static_cast<double>(std::set<int>(ids.begin(), ids.end()).size())};
}

// Frames (at fps) per recognised window: transition_window_s, or by default (0) the classifier's
// own training window, so each window is scored as the classifier learned to score.
int transition_frames(const EvalOptions& o, const nn::LoadedRun& cls, double fps) {
  const double seconds = o.transition_window_s > 0 ? o.transition_window_s : detail::training_window(cls) / cls.dataset.fps;
  return std::max(2, static_cast<int>(std::lround(seconds * fps)));
}

// The per-sample measures, collected over every prefix.
struct Collected {
  std::vector<double> body_last, root_last, body_real, root_real, body_within, root_within, height_in, height,
      real_height, frozen, exploded, changes, contents;
  std::vector<double> body_real_within, root_real_within;  // per sample: its content's real clips' own fraction
  std::vector<int> prefix_content;                   // the prefix clip's content label, per sample
  std::vector<std::vector<double>> window_distance;  // [window][prefix]
};

// The speed rows again for the prefixes of each content: a standing content's root barely moves,
// so "within 2x" is far stricter there than for a walk, and the mean hides which prefixes fail.
void per_content_rows(const Collected& all, const std::vector<std::string>& content_labels, EvalResult& result) {
  std::map<int, std::vector<size_t>> samples;
  for (size_t k = 0; k < all.prefix_content.size(); ++k) samples[all.prefix_content[k]].push_back(k);
  for (const auto& [content, ks] : samples) {
    const std::string name =
        content >= 0 && content < static_cast<int>(content_labels.size()) ? content_labels[content] : "unlabelled";
    auto mean_of = [&](const std::vector<double>& v) {
      std::vector<double> picked;
      for (size_t k : ks) picked.push_back(v[k]);
      return mean_finite(picked);
    };
    auto row = [&](const std::string& key, const std::string& label, double model, double real) {
      result.rows.push_back({"prefix_generation." + key + "." + name,
                             "from " + name + " prefixes (" + std::to_string(ks.size()) + " samples): " + label, model,
                             real});
    };
    row("body_speed_mps.last", "body speed, last window (m/s)", mean_of(all.body_last), mean_of(all.body_real));
    row("root_speed_mps.last", "root speed, last window (m/s)", mean_of(all.root_last), mean_of(all.root_real));
    row("body_speed_within_2x", "fraction with body speed within 2x of real", mean_of(all.body_within),
        mean_of(all.body_real_within));
    row("root_speed_within_2x", "fraction with root speed within 2x of real", mean_of(all.root_within),
        mean_of(all.root_real_within));
  }
}

class PrefixGenerationProtocol : public Protocol {
 public:
  std::string name() const override { return "prefix_generation"; }
  bool enabled(const EvalOptions& o) const override { return o.prefix_generation_s > 0; }
  bool applies_to(const nn::ModelTraits& t) const override { return t.prefix; }
  void run(EvalContext& ctx, EvalResult& result) const override;

 private:
  void score_prefix(EvalContext& ctx, size_t i, const std::map<int, ContentReference>& refs, const nn::LoadedRun* cls,
                    Collected& all, EvalResult& result) const;
};

void PrefixGenerationProtocol::score_prefix(EvalContext& ctx, size_t i, const std::map<int, ContentReference>& refs,
                                            const nn::LoadedRun* cls, Collected& all, EvalResult& result) const {
  const EvalOptions& o = ctx.options();
  const nn::LoadedRun& run = ctx.run();
  const data::ClipRecord& rec = ctx.clip(i);
  const int d = run.context.pose_dim, c = run.context.control_dim, p = o.prefix_generation_frames;
  const double frames = std::max(2.0, std::round(o.prefix_generation_s * run.dataset.fps));
  const int window = std::max(2, static_cast<int>(std::lround(o.long_horizon_window_s * run.dataset.fps)));
  const ContentReference& ref = refs.count(rec.content) ? refs.at(rec.content) : refs.at(-2);
  const double real_body = mean_finite(ref.body_speed), real_root = mean_finite(ref.root_speed);
  nn::SampleExtras extras = ctx.clip_labels(i);
  extras.prefix_pose = detail::rows_of(rec.pose, 0, p, d);
  extras.prefix_control = detail::rows_of(rec.control, 0, p, c);
  const auto futures = nn::sample_motions(run, detail::long_horizon_control(run, frames / run.dataset.fps),
                                          ctx.num_samples(), o.seed + 7000003 + i, o.temperature, extras);
  std::vector<Eigen::MatrixXd> poses;
  for (size_t k = 0; k < futures.size(); ++k) {
    nn::SampledMotion whole{extras.prefix_pose, extras.prefix_control};
    whole.pose.insert(whole.pose.end(), futures[k].pose.begin(), futures[k].pose.end());
    whole.control.insert(whole.control.end(), futures[k].control.begin(), futures[k].control.end());
    const MotionPositions m = motion_positions(nn::decode_motion(run, whole), 0.0, rec.source + " continued");
    const int end = m.num_frames, last = std::max(p, end - window);
    const double body = body_speed_mps(slice(m, last, end)), root = root_speed_mps(m, last, end);
    all.body_last.push_back(body);
    all.root_last.push_back(root);
    all.body_real.push_back(real_body);
    all.root_real.push_back(real_root);
    all.body_within.push_back(within_2x(body, real_body));
    all.root_within.push_back(within_2x(root, real_root));
    all.body_real_within.push_back(ref.body_within);
    all.root_real_within.push_back(ref.root_within);
    all.prefix_content.push_back(rec.content);
    bool frozen = false;
    for (int from = p; from + window <= end; from += window)
      if (!(body_speed_mps(slice(m, from, from + window)) >= kFrozenFraction * real_body)) frozen = true;
    all.frozen.push_back(frozen ? 1.0 : 0.0);
    all.exploded.push_back(detail::largest_extent_m(m) > kExplodedExtent * ref.extent ? 1.0 : 0.0);
    for (int t = p; t < end; ++t) {
      const double h = m.position(t, 0)[m.up_axis];
      all.height.push_back(h);
      all.height_in.push_back(h >= ref.height_min && h <= ref.height_max ? 1.0 : 0.0);
    }
    all.real_height.push_back(ref.height_frames > 0 ? ref.height_sum / ref.height_frames : kNaN);
    poses.push_back(heading_frame_pose(run, m, whole.control));
    if (cls) {
      const int tw = transition_frames(o, *cls, run.dataset.fps);
      const auto counts = transition_counts(
          recognised_contents(ctx, *cls, futures[k].pose, futures[k].control, tw, rec.source + " continued"),
          tw / run.dataset.fps);
      all.changes.push_back(counts.first);
      all.contents.push_back(counts.second);
    }
  }
  const MeanPoseDistance spread = mean_pose_distance(poses);
  EvalCurve curve;
  curve.key = "prefix_generation.mean_pose_distance.c" + std::to_string(result.curves.size());
  curve.label = rec.source + ", " + std::to_string(p) + " frames observed: distance to the per-frame mean pose (m)";
  curve.fps = run.dataset.fps;
  curve.mean.assign(spread.mean_m.data(), spread.mean_m.data() + spread.mean_m.size());
  curve.spread.assign(spread.std_m.data(), spread.std_m.data() + spread.std_m.size());
  for (int w = 0; w * window < static_cast<int>(curve.mean.size()); ++w) {
    if (static_cast<int>(all.window_distance.size()) <= w) all.window_distance.resize(w + 1);
    const int from = w * window, to = std::min(static_cast<int>(curve.mean.size()), from + window);
    all.window_distance[w].push_back(spread.mean_m.segment(from, to - from).mean());
  }
  result.curves.push_back(std::move(curve));
}

void PrefixGenerationProtocol::run(EvalContext& ctx, EvalResult& result) const {
  const EvalOptions& o = ctx.options();
  if (o.prefix_generation_frames < 1 || o.prefix_generation_clips < 1)
    throw Error("evaluate: prefix_generation_frames and prefix_generation_clips must be >= 1");
  if (!(o.transition_window_s >= 0) || !(o.long_horizon_window_s > 0))
    throw Error("evaluate: transition_window_s must be >= 0 and long_horizon_window_s > 0");
  std::vector<size_t> long_enough;
  for (size_t i = 0; i < ctx.num_clips(); ++i)
    if (ctx.clip(i).num_frames >= o.prefix_generation_frames) long_enough.push_back(i);
  if (long_enough.empty())
    throw Error("evaluate: no held-out clip has the " + std::to_string(o.prefix_generation_frames) +
                " frames of prefix asked for");
  const size_t n = std::min(long_enough.size(), static_cast<size_t>(o.prefix_generation_clips));
  const auto refs = content_references(ctx);
  std::optional<nn::LoadedRun> cls;
  if (!o.classifier_dir.empty()) cls = detail::load_classifier(o);
  const size_t first_curve = result.curves.size();
  Collected all;
  for (size_t k = 0; k < n; ++k) {
    ctx.report("prefix generation", static_cast<int>(k), static_cast<int>(n));
    score_prefix(ctx, long_enough[k * long_enough.size() / n], refs, cls ? &*cls : nullptr, all, result);
  }
  const auto [train_mean, train_spread] = training_spread(ctx, o.reference_clips);
  for (size_t k = first_curve; k < result.curves.size(); ++k) {
    result.curves[k].reference_mean = train_mean;
    result.curves[k].reference_spread = train_spread;
  }
  auto row = [&](const std::string& key, const std::string& label, double model, double real) {
    result.rows.push_back({"prefix_generation." + key, "from a prefix: " + label, model, real});
  };
  row("body_speed_mps.last", "body speed relative to the pelvis, last window (m/s)", mean_finite(all.body_last),
      mean_finite(all.body_real));
  row("root_speed_mps.last", "root speed, last window (m/s)", mean_finite(all.root_last), mean_finite(all.root_real));
  row("body_speed_within_2x", "fraction of samples with body speed within 2x of real", mean_finite(all.body_within),
      mean_finite(all.body_real_within));
  row("root_speed_within_2x", "fraction of samples with root speed within 2x of real", mean_finite(all.root_within),
      mean_finite(all.root_real_within));
  row("root_height_m", "root height (m)", mean_finite(all.height), mean_finite(all.real_height));
  row("root_height_in_range", "fraction of frames with root height in the real range", mean_finite(all.height_in), kNaN);
  row("frozen_fraction", "fraction of samples that freeze", mean_finite(all.frozen), kNaN);
  row("exploded_fraction", "fraction of samples that explode", mean_finite(all.exploded), kNaN);
  const double window_s = o.long_horizon_window_s;
  for (size_t w = 0; w < all.window_distance.size(); ++w) {
    char label[96];
    std::snprintf(label, sizeof label, "%.3g-%.3g s: distance to the per-frame mean pose (m)", w * window_s,
                  (w + 1) * window_s);
    row("mean_pose_distance_m.w" + std::to_string(w), label, mean_finite(all.window_distance[w]), train_mean);
  }
  per_content_rows(all, ctx.run().dataset.content_labels, result);
  if (cls) {
    std::vector<double> real_changes, real_contents;
    const int tw = transition_frames(o, *cls, ctx.run().dataset.fps);
    for (size_t i = 0; i < ctx.num_clips(); ++i) {
      if (ctx.clip(i).num_frames < 2 * tw) continue;
      const auto counts = transition_counts(
          recognised_contents(ctx, *cls, ctx.clip(i).pose, ctx.clip(i).control, tw, ctx.clip(i).source),
          tw / ctx.run().dataset.fps);
      real_changes.push_back(counts.first);
      real_contents.push_back(counts.second);
    }
    row("content_changes_per_min", "content changes recognised per minute", mean_finite(all.changes),
        mean_finite(real_changes));
    row("contents_per_sample", "distinct contents recognised per motion", mean_finite(all.contents),
        mean_finite(real_contents));
  }
  ctx.report("prefix generation", static_cast<int>(n), static_cast<int>(n));
}

}  // namespace

std::unique_ptr<Protocol> make_prefix_generation_protocol() { return std::make_unique<PrefixGenerationProtocol>(); }

}  // namespace mosyn::eval

// Drawn paths (eval/path_protocol.h) scored with the set metrics against the held-out walks.
#include <algorithm>
#include <cmath>

#include "eval/path_protocol.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

namespace {

// The footstep and skating rows of the set metrics of motions, keyed `paths.<part>.<key>` and
// labelled "<label> (<what>)", beside the real clips' rows.
void footstep_rows(const std::string& part, const std::string& what, const std::vector<MotionPositions>& motions,
                   const std::vector<MetricValue>& real_rows, const SetMetricsOptions& options, EvalResult& result) {
  if (motions.empty()) return;
  const auto rows = set_metrics(motions, options);
  for (size_t r = 0; r < rows.size() && r < real_rows.size(); ++r)
    if (detail::is_gait_row(rows[r].key))
      result.rows.push_back({"paths." + part + "." + rows[r].key, rows[r].label + " (" + what + ")", rows[r].value,
                             real_rows[r].value});
}

// One path's samples (named after it by sample_synthetic_paths), so that a pooled figure shows
// which path it comes from (`paths.straight-1.8.footsteps.v_tol95_cmps`).
void per_path_rows(const std::string& name, const std::vector<MotionPositions>& along_paths,
                   const std::vector<MetricValue>& real_rows, const SetMetricsOptions& options, EvalResult& result) {
  std::vector<MotionPositions> mine;
  for (const auto& m : along_paths)
    if (m.name == name) mine.push_back(m);
  footstep_rows(name, "path " + name, mine, real_rows, options, result);
}

// The steady parts of the paths, each run at speed of at least one second (`paths.steady.*`).
void steady_rows(const std::vector<MotionPositions>& along_paths, const std::vector<std::vector<PathPhase>>& phases,
                 const std::vector<MetricValue>& real_rows, const SetMetricsOptions& options, EvalResult& result) {
  if (along_paths.empty()) return;
  const int one_second = static_cast<int>(std::lround(along_paths[0].fps));
  footstep_rows("steady", "drawn paths, at speed", steady_parts(along_paths, phases, one_second), real_rows, options,
                result);
}

// What the paths are scored against: the held-out "walk" clips when the chosen clips hold that
// content (the paths ask for walking; runs step with a far larger footstep tolerance and skate
// less, so a pooled reference mixes gaits), else every chosen clip. clips index ctx.real(); rows
// are their set metrics, owned by ctx.
struct Reference {
  std::vector<size_t> clips;
  const std::vector<MetricValue>* rows = nullptr;
};

Reference walk_reference(EvalContext& ctx) {
  const int walk = detail::label_index(ctx.info().content_labels, "walk");
  Reference ref;
  if (walk >= 0) ref.clips = ctx.clips_of_content(walk);
  if (!ref.clips.empty()) {
    ref.rows = &ctx.real_set_metrics(walk);
    return ref;
  }
  for (size_t i = 0; i < ctx.num_clips(); ++i) ref.clips.push_back(i);
  ref.rows = &ctx.real_set_metrics();
  return ref;
}

double median_of(std::vector<double> v) {
  if (v.empty()) return detail::kNaN;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

// The slower foot's median speed in each phase of the paths (PathPhase), beside the real walks'
// (all in stride: there is no real standing to compare with). Shows where along a path feet
// glide: on Bandai-Namco the models walk the steady parts and slide through starts and stops.
void phase_rows(const std::vector<MotionPositions>& along_paths, const std::vector<std::vector<PathPhase>>& phases,
                const EvalContext& ctx, const std::vector<size_t>& reference, EvalResult& result) {
  std::vector<double> by_phase[3], real_speeds;
  for (size_t m = 0; m < along_paths.size() && m < phases.size(); ++m) {
    const std::vector<double> v = slower_foot_speed_mps(along_paths[m], find_foot_joints(along_paths[m]));
    // Transition t-1 -> t belongs to frame t's phase.
    for (size_t t = 0; t < v.size() && t + 1 < phases[m].size(); ++t)
      by_phase[static_cast<int>(phases[m][t + 1])].push_back(v[t]);
  }
  for (size_t i : reference) {
    const MotionPositions& real = ctx.real()[i];
    const std::vector<double> v = slower_foot_speed_mps(real, find_foot_joints(real));
    real_speeds.insert(real_speeds.end(), v.begin(), v.end());
  }
  const double real_median = median_of(real_speeds);
  const struct {
    PathPhase phase;
    const char* key;
    const char* label;
  } kPhases[] = {{PathPhase::kSteady, "steady", "at speed"},
                 {PathPhase::kChanging, "changing", "starting, stopping, slowing"},
                 {PathPhase::kStanding, "standing", "standing"}};
  for (const auto& p : kPhases) {
    const int k = static_cast<int>(p.phase);
    result.rows.push_back({std::string("paths.phases.") + p.key + ".slower_foot_speed_mps",
                           std::string("slower foot's median speed, m/s (drawn paths, ") + p.label + ")",
                           median_of(by_phase[k]), p.phase == PathPhase::kStanding ? detail::kNaN : real_median});
    result.rows.push_back({std::string("paths.phases.") + p.key + ".frames",
                           std::string("frames (drawn paths, ") + p.label + ")", static_cast<double>(by_phase[k].size()),
                           detail::kNaN});
  }
}

class PathsProtocol : public Protocol {
 public:
  std::string name() const override { return "paths"; }
  bool enabled(const EvalOptions& o) const override { return o.synthetic_paths; }
  bool applies_to(const nn::ModelTraits& t) const override { return t.control == nn::InputUse::kTakes; }
  void run(EvalContext& ctx, EvalResult& result) const override {
    const Reference reference = walk_reference(ctx);
    const std::vector<MetricValue>& real_rows = *reference.rows;
    ctx.report("paths", 0, 1);
    std::vector<std::vector<PathPhase>> phases;
    const auto along_paths = sample_synthetic_paths(ctx.run(), ctx.num_samples(), ctx.options().seed + 3000017,
                                                    ctx.options().temperature, ctx.warmup_frames(), &phases);
    const auto rows = set_metrics(along_paths, ctx.options().metrics);
    for (size_t r = 0; r < rows.size() && r < real_rows.size(); ++r)
      result.rows.push_back({"paths." + rows[r].key, rows[r].label + " (drawn paths)", rows[r].value, real_rows[r].value});
    for (const SyntheticPath& path : synthetic_paths()) per_path_rows(path.name, along_paths, real_rows, ctx.options().metrics, result);
    phase_rows(along_paths, phases, ctx, reference.clips, result);
    steady_rows(along_paths, phases, real_rows, ctx.options().metrics, result);
    ctx.report("paths", 1, 1);
  }
};

}  // namespace

std::unique_ptr<Protocol> make_paths_protocol() { return std::make_unique<PathsProtocol>(); }

}  // namespace mosyn::eval

// Drawn paths (eval/path_protocol.h) scored with the set metrics against the real clips.
#include "eval/path_protocol.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

namespace {

// The footstep and skating rows of one path's samples (named after it by sample_synthetic_paths),
// so that a pooled figure shows which path it comes from (`paths.straight-1.8.footsteps.v_tol95_cmps`).
void per_path_rows(const std::string& name, const std::vector<MotionPositions>& along_paths,
                   const std::vector<MetricValue>& real_rows, const SetMetricsOptions& options, EvalResult& result) {
  std::vector<MotionPositions> mine;
  for (const auto& m : along_paths)
    if (m.name == name) mine.push_back(m);
  if (mine.empty()) return;
  const auto rows = set_metrics(mine, options);
  for (size_t r = 0; r < rows.size() && r < real_rows.size(); ++r)
    if (rows[r].key.rfind("footsteps.", 0) == 0 || rows[r].key == "foot_skating_ratio")
      result.rows.push_back({"paths." + name + "." + rows[r].key, rows[r].label + " (path " + name + ")", rows[r].value,
                             real_rows[r].value});
}

class PathsProtocol : public Protocol {
 public:
  std::string name() const override { return "paths"; }
  bool enabled(const EvalOptions& o) const override { return o.synthetic_paths; }
  bool applies_to(const nn::ModelTraits& t) const override { return t.control == nn::InputUse::kTakes; }
  void run(EvalContext& ctx, EvalResult& result) const override {
    const std::vector<MetricValue>& real_rows = ctx.real_set_metrics();
    ctx.report("paths", 0, 1);
    const auto along_paths = sample_synthetic_paths(ctx.run(), ctx.num_samples(), ctx.options().seed + 3000017,
                                                    ctx.options().temperature, ctx.warmup_frames());
    const auto rows = set_metrics(along_paths, ctx.options().metrics);
    for (size_t r = 0; r < rows.size() && r < real_rows.size(); ++r)
      result.rows.push_back({"paths." + rows[r].key, rows[r].label + " (drawn paths)", rows[r].value, real_rows[r].value});
    for (const SyntheticPath& path : synthetic_paths()) per_path_rows(path.name, along_paths, real_rows, ctx.options().metrics, result);
    ctx.report("paths", 1, 1);
  }
};

}  // namespace

std::unique_ptr<Protocol> make_paths_protocol() { return std::make_unique<PathsProtocol>(); }

}  // namespace mosyn::eval

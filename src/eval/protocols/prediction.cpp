// Stochastic prediction from a real prefix given the true control (DLow / MOJO protocol).
#include <cmath>

#include "core/error.h"
#include "data/prepare.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

namespace {

using detail::kNaN;
using detail::root_relative;
using detail::rows_of;

// The baseline a stochastic predictor must beat (MOJO's done-when asks best-of-50 ADE below 0.8x
// of it): the body carried on at constant velocity, its last observed pose moved rigidly at the
// root's last velocity. In the pelvis-relative frame the errors are read in, that is the last pose
// held (the zero-velocity baseline of Martinez et al. 2017, strong at these horizons; carrying
// every joint on at its own velocity flies the limbs off within a second: ADE 1.9 m over 3 s).
// truth [p + h, 3J] pelvis-relative; one sample, so its "best of" is itself.
PredictionWindow constant_velocity_window(const Eigen::MatrixXd& truth, int p, int h) {
  PredictionWindow w;
  w.ground_truth = truth.middleRows(p, h);
  w.last_context_pose = truth.row(p - 1).transpose();
  w.samples.push_back(truth.row(p - 1).replicate(h, 1));
  return w;
}

class PredictionProtocol : public Protocol {
 public:
  std::string name() const override { return "prediction"; }
  bool enabled(const EvalOptions& o) const override { return o.prediction; }
  bool applies_to(const nn::ModelTraits& t) const override { return t.prefix; }
  void run(EvalContext& ctx, EvalResult& result) const override;
};

void PredictionProtocol::run(EvalContext& ctx, EvalResult& result) const {
  const EvalOptions& o = ctx.options();
  const nn::LoadedRun& run = ctx.run();
  const int d = run.context.pose_dim, c = run.context.control_dim;
  const int p = static_cast<int>(std::lround(o.prefix_s * ctx.info().fps));
  const int h = static_cast<int>(std::lround(o.horizon_s * ctx.info().fps));
  if (p < 1 || h < 2) throw Error("evaluate: prefix must be >= 1 frame and horizon >= 2 frames");
  std::vector<PredictionWindow> windows, constant_velocity;
  for (size_t i = 0; i < ctx.num_clips(); ++i) {
    ctx.report("prediction", static_cast<int>(i), static_cast<int>(ctx.num_clips()));
    const data::ClipRecord& rec = ctx.clip(i);
    if (rec.num_frames < p + h) continue;
    PredictionWindow w;
    const Eigen::MatrixXd truth = root_relative(
        motion_positions(nn::decode_motion(run, rows_of(rec.pose, 0, p + h, d), rows_of(rec.control, 0, p + h, c)))
            .sequence());
    w.ground_truth = truth.middleRows(p, h);
    w.last_context_pose = truth.row(p - 1).transpose();
    for (const auto& s : ctx.continuations(i, p, p + h, o.seed + 1000003 + i))
      w.samples.push_back(root_relative(s).middleRows(p, h));
    constant_velocity.push_back(constant_velocity_window(truth, p, h));
    windows.push_back(std::move(w));
  }
  if (windows.empty()) return;
  const PredictionMetrics pm = evaluate_predictions(windows, o.multimodal_threshold_m);
  result.prediction_windows = pm.num_windows;
  result.rows.push_back({"prediction.apd_m", "prediction APD (m)", pm.apd_m, kNaN});
  result.rows.push_back({"prediction.ade_m", "prediction ADE (m)", pm.ade_m, kNaN});
  result.rows.push_back({"prediction.fde_m", "prediction FDE (m)", pm.fde_m, kNaN});
  result.rows.push_back({"prediction.mmade_m", "prediction MMADE (m)", pm.mmade_m, kNaN});
  result.rows.push_back({"prediction.mmfde_m", "prediction MMFDE (m)", pm.mmfde_m, kNaN});
  result.rows.push_back({"prediction.fse", "prediction FSE (nats)", pm.fse, 0.0});
  const PredictionMetrics cv = evaluate_predictions(constant_velocity, o.multimodal_threshold_m);
  result.rows.push_back({"prediction.cv_ade_m", "constant-velocity ADE (m)", cv.ade_m, kNaN});
  result.rows.push_back({"prediction.cv_fde_m", "constant-velocity FDE (m)", cv.fde_m, kNaN});
  result.rows.push_back({"prediction.ade_over_cv", "ADE / constant-velocity ADE", pm.ade_m / cv.ade_m, kNaN});
}

}  // namespace

std::unique_ptr<Protocol> make_prediction_protocol() { return std::make_unique<PredictionProtocol>(); }

}  // namespace mosyn::eval

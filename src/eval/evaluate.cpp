#include "eval/evaluate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>

#include "core/error.h"
#include "core/foot_lock.h"
#include "eval/path_protocol.h"
#include "data/prepare.h"
#include "nn/classifier/classify.h"
#include "nn/model.h"
#include "nn/sampling.h"

namespace mosyn::eval {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double mean_finite(const std::vector<double>& values) {
  double sum = 0;
  int n = 0;
  for (double v : values)
    if (std::isfinite(v)) {
      sum += v;
      ++n;
    }
  return n > 0 ? sum / n : kNaN;
}

std::vector<float> rows_of(const std::vector<float>& a, int from, int to, int dim) {
  return std::vector<float>(a.begin() + static_cast<size_t>(from) * dim, a.begin() + static_cast<size_t>(to) * dim);
}

Eigen::MatrixXd to_matrix(const std::vector<float>& v, int rows, int cols) {
  Eigen::MatrixXd m(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) m(r, c) = v[static_cast<size_t>(r) * cols + c];
  return m;
}

int label_for_run(int id, const std::vector<std::string>& dataset_labels, const std::vector<std::string>& run_labels) {
  if (id < 0 || id >= static_cast<int>(dataset_labels.size())) return -1;
  const auto it = std::find(run_labels.begin(), run_labels.end(), dataset_labels[id]);
  return it == run_labels.end() ? -1 : static_cast<int>(it - run_labels.begin());
}

// Joint positions relative to joint 0 (the pelvis) per frame: sequence [T, J * 3].
Eigen::MatrixXd root_relative(const Eigen::MatrixXd& sequence) {
  Eigen::MatrixXd out = sequence;
  for (Eigen::Index j = 0; j + 2 < out.cols(); j += 3) out.middleCols(j, 3) -= sequence.leftCols(3);
  return out;
}

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
double number_from(const nlohmann::json& j) { return j.is_number() ? j.get<double>() : kNaN; }

}  // namespace

const EvalRow& EvalResult::row(const std::string& key) const {
  for (const auto& r : rows)
    if (r.key == key) return r;
  throw Error("evaluation has no metric '" + key + "'");
}

nlohmann::json EvalResult::to_json() const {
  nlohmann::json j;
  j["format"] = "mosyn-eval-1";
  j["run"] = run_dir;
  j["family"] = family;
  j["split"] = split;
  j["n"] = num_samples;
  j["seed"] = seed;
  j["clips"] = clips;
  j["prediction_windows"] = prediction_windows;
  j["joint_error_clips"] = joint_error_clips;
  nlohmann::json list = nlohmann::json::array(), map = nlohmann::json::object();
  for (const auto& r : rows) {
    list.push_back({{"key", r.key}, {"label", r.label}, {"model", number_or_null(r.model)}, {"real", number_or_null(r.real)}});
    map[r.key] = {{"model", number_or_null(r.model)}, {"real", number_or_null(r.real)}};
  }
  j["rows"] = list;
  j["metrics"] = map;
  return j;
}

EvalResult EvalResult::from_json(const nlohmann::json& j) {
  EvalResult r;
  try {
    r.run_dir = j.value("run", "");
    r.family = j.value("family", "");
    r.split = j.value("split", "");
    r.num_samples = j.value("n", 0);
    r.seed = j.value("seed", std::uint64_t{0});
    if (j.contains("clips")) r.clips = j.at("clips").get<std::vector<std::string>>();
    r.prediction_windows = j.value("prediction_windows", 0);
    r.joint_error_clips = j.value("joint_error_clips", 0);
    for (const auto& row : j.at("rows"))
      r.rows.push_back({row.at("key").get<std::string>(), row.at("label").get<std::string>(), number_from(row.at("model")),
                        number_from(row.at("real"))});
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(std::string("not an evaluation (mosyn eval --out) JSON: ") + e.what());
  }
  return r;
}

std::string format_metric_value(double v) {
  if (!std::isfinite(v)) return "n/a";
  if (std::abs(v) < 1e-9) v = 0;  // rounding noise of exact zeros (e.g. rigid parts under FK)
  char buf[32];
  if (v == std::round(v) && std::abs(v) < 1e9)
    std::snprintf(buf, sizeof buf, "%.0f", v);
  else
    std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

std::string format_markdown(const EvalResult& result) {
  std::string s = "| metric | model | real data |\n|---|---|---|\n";
  for (const auto& r : result.rows)
    s += "| " + r.label + " | " + format_metric_value(r.model) + " | " + format_metric_value(r.real) + " |\n";
  return s;
}

EvalResult evaluate(const std::string& run_dir, const data::Dataset& dataset, const EvalOptions& options,
                    const EvalProgressCallback& progress) {
  nn::LoadOptions lo;
  lo.threads = options.threads;
  lo.checkpoint = options.checkpoint;
  return evaluate(nn::load_run(run_dir, lo), dataset, options, progress);
}

EvalResult evaluate(const nn::LoadedRun& run, const data::Dataset& dataset, const EvalOptions& o,
                    const EvalProgressCallback& progress) {
  if (!run.model) throw Error("evaluate: the run has no model");
  if (o.num_samples < 1) throw Error("evaluate: the number of samples must be >= 1");
  if (o.max_clips < 0) throw Error("evaluate: max_clips must not be negative");
  const data::DatasetInfo& info = dataset.info();
  const int d = run.context.pose_dim, c = run.context.control_dim;
  if (info.layout.pose_dim != d || static_cast<int>(dataset.stats().control_mean.size()) != c ||
      info.skeleton.num_joints() != run.dataset.skeleton.num_joints())
    throw Error("evaluate: the dataset's features (pose_dim " + std::to_string(info.layout.pose_dim) +
                ") do not match the run's (pose_dim " + std::to_string(d) + ")");
  auto report = [&](const std::string& stage, int done, int total) {
    if (progress) progress(EvalProgress{stage, done, total});
  };

  // ---- Held-out clips.
  const auto& all = dataset.clips(o.split);
  std::vector<int> candidates;
  for (int i = 0; i < static_cast<int>(all.size()); ++i)
    if (all[i].num_frames >= 2 && (o.include_augmented || (!all[i].mirrored && !all[i].reversed))) candidates.push_back(i);
  if (candidates.empty()) throw Error("evaluate: the '" + o.split + "' split has no clip to evaluate");
  std::vector<int> chosen;
  const size_t n_clips = o.max_clips > 0 ? std::min<size_t>(o.max_clips, candidates.size()) : candidates.size();
  for (size_t i = 0; i < n_clips; ++i) chosen.push_back(candidates[i * candidates.size() / n_clips]);

  EvalResult result;
  result.run_dir = run.run_dir;
  result.family = run.family;
  result.split = o.split;
  result.num_samples = o.num_samples;
  result.seed = o.seed;
  const int n = o.num_samples;

  // ---- Sampling: N motions per held-out control.
  const int warmup_frames =
      o.warmup_s >= 0 ? static_cast<int>(std::lround(o.warmup_s * run.dataset.fps)) : nn::kFamilyWarmup;
  std::vector<MotionPositions> real;                   // [clips]
  std::vector<std::vector<MotionPositions>> samples;   // [clips][N]
  std::vector<std::vector<std::vector<float>>> sample_poses;  // raw, for the classifier
  std::vector<std::vector<MotionPositions>> locked;           // [clips][N], with foot_lock only
  for (size_t i = 0; i < chosen.size(); ++i) {
    report("sampling", static_cast<int>(i), static_cast<int>(chosen.size()));
    const data::ClipRecord& rec = all[chosen[i]];
    result.clips.push_back(rec.source);
    result.clip_indices.push_back(chosen[i]);
    real.push_back(motion_positions(data::decode_record(info, rec), 0.0, rec.source));
    nn::SampleExtras extras;
    if (run.model->takes_labels()) {  // the clip's own labels, when the model is conditioned on labels
      extras.content = label_for_run(rec.content, info.content_labels, run.dataset.content_labels);
      extras.style = label_for_run(rec.style, info.style_labels, run.dataset.style_labels);
    }
    extras.warmup_frames = warmup_frames;
    auto poses = nn::sample_motions(run, rec.control, n, o.seed + i, o.temperature, extras);
    std::vector<MotionPositions> mine, mine_locked;
    for (int k = 0; k < n; ++k) {
      const Clip clip = nn::decode_motion(run, poses[k], rec.control);
      const std::string name = rec.source + " sample " + std::to_string(k);
      mine.push_back(motion_positions(clip, 0.0, name));
      if (o.foot_lock) {
        Clip pinned = clip;
        pinned.motion = foot_lock(clip.skeleton, clip.motion);
        mine_locked.push_back(motion_positions(pinned, 0.0, name + " foot-locked"));
      }
    }
    samples.push_back(std::move(mine));
    if (o.foot_lock) locked.push_back(std::move(mine_locked));
    sample_poses.push_back(std::move(poses));
  }
  report("sampling", static_cast<int>(chosen.size()), static_cast<int>(chosen.size()));

  // ---- Set metrics: real clips, and the mean over the N replicate sets of samples.
  const std::vector<MetricValue> real_rows = set_metrics(real, o.metrics);
  // Rows of [clips][N] samples: each set metric averaged over the N replicate sets.
  auto add_replicate_rows = [&](const std::vector<std::vector<MotionPositions>>& per_clip, const std::string& key_prefix,
                                const std::string& label_suffix) {
    std::vector<std::vector<double>> values(real_rows.size());
    for (int k = 0; k < n; ++k) {
      std::vector<MotionPositions> set;
      for (const auto& s : per_clip) set.push_back(s[k]);
      const auto rows = set_metrics(set, o.metrics);
      for (size_t r = 0; r < rows.size() && r < real_rows.size(); ++r) values[r].push_back(rows[r].value);
    }
    for (size_t r = 0; r < real_rows.size(); ++r)
      result.rows.push_back({key_prefix + real_rows[r].key, real_rows[r].label + label_suffix, mean_finite(values[r]),
                             real_rows[r].value});
  };
  add_replicate_rows(samples, "", "");
  if (o.foot_lock) add_replicate_rows(locked, "foot_locked.", " (foot-locked)");

  if (o.synthetic_paths) {
    report("paths", 0, 1);
    const auto along_paths = sample_synthetic_paths(run, n, o.seed + 3000017, o.temperature, warmup_frames);
    const auto rows = set_metrics(along_paths, o.metrics);
    for (size_t r = 0; r < rows.size() && r < real_rows.size(); ++r)
      result.rows.push_back({"paths." + rows[r].key, rows[r].label + " (drawn paths)", rows[r].value, real_rows[r].value});
    report("paths", 1, 1);
  }

  // ---- Diversity across the N samples of one control.
  {
    std::vector<double> apd, spread;
    for (const auto& s : samples) {
      if (n < 2) break;
      std::vector<Eigen::MatrixXd> seqs;
      for (const auto& m : s) seqs.push_back(m.sequence());
      apd.push_back(average_pairwise_distance(seqs));
      spread.push_back(mean_pose_distance(seqs).mean_m.mean());
    }
    result.rows.push_back({"diversity.apd_m", "APD across the N samples of a control (m)", mean_finite(apd), kNaN});
    result.rows.push_back({"diversity.mean_pose_distance_m", "distance to the per-frame mean of the N samples (m)",
                           mean_finite(spread), kNaN});
  }
  {
    std::vector<Eigen::MatrixXd> seqs, real_seqs;
    for (const auto& s : samples)
      for (const auto& m : s) seqs.push_back(m.sequence());
    for (const auto& m : real) real_seqs.push_back(m.sequence());
    result.rows.push_back({"fse", "FSE: spectral entropy minus real data's (nats)",
                           spectral_entropy_difference(seqs, real_seqs), 0.0});
  }

  // N continuations of a clip's first p frames up to frame `end`, given its true control (and
  // labels): world joint-position sequences [end, J * 3] of the real prefix + generated frames.
  auto continuations = [&](const data::ClipRecord& rec, int p, int end, std::uint64_t seed) {
    nn::SampleExtras extras;
    extras.prefix_pose = rows_of(rec.pose, 0, p, d);
    extras.prefix_control = rows_of(rec.control, 0, p, c);
    if (run.model->takes_labels()) {  // the clip's own labels, when the model is conditioned on labels
      extras.content = label_for_run(rec.content, info.content_labels, run.dataset.content_labels);
      extras.style = label_for_run(rec.style, info.style_labels, run.dataset.style_labels);
    }
    const std::vector<float> control = rows_of(rec.control, 0, end, c);
    std::vector<Eigen::MatrixXd> out;
    for (const auto& future : nn::sample_motions(run, rows_of(rec.control, p, end, c), n, seed, o.temperature, extras)) {
      std::vector<float> whole = extras.prefix_pose;
      whole.insert(whole.end(), future.begin(), future.end());
      out.push_back(motion_positions(nn::decode_motion(run, whole, control)).sequence());
    }
    return out;
  };

  // ---- Joint-position errors against the clip itself (Habibie et al. 2017, Tables 1-2).
  if (o.joint_errors && !o.error_frames.empty()) {
    if (!(o.error_frames_fps > 0)) throw Error("evaluate: error_frames_fps must be > 0");
    if (o.initial_frames < 1) throw Error("evaluate: initial_frames must be >= 1");
    std::vector<int> frames;  // at the dataset's rate
    for (int f : o.error_frames) {
      if (f < 0) throw Error("evaluate: error frames must be >= 0");
      frames.push_back(static_cast<int>(std::lround(f / o.error_frames_fps * info.fps)));
    }
    const int last = *std::max_element(frames.begin(), frames.end());
    if (last < o.initial_frames)
      throw Error("evaluate: every error frame lies inside the " + std::to_string(o.initial_frames) + " initial frames");
    const size_t nf = frames.size();
    // [setting][frame] sums over clips x samples; settings: motion/pose x prior/initial.
    std::vector<std::vector<double>> sums(4, std::vector<double>(nf, 0.0));
    int count = 0;
    // Adds the errors of one sample against the clip (world and pelvis-relative sequences).
    auto accumulate = [&](int setting, const Eigen::MatrixXd& sample, const Eigen::MatrixXd& truth,
                          const Eigen::MatrixXd& truth_relative) {
      const auto motion = joint_position_errors_m(sample, truth, frames);
      const auto pose = joint_position_errors_m(root_relative(sample), truth_relative, frames);
      for (size_t k = 0; k < nf; ++k) {
        sums[setting][k] += motion[k];
        sums[setting + 1][k] += pose[k];
      }
    };
    for (size_t i = 0; i < chosen.size(); ++i) {
      report("joint errors", static_cast<int>(i), static_cast<int>(chosen.size()));
      const data::ClipRecord& rec = all[chosen[i]];
      if (rec.num_frames <= last) continue;
      const Eigen::MatrixXd truth = real[i].sequence(), truth_relative = root_relative(truth);
      for (const auto& m : samples[i]) accumulate(0, m.sequence(), truth, truth_relative);
      for (const auto& s : continuations(rec, o.initial_frames, rec.num_frames, o.seed + 2000003 + i))
        accumulate(2, s, truth, truth_relative);
      ++count;
    }
    result.joint_error_clips = count;
    const char* names[4] = {"motion_prior", "pose_prior", "motion_initial", "pose_initial"};
    const std::string what[4] = {"motion error, prior sample", "pose error (root-relative), prior sample",
                                 "motion error, " + std::to_string(o.initial_frames) + " initial frames",
                                 "pose error (root-relative), " + std::to_string(o.initial_frames) + " initial frames"};
    for (int s = 0; s < 4; ++s)
      for (size_t k = 0; k < nf; ++k) {
        char at[64];
        std::snprintf(at, sizeof at, " at %.2f s (cm)", o.error_frames[k] / o.error_frames_fps);
        result.rows.push_back({std::string("joint_error.") + names[s] + ".f" + std::to_string(o.error_frames[k]),
                               what[s] + at, count > 0 ? 100.0 * sums[s][k] / (count * n) : kNaN, kNaN});
      }
  }

  // ---- Stochastic prediction from a real prefix, given the true control.
  if (o.prediction) {
    const int p = static_cast<int>(std::lround(o.prefix_s * info.fps));
    const int h = static_cast<int>(std::lround(o.horizon_s * info.fps));
    if (p < 1 || h < 2) throw Error("evaluate: prefix must be >= 1 frame and horizon >= 2 frames");
    std::vector<PredictionWindow> windows;
    for (size_t i = 0; i < chosen.size(); ++i) {
      report("prediction", static_cast<int>(i), static_cast<int>(chosen.size()));
      const data::ClipRecord& rec = all[chosen[i]];
      if (rec.num_frames < p + h) continue;
      PredictionWindow w;
      const Eigen::MatrixXd truth = root_relative(
          motion_positions(nn::decode_motion(run, rows_of(rec.pose, 0, p + h, d), rows_of(rec.control, 0, p + h, c)))
              .sequence());
      w.ground_truth = truth.middleRows(p, h);
      w.last_context_pose = truth.row(p - 1).transpose();
      for (const auto& s : continuations(rec, p, p + h, o.seed + 1000003 + i))
        w.samples.push_back(root_relative(s).middleRows(p, h));
      windows.push_back(std::move(w));
    }
    if (!windows.empty()) {
      const PredictionMetrics pm = evaluate_predictions(windows, o.multimodal_threshold_m);
      result.prediction_windows = pm.num_windows;
      result.rows.push_back({"prediction.apd_m", "prediction APD (m)", pm.apd_m, kNaN});
      result.rows.push_back({"prediction.ade_m", "prediction ADE (m)", pm.ade_m, kNaN});
      result.rows.push_back({"prediction.fde_m", "prediction FDE (m)", pm.fde_m, kNaN});
      result.rows.push_back({"prediction.mmade_m", "prediction MMADE (m)", pm.mmade_m, kNaN});
      result.rows.push_back({"prediction.mmfde_m", "prediction MMFDE (m)", pm.mmfde_m, kNaN});
      result.rows.push_back({"prediction.fse", "prediction FSE (nats)", pm.fse, 0.0});
    }
  }

  // ---- Recognisability with a trained classifier.
  if (!o.classifier_dir.empty()) {
    report("classifier", 0, 1);
    nn::LoadOptions lo;
    lo.threads = o.threads;
    if (std::filesystem::exists(std::filesystem::path(o.classifier_dir) / "best.pt")) lo.checkpoint = "best.pt";
    const nn::LoadedRun cls = nn::load_run(o.classifier_dir, lo);
    if (cls.family != "classifier") throw Error(o.classifier_dir + ": not a classifier run (family '" + cls.family + "')");
    // Another feature form (e.g. a joint-position model scored by a joint-rotation classifier):
    // every motion is decoded to a clip and encoded as the classifier's data, so one classifier
    // scores every family. Same form: the features as they are.
    const bool same_features = data::layout_to_json(cls.dataset.layout) == data::layout_to_json(info.layout);
    auto to_classifier = [&](const std::vector<float>& pose, const std::vector<float>& control, const std::string& name,
                             std::vector<float>* pose_out, std::vector<float>* control_out) {
      if (same_features) {
        *pose_out = pose;
        *control_out = control;
        return;
      }
      const int frames = static_cast<int>(control.size()) / c;
      data::encode_clip_for_dataset(cls.dataset, data::decode_features(info, pose.data(), control.data(), frames), name,
                                    pose_out, control_out);
    };
    std::vector<std::vector<float>> poses, controls, real_poses, real_controls;
    std::vector<int> content, style;  // classifier label ids per sample / real clip
    std::vector<int> real_content, real_style;
    for (size_t i = 0; i < chosen.size(); ++i) {
      const data::ClipRecord& rec = all[chosen[i]];
      const int ci = label_for_run(rec.content, info.content_labels, cls.dataset.content_labels);
      const int si = label_for_run(rec.style, info.style_labels, cls.dataset.style_labels);
      std::vector<float> pose, control;
      for (int k = 0; k < n; ++k) {
        to_classifier(sample_poses[i][k], rec.control, rec.source + " sample " + std::to_string(k), &pose, &control);
        poses.push_back(pose);
        controls.push_back(control);
        content.push_back(ci);
        style.push_back(si);
      }
      to_classifier(rec.pose, rec.control, rec.source, &pose, &control);
      real_poses.push_back(pose);
      real_controls.push_back(control);
      real_content.push_back(ci);
      real_style.push_back(si);
    }
    const nn::ClassifierOutputs mo = nn::classify_windows(cls, poses, controls);
    const nn::ClassifierOutputs ro = nn::classify_windows(cls, real_poses, real_controls);
    auto accuracy = [](const std::vector<float>& probs, int k, const std::vector<int>& labels) {
      int right = 0, total = 0;
      for (size_t i = 0; i < labels.size(); ++i) {
        if (labels[i] < 0) continue;
        const float* row = probs.data() + i * k;
        right += static_cast<int>(std::max_element(row, row + k) - row) == labels[i];
        ++total;
      }
      return total > 0 ? 100.0 * right / total : kNaN;
    };
    result.rows.push_back({"classifier.content_acc", "classifier content accuracy (%)",
                           accuracy(mo.content_probabilities, mo.num_content, content),
                           accuracy(ro.content_probabilities, ro.num_content, real_content)});
    if (mo.num_style > 0)
      result.rows.push_back({"classifier.style_acc", "classifier style accuracy (%)",
                             accuracy(mo.style_probabilities, mo.num_style, style),
                             accuracy(ro.style_probabilities, ro.num_style, real_style)});
    result.rows.push_back({"classifier.is", "Inception score (content)",
                           inception_score(to_matrix(mo.content_probabilities, mo.num_windows, mo.num_content)),
                           inception_score(to_matrix(ro.content_probabilities, ro.num_windows, ro.num_content))});
    const Eigen::MatrixXd fm = to_matrix(mo.features, mo.num_windows, mo.num_features);
    const Eigen::MatrixXd fr = to_matrix(ro.features, ro.num_windows, ro.num_features);
    double fid_model = kNaN, fid_real = kNaN;
    if (fm.rows() >= 2 && fr.rows() >= 2) fid_model = frechet_inception_distance(fm, fr);
    if (fr.rows() >= 4) {
      Eigen::MatrixXd even((fr.rows() + 1) / 2, fr.cols()), odd(fr.rows() / 2, fr.cols());
      for (Eigen::Index r = 0; r < fr.rows(); ++r) {
        if (r % 2 == 0)
          even.row(r / 2) = fr.row(r);
        else
          odd.row(r / 2) = fr.row(r);
      }
      fid_real = frechet_inception_distance(even, odd);
    }
    result.rows.push_back({"classifier.fid", "FID (classifier features, vs real data)", fid_model, fid_real});
    report("classifier", 1, 1);
  }
  return result;
}

}  // namespace mosyn::eval

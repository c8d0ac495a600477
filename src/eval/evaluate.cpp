#include "eval/evaluate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>

#include "core/error.h"
#include "eval/protocol.h"
#include "nn/registry.h"
#include "io/json_number.h"

namespace mosyn::eval {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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
  if (!curves.empty()) {
    nlohmann::json cs = nlohmann::json::array();
    for (const auto& c : curves) {
      nlohmann::json mean = nlohmann::json::array(), spread = nlohmann::json::array();
      for (double v : c.mean) mean.push_back(number_or_null(v));
      for (double v : c.spread) spread.push_back(number_or_null(v));
      cs.push_back({{"key", c.key}, {"label", c.label}, {"fps", c.fps}, {"mean", mean}, {"spread", spread},
                    {"reference_mean", number_or_null(c.reference_mean)},
                    {"reference_spread", number_or_null(c.reference_spread)}});
    }
    j["curves"] = cs;
  }
  return j;
}

EvalResult EvalResult::from_json(const nlohmann::json& j) {
  EvalResult r;
  try {
    r.run_dir = j.value("run", "");
    r.family = j.value("family", "");
    r.split = j.value("split", "");
    r.num_samples = io::json_value(j, "n", 0);
    r.seed = io::json_value(j, "seed", std::uint64_t{0});
    if (j.contains("clips")) r.clips = j.at("clips").get<std::vector<std::string>>();
    r.prediction_windows = io::json_value(j, "prediction_windows", 0);
    r.joint_error_clips = io::json_value(j, "joint_error_clips", 0);
    for (const auto& row : j.at("rows"))
      r.rows.push_back({row.at("key").get<std::string>(), row.at("label").get<std::string>(), number_from(row.at("model")),
                        number_from(row.at("real"))});
    if (j.contains("curves"))
      for (const auto& c : j.at("curves")) {
        EvalCurve curve;
        curve.key = c.at("key").get<std::string>();
        curve.label = c.at("label").get<std::string>();
        curve.fps = c.at("fps").get<double>();
        for (const auto& v : c.at("mean")) curve.mean.push_back(number_from(v));
        for (const auto& v : c.at("spread")) curve.spread.push_back(number_from(v));
        if (curve.spread.size() != curve.mean.size())
          throw Error("evaluation JSON: curve '" + curve.key + "' has " + std::to_string(curve.mean.size()) +
                      " means but " + std::to_string(curve.spread.size()) + " spreads");
        curve.reference_mean = number_from(c.at("reference_mean"));
        curve.reference_spread = number_from(c.at("reference_spread"));
        r.curves.push_back(std::move(curve));
      }
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(std::string("not an evaluation (mosyn eval --out) JSON: ") + e.what());
  }
  return r;
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
  lo.raw_root = options.raw_root;
  return evaluate(nn::load_run(run_dir, lo), dataset, options, progress);
}

EvalResult evaluate(const nn::LoadedRun& run, const data::Dataset& dataset, const EvalOptions& o,
                    const EvalProgressCallback& progress) {
  if (run.kind == nn::FamilyKind::kClassifier) return evaluate_classifier(run, dataset, o, progress);
  EvalContext context(run, dataset, o, progress);
  EvalResult result;
  result.run_dir = run.run_dir;
  result.family = run.family;
  result.split = o.split;
  result.num_samples = o.num_samples;
  result.seed = o.seed;
  result.clip_indices = context.clip_indices();
  for (size_t i = 0; i < context.num_clips(); ++i) result.clips.push_back(context.clip(i).source);
  const std::vector<std::string> chosen = protocols_for(run.traits, o);
  for (const auto& protocol : all_protocols()) {
    if (std::find(chosen.begin(), chosen.end(), protocol->name()) == chosen.end()) continue;
    protocol->run(context, result);
    result.protocols.push_back(protocol->name());
  }
  return result;
}

}  // namespace mosyn::eval

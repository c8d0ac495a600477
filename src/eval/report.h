// `mosyn report`: one self-contained HTML page about a run: its config, training curves drawn as
// inline SVG, the evaluation table beside natural data, and (given by the caller, which builds it
// with render/view.h) the three.js viewer page of sample motions, embedded in an iframe.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "eval/evaluate.h"

namespace mosyn::eval {

// Loss curves of a run's log.jsonl.
struct TrainingCurve {
  std::vector<double> step, loss;          // every logged step
  std::vector<double> val_step, val_loss;  // validation steps only
};

// Reads log.jsonl (one JSON object per line with "step", "loss" and optionally "val_loss");
// damaged lines are skipped. Throws mosyn::Error when the file cannot be read.
TrainingCurve read_training_log(const std::string& path);

// An <svg> element plotting loss (and val_loss) against step, with axes, tick labels and a
// legend; width x height pixels. A curve with no point gives a placeholder text.
std::string training_curve_svg(const TrainingCurve& curve, int width = 640, int height = 300);

struct ReportInputs {
  std::string title;                   // page heading, e.g. the run directory
  nlohmann::json config;               // the run's config.json
  TrainingCurve curve;
  std::optional<EvalResult> metrics;   // the evaluation table (absent: a note instead)
  std::string viewer_page;             // a whole HTML page (render::viewer_page); "" = none
  std::string viewer_note;             // shown where the viewer would be, e.g. why there is none
};

// The page: title, config (pretty JSON), training curves (inline SVG), metrics table (metric |
// model | real data), sample viewer (iframe srcdoc, so the page stays one offline file). Text is
// HTML-escaped.
std::string report_html(const ReportInputs& inputs);

}  // namespace mosyn::eval

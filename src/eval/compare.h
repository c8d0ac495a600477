// `mosyn compare`: several runs evaluated with the same protocols and options (eval/protocol.h),
// side by side in one table with the real held-out clips of each dataset, plus a few sample
// motions of each run for the viewer. See src/eval/README.md, "Compare".
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/skeleton.h"
#include "data/dataset.h"
#include "eval/evaluate.h"
#include "nn/run.h"

namespace mosyn::eval {

// One run to compare, with the dataset of its held-out clips.
struct CompareEntry {
  std::string name;                  // column heading, e.g. the run directory's name
  const nn::LoadedRun* run = nullptr;
  const data::Dataset* dataset = nullptr;
  std::string dataset_name;          // identifies the dataset (e.g. its directory); one real column each
};

struct CompareOptions {
  EvalOptions eval;               // the same for every run (checkpoint and threads: the dir overload)
  int showcase_samples = 2;       // sample motions of each run for the viewer (0 = none)
  double showcase_seconds = 4.0;  // their length: along a gentle curve ("0,0 0,2 1.5,4")
};

// A column of the table: a run, or the real clips of one dataset.
struct CompareColumn {
  std::string name;      // heading: the run's name, "real" or "real (<dataset>)"
  bool real = false;
  std::string run_dir;   // runs only
  std::string dataset;   // CompareEntry::dataset_name
};

struct CompareRow {
  std::string key, label;       // as EvalRow
  std::vector<double> values;   // one per column; NaN = the metric does not apply (n/a)
};

// A few motions to show: decoded clips with a display name.
struct ShowcaseMotion {
  std::string name;   // e.g. "moglow-locomotion 1", "real: walk_03.bvh"
  int column = 0;     // the column it belongs to (colour)
  Clip clip;
};

struct CompareResult {
  std::vector<CompareColumn> columns;     // runs in the given order, then one real column per dataset
  std::vector<CompareRow> rows;           // every key of every run, in protocol order
  std::vector<EvalResult> evaluations;    // one per run
  std::vector<ShowcaseMotion> showcase;   // showcase_samples per run, then one real clip per dataset

  // {"format": "mosyn-compare-1", "columns": [{"name", "kind": "run"|"real", "run", "dataset"}],
  //  "runs": [{"name", "run", "family", "dataset", "protocols", "clips", "prediction_windows",
  //  "joint_error_clips"}], "rows": [{"key", "label", "values": [...]}], "metrics": {key: {column
  //  name: value}}}, NaN as null.
  nlohmann::json to_json() const;
};

using CompareProgressCallback = std::function<void(const std::string& column, const EvalProgress& progress)>;

// Evaluates every entry with options.eval (eval::evaluate: every protocol enabled by the options
// that applies to the run's traits) and merges the rows: a key's row holds each run's model value
// and, per distinct dataset_name, the real value of the first run on that dataset that has the
// key; n/a where a run has no such row. Row order: each run's rows in order, keys new in a later
// run inserted after the key that precedes them there. Throws mosyn::Error for no entry, a null
// run or dataset, or whatever evaluate throws (prefixed with the run's name).
CompareResult compare(const std::vector<CompareEntry>& entries, const CompareOptions& options,
                      const CompareProgressCallback& progress = {});

// Loads every run (options.eval.checkpoint, threads) and dataset (each distinct directory once)
// and compares them. data_dirs holds one directory for all runs or one per run; columns are named
// after the run directories (the whole path when two share a name). Throws mosyn::Error for a
// wrong number of data_dirs or an unreadable run or dataset (naming the directory).
CompareResult compare(const std::vector<std::string>& run_dirs, const std::vector<std::string>& data_dirs,
                      const CompareOptions& options, const CompareProgressCallback& progress = {});

// | metric | run1 | run2 | ... | real | as Markdown, values by format_metric_value (n/a for NaN).
std::string format_compare_markdown(const CompareResult& result);

// A self-contained HTML page: title, the runs (family, dataset, protocols), the table, and the
// viewer page (render::viewer_page of the showcase motions, built by the caller; "" = none) in an
// iframe, with viewer_note under it. Text HTML-escaped.
std::string compare_html(const CompareResult& result, const std::string& title, const std::string& viewer_page,
                         const std::string& viewer_note);

}  // namespace mosyn::eval

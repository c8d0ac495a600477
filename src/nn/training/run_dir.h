// Run-directory plumbing of the trainer (internal to nn/training): the files of a run, the
// one-writer lock, the appending training log and the model config of a warm start.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "nn/checkpoint.h"

namespace mosyn::nn::training {

// The files of a run directory (see nn/training/train.h).
struct RunPaths {
  explicit RunPaths(const std::filesystem::path& dir);
  std::filesystem::path dir;
  std::string config, stats, checkpoint, best, log;
  // checkpoint-<step>.pt, a kept checkpoint (TrainOptions::keep_checkpoints).
  std::string kept_checkpoint(int step) const;
  // Whether a file name is a kept checkpoint's (checkpoint-<digits>.pt).
  static bool is_kept_checkpoint(const std::string& filename);
};

// One writer per run directory: an exclusive advisory lock on RUN/.lock held while training. The
// kernel releases it when the process exits or dies, so a killed run never leaves it stuck.
// Throws mosyn::Error naming the directory when another process holds it.
class RunLock {
 public:
  // Takes the lock (throws mosyn::Error naming the directory when another process holds it) and
  // removes temporary files that a killed writer left in the directory.
  explicit RunLock(const std::filesystem::path& dir);
  ~RunLock();
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;

 private:
  int fd_ = -1;
};

// log.jsonl grows a line at a time as training logs, so progress is visible at once; a line torn
// by a crash is dropped when the run resumes (truncate_log), which also drops lines past the
// checkpoint it resumes from.
class LogAppender {
 public:
  explicit LogAppender(std::string path) : path_(std::move(path)) {}
  // Appends one line (a JSON object without newline); throws mosyn::Error when it cannot.
  void append(const std::string& line);

 private:
  std::string path_;
};

// Rewrites the log at path atomically keeping only the well-formed lines of steps <= step.
void truncate_log(const std::string& path, int step);

// Checks the run directory for a new run or a resume and creates it: throws mosyn::Error when it
// exists (holds anything besides the lock) without resume or overwrite. Returns whether it held
// an earlier run. Call clear_run after taking the RunLock.
bool check_run_directory(const RunPaths& paths, bool resume, bool overwrite);

// Before a resume: throws when there is no checkpoint. Before a fresh run in a directory that held
// one (existed): removes the earlier run's files.
void clear_run(const RunPaths& paths, bool resume, bool existed);

// The label vocabularies an init run was trained with (its config.json "dataset" content_labels
// and style_labels; empty when it has none). Throws mosyn::Error for an unreadable config.
LabelVocabularies init_label_vocabularies(const std::string& init_dir);

// The model config of a warm start: the init run's resolved config (its config.json "model"), then
// the caller's keys. Throws mosyn::Error when it is not a run of `family`.
nlohmann::json init_model_config(const std::string& init_dir, const std::string& family,
                                 const nlohmann::json& overrides);

}  // namespace mosyn::nn::training

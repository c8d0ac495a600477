#include "nn/training/run_dir.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <vector>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/json_file.h"
#include "io/json_number.h"

namespace mosyn::nn::training {

namespace fs = std::filesystem;

RunPaths::RunPaths(const fs::path& d)
    : dir(d),
      config((d / "config.json").string()),
      stats((d / "stats.json").string()),
      checkpoint((d / "checkpoint.pt").string()),
      best((d / "best.pt").string()),
      log((d / "log.jsonl").string()) {}

std::string RunPaths::kept_checkpoint(int step) const {
  return (dir / ("checkpoint-" + std::to_string(step) + ".pt")).string();
}

bool RunPaths::is_kept_checkpoint(const std::string& filename) {
  const std::string prefix = "checkpoint-", suffix = ".pt";
  if (filename.size() <= prefix.size() + suffix.size() || filename.rfind(prefix, 0) != 0 ||
      filename.compare(filename.size() - suffix.size(), suffix.size(), suffix) != 0)
    return false;
  for (size_t i = prefix.size(); i < filename.size() - suffix.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(filename[i]))) return false;
  return true;
}

RunLock::RunLock(const fs::path& dir) {
  const std::string path = (dir / ".lock").string();
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error(path + ": cannot open the run lock: " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd_);
    throw Error(dir.string() + ": another mosyn process is training into this run directory (its lock " + path +
                " is held); wait for it to finish or stop it");
  }
  // A writer killed mid-write (SIGKILL, power loss) leaves its temporary file behind
  // (io/atomic_file.h: "<name>.tmp.<pid>.<n>"); the final files are whole. Holding the lock, no
  // one else is writing here, so the leftovers can go.
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    const size_t at = name.find(".tmp.");
    if (at != std::string::npos && at > 0 && entry.is_regular_file(ec)) fs::remove(entry.path(), ec);
  }
}

RunLock::~RunLock() {
  if (fd_ >= 0) ::close(fd_);
}

void LogAppender::append(const std::string& line) {
  std::ofstream out(path_, std::ios::app | std::ios::binary);
  out << line << '\n';
  out.flush();
  if (!out) throw Error(path_ + ": cannot append to the training log");
}

void truncate_log(const std::string& path, int step) {
  std::string text;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    try {
      if (io::json_get<int>(nlohmann::json::parse(line).at("step")) <= step) text += line + "\n";
    } catch (const std::exception&) {
      // A damaged log line is dropped; the log is informational.
    }
  }
  io::write_file_atomically(path, text);
}

bool check_run_directory(const RunPaths& paths, bool resume, bool overwrite) {
  bool exists = false;  // holds anything besides the lock file
  if (fs::is_directory(paths.dir))
    for (const auto& entry : fs::directory_iterator(paths.dir))
      exists = exists || entry.path().filename() != ".lock";
  if (!resume && exists && !overwrite)
    throw Error(paths.dir.string() + ": run directory already exists and is not empty (resume or overwrite it)");
  fs::create_directories(paths.dir);
  return exists;
}

void clear_run(const RunPaths& paths, bool resume, bool existed) {
  if (resume) {
    if (!fs::exists(paths.checkpoint)) throw Error(paths.checkpoint + ": nothing to resume (no checkpoint)");
  } else if (existed) {
    for (const char* f : {"config.json", "stats.json", "checkpoint.pt", "best.pt", "log.jsonl"})
      fs::remove(paths.dir / f);
    std::vector<fs::path> kept;  // collected first: removing while iterating is unspecified
    for (const auto& entry : fs::directory_iterator(paths.dir))
      if (RunPaths::is_kept_checkpoint(entry.path().filename().string())) kept.push_back(entry.path());
    for (const auto& path : kept) fs::remove(path);
  }
}

nlohmann::json init_model_config(const std::string& init_dir, const std::string& family,
                                 const nlohmann::json& overrides) {
  const std::string path = (fs::path(init_dir) / "config.json").string();
  const nlohmann::json saved = io::read_json(path);
  std::string saved_family;
  nlohmann::json config;
  try {
    saved_family = saved.at("family").get<std::string>();
    config = saved.at("model");
  } catch (const std::exception& e) {
    throw Error(path + ": not a mosyn run configuration (" + e.what() + ")");
  }
  if (saved_family != family)
    throw Error(path + ": --init-from needs a run of the same family ('" + saved_family + "', not '" + family + "')");
  if (overrides.is_object())
    for (const auto& [key, value] : overrides.items()) config[key] = value;
  return config;
}

LabelVocabularies init_label_vocabularies(const std::string& init_dir) {
  const std::string path = (fs::path(init_dir) / "config.json").string();
  const nlohmann::json saved = io::read_json(path);
  LabelVocabularies v;
  try {
    if (const auto d = saved.find("dataset"); d != saved.end() && d->is_object()) {
      if (d->contains("content_labels")) v.content = d->at("content_labels").get<std::vector<std::string>>();
      if (d->contains("style_labels")) v.style = d->at("style_labels").get<std::vector<std::string>>();
    }
  } catch (const std::exception& e) {
    throw Error(path + ": dataset content_labels/style_labels must be lists of strings (" + e.what() + ")");
  }
  return v;
}

}  // namespace mosyn::nn::training

#include <ATen/CPUGeneratorImpl.h>
#include <torch/types.h>
// clip_grad.h relies on torch/types.h being included first.
#include <torch/nn/utils/clip_grad.h>
#include <torch/optim/adam.h>
#include <torch/utils.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <cerrno>
#include <cstring>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/json_file.h"
#include "nn/checkpoint.h"
#include "nn/model.h"
#include "nn/run_info.h"
#include "nn/standardiser.h"
#include "nn/training/train.h"

namespace mosyn::nn {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Options

nlohmann::json TrainOptions::to_json() const {
  return {{"family", family},
          {"data_dir", data_dir},
          {"out_dir", out_dir},
          {"model_config", model_config},
          {"steps", steps},
          {"batch", batch},
          {"window", window},
          {"lr", lr},
          {"warmup", warmup},
          {"grad_clip", grad_clip},
          {"seed", seed},
          {"threads", threads},
          {"device", device},
          {"checkpoint_every", checkpoint_every},
          {"validate_every", validate_every},
          {"val_windows", val_windows},
          {"log_every", log_every},
          {"init_from", init_from}};
}

TrainOptions TrainOptions::from_json(const nlohmann::json& j) {
  TrainOptions o;
  try {
    for (auto it = j.begin(); it != j.end(); ++it) {
      const auto& k = it.key();
      const auto& v = it.value();
      if (k == "family") o.family = v.get<std::string>();
      else if (k == "data_dir") o.data_dir = v.get<std::string>();
      else if (k == "out_dir") o.out_dir = v.get<std::string>();
      else if (k == "model_config") o.model_config = v;
      else if (k == "steps") o.steps = v.get<int>();
      else if (k == "batch") o.batch = v.get<int>();
      else if (k == "window") o.window = v.get<int>();
      else if (k == "lr") o.lr = v.get<double>();
      else if (k == "warmup") o.warmup = v.get<int>();
      else if (k == "grad_clip") o.grad_clip = v.get<double>();
      else if (k == "seed") o.seed = v.get<std::uint64_t>();
      else if (k == "threads") o.threads = v.get<int>();
      else if (k == "device") o.device = v.get<std::string>();
      else if (k == "resume") o.resume = v.get<bool>();
      else if (k == "overwrite") o.overwrite = v.get<bool>();
      else if (k == "checkpoint_every") o.checkpoint_every = v.get<int>();
      else if (k == "validate_every") o.validate_every = v.get<int>();
      else if (k == "val_windows") o.val_windows = v.get<int>();
      else if (k == "log_every") o.log_every = v.get<int>();
      else if (k == "init_from") o.init_from = v.get<std::string>();
      else throw Error("unknown training option '" + k + "'");
    }
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(std::string("bad training option: ") + e.what());
  }
  return o;
}

double noam_lr(double peak_lr, int warmup, int step) {
  if (warmup <= 0) return peak_lr;
  const double s = std::max(step, 1);
  return peak_lr * std::min(s / warmup, std::sqrt(static_cast<double>(warmup) / s));
}

// ---------------------------------------------------------------------------------------------
// Batches

namespace {

struct Window {
  int clip;
  int start;
};

const std::vector<data::ClipRecord>& split_clips(const data::Dataset& ds, bool train) {
  return ds.clips(train ? "train" : "val");
}

std::vector<Window> enumerate_windows(const std::vector<data::ClipRecord>& clips, int window, int hop) {
  std::vector<Window> out;
  for (int c = 0; c < static_cast<int>(clips.size()); ++c)
    for (int s = 0; s + window <= clips[c].num_frames; s += hop) out.push_back({c, s});
  return out;
}

class BatchMaker {
 public:
  BatchMaker(const data::Dataset& ds, int pose_dim, int control_dim, const torch::Device& device)
      : d_(pose_dim), c_(control_dim), device_(device), standardiser_(ds.stats()) {}

  Batch make(const std::vector<data::ClipRecord>& clips, const std::vector<Window>& windows, size_t begin,
             size_t count, int window) const {
    auto pose = torch::empty({static_cast<int64_t>(count), window, d_});
    auto ctrl = torch::empty({static_cast<int64_t>(count), window, c_});
    auto content = torch::empty({static_cast<int64_t>(count)}, torch::kInt64);
    auto style = torch::empty({static_cast<int64_t>(count)}, torch::kInt64);
    for (size_t i = 0; i < count; ++i) {
      const Window& w = windows[begin + i];
      const auto& clip = clips[w.clip];
      std::memcpy(pose[i].data_ptr<float>(), clip.pose.data() + static_cast<size_t>(w.start) * d_,
                  sizeof(float) * window * d_);
      std::memcpy(ctrl[i].data_ptr<float>(), clip.control.data() + static_cast<size_t>(w.start) * c_,
                  sizeof(float) * window * c_);
      content[i] = clip.content;
      style[i] = clip.style;
    }
    Batch b;
    b.pose = standardiser_.pose(pose).to(device_);
    b.control = standardiser_.control(ctrl).to(device_);
    b.content = content.to(device_);
    b.style = style.to(device_);
    return b;
  }

 private:
  int d_, c_;
  torch::Device device_;
  Standardiser standardiser_;
};

std::string rng_to_string(const std::mt19937_64& rng) {
  std::ostringstream s;
  s << rng;
  return s.str();
}

void write_log(const std::string& path, const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& l : lines) text += l + "\n";
  io::write_file_atomically(path, text);
}

// log.jsonl grows a line at a time as training logs, so progress is visible at once; a line torn
// by a crash is dropped when the run resumes (read_log_until), which also drops lines past the
// checkpoint it resumes from.
class LogAppender {
 public:
  explicit LogAppender(std::string path) : path_(std::move(path)) {}
  void append(const std::string& line) {
    std::ofstream out(path_, std::ios::app | std::ios::binary);
    out << line << '\n';
    out.flush();
    if (!out) throw Error(path_ + ": cannot append to the training log");
  }

 private:
  std::string path_;
};

// One writer per run directory: an exclusive advisory lock on RUN/.lock held while training. The
// kernel releases it when the process exits or dies, so a killed run never leaves it stuck.
class RunLock {
 public:
  explicit RunLock(const fs::path& dir) {
    const std::string path = (dir / ".lock").string();
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error(path + ": cannot open the run lock: " + std::strerror(errno));
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd_);
      throw Error(dir.string() + ": another mosyn process is training into this run directory (its lock " + path +
                  " is held); wait for it to finish or stop it");
    }
  }
  ~RunLock() {
    if (fd_ >= 0) ::close(fd_);
  }
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;

 private:
  int fd_ = -1;
};

std::vector<std::string> read_log_until(const std::string& path, int step) {
  std::vector<std::string> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    try {
      if (nlohmann::json::parse(line).at("step").get<int>() <= step) out.push_back(line);
    } catch (const std::exception&) {
      // A damaged log line is dropped; the log is informational.
    }
  }
  return out;
}

// The model config of a warm start: the init run's resolved config, then the caller's keys.
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

}  // namespace

// ---------------------------------------------------------------------------------------------
// Training

TrainResult train(const TrainOptions& opts, const data::Dataset& dataset, const TrainCallbacks& cb) {
  using Clock = std::chrono::steady_clock;
  auto message = [&](const std::string& m) {
    if (cb.on_message) cb.on_message(m);
  };
  if (opts.out_dir.empty()) throw Error("train: no output (run) directory given");
  if (opts.steps < 1) throw Error("train: steps must be >= 1");
  if (opts.batch < 1) throw Error("train: batch must be >= 1");
  if (opts.checkpoint_every < 1) throw Error("train: checkpoint_every must be >= 1");
  if (opts.log_every < 1) throw Error("train: log_every must be >= 1");
  if (opts.lr <= 0) throw Error("train: lr must be positive");
  if (opts.resume && !opts.init_from.empty()) throw Error("train: resume and init_from exclude each other");
  set_num_threads(opts.threads);
  const torch::Device device = parse_device(opts.device);

  const fs::path dir(opts.out_dir);
  const std::string config_path = (dir / "config.json").string(), stats_path = (dir / "stats.json").string();
  const std::string ckpt_path = (dir / "checkpoint.pt").string(), best_path = (dir / "best.pt").string();
  const std::string log_path = (dir / "log.jsonl").string();
  bool exists = false;  // holds anything besides the lock file
  if (fs::is_directory(dir))
    for (const auto& entry : fs::directory_iterator(dir)) exists = exists || entry.path().filename() != ".lock";
  if (!opts.resume && exists && !opts.overwrite)
    throw Error(opts.out_dir + ": run directory already exists and is not empty (resume or overwrite it)");
  fs::create_directories(dir);
  const RunLock lock(dir);  // before touching anything: another writer may own the directory
  if (opts.resume) {
    if (!fs::exists(ckpt_path)) throw Error(ckpt_path + ": nothing to resume (no checkpoint)");
  } else if (exists) {
    for (const char* f : {"config.json", "stats.json", "checkpoint.pt", "best.pt", "log.jsonl"}) fs::remove(dir / f);
  }

  const ModelContext context = context_for(dataset.info());
  if (context.pose_dim <= 0) throw Error("train: the dataset has no pose dimensions");
  if (static_cast<int>(dataset.stats().pose_std.size()) != context.pose_dim ||
      static_cast<int>(dataset.stats().control_std.size()) != context.control_dim)
    throw Error("train: dataset statistics do not match its feature layout");

  std::string family = opts.family;
  nlohmann::json model_config = opts.model_config;
  if (opts.resume) {
    const auto saved = io::read_json(config_path);
    family = saved.at("family").get<std::string>();
    model_config = saved.at("model");
  } else if (!opts.init_from.empty()) {
    model_config = init_model_config(opts.init_from, family, model_config);
  }
  torch::manual_seed(opts.seed);
  auto model = create_trainable(family, model_config, context);
  model->to(device);
  if (!opts.resume && !opts.init_from.empty()) {
    const std::string from = (fs::path(opts.init_from) / "checkpoint.pt").string();
    const InitReport r = init_from_checkpoint(from, *model, device);
    std::string text = "initialised from " + from + " (step " + std::to_string(r.step) + "): " +
                       std::to_string(r.copied) + " tensors copied";
    if (!r.grown.empty()) text += ", " + std::to_string(r.grown.size()) + " grown (new inputs start at zero)";
    if (!r.missing.empty()) text += ", " + std::to_string(r.missing.size()) + " left as initialised";
    message(text);
  }

  const int window = opts.window > 0 ? opts.window : dataset.info().window_frames;
  if (window < 2) throw Error("train: window must be at least 2 frames (set window)");
  const auto& train_clips = split_clips(dataset, true);
  const auto& val_clips = split_clips(dataset, false);
  const auto train_windows = enumerate_windows(train_clips, window, 1);
  if (train_windows.empty())
    throw Error("train: no training clip has " + std::to_string(window) + " frames (shorten the window)");
  std::vector<Window> val_windows;
  {
    const auto all = enumerate_windows(val_clips, window, std::max(1, window / 2));
    const size_t n = std::min<size_t>(all.size(), std::max(0, opts.val_windows));
    for (size_t i = 0; i < n; ++i) val_windows.push_back(all[i * all.size() / n]);
  }
  BatchMaker maker(dataset, context.pose_dim, context.control_dim, device);

  torch::optim::Adam optimizer(model->parameters(), torch::optim::AdamOptions(opts.lr));
  std::mt19937_64 rng(opts.seed * 0x9E3779B97F4A7C15ull + 1);
  int step = 0;
  // NaN = not validated yet (a validation NLL may be any real number, negative included).
  double best_val = std::numeric_limits<double>::quiet_NaN();
  LogAppender log(log_path);

  if (opts.resume) {
    const auto state = load_checkpoint(ckpt_path, *model, &optimizer, device);
    step = state.step;
    best_val = state.best_val_loss;
    std::istringstream s(state.data_rng);
    s >> rng;
    if (s.fail()) throw Error(ckpt_path + ": corrupt data-order RNG state");
    if (state.torch_rng.defined()) {
      auto gen = at::detail::getDefaultCPUGenerator();  // a handle sharing the global state
      gen.set_state(state.torch_rng);
    }
    // Drop what was logged after the checkpoint (and a line torn by a crash).
    write_log(log_path, read_log_until(log_path, step));
    message("resumed " + opts.out_dir + " at step " + std::to_string(step));
  } else {
    nlohmann::json config = {{"format", "mosyn-run-1"},
                             {"family", family},
                             {"model", model->config()},
                             {"context", context_to_json(context)},
                             {"train", opts.to_json()},
                             {"dataset", data::info_to_json(dataset.info())}};
    config["train"]["window"] = window;
    io::write_json(config_path, config);
    io::write_json(stats_path, data::stats_to_json(dataset.stats()));
  }

  auto save = [&](const std::string& path) {
    CheckpointState st;
    st.step = step;
    st.best_val_loss = best_val;
    st.data_rng = rng_to_string(rng);
    st.torch_rng = at::detail::getDefaultCPUGenerator().get_state();
    save_checkpoint(path, *model, &optimizer, st);
  };

  auto validate = [&]() -> double {
    if (val_windows.empty()) return std::numeric_limits<double>::quiet_NaN();
    torch::NoGradGuard no_grad;
    model->eval();
    double total = 0;
    size_t n = 0;
    for (size_t b = 0; b < val_windows.size(); b += opts.batch) {
      const size_t count = std::min<size_t>(opts.batch, val_windows.size() - b);
      auto terms = model->loss(maker.make(val_clips, val_windows, b, count, window));
      total += terms.loss().item<double>() * count;
      n += count;
    }
    model->train();
    return total / n;
  };

  TrainResult result;
  result.run_dir = opts.out_dir;
  const auto t0 = Clock::now();
  auto t_last = t0;
  int step_last = step;
  double rate = 0;
  std::uniform_int_distribution<size_t> pick(0, train_windows.size() - 1);
  std::vector<Window> chosen(opts.batch);
  model->train();
  while (step < opts.steps) {
    if (cb.should_stop && cb.should_stop()) {
      save(ckpt_path);
      result.stopped_early = true;
      message("stopped at step " + std::to_string(step) + "; checkpoint saved");
      break;
    }
    const int next = step + 1;
    const double lr = noam_lr(opts.lr, opts.warmup, next);
    for (auto& group : optimizer.param_groups()) static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
    for (auto& w : chosen) w = train_windows[pick(rng)];
    auto batch = maker.make(train_clips, chosen, 0, chosen.size(), window);
    model->set_progress(next, opts.steps);
    auto terms = model->loss(batch);
    const double loss = terms.loss().item<double>();
    auto fail = [&](const std::string& what) {
      throw Error("training diverged: " + what + " at step " + std::to_string(next) +
                  (fs::exists(ckpt_path) ? "; the last good checkpoint (" + ckpt_path + ") is kept"
                                         : "; no checkpoint was written yet"));
    };
    if (!std::isfinite(loss)) fail("non-finite loss (" + std::to_string(loss) + ")");
    optimizer.zero_grad();
    terms.loss().backward();
    {
      // The norm is checked even without clipping, so a NaN gradient never reaches a checkpoint.
      const double max_norm = opts.grad_clip > 0 ? opts.grad_clip : std::numeric_limits<double>::infinity();
      const double norm = torch::nn::utils::clip_grad_norm_(model->parameters(), max_norm);
      if (!std::isfinite(norm)) fail("non-finite gradient norm");
    }
    optimizer.step();
    step = next;
    result.last_loss = loss;

    const bool last = step == opts.steps;
    const bool do_val = (opts.validate_every > 0 && step % opts.validate_every == 0) || (last && opts.validate_every > 0);
    double val = std::numeric_limits<double>::quiet_NaN();
    if (do_val) {
      val = validate();
      if (std::isfinite(val) && (!std::isfinite(best_val) || val < best_val)) {
        best_val = val;
        save(best_path);
      }
    }
    if (step % opts.log_every == 0 || do_val || last) {
      const auto now = Clock::now();
      const double dt = std::chrono::duration<double>(now - t_last).count();
      if (dt > 0 && step > step_last) {
        const double r = (step - step_last) / dt;
        rate = rate == 0 ? r : 0.7 * rate + 0.3 * r;
      }
      t_last = now;
      step_last = step;
      TrainProgress p;
      p.step = step;
      p.total_steps = opts.steps;
      p.loss = loss;
      for (const auto& kv : terms.terms)
        if (kv.first != "loss") p.metrics[kv.first] = kv.second.item<double>();
      p.has_val = do_val && std::isfinite(val);
      p.val_loss = val;
      p.lr = lr;
      p.steps_per_s = rate;
      p.eta_s = rate > 0 ? (opts.steps - step) / rate : 0;
      p.elapsed_s = std::chrono::duration<double>(now - t0).count();
      nlohmann::json line = {{"step", step}, {"loss", loss}, {"lr", lr}, {"time_s", p.elapsed_s}};
      for (const auto& kv : p.metrics) line[kv.first] = kv.second;
      if (p.has_val) line["val_loss"] = val;
      log.append(line.dump());
      if (cb.on_progress) cb.on_progress(p);
    }
    if (step % opts.checkpoint_every == 0 || last) {
      save(ckpt_path);
    }
  }
  result.step = step;
  result.best_val_loss = best_val;
  return result;
}

}  // namespace mosyn::nn

#include "nn/run.h"

#include <torch/nn/modules/rnn.h>
#include <torch/serialize.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/json_file.h"
#include "io/zip_check.h"
#include "nn/checkpoint.h"
#include "nn/root_planting.h"
#include "nn/run_info.h"

namespace mosyn::nn {

namespace {
constexpr const char* kCheckpointFormat = "mosyn-checkpoint-1";

// A checkpoint with NaN or infinite weights is refused: a model loaded from it would only
// produce NaN motion (and training resumed from it fails at its first step).
void check_finite(const torch::Tensor& stored, const std::string& name) {
  if (stored.is_floating_point() && stored.numel() > 0 && !torch::isfinite(stored).all().item<bool>())
    throw Error("tensor '" + name + "' holds NaN or infinite values");
}

// Module::load, except that stored tensors are copied into the existing ones: the model keeps its
// dtype (float16 weights from narrow_to_half compute in float32) and its tensor identities
// (LSTM flat-weight views stay valid). Shapes must match.
void load_module(torch::nn::Module& module, torch::serialize::InputArchive& archive) {
  torch::NoGradGuard no_grad;
  auto copy_into = [](torch::Tensor& target, const torch::Tensor& stored, const std::string& name) {
    if (stored.sizes() != target.sizes())
      throw Error("tensor '" + name + "' has shape " + c10::str(stored.sizes()) + ", expected " +
                  c10::str(target.sizes()));
    check_finite(stored, name);
    target.copy_(stored);
  };
  for (auto& p : module.named_parameters(/*recurse=*/false)) {
    torch::Tensor stored;
    archive.read(p.key(), stored);
    copy_into(p.value(), stored, p.key());
  }
  for (auto& b : module.named_buffers(/*recurse=*/false)) {
    torch::Tensor stored;
    archive.read(b.key(), stored, /*is_buffer=*/true);
    copy_into(b.value(), stored, b.key());
  }
  for (auto& child : module.named_children()) {
    torch::serialize::InputArchive child_archive;
    archive.read(child.key(), child_archive);
    load_module(*child.value(), child_archive);
  }
}
// Copies what fits from a stored tensor into target (see init_from_checkpoint); returns how.
enum class Fit { kExact, kGrown, kSkipped };
Fit copy_what_fits(torch::Tensor& target, const torch::Tensor& stored, const std::string& name) {
  check_finite(stored, name);
  if (stored.sizes() == target.sizes()) {
    target.copy_(stored);
    return Fit::kExact;
  }
  if (stored.dim() != target.dim() || stored.dim() == 0) return Fit::kSkipped;
  int grown = -1;
  for (int64_t k = 0; k < stored.dim(); ++k) {
    if (stored.size(k) == target.size(k)) continue;
    if (stored.size(k) > target.size(k) || grown >= 0) return Fit::kSkipped;
    grown = static_cast<int>(k);
  }
  target.zero_();
  target.narrow(grown, 0, stored.size(grown)).copy_(stored);
  return Fit::kGrown;
}

// Gates stacked along dim 0 of a recurrent layer's tensors (weight_ih_lK [gates*H, in],
// weight_hh_lK [gates*H, H], bias_ih_lK / bias_hh_lK [gates*H]); 0 for any other module.
int recurrent_gates(const torch::nn::Module& module) {
  if (dynamic_cast<const torch::nn::LSTMImpl*>(&module)) return 4;
  if (dynamic_cast<const torch::nn::GRUImpl*>(&module)) return 3;
  if (dynamic_cast<const torch::nn::RNNImpl*>(&module)) return 1;
  return 0;
}

// A recurrent tensor of a wider layer (more hidden units, and or more input columns). The gates
// are stacked, so the stored block cannot go in as one piece: each gate's stored rows go to the
// first rows of that gate. The new units' own rows keep their fresh initialisation (zeros would
// leave them dead: zero state, zero gradient), and the columns through which the old units would
// read new inputs or new units are zero, so the old units compute exactly what they did; whatever
// reads the layer's output grows its input columns at zero (copy_what_fits), so the wider model
// starts as the stored one. kSkipped when the shapes are not such a widening.
Fit copy_widened_recurrent(torch::Tensor& target, const torch::Tensor& stored, int gates, const std::string& name) {
  check_finite(stored, name);
  if (gates <= 0 || stored.dim() != target.dim() || stored.dim() < 1 || stored.dim() > 2) return Fit::kSkipped;
  if (stored.size(0) % gates != 0 || target.size(0) % gates != 0) return Fit::kSkipped;
  const int64_t units_stored = stored.size(0) / gates, units = target.size(0) / gates;
  if (units_stored > units) return Fit::kSkipped;
  if (stored.dim() == 2 && stored.size(1) > target.size(1)) return Fit::kSkipped;
  for (int64_t g = 0; g < gates; ++g) {
    auto rows = target.narrow(0, g * units, units_stored);
    const auto from = stored.narrow(0, g * units_stored, units_stored);
    if (stored.dim() == 1) {
      rows.copy_(from);
      continue;
    }
    rows.narrow(1, 0, stored.size(1)).copy_(from);
    rows.narrow(1, stored.size(1), target.size(1) - stored.size(1)).zero_();
  }
  return Fit::kGrown;
}

// Label columns moved by name (InitLabels). Returns false when the shapes do not fit the two
// vocabularies, leaving target alone.
bool copy_relabelled(torch::Tensor& target, const torch::Tensor& stored, const LabelInput& in, const InitLabels& labels) {
  const auto& from = labels.stored;
  const auto& to = labels.model;
  const int64_t from_width = static_cast<int64_t>(from.content.size() + from.style.size());
  const int64_t to_width = static_cast<int64_t>(to.content.size() + to.style.size());
  const int64_t axis = in.axis, off = in.offset;
  if (stored.dim() != target.dim() || axis < 0 || axis >= stored.dim()) return false;
  for (int64_t k = 0; k < stored.dim(); ++k)
    if (k != axis && stored.size(k) != target.size(k)) return false;
  const int64_t tail = stored.size(axis) - off - from_width;
  if (off < 0 || tail < 0 || target.size(axis) != off + to_width + tail) return false;
  target.zero_();
  target.narrow(axis, 0, off).copy_(stored.narrow(axis, 0, off));
  target.narrow(axis, off + to_width, tail).copy_(stored.narrow(axis, off + from_width, tail));
  auto move_block = [&](const std::vector<std::string>& names_from, const std::vector<std::string>& names_to,
                        int64_t base_from, int64_t base_to) {
    for (size_t j = 0; j < names_to.size(); ++j) {
      const auto it = std::find(names_from.begin(), names_from.end(), names_to[j]);
      if (it == names_from.end()) continue;  // new label: zero, i.e. "none"
      target.narrow(axis, base_to + static_cast<int64_t>(j), 1)
          .copy_(stored.narrow(axis, base_from + (it - names_from.begin()), 1));
    }
  };
  move_block(from.content, to.content, off, off);
  move_block(from.style, to.style, off + static_cast<int64_t>(from.content.size()),
             off + static_cast<int64_t>(to.content.size()));
  return true;
}

struct InitContext {
  InitReport* report;
  const InitLabels* labels;  // null or equal vocabularies: no relabelling
  std::map<std::string, LabelInput> label_inputs;
};

void init_module(torch::nn::Module& module, torch::serialize::InputArchive& archive, const std::string& prefix,
                 InitContext& ctx) {
  InitReport* report = ctx.report;
  torch::NoGradGuard no_grad;
  const int gates = recurrent_gates(module);
  auto take = [&](torch::Tensor& target, const std::string& key, bool is_buffer) {
    torch::Tensor stored;
    const std::string name = prefix + key;
    if (!archive.try_read(key, stored, is_buffer)) {
      report->missing.push_back(name);
      return;
    }
    if (const auto it = ctx.label_inputs.find(name); it != ctx.label_inputs.end() && ctx.labels) {
      const torch::Tensor converted = stored.to(target.dtype());
      check_finite(converted, name);
      if (copy_relabelled(target, converted, it->second, *ctx.labels)) {
        report->relabelled.push_back(name);
      } else {
        report->missing.push_back(name);
      }
      return;
    }
    const torch::Tensor converted = stored.to(target.dtype());
    const bool widened = gates > 0 && converted.sizes() != target.sizes();
    switch (widened ? copy_widened_recurrent(target, converted, gates, name) : copy_what_fits(target, converted, name)) {
      case Fit::kExact: ++report->copied; break;
      case Fit::kGrown: report->grown.push_back(name); break;
      case Fit::kSkipped: report->missing.push_back(name); break;
    }
  };
  for (auto& p : module.named_parameters(/*recurse=*/false)) take(p.value(), p.key(), false);
  for (auto& b : module.named_buffers(/*recurse=*/false)) take(b.value(), b.key(), true);
  for (auto& child : module.named_children()) {
    torch::serialize::InputArchive child_archive;
    if (!archive.try_read(child.key(), child_archive)) {
      report->missing.push_back(prefix + child.key() + ".*");
      continue;
    }
    init_module(*child.value(), child_archive, prefix + child.key() + ".", ctx);
  }
}

// Loads checkpoint bytes into *archive and checks its format and family (mosyn::Error otherwise).
void open_checkpoint(const std::string& bytes, const torch::Device& device, const std::string& family,
                     torch::serialize::InputArchive* archive) {
  io::check_zip_integrity(bytes, "checkpoint archive");  // LibTorch trusts the archive: damaged bytes can crash it
  archive->load_from(bytes.data(), bytes.size(), device);
  c10::IValue v;
  if (!archive->try_read("format", v) || !v.isString() || v.toStringRef() != kCheckpointFormat)
    throw Error("not a mosyn checkpoint");
  if (!archive->try_read("family", v) || v.toStringRef() != family)
    throw Error("checkpoint is of family '" + (v.isString() ? v.toStringRef() : std::string("?")) + "', expected '" +
                family + "'");
}

// The first line of a LibTorch exception, for a one-line error.
std::string first_line(const std::exception& e) {
  std::string msg = e.what();
  if (auto nl = msg.find('\n'); nl != std::string::npos) msg = msg.substr(0, nl);
  return msg;
}

}  // namespace

InitReport init_from_checkpoint(const std::string& path, TrainableModel& model, const torch::Device& device,
                                const InitLabels* labels) {
  const std::string bytes = io::read_file(path);
  InitReport report;
  try {
    torch::serialize::InputArchive archive;
    open_checkpoint(bytes, device, model.family(), &archive);
    c10::IValue v;
    archive.read("step", v);
    report.step = static_cast<int>(v.toInt());
    torch::serialize::InputArchive model_archive;
    archive.read("model", model_archive);
    InitContext ctx{&report, labels && !(labels->stored == labels->model) ? labels : nullptr, {}};
    if (ctx.labels)
      for (const LabelInput& in : model.label_inputs()) ctx.label_inputs[in.parameter] = in;
    init_module(model, model_archive, "", ctx);
  } catch (const Error& e) {
    throw Error(path + ": cannot initialise from this checkpoint: " + e.what());
  } catch (const std::exception& e) {
    throw Error(path + ": corrupt or truncated checkpoint (" + first_line(e) + ")");
  }
  return report;
}

void save_checkpoint(const std::string& path, TrainableModel& model, const torch::optim::Optimizer* optimizer,
                     const CheckpointState& state) {
  torch::serialize::OutputArchive archive;
  archive.write("format", c10::IValue(std::string(kCheckpointFormat)));
  archive.write("family", c10::IValue(model.family()));
  archive.write("step", c10::IValue(static_cast<int64_t>(state.step)));
  archive.write("best_val_loss", c10::IValue(state.best_val_loss));
  archive.write("data_rng", c10::IValue(state.data_rng));
  if (state.torch_rng.defined()) archive.write("torch_rng", state.torch_rng, /*is_buffer=*/true);
  if (state.stage >= 0) {
    archive.write("stage", c10::IValue(static_cast<int64_t>(state.stage)));
    archive.write("stage_step", c10::IValue(static_cast<int64_t>(state.stage_step)));
  }
  torch::serialize::OutputArchive model_archive;
  model.save(model_archive);
  archive.write("model", model_archive);
  if (optimizer) {
    torch::serialize::OutputArchive opt_archive;
    optimizer->save(opt_archive);
    archive.write("optimizer", opt_archive);
  }
  std::string bytes;
  archive.save_to([&bytes](const void* data, size_t n) {
    bytes.append(static_cast<const char*>(data), n);
    return n;
  });
  io::write_file_atomically(path, bytes);
}

CheckpointState load_checkpoint(const std::string& path, TrainableModel& model, torch::optim::Optimizer* optimizer,
                                const torch::Device& device) {
  const std::string bytes = io::read_file(path);
  CheckpointState state;
  try {
    torch::serialize::InputArchive archive;
    open_checkpoint(bytes, device, model.family(), &archive);
    c10::IValue v;
    archive.read("step", v);
    state.step = static_cast<int>(v.toInt());
    archive.read("best_val_loss", v);
    state.best_val_loss = v.toDouble();
    archive.read("data_rng", v);
    state.data_rng = v.toStringRef();
    torch::Tensor rng;
    if (archive.try_read("torch_rng", rng, /*is_buffer=*/true)) state.torch_rng = rng.to(torch::kCPU);
    if (archive.try_read("stage", v) && v.isInt()) {
      state.stage = static_cast<int>(v.toInt());
      archive.read("stage_step", v);
      state.stage_step = static_cast<int>(v.toInt());
    }
    torch::serialize::InputArchive model_archive;
    archive.read("model", model_archive);
    load_module(model, model_archive);
    if (optimizer) {
      torch::serialize::InputArchive opt_archive;
      if (!archive.try_read("optimizer", opt_archive)) throw Error("no optimizer state");
      optimizer->load(opt_archive);
    }
  } catch (const Error& e) {
    throw Error(path + ": corrupt or incompatible checkpoint: " + e.what());
  } catch (const std::exception& e) {
    throw Error(path + ": corrupt or truncated checkpoint (" + first_line(e) + ")");
  }
  return state;
}

void narrow_to_half(TrainableModel& model) {
  torch::NoGradGuard no_grad;
  for (auto& t : model.parameters())
    if (t.scalar_type() == torch::kFloat32) t.set_data(t.to(torch::kHalf));
  for (auto& t : model.buffers())
    if (t.scalar_type() == torch::kFloat32) t.set_data(t.to(torch::kHalf));
}

void fold_into_mean(TrainableModel& mean, const TrainableModel& other, int n) {
  if (n < 1) throw Error("fold_into_mean: n must be >= 1 (the models already averaged)");
  using Tensors = torch::OrderedDict<std::string, torch::Tensor>;
  const std::pair<Tensors, Tensors> pairs[] = {{mean.named_parameters(), other.named_parameters()},
                                                {mean.named_buffers(), other.named_buffers()}};
  // Every tensor is checked before any changes, so a refused model leaves `mean` as it was.
  for (const auto& [into, from] : pairs) {
    if (into.size() != from.size()) throw Error("fold_into_mean: the models have different tensors");
    for (const auto& item : into) {
      const torch::Tensor* o = from.find(item.key());
      if (!o || !o->sizes().equals(item.value().sizes()))
        throw Error("fold_into_mean: tensor " + item.key() + " differs in name or shape between the models");
    }
  }
  torch::NoGradGuard no_grad;
  for (const auto& [into, from] : pairs)
    for (const auto& item : into) {
      torch::Tensor t = item.value();
      if (t.is_floating_point()) t.add_((from[item.key()].to(t.dtype()) - t) / static_cast<double>(n + 1));
    }
}

LoadedRun load_run(const std::string& run_dir, const LoadOptions& options) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(run_dir))
    throw Error(run_dir + ": run directory does not exist (a run is what `mosyn train --out DIR` writes; the shipped "
                "models are models/NAME of the repository, listed in models/README.md)");
  if (options.threads >= 0) set_num_threads(options.threads);
  LoadedRun run;
  run.run_dir = run_dir;
  const std::string config_path = (fs::path(run_dir) / "config.json").string();
  const std::string stats_path = (fs::path(run_dir) / "stats.json").string();
  run.config = io::read_json(config_path);
  try {
    if (run.config.at("format").get<std::string>() != "mosyn-run-1") throw Error("unknown format");
    run.family = run.config.at("family").get<std::string>();
  } catch (const std::exception& e) {
    throw Error(config_path + ": not a mosyn run configuration (" + e.what() + ")");
  }
  if (!run.config.contains("context") || !run.config.contains("dataset") || !run.config.contains("model"))
    throw Error(config_path + ": missing 'context', 'dataset' or 'model'");
  run.context = context_from_json(run.config["context"], config_path);
  run.dataset = data::info_from_json(run.config["dataset"], config_path);
  run.stats = data::stats_from_json(io::read_json(stats_path), stats_path);
  run.root_planting = root_planting_from_config(run.config, config_path);
  if (options.raw_root) run.root_planting.reset();
  if (static_cast<int>(run.stats.pose_mean.size()) != run.context.pose_dim ||
      static_cast<int>(run.stats.control_mean.size()) != run.context.control_dim)
    throw Error(stats_path + ": statistics do not match the model's dimensions");
  run.context.skeleton = run.dataset.skeleton;  // the data itself (ModelContext), not in "context"
  run.context.layout = run.dataset.layout;
  run.context.content_labels = run.dataset.content_labels;
  run.context.style_labels = run.dataset.style_labels;
  run.context.stats = run.stats;
  const torch::Device device = parse_device(options.device);
  run.kind = family_info(run.family).kind;
  run.trainable = create_trainable(run.family, run.config["model"], run.context);
  run.trainable->to(device);
  const std::string ckpt = (fs::path(run_dir) / options.checkpoint).string();
  if (!fs::exists(ckpt)) throw Error(ckpt + ": checkpoint not found (a shipped model holds only checkpoint.pt; a run keeps checkpoint-STEP.pt files with keep_checkpoints)");
  run.step = load_checkpoint(ckpt, *run.trainable, nullptr, device).step;
  run.model = std::dynamic_pointer_cast<MotionModel>(run.trainable);
  if (run.model) run.traits = run.model->traits();
  run.trainable->eval();
  return run;
}

}  // namespace mosyn::nn

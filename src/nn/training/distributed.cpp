#include "nn/training/distributed.h"

#include <torch/version.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <optional>

#include "core/error.h"

// The c10d headers include Gloo's (Debian's libgloo-dev); CMake defines MOSYN_HAVE_GLOO when they
// are there, and MOSYN_HAVE_NCCL (with USE_C10D_NCCL) for a CUDA LibTorch with NCCL.
#if defined(MOSYN_HAVE_GLOO)
#include <torch/csrc/distributed/c10d/PrefixStore.hpp>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#endif
#if defined(MOSYN_HAVE_NCCL)
#include <torch/csrc/distributed/c10d/ProcessGroupNCCL.hpp>
#endif

namespace mosyn::nn {

namespace {

using Millis = std::chrono::milliseconds;

Millis to_millis(double seconds) { return Millis(static_cast<int64_t>(seconds * 1000.0)); }

std::string seconds_text(double s) {
  std::string t = std::to_string(s);
  t.erase(t.find_last_not_of('0') + 1);
  if (!t.empty() && t.back() == '.') t.pop_back();
  return t + " s";
}

long long parse_integer(const std::string& name, const std::string& value) {
  size_t used = 0;
  long long v = 0;
  try {
    v = std::stoll(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != value.size()) throw Error(name + "='" + value + "' is not an integer");
  return v;
}

double parse_seconds(const std::string& name, const std::string& value) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != value.size() || !(v > 0))
    throw Error(name + "='" + value + "' is not a positive number of seconds");
  return v;
}

// LibTorch's errors carry a stack trace in what(); the message alone is what users need.
[[maybe_unused]] std::string message_of(const std::exception& e) {
  if (const auto* c10_error = dynamic_cast<const c10::Error*>(&e)) return c10_error->what_without_backtrace();
  return e.what();
}

[[maybe_unused]] bool is_loopback(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

}  // namespace

void DistributedOptions::check() const {
  if (world_size < 1) throw Error("WORLD_SIZE=" + std::to_string(world_size) + ": must be at least 1");
  if (rank < 0 || rank >= world_size)
    throw Error("RANK=" + std::to_string(rank) + " is out of range for WORLD_SIZE=" + std::to_string(world_size) +
                " (ranks are 0.." + std::to_string(world_size - 1) + ")");
  if (world_size > 1 && master_addr.empty())
    throw Error("WORLD_SIZE=" + std::to_string(world_size) +
                " is set without MASTER_ADDR: every rank needs the host of rank 0's rendezvous (and MASTER_PORT)");
  if (master_port < 1 || master_port > 65535)
    throw Error("MASTER_PORT=" + std::to_string(master_port) + " is not a TCP port (1..65535)");
  if (!(timeout_s > 0)) throw Error("MOSYN_DIST_TIMEOUT must be positive");
}

DistributedOptions distributed_from_environment(const EnvLookup& lookup) {
  const EnvLookup env = lookup ? lookup : EnvLookup([](const char* n) { return std::getenv(n); });
  auto get = [&](const std::string& name) -> std::optional<std::string> {
    const char* v = env(name.c_str());
    if (v == nullptr || *v == '\0') return std::nullopt;
    return std::string(v);
  };
  // torchrun and hand-made launches set RANK/WORLD_SIZE; srun alone sets SLURM_*.
  std::string rank_var = "RANK", size_var = "WORLD_SIZE", local_var = "LOCAL_RANK";
  if (!get(size_var) && get("SLURM_PROCID") && get("SLURM_NTASKS")) {
    rank_var = "SLURM_PROCID";
    size_var = "SLURM_NTASKS";
    local_var = "SLURM_LOCALID";
  }
  DistributedOptions o;
  const auto size = get(size_var);
  const auto rank = get(rank_var);
  if (!size) {
    if (rank && parse_integer(rank_var, *rank) != 0)
      throw Error(rank_var + "=" + *rank + " is set but " + size_var + " is not: set both (or neither)");
    return o;
  }
  o.world_size = static_cast<int>(parse_integer(size_var, *size));
  if (!rank && o.world_size > 1)
    throw Error(size_var + "=" + *size + " is set but " + rank_var + " is not: every process needs its rank 0.." +
                std::to_string(o.world_size - 1));
  if (rank) o.rank = static_cast<int>(parse_integer(rank_var, *rank));
  if (const auto v = get(local_var)) o.local_rank = static_cast<int>(parse_integer(local_var, *v));
  if (const auto v = get("MASTER_ADDR")) o.master_addr = *v;
  if (const auto v = get("MASTER_PORT")) o.master_port = static_cast<int>(parse_integer("MASTER_PORT", *v));
  if (const auto v = get("MOSYN_DIST_TIMEOUT")) o.timeout_s = parse_seconds("MOSYN_DIST_TIMEOUT", *v);
  if (const auto v = get("GLOO_SOCKET_IFNAME")) o.socket_interface = *v;
  // torchrun's static rendezvous hosts the store in its agent; workers join it as clients, under
  // a prefix per restart so that a restarted group never reads the keys of the one before.
  o.agent_store = get("TORCHELASTIC_USE_AGENT_STORE").value_or("") == "True";
  o.store_prefix = "mosyn/attempt_" + get("TORCHELASTIC_RESTART_COUNT").value_or("0") + "/";
  o.check();
  return o;
}

// ---------------------------------------------------------------------------------------------
// ProcessGroup

#if defined(MOSYN_HAVE_GLOO)
// LibTorch 2 split the collectives' implementations (Backend) from the ProcessGroup front.
#if TORCH_VERSION_MAJOR >= 2
using CommGroup = c10d::Backend;
#else
using CommGroup = c10d::ProcessGroup;
#endif

struct ProcessGroup::Impl {
  c10::intrusive_ptr<c10d::Store> store;
  c10::intrusive_ptr<CommGroup> group;
  std::string backend = "gloo";
};

namespace {

std::shared_ptr<::gloo::transport::Device> gloo_device(const DistributedOptions& o) {
  if (!o.socket_interface.empty()) return c10d::ProcessGroupGloo::createDeviceForInterface(o.socket_interface);
  // All ranks on this machine: bind loopback, whatever the host name resolves to.
  if (is_loopback(o.master_addr)) return c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1");
  return c10d::ProcessGroupGloo::createDefaultDevice();
}

}  // namespace

ProcessGroup::ProcessGroup(const DistributedOptions& o, const torch::Device& device)
    : options_(o), impl_(std::make_unique<Impl>()) {
  o.check();
  if (!o.enabled()) throw Error("distributed training: a process group needs WORLD_SIZE > 1");
  const Millis timeout = to_millis(o.timeout_s);
  const std::string where = o.master_addr + ":" + std::to_string(o.master_port);
  const std::string who = "rank " + std::to_string(o.rank) + " of " + std::to_string(o.world_size);
  // A peer missing shows in the store's rendezvous or in Gloo's pairwise connection that follows.
  auto not_joined = [&](const std::exception& e) {
    return Error(who + ": not all " + std::to_string(o.world_size) + " processes joined at " + where + " within " +
                 seconds_text(o.timeout_s) +
                 " (are all ranks started with the same MASTER_ADDR, MASTER_PORT and WORLD_SIZE, and can they reach "
                 "it?): " + message_of(e));
  };
  try {
    c10d::TCPStoreOptions so;
    so.port = static_cast<std::uint16_t>(o.master_port);
    so.isServer = o.rank == 0 && !o.agent_store;
    so.numWorkers = static_cast<size_t>(o.world_size);
    so.waitWorkers = true;
    so.timeout = timeout;
    auto tcp = c10::make_intrusive<c10d::TCPStore>(o.master_addr, so);
    impl_->store = c10::make_intrusive<c10d::PrefixStore>(o.store_prefix, tcp);
  } catch (const std::exception& e) {
    throw not_joined(e);
  }
  try {
#if defined(MOSYN_HAVE_NCCL)
    if (device.is_cuda()) {
      auto nccl = c10d::ProcessGroupNCCL::Options::create();
      nccl->timeout = timeout;
      impl_->group = c10::make_intrusive<c10d::ProcessGroupNCCL>(impl_->store, o.rank, o.world_size, nccl);
      impl_->backend = "nccl";
      return;
    }
#endif
    auto gloo = c10d::ProcessGroupGloo::Options::create(timeout);
    gloo->devices.push_back(gloo_device(o));
    impl_->group = c10::make_intrusive<c10d::ProcessGroupGloo>(impl_->store, o.rank, o.world_size, gloo);
  } catch (const std::exception& e) {
    throw not_joined(e);
  }
}

ProcessGroup::~ProcessGroup() = default;

const std::string& ProcessGroup::backend() const { return impl_->backend; }

std::string ProcessGroup::next_key(const char* what) { return std::string(what) + "/" + std::to_string(sequence_++); }

namespace {

// Waits for a collective; a peer that died or stalls past the timeout becomes an Error.
void finish(const c10::intrusive_ptr<c10d::Work>& work, const DistributedOptions& o, const char* what) {
  try {
    work->wait();
  } catch (const std::exception& e) {
    throw Error("rank " + std::to_string(o.rank) + ": " + what + " across " + std::to_string(o.world_size) +
                " processes failed (a peer stopped, or did not answer within " + seconds_text(o.timeout_s) +
                "): " + message_of(e));
  }
}

}  // namespace

void ProcessGroup::allreduce_sum(torch::Tensor& tensor) {
  // Gloo built without CUDA reduces host memory only.
  const bool via_host = tensor.is_cuda() && impl_->backend == "gloo";
  std::vector<at::Tensor> v{via_host ? tensor.cpu() : tensor};
  finish(impl_->group->allreduce(v), options_, "allreduce");
  if (via_host) tensor.copy_(v[0]);
}

void ProcessGroup::broadcast(torch::Tensor& tensor, int root) {
  const bool via_host = tensor.is_cuda() && impl_->backend == "gloo";
  std::vector<at::Tensor> v{via_host ? tensor.cpu() : tensor};
  c10d::BroadcastOptions bo;
  bo.rootRank = root;
  finish(impl_->group->broadcast(v, bo), options_, "broadcast");
  if (via_host) tensor.copy_(v[0]);
}

std::string ProcessGroup::broadcast_bytes(const std::string& bytes, int root) {
  const std::string key = next_key("bytes");
  try {
    if (rank() == root) {
      impl_->store->set(key, std::vector<uint8_t>(bytes.begin(), bytes.end()));
      return bytes;
    }
    const std::vector<uint8_t> got = impl_->store->get(key);  // waits up to the store's timeout
    return std::string(got.begin(), got.end());
  } catch (const std::exception& e) {
    throw Error("rank " + std::to_string(rank()) + ": no word from rank " + std::to_string(root) + " within " +
                seconds_text(options_.timeout_s) + " (did it stop?): " + message_of(e));
  }
}

std::vector<std::string> ProcessGroup::all_gather_text(const std::string& text) {
  const std::string key = next_key("text");
  std::vector<std::string> out(world_size());
  int r = 0;
  try {
    impl_->store->set(key + "/" + std::to_string(rank()), std::vector<uint8_t>(text.begin(), text.end()));
    for (; r < world_size(); ++r) {
      const std::vector<uint8_t> got = impl_->store->get(key + "/" + std::to_string(r));
      out[r].assign(got.begin(), got.end());
    }
  } catch (const std::exception& e) {
    throw Error("rank " + std::to_string(rank()) + ": no word from rank " + std::to_string(r) + " within " +
                seconds_text(options_.timeout_s) + " (did it stop?): " + message_of(e));
  }
  return out;
}

#else  // built without Gloo

struct ProcessGroup::Impl {};

ProcessGroup::ProcessGroup(const DistributedOptions& o, const torch::Device&) : options_(o) {
  o.check();
  throw Error("distributed training (WORLD_SIZE=" + std::to_string(o.world_size) +
              "): this mosyn was built without Gloo; install libgloo-dev and rebuild (cmake picks it up)");
}
ProcessGroup::~ProcessGroup() = default;
const std::string& ProcessGroup::backend() const {
  static const std::string none = "none";
  return none;
}
std::string ProcessGroup::next_key(const char* what) { return what; }
void ProcessGroup::allreduce_sum(torch::Tensor&) {}
void ProcessGroup::broadcast(torch::Tensor&, int) {}
std::string ProcessGroup::broadcast_bytes(const std::string& bytes, int) { return bytes; }
std::vector<std::string> ProcessGroup::all_gather_text(const std::string& text) { return {text}; }

#endif

// ---------------------------------------------------------------------------------------------
// Gradients and modules

std::vector<double> allreduce_gradients(ProcessGroup& group, const std::vector<torch::Tensor>& params, double weight,
                                        const std::vector<double>& scalars) {
  torch::NoGradGuard no_grad;
  // One buffer: [every gradient, zero where absent] [presence per parameter] [scalars].
  int64_t total = 0;
  for (const auto& p : params) total += p.numel();
  const auto count = static_cast<int64_t>(params.size()), extra = static_cast<int64_t>(scalars.size());
  const torch::TensorOptions options =
      params.empty() ? torch::TensorOptions(torch::kFloat) : params.front().options().requires_grad(false);
  torch::Tensor flat = torch::zeros({total + count + extra}, options);
  torch::Tensor tail = torch::zeros({count + extra}, torch::kDouble);
  auto marks = tail.accessor<double, 1>();
  int64_t at = 0;
  for (int64_t i = 0; i < count; ++i) {
    const torch::Tensor& grad = params[i].grad();
    const int64_t n = params[i].numel();
    if (grad.defined()) {
      flat.narrow(0, at, n).copy_(grad.reshape(-1));
      marks[i] = 1.0;
    }
    at += n;
  }
  for (int64_t s = 0; s < extra; ++s) marks[count + s] = scalars[s];
  flat.narrow(0, 0, total).mul_(weight);
  flat.narrow(0, total, count + extra).copy_(tail);
  group.allreduce_sum(flat);
  tail = flat.narrow(0, total, count + extra).to(torch::kCPU, torch::kDouble);
  const auto sums = tail.accessor<double, 1>();
  at = 0;
  for (int64_t i = 0; i < count; ++i) {
    torch::Tensor p = params[i];  // shares the parameter; its grad is set through it
    const int64_t n = p.numel();
    if (sums[i] > 0) {
      const torch::Tensor reduced = flat.narrow(0, at, n).view_as(p);
      if (p.grad().defined()) p.mutable_grad().copy_(reduced);
      else p.mutable_grad() = reduced.to(p.dtype()).clone();
    }
    at += n;
  }
  std::vector<double> out(extra);
  for (int64_t s = 0; s < extra; ++s) out[s] = sums[count + s];
  return out;
}

void broadcast_module(ProcessGroup& group, torch::nn::Module& module, int root) {
  torch::NoGradGuard no_grad;
  std::map<c10::ScalarType, std::vector<torch::Tensor>> by_type;  // one buffer per dtype
  for (const auto& p : module.parameters()) by_type[p.scalar_type()].push_back(p);
  for (const auto& b : module.buffers()) by_type[b.scalar_type()].push_back(b);
  for (auto& [type, tensors] : by_type) {
    std::vector<torch::Tensor> flat_parts;
    for (const auto& t : tensors) flat_parts.push_back(t.reshape(-1));
    torch::Tensor flat = torch::cat(flat_parts);
    group.broadcast(flat, root);
    int64_t at = 0;
    for (auto& t : tensors) {
      t.copy_(flat.narrow(0, at, t.numel()).view_as(t));
      at += t.numel();
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Setup exchanges

std::string share_from_root(ProcessGroup& group, const std::function<std::string()>& make, int root) {
  // The first byte says what follows: 'K' a result, 'E' the root's error message.
  if (group.rank() == root) {
    std::string out;
    try {
      out = make();
    } catch (const std::exception& e) {
      group.broadcast_bytes("E" + message_of(e), root);
      throw;
    }
    group.broadcast_bytes("K" + out, root);
    return out;
  }
  const std::string got = group.broadcast_bytes(std::string(), root);
  if (got.empty() || got[0] != 'K')
    throw Error("rank " + std::to_string(root) + " stopped: " + (got.empty() ? std::string("?") : got.substr(1)));
  return got.substr(1);
}

void check_agreement(ProcessGroup& group, const std::function<std::string()>& fingerprint, const std::string& what) {
  std::string mine;
  try {
    mine = "K" + fingerprint();
  } catch (const std::exception& e) {
    mine = "E" + message_of(e);
  }
  const std::vector<std::string> all = group.all_gather_text(mine);
  for (size_t r = 0; r < all.size(); ++r)
    if (all[r].empty() || all[r][0] != 'K')
      throw Error("rank " + std::to_string(r) + " stopped: " + (all[r].empty() ? std::string("?") : all[r].substr(1)));
  for (size_t r = 1; r < all.size(); ++r)
    if (all[r] != all[0])
      throw Error("rank " + std::to_string(r) + "'s " + what + " differs from rank 0's (" + all[r].substr(1) +
                  " against " + all[0].substr(1) + "): every rank needs the same " + what);
}

}  // namespace mosyn::nn

// Data-parallel training across processes (and machines) through LibTorch's c10d: the launcher's
// environment, the process group, and the few collectives the trainer needs.
//
// A data-parallel run is N copies of `mosyn train` with the same options and the same dataset,
// one per rank, configured by the environment that launchers set (torchrun, srun, or by hand):
//   WORLD_SIZE   number of processes (absent or 1: an ordinary single-process run)
//   RANK         this process, 0 .. WORLD_SIZE-1; rank 0 alone writes the run directory
//   MASTER_ADDR  host (name or address) where rank 0 (or torchrun's agent) serves the rendezvous
//                store; every rank must reach it
//   MASTER_PORT  its TCP port (default 29500)
//   LOCAL_RANK   this process's index on its machine: picks the GPU of `--device cuda`
//   MOSYN_DIST_TIMEOUT  seconds to wait for peers (connection and every collective; default 300)
// Under srun without these, SLURM_PROCID / SLURM_NTASKS / SLURM_LOCALID give rank, world size and
// local rank (MASTER_ADDR is still needed). torchrun's agent-hosted store
// (TORCHELASTIC_USE_AGENT_STORE=True) is joined as a client, under a prefix per restart attempt.
//
// Transport: Gloo over TCP on CPU (GLOO_SOCKET_IFNAME picks the network interface, as in
// PyTorch); NCCL for CUDA tensors when mosyn is built against a CUDA LibTorch with NCCL
// (MOSYN_HAVE_NCCL), otherwise Gloo with a copy through host memory. Built without the Gloo
// headers (Debian's libgloo-dev), connecting throws mosyn::Error saying so.
//
// Errors are mosyn::Error naming the variable or the peer: WORLD_SIZE without MASTER_ADDR, RANK
// out of range, malformed numbers, and a peer that does not connect or answer within the timeout
// (never an indefinite hang).
#pragma once

#include <torch/nn/module.h>
#include <torch/types.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace mosyn::nn {

// Where this process stands in a data-parallel run.
struct DistributedOptions {
  int rank = 0;
  int world_size = 1;          // 1 = not distributed
  int local_rank = -1;         // -1 = not given (the GPU is then rank modulo the device count)
  std::string master_addr;     // rendezvous host
  int master_port = 29500;     // rendezvous TCP port
  double timeout_s = 300;      // connecting, and each collective
  bool agent_store = false;    // the launcher (torchrun) hosts the store: rank 0 joins as a client
  std::string store_prefix = "mosyn/";  // key prefix in the store (per torchrun restart attempt)
  std::string socket_interface;  // GLOO_SOCKET_IFNAME: the network interface Gloo binds; empty = by host

  bool enabled() const { return world_size > 1; }
  // Throws mosyn::Error when the fields contradict each other (rank out of range, no master
  // address for world size > 1, port outside 1..65535, timeout <= 0).
  void check() const;
};

// Looks up one environment variable: its value, or nullptr when unset (std::getenv's contract).
using EnvLookup = std::function<const char*(const char*)>;

// The options from the launcher's environment (see the file comment); checked. The default
// lookup is std::getenv. Throws mosyn::Error naming the variable when one is malformed or they
// contradict each other.
DistributedOptions distributed_from_environment(const EnvLookup& env = {});

// A connected group of world_size processes. Every collective must be called by every rank in
// the same order with tensors of the same shape and dtype (the trainer's steps guarantee it).
class ProcessGroup {
 public:
  // Rendezvous through a TCP store at master_addr:master_port (rank 0 serves it unless
  // agent_store), then connects every pair of ranks: NCCL when `device` is CUDA and mosyn has
  // it, else Gloo. Throws mosyn::Error when a peer does not join within timeout_s, naming the
  // address, or when the options are not enabled().
  ProcessGroup(const DistributedOptions& options, const torch::Device& device);
  ~ProcessGroup();
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;

  int rank() const { return options_.rank; }
  int world_size() const { return options_.world_size; }
  const std::string& backend() const;  // "gloo" or "nccl"

  // Sums `tensor` (contiguous, any device, float or double) over all ranks, in place; every
  // rank ends with the same values.
  void allreduce_sum(torch::Tensor& tensor);
  // Overwrites `tensor` on every rank with root's (contiguous, same shape everywhere).
  void broadcast(torch::Tensor& tensor, int root = 0);
  // Root's bytes (config, a checkpoint file) to every rank, through the store; `bytes` is read
  // on root only. Returns them on every rank.
  std::string broadcast_bytes(const std::string& bytes, int root = 0);
  // Every rank's text in rank order (setup status, data fingerprints), through the store.
  std::vector<std::string> all_gather_text(const std::string& text);

 private:
  struct Impl;
  std::string next_key(const char* what);

  DistributedOptions options_;
  std::unique_ptr<Impl> impl_;
  long sequence_ = 0;  // makes every store exchange's keys unique
};

// Sums the gradients of `params` (undefined ones count as absent, not zero) and `scalars` over
// all ranks in one flattened buffer per call: each rank contributes gradient * weight, so with
// weight = (this rank's windows) / (the global batch) the result is the gradient of the global
// batch's mean loss. A gradient absent on every rank stays undefined, as in one process; one
// present anywhere is defined everywhere. `scalars` (e.g. the weighted loss, a stop request) are
// summed as given, in float32 precision; returns the sums.
std::vector<double> allreduce_gradients(ProcessGroup& group, const std::vector<torch::Tensor>& params, double weight,
                                        const std::vector<double>& scalars);

// Runs make() on root alone and returns its result on every rank (through the store). When it
// throws on root, root rethrows and every other rank throws mosyn::Error quoting it, so a failure
// there never leaves the peers waiting for a collective until the timeout.
std::string share_from_root(ProcessGroup& group, const std::function<std::string()>& make, int root = 0);

// Runs fingerprint() on every rank and compares: throws mosyn::Error on every rank when any rank's
// call threw (naming the rank and its message) or returned other text than rank 0's (naming
// `what`, e.g. "dataset", and both texts).
void check_agreement(ProcessGroup& group, const std::function<std::string()>& fingerprint, const std::string& what);

// Copies rank root's parameters and buffers of `module` to every rank (one flattened broadcast).
void broadcast_module(ProcessGroup& group, torch::nn::Module& module, int root = 0);

}  // namespace mosyn::nn

// Data-parallel training (nn/training/distributed.h): the launcher's environment, a peer that never
// comes, and two local processes on loopback against one process on the same global batch.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "core/error.h"
#include "io/json_file.h"
#include "nn/checkpoint.h"
#include "nn/registry.h"
#include "nn/run_info.h"
#include "nn/training/distributed.h"
#include "nn/training/train.h"
#include "nn_test_util.h"

extern char** environ;

using namespace mosyn;
using namespace mosyn::nn;
namespace fs = std::filesystem;

namespace {

// A lookup over a fixed environment.
EnvLookup env_of(const std::map<std::string, std::string>& vars) {
  return [vars](const char* name) -> const char* {
    const auto it = vars.find(name);
    return it == vars.end() ? nullptr : it->second.c_str();
  };
}

std::string error_of(const std::map<std::string, std::string>& vars) {
  try {
    distributed_from_environment(env_of(vars));
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// A TCP port free on loopback now: bind port 0 and read back what the kernel chose.
int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof addr;
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0)
    throw std::runtime_error("no free port");
  ::close(fd);
  return ntohs(addr.sin_port);
}

// The same tiny deterministic MoGlow run in every process: no dropout, so that the only
// difference between one process and two is how the batch is split (5 windows: 2 + 3).
TrainOptions tiny_options(const fs::path& dir) {
  TrainOptions o;
  o.family = "moglow";
  o.out_dir = dir.string();
  o.model_config = {{"num_steps", 2}, {"hidden", 8}, {"tau", 2}, {"dropout", 0.0}, {"label_dropout", 0.0}};
  o.steps = 3;
  o.batch = 5;
  o.lr = 1e-3;
  o.warmup = 2;
  o.threads = 1;
  o.checkpoint_every = 1;
  o.validate_every = 1;
  o.log_every = 1;
  o.seed = 11;
  return o;
}

// Starts this test binary as rank `rank` of a two-process run into `out`.
pid_t start_worker(int rank, int port, const fs::path& out) {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) env.emplace_back(*e);
  for (const std::string& v : {"RANK=" + std::to_string(rank), std::string("WORLD_SIZE=2"),
                                std::string("MASTER_ADDR=127.0.0.1"), "MASTER_PORT=" + std::to_string(port),
                                std::string("MOSYN_DIST_TIMEOUT=60"), "MOSYN_TEST_WORKER_OUT=" + out.string()})
    env.push_back(v);
  std::vector<char*> envp;
  for (auto& v : env) envp.push_back(v.data());
  envp.push_back(nullptr);
  std::string self = fs::read_symlink("/proc/self/exe").string(), filter = "--gtest_filter=DistributedWorker.Train";
  char* argv[] = {self.data(), filter.data(), nullptr};
  pid_t pid = 0;
  if (::posix_spawn(&pid, self.c_str(), nullptr, nullptr, argv, envp.data()) != 0) return -1;
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  if (::waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::shared_ptr<TrainableModel> load_model(const fs::path& run) {
  const auto config = io::read_json((run / "config.json").string());
  auto model = create_trainable(config.at("family").get<std::string>(), config.at("model"),
                                context_from_json(config.at("context"), run.string()));
  load_checkpoint((run / "checkpoint.pt").string(), *model, nullptr, torch::kCPU);
  return model;
}

// max |a - b| over parameters and buffers, relative to the largest |b| (at least 1).
double relative_difference(torch::nn::Module& a, torch::nn::Module& b) {
  double diff = 0, scale = 1;
  auto pb = b.named_parameters();
  for (const auto& kv : a.named_parameters()) {
    diff = std::max(diff, (kv.value() - pb[kv.key()]).abs().max().item<double>());
    scale = std::max(scale, pb[kv.key()].abs().max().item<double>());
  }
  auto bb = b.named_buffers();
  for (const auto& kv : a.named_buffers()) diff = std::max(diff, (kv.value() - bb[kv.key()]).abs().max().item<double>());
  return diff / scale;
}

std::vector<nlohmann::json> log_lines(const fs::path& run) {
  std::vector<nlohmann::json> lines;
  std::ifstream in(run / "log.jsonl");
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

}  // namespace

TEST(Distributed, EnvironmentOfLaunchers) {
  EXPECT_FALSE(distributed_from_environment(env_of({})).enabled());
  EXPECT_FALSE(distributed_from_environment(env_of({{"RANK", "0"}, {"WORLD_SIZE", "1"}})).enabled());
  const auto torchrun = distributed_from_environment(env_of({{"RANK", "1"}, {"WORLD_SIZE", "4"}, {"LOCAL_RANK", "1"},
                                                             {"MASTER_ADDR", "node0"}, {"MASTER_PORT", "29400"},
                                                             {"TORCHELASTIC_USE_AGENT_STORE", "True"},
                                                             {"TORCHELASTIC_RESTART_COUNT", "2"}}));
  EXPECT_EQ(torchrun.rank, 1);
  EXPECT_EQ(torchrun.world_size, 4);
  EXPECT_EQ(torchrun.local_rank, 1);
  EXPECT_EQ(torchrun.master_addr, "node0");
  EXPECT_EQ(torchrun.master_port, 29400);
  EXPECT_TRUE(torchrun.agent_store);
  EXPECT_EQ(torchrun.store_prefix, "mosyn/attempt_2/");
  const auto slurm = distributed_from_environment(env_of(
      {{"SLURM_PROCID", "3"}, {"SLURM_NTASKS", "8"}, {"SLURM_LOCALID", "1"}, {"MASTER_ADDR", "10.0.0.1"}}));
  EXPECT_EQ(slurm.rank, 3);
  EXPECT_EQ(slurm.world_size, 8);
  EXPECT_EQ(slurm.local_rank, 1);
  EXPECT_EQ(slurm.master_port, 29500);

  EXPECT_NE(error_of({{"RANK", "0"}, {"WORLD_SIZE", "2"}}).find("without MASTER_ADDR"), std::string::npos);
  EXPECT_NE(error_of({{"RANK", "2"}, {"WORLD_SIZE", "2"}, {"MASTER_ADDR", "h"}}).find("RANK=2 is out of range"),
            std::string::npos);
  EXPECT_NE(error_of({{"WORLD_SIZE", "2"}, {"MASTER_ADDR", "h"}}).find("RANK is not"), std::string::npos);
  EXPECT_NE(error_of({{"RANK", "1"}}).find("WORLD_SIZE is not"), std::string::npos);
  EXPECT_NE(error_of({{"RANK", "x"}, {"WORLD_SIZE", "2"}, {"MASTER_ADDR", "h"}}).find("RANK='x' is not an integer"),
            std::string::npos);
  EXPECT_NE(error_of({{"RANK", "0"}, {"WORLD_SIZE", "2"}, {"MASTER_ADDR", "h"}, {"MASTER_PORT", "70000"}})
                .find("MASTER_PORT=70000"),
            std::string::npos);
}

TEST(Distributed, PeerThatNeverComesTimesOut) {
  DistributedOptions o;
  o.world_size = 2;
  o.master_addr = "127.0.0.1";
  o.master_port = free_port();
  o.timeout_s = 1.5;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    ProcessGroup group(o, torch::kCPU);
    FAIL() << "connected without its peer";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not all 2 processes joined at 127.0.0.1:"), std::string::npos)
        << e.what();
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0);
}

// One rank of TwoProcessesEqualOne, started by it with the launcher's environment.
TEST(DistributedWorker, Train) {
  const char* out = std::getenv("MOSYN_TEST_WORKER_OUT");
  if (out == nullptr) GTEST_SKIP() << "started by Distributed.TwoProcessesEqualOne";
  const auto ds = nn::testing::synthetic_dataset();
  TrainOptions o = tiny_options(out);
  o.distributed = distributed_from_environment();
  const TrainResult r = train(o, ds);
  EXPECT_EQ(r.step, 3);
}

TEST(Distributed, TwoProcessesEqualOne) {
  const fs::path base = fs::temp_directory_path() / ("mosyn_dist_" + std::to_string(::getpid()));
  fs::remove_all(base);
  const fs::path two = base / "two", one = base / "one";
  const int port = free_port();
  const pid_t r0 = start_worker(0, port, two), r1 = start_worker(1, port, two);
  ASSERT_GT(r0, 0);
  ASSERT_GT(r1, 0);
  const auto ds = nn::testing::synthetic_dataset();
  train(tiny_options(one), ds);  // the reference, meanwhile
  EXPECT_EQ(wait_exit(r0), 0);
  EXPECT_EQ(wait_exit(r1), 0);
  ASSERT_TRUE(fs::exists(two / "checkpoint.pt"));

  // The same weights (and validation losses) as one process on the same global batches.
  EXPECT_LT(relative_difference(*load_model(two), *load_model(one)), 1e-5);
  const auto logs_two = log_lines(two), logs_one = log_lines(one);
  ASSERT_EQ(logs_two.size(), 3u);  // one writer: a line per step, none twice
  ASSERT_EQ(logs_one.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(logs_two[i].at("step"), logs_one[i].at("step"));
    EXPECT_NEAR(logs_two[i].at("loss").get<double>(), logs_one[i].at("loss").get<double>(), 1e-5);
    EXPECT_NEAR(logs_two[i].at("val_loss").get<double>(), logs_one[i].at("val_loss").get<double>(), 1e-5);
    // The validation terms are reduced over the ranks too (here MoGlow's nll_frame, logdet_frame).
    int val_terms = 0;
    for (auto it = logs_one[i].begin(); it != logs_one[i].end(); ++it) {
      if (it.key().rfind("val_", 0) != 0 || it.key() == "val_loss") continue;
      ++val_terms;
      EXPECT_NEAR(logs_two[i].at(it.key()).get<double>(), it.value().get<double>(),
                  1e-5 * std::max(1.0, std::abs(it.value().get<double>())))
          << it.key();
    }
    EXPECT_GT(val_terms, 0);
  }
  // Only rank 0 wrote the run: its files and nothing else (a second writer would have failed on
  // the run lock, and a resumed copy of a checkpoint would be a stray file).
  std::set<std::string> files;
  for (const auto& entry : fs::directory_iterator(two)) files.insert(entry.path().filename().string());
  EXPECT_EQ(files, (std::set<std::string>{".lock", "best.pt", "checkpoint.pt", "config.json", "log.jsonl", "stats.json"}));
  EXPECT_EQ(io::read_json((two / "config.json").string()).at("world_size"), 2);

  // Resumed by one process: continues from rank 0's checkpoint as the one-process run does.
  TrainOptions more_two = tiny_options(two), more_one = tiny_options(one);
  more_two.resume = more_one.resume = true;
  more_two.steps = more_one.steps = 5;
  EXPECT_EQ(train(more_two, ds).step, 5);
  train(more_one, ds);
  EXPECT_EQ(io::read_json((two / "config.json").string()).at("world_size"), 1);
  EXPECT_LT(relative_difference(*load_model(two), *load_model(one)), 1e-5);
  fs::remove_all(base);
}

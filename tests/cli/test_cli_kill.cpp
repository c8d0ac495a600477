// Training survives SIGKILL at any moment (issue "reliability"): a small run is killed at random
// moments (during start-up, steps and checkpoint writes) and resumed, again and again. Every
// checkpoint left behind loads, the step count never goes back past the last completed
// checkpoint, a killed writer's temporary files are removed when the run resumes, and the final
// weights equal those of an uninterrupted run (schedule, data order and dropout are deterministic
// given the seed).
#include <gtest/gtest.h>

#include <cstdio>
#include <signal.h>
#include <sys/wait.h>
#include <torch/torch.h>
#include <unistd.h>

#include <chrono>
#include <random>
#include <thread>

#include "cli_test_util.h"
#include "data/dataset.h"
#include "data/prepare.h"
#include "io/bvh.h"
#include "io/json_file.h"
#include "nn/model.h"
#include "nn/run.h"

namespace mosyn {
namespace {

namespace fs = std::filesystem;

// Starts `mosyn args...` (stdout and stderr to /dev/null); returns its pid.
pid_t spawn_mosyn(const std::vector<std::string>& args) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    std::string binary = MOSYN_CLI_PATH;
    argv.push_back(binary.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    freopen("/dev/null", "w", stdout);
    freopen("/dev/null", "w", stderr);
    execv(binary.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// Steps of the killed run: enough that 20 starts (each killed up to 300 ms after its first
// checkpoint) do not finish it however fast a step is (120 did on an idle machine).
constexpr int kKillSteps = 600;

std::vector<std::string> train_args(const std::string& data, const std::string& out, bool resume) {
  std::vector<std::string> a = {"train",   "moglow",       "--data", data,  "--out",          out,
                                "--steps", std::to_string(kKillSteps), "--batch", "4",  "--window", "20",
                                "--warmup", "0",           "--seed", "5",   "--checkpoint-every", "3",
                                "--validate-every", "12",  "--threads", "1"};
  if (resume) a.push_back("--resume");
  return a;
}

// Waits (at most 120 s) until `checkpoint` exists with a write time after `since`, or the process
// has ended (a zombie still answers kill(pid, 0), so this checks the file only).
void wait_for_checkpoint(const fs::path& checkpoint, fs::file_time_type since, pid_t pid) {
  for (int i = 0; i < 1200; ++i) {
    std::error_code ec;
    const auto t = fs::last_write_time(checkpoint, ec);
    if (!ec && t > since) return;
    if (kill(pid, 0) != 0) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

// Step of the run's checkpoint (loads every file the run needs), or -1 when the run has none yet.
int checkpoint_step(const std::string& run) {
  if (!fs::exists(fs::path(run) / "checkpoint.pt")) return -1;
  return nn::load_run(run, nn::LoadOptions{"checkpoint.pt", "cpu", 1}).step;
}

TEST(CliKill, TrainingSurvivesSigkillAtAnyMoment) {
  const std::string root = testing::fresh_dir("cli_kill").string();
  testing::copy_test_model(root, "dataset-rotations", "dataset");
  std::ofstream(root + "/tiny.json") << R"({"model": {"num_steps": 2, "hidden": 8, "tau": 3}})";
  auto with_config = [&](std::vector<std::string> a) {
    a.insert(a.end(), {"--config", root + "/tiny.json"});
    return a;
  };
  const std::string whole = root + "/whole", killed = root + "/killed";
  ASSERT_EQ(wait_exit(spawn_mosyn(with_config(train_args(root + "/dataset", whole, false)))), 0);

  std::mt19937 rng(11);
  // Each start is killed a random moment after it has written a checkpoint of its own (so kills
  // land mid-training and mid-write, whatever the machine's load; a fixed delay on a loaded
  // machine killed every start before its first checkpoint).
  std::uniform_int_distribution<int> delay_ms(0, 300);
  int last_step = -1, kills = 0, attempts = 0, resumes = 0;
  for (int attempt = 0; attempt < 40 && kills < 20; ++attempt) {
    ++attempts;
    const bool resume = fs::exists(fs::path(killed) / "checkpoint.pt");
    if (!resume) fs::remove_all(killed);  // killed before its first checkpoint: start again
    resumes += resume;
    const fs::path checkpoint = fs::path(killed) / "checkpoint.pt";
    const auto since = resume ? fs::last_write_time(checkpoint) : fs::file_time_type::min();
    const pid_t pid = spawn_mosyn(with_config(train_args(root + "/dataset", killed, resume)));
    wait_for_checkpoint(checkpoint, since, pid);
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(rng)));
    const bool was_running = kill(pid, SIGKILL) == 0;
    const int code = wait_exit(pid);
    if (was_running && code == 128 + SIGKILL) ++kills;
    const int step = checkpoint_step(killed);  // throws (fails the test) on a torn checkpoint
    EXPECT_GE(step, last_step) << "the step went back past a completed checkpoint";
    last_step = step;
    if (fs::exists(fs::path(killed) / "best.pt")) {
      EXPECT_NO_THROW(nn::load_run(killed, nn::LoadOptions{"best.pt", "cpu", 1}));
    }
    if (code == 0) break;  // finished before the kill
  }
  EXPECT_GE(kills, 10) << "too few kills landed while the run was going";
  EXPECT_GE(resumes, 10) << "too few kills landed after a checkpoint";
  std::printf("SIGKILL landed %d times in %d starts (%d of them resumes); last checkpoint before finishing: step %d\n",
              kills, attempts, resumes, last_step);
  // Finish, then compare with the uninterrupted run.
  const bool resume = fs::exists(fs::path(killed) / "checkpoint.pt");
  ASSERT_EQ(wait_exit(spawn_mosyn(with_config(train_args(root + "/dataset", killed, resume)))), 0);
  const nn::LoadedRun a = nn::load_run(whole, nn::LoadOptions{"checkpoint.pt", "cpu", 1});
  const nn::LoadedRun b = nn::load_run(killed, nn::LoadOptions{"checkpoint.pt", "cpu", 1});
  // A killed writer's temporary files are gone once the run has been resumed (RunLock).
  for (const auto& entry : fs::directory_iterator(killed))
    EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos) << entry.path();
  EXPECT_EQ(a.step, kKillSteps);
  EXPECT_EQ(b.step, kKillSteps);
  auto pa = a.trainable->named_parameters(), pb = b.trainable->named_parameters();
  for (const auto& kv : pa) EXPECT_TRUE(torch::equal(kv.value(), pb[kv.key()])) << kv.key();
}

// `data prepare` and `sample` killed at random moments leave no partial file under a final name:
// every dataset file there opens, every BVH there parses.
TEST(CliKill, PrepareAndSampleLeaveNoPartialFiles) {
  const std::string root = testing::fresh_dir("cli_kill_outputs").string();
  data::write_synthetic_source(root + "/source", 2, 90, 3);
  testing::copy_test_model(root, "moglow", "run");
  std::mt19937 rng(12);
  std::uniform_int_distribution<int> delay_ms(800, 5000);
  int checked = 0;  // files found under final names, all whole
  for (int k = 0; k < 5; ++k) {
    const std::string ds = root + "/ds" + std::to_string(k), out = root + "/s" + std::to_string(k);
    const pid_t prep = spawn_mosyn({"data", "prepare", root + "/source", "--out", ds, "--window", "40", "--hop", "10",
                                    "--val", "0.25", "--threads", "1", "--mirror"});
    const pid_t sample = spawn_mosyn({"sample", root + "/run", "--out", out, "--n", "8", "--seconds", "6",
                                      "--positions", "--threads", "1"});
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(rng)));
    kill(prep, SIGKILL);
    kill(sample, SIGKILL);
    wait_exit(prep);
    wait_exit(sample);
    if (fs::exists(fs::path(ds) / "dataset.json")) {
      EXPECT_NO_THROW(data::Dataset::open(ds)) << ds;
      ++checked;
    }
    if (!fs::exists(out)) continue;
    for (const auto& entry : fs::directory_iterator(out)) {
      const std::string name = entry.path().filename().string();
      if (name.find(".tmp.") != std::string::npos) continue;  // a killed writer's own temporary file
      if (entry.path().extension() == ".bvh") {
        EXPECT_NO_THROW(io::read_bvh(entry.path().string())) << name;
      }
      if (entry.path().extension() == ".json") {
        EXPECT_NO_THROW(io::read_json(entry.path().string())) << name;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 0) << "every kill landed before any output was written: the test checked nothing";
}

}  // namespace
}  // namespace mosyn

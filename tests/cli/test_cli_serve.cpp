// `mosyn serve` from the command line: a missing or unsuitable run is exit 1 naming it, a bad flag
// exit 2, and a server on a free port starts, says where, and stops cleanly on SIGINT.
#include <gtest/gtest.h>

#include "cli_test_util.h"

namespace mosyn::testing {
namespace {

const std::string kModels = std::string(MOSYN_SOURCE_DIR) + "/tests/models";

TEST(CliServe, AMissingOrUnsuitableRunIsAnError) {
  CommandResult r = run_mosyn("serve /nonexistent/run --port 0");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("/nonexistent/run"), std::string::npos) << r.err;
  r = run_mosyn("serve " + kModels + "/classifier --port 0");  // classifies; cannot stream
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("frame by frame"), std::string::npos) << r.err;
  r = run_mosyn("serve " + kModels + "/moglow --port 70000");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  r = run_mosyn("serve " + kModels + "/moglow --port 0 --max-characters 0");
  EXPECT_EQ(r.exit_code, 2) << r.err;
}

TEST(CliServe, StartsOnAFreePortAndStopsOnInterrupt) {
  const std::string dir = fresh_dir("serve").string();
  // Interrupted once it says it is serving (up to 120 s: a sanitizer build on a loaded machine
  // starts slowly), not after a fixed sleep: a signal sent before the server installs its
  // handler meets the shell's SIG_IGN for background jobs and is lost.
  const std::string cmd = std::string(MOSYN_CLI_PATH) + " serve " + kModels + "/moglow --port 0 >" + dir + "/out 2>" +
                          dir + "/err </dev/null & pid=$!; for i in $(seq 1200); do grep -q 'at http' " + dir +
                          "/out && break; sleep 0.1; done; kill -INT $pid; wait $pid";
  const int status = std::system(cmd.c_str());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << slurp(dir + "/err");
  EXPECT_NE(slurp(dir + "/out").find("at http://127.0.0.1:"), std::string::npos) << slurp(dir + "/out");
}

}  // namespace
}  // namespace mosyn::testing

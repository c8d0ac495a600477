// `mosyn compare` as a user runs it: two tiny runs, one dataset; the table in three forms, and the
// usage errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "io/json_file.h"

namespace mosyn {
namespace {

using testing::fresh_dir;
using testing::run_mosyn;
using testing::slurp;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

class CliCompareTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new std::string(fresh_dir("cli_compare").string());
    testing::make_tiny_moglow_run(*root_);
    fs::copy(*root_ + "/run", *root_ + "/other", fs::copy_options::recursive);
  }
  static void TearDownTestSuite() { delete root_; }
  static std::string* root_;
};
std::string* CliCompareTest::root_ = nullptr;

TEST_F(CliCompareTest, TableJsonAndPage) {
  const std::string out = *root_ + "/cmp";
  const auto r = run_mosyn("compare " + *root_ + "/run " + *root_ + "/other --data " + *root_ +
                           "/dataset --out " + out + " --n 2 --max-clips 2 --seed 3 --threads 1 --show 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("| metric | run | other | real |"));
  EXPECT_THAT(r.out, HasSubstr("| motions | 2 | 2 | 2 |"));
  EXPECT_EQ(slurp(out + "/compare.md"), r.out);
  const nlohmann::json j = io::read_json(out + "/compare.json");
  EXPECT_EQ(j["columns"].size(), 3u);
  EXPECT_EQ(j["columns"][2]["kind"], "real");
  EXPECT_EQ(j["runs"][0]["family"], "moglow");
  // The same run twice with the same seed: the same numbers.
  EXPECT_EQ(j["metrics"]["foot_skating_ratio"]["run"], j["metrics"]["foot_skating_ratio"]["other"]);
  EXPECT_TRUE(j["metrics"]["diversity.apd_m"]["real"].is_null());
  const std::string html = slurp(out + "/compare.html");
  EXPECT_THAT(html, HasSubstr("<table class=\"compare\">"));
  EXPECT_THAT(html, HasSubstr("<th>other</th>"));
}

TEST_F(CliCompareTest, UsageAndRuntimeErrors) {
  const std::string run = *root_ + "/run", data = *root_ + "/dataset", out = *root_ + "/bad";
  // Two datasets for three runs.
  EXPECT_EQ(run_mosyn("compare " + run + " " + run + " " + run + " --data " + data + " --data " + data + " --out " + out)
                .exit_code,
            2);
  EXPECT_EQ(run_mosyn("compare " + run + " --data " + data + " --out " + out + " --n 0").exit_code, 2);
  EXPECT_EQ(run_mosyn("compare " + run + " --out " + out).exit_code, 2);  // no --data
  const auto missing = run_mosyn("compare " + run + " /nonexistent/run --data " + data + " --out " + out);
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("/nonexistent/run"));
}

}  // namespace
}  // namespace mosyn

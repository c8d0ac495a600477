// `mosyn train classifier`, `mosyn eval` and `mosyn report` end to end on a small synthetic source
// with a tiny MoGlow run and a tiny classifier.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "data/prepare.h"
#include "io/json_file.h"
#include "render/view.h"

namespace mosyn {
namespace {

using testing::fresh_dir;
using testing::run_mosyn;
using testing::slurp;
using ::testing::HasSubstr;

class CliReportTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new std::string(fresh_dir("cli_report").string());
    testing::make_tiny_moglow_run(*root_);
    testing::copy_test_model(*root_, "classifier", "cls");
  }
  static void TearDownTestSuite() { delete root_; }
  static std::string* root_;
};
std::string* CliReportTest::root_ = nullptr;

TEST_F(CliReportTest, EvalThenReport) {
  const std::string metrics = *root_ + "/run/metrics.json";
  const auto e = run_mosyn("eval " + *root_ + "/run --data " + *root_ + "/dataset --n 2 --max-clips 2 --seed 3 --prefix 0.5 "
                           "--horizon 1 --error-frames 20,60 --threads 1 --classifier " + *root_ + "/cls --out " + metrics);
  ASSERT_EQ(e.exit_code, 0) << e.err;
  EXPECT_THAT(e.out, HasSubstr("| metric | model | real data |"));
  EXPECT_THAT(e.out, HasSubstr("prediction ADE (m)"));
  EXPECT_THAT(e.out, HasSubstr("Inception score"));
  EXPECT_THAT(e.out, HasSubstr("pose error (root-relative), 4 initial frames at 1.00 s (cm)"));
  const nlohmann::json j = io::read_json(metrics);
  EXPECT_EQ(j["n"], 2);
  EXPECT_EQ(j["clips"].size(), 2u);
  EXPECT_TRUE(j["metrics"]["bone_length_rmse_cm"]["model"].is_number());
  EXPECT_TRUE(j["metrics"]["classifier.fid"]["model"].is_number());
  EXPECT_TRUE(j["metrics"]["joint_error.motion_prior.f60"]["model"].is_number());
  EXPECT_EQ(j["joint_error_clips"], 2);

  // The run's metrics.json is picked up without --metrics; samples are drawn by report itself.
  const std::string page = *root_ + "/report.html";
  const auto r = run_mosyn("report " + *root_ + "/run --out " + page + " --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = slurp(page);
  EXPECT_THAT(html, HasSubstr("<svg"));
  EXPECT_THAT(html, HasSubstr("class=\"val_loss\""));
  EXPECT_THAT(html, HasSubstr("bone-length RMSE (cm)"));
  EXPECT_THAT(html, HasSubstr("&quot;num_steps&quot;: 2"));
  if (render::viewer_available()) {
    EXPECT_THAT(html, HasSubstr("<iframe"));
    EXPECT_THAT(html, HasSubstr("mosyn-data"));
  }
}

TEST_F(CliReportTest, ReportShowsGivenSamplesAndClassifierRuns) {
  // The classifier run is an ordinary run (trained by `mosyn train classifier`) that cannot sample.
  const nlohmann::json config = io::read_json(*root_ + "/cls/config.json");
  EXPECT_EQ(config["family"], "classifier");
  EXPECT_THAT(slurp(*root_ + "/cls/log.jsonl"), HasSubstr("content_acc"));
  const auto no = run_mosyn("sample " + *root_ + "/cls --out " + *root_ + "/cls_samples --n 1 --threads 1");
  EXPECT_EQ(no.exit_code, 2);  // the wrong kind of run for sample: a usage error
  EXPECT_THAT(no.err, HasSubstr("does not generate motion"));

  const auto s = run_mosyn("sample " + *root_ + "/run --out " + *root_ + "/samples --n 2 --seconds 2 --threads 1 "
                           "--path '0,0 0,2'");
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const auto r = run_mosyn("report " + *root_ + "/run --samples " + *root_ + "/samples --out " + *root_ + "/r2.html");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = slurp(*root_ + "/r2.html");
  if (render::viewer_available()) {
    EXPECT_THAT(html, HasSubstr("sample_001.bvh"));
  }
  // A classifier run has curves and config but no samples: the page says why.
  const auto c = run_mosyn("report " + *root_ + "/cls --out " + *root_ + "/r3.html --threads 1");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const std::string html3 = slurp(*root_ + "/r3.html");
  EXPECT_THAT(html3, HasSubstr("<svg"));
  EXPECT_THAT(html3, HasSubstr("does not generate motion"));
}

// Flag errors exit 2 before any data is read; missing runs and data exit 1.
TEST(CliReport, ErrorsAndExitCodes) {
  const std::string dir = fresh_dir("cli_report_errors").string();
  EXPECT_EQ(run_mosyn("eval " + dir + "/run --data " + dir + "/dataset --split test").exit_code, 2);
  EXPECT_EQ(run_mosyn("eval " + dir + "/run --data " + dir + "/dataset --n 0").exit_code, 2);
  EXPECT_EQ(run_mosyn("eval " + dir + "/run").exit_code, 2);  // --data is required
  EXPECT_EQ(run_mosyn("eval " + dir + "/run --data " + dir + "/dataset --error-frames 70,x").exit_code, 2);
  EXPECT_EQ(run_mosyn("eval " + dir + "/run --data " + dir + "/dataset --error-frames=-3").exit_code, 2);
  EXPECT_EQ(run_mosyn("eval " + dir + "/run --data " + dir + "/dataset --error-fps 0").exit_code, 2);
  EXPECT_EQ(run_mosyn("eval " + dir + "/run --data " + dir + "/dataset --initial-frames 0").exit_code, 2);
  const auto missing = run_mosyn("eval " + dir + "/run --data " + dir + "/dataset --threads 1");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr(dir + "/dataset"));
  EXPECT_EQ(run_mosyn("report " + dir + "/run --out " + dir + "/x.html").exit_code, 1);
  EXPECT_EQ(run_mosyn("report " + dir + "/run --out " + dir + "/x.txt").exit_code, 2);
}

}  // namespace
}  // namespace mosyn

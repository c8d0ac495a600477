// Family options through nn/options_fields.h: the same JSON keys, defaults, written keys and error
// messages as the hand-written readers they replaced, and the shipped models' configs round-trip.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/json_file.h"
#include "nn/classifier/classifier.h"
#include "nn/dfn/dfn.h"
#include "nn/hvrnn/hvrnn.h"
#include "nn/moglow/moglow.h"
#include "nn/mojo/mojo.h"
#include "nn/options_fields.h"
#include "nn/registry.h"
#include "nn/run_info.h"
#include "nn/rvae/rvae.h"
#include "nn/training/train.h"

using namespace mosyn;
using ::testing::HasSubstr;
using namespace mosyn::nn;
namespace fs = std::filesystem;

namespace {

ModelContext positions_context() {
  ModelContext ctx;
  ctx.pose_dim = 6;
  ctx.control_dim = 3;
  ctx.pose_form = data::PoseForm::kPositions;
  return ctx;
}

// The message of the mosyn::Error that reading config throws, or "" when none.
std::string error_of(const std::string& family, const nlohmann::json& config) {
  try {
    if (family == "moglow") MoGlowOptions::from_json(config, positions_context());
    if (family == "rvae") RvaeOptions::from_json(config);
    if (family == "classifier") ClassifierOptions::from_json(config);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// The message of the mosyn::Error that reading training options throws, or "" when none.
std::string train_error_of(const nlohmann::json& config) {
  try {
    TrainOptions::from_json(config);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

struct BadConfig {
  const char* family;
  nlohmann::json config;
  const char* message;
};

}  // namespace

TEST(Options, BadValuesGiveTheSameMessagesAsBefore) {
  const std::vector<BadConfig> cases = {
      {"moglow", nlohmann::json::array(), "moglow config must be a JSON object"},
      {"moglow", {{"preset", 3}}, "moglow config: 'preset' must be a string"},
      {"moglow", {{"preset", "huge"}}, "moglow config: unknown preset 'huge' (known: default, paper)"},
      {"moglow", {{"nonsense", 1}}, "moglow config: unknown key 'nonsense'"},
      {"moglow", {{"hidden", 2.5}}, "moglow config: 'hidden' must be an integer"},
      {"moglow", {{"hidden", 10000000000LL}}, "moglow config: 'hidden' must be an integer"},  // would wrap to int
      {"moglow", {{"lookahead", {1, -10000000000LL}}}, "moglow config: 'lookahead' must be an array of integers"},
      {"moglow", {{"dropout", "x"}}, "moglow config: 'dropout' must be a number"},
      {"moglow", {{"labels", 1}}, "moglow config: 'labels' must be true or false"},
      {"moglow", {{"lookahead", {1, "x"}}}, "moglow config: 'lookahead' must be an array of integers"},
      {"moglow", {{"lookahead", {0}}}, "moglow config: 'lookahead' entries must be >= 1"},
      {"moglow", {{"num_steps", 0}}, "moglow config: num_steps must be >= 1"},
      {"moglow", {{"hidden", 0}}, "moglow config: hidden must be >= 1"},
      {"moglow", {{"lstm_layers", 0}}, "moglow config: lstm_layers must be >= 1"},
      {"moglow", {{"tau", 0}}, "moglow config: tau must be >= 1"},
      {"moglow", {{"dropout", 1.5}}, "moglow config: dropout must be in [0, 1]"},
      {"moglow", {{"scale_eps", -0.1}}, "moglow config: scale_eps must be >= 0"},
      {"moglow", {{"label_dropout", 2}}, "moglow config: label_dropout must be in [0, 1]"},
      {"moglow", {{"lookahead", std::vector<int>(17, 1)}}, "moglow config: at most 16 look-ahead offsets"},
      {"moglow", {{"lookahead", {5, 1001}}}, "moglow config: look-ahead offsets must be at most 1000 frames"},
      {"rvae", "x", "rvae config must be a JSON object"},
      {"rvae", {{"nonsense", 1}}, "rvae config: unknown key 'nonsense'"},
      {"rvae", {{"kernel", "x"}}, "rvae config: 'kernel' must be an integer"},
      {"rvae", {{"kernel", 4}}, "rvae config: kernel must be odd and >= 1"},
      {"rvae", {{"latent", 0}}, "rvae config: latent must be >= 1"},
      {"rvae", {{"encoder_channels", {0, 4}}}, "rvae config: 'encoder_channels' entries must be >= 1"},
      {"rvae", {{"encoder_channels", nlohmann::json::array()}},
       "rvae config: encoder_channels must have 1 to 8 entries (one per conv/pool block)"},
      {"rvae", {{"encoder_channels", {8}}}, "rvae config: control_channels must have as many entries as encoder_channels"},
      {"rvae", {{"decoder_channels", {8, 8}}}, "rvae config: decoder_channels must have one entry fewer than encoder_channels"},
      {"rvae", {{"input_dropout", 1.0}}, "rvae config: input_dropout must be in [0, 1)"},
      {"rvae", {{"kl_weight", -1}}, "rvae config: kl_weight must be >= 0"},
      {"rvae", {{"kl_anneal", 1.5}}, "rvae config: kl_anneal must be in [0, 1]"},
      {"rvae", {{"l1", -1}}, "rvae config: l1 must be >= 0"},
      {"rvae", {{"label_dropout", -0.5}}, "rvae config: label_dropout must be in [0, 1]"},
      {"rvae", {{"free_running", 2}}, "rvae config: free_running must be in [0, 1]"},
      {"rvae", {{"latent_prior", 1}}, "rvae config: latent_prior must be \"standard\" or \"conditional\""},
      {"rvae", {{"latent_prior", "x"}}, "rvae config: latent_prior must be \"standard\" or \"conditional\", not \"x\""},
      {"rvae", {{"prior_hidden", 0}}, "rvae config: prior_hidden must be >= 1"},
      {"rvae", {{"latent_prior", "conditional"}, {"free_running", 0.5}},
       "rvae config: a conditional latent prior draws every step's latent; free_running must be 0"},
      {"rvae", {{"test_latents", false}}, "rvae config: test_latents must be \"first\" or \"every_step\""},
      {"rvae", {{"test_latents", "all"}}, "rvae config: test_latents must be \"first\" or \"every_step\", not \"all\""},
      {"classifier", 1, "classifier config must be a JSON object"},
      {"classifier", {{"nosuchkey", 1}}, "classifier config: unknown key 'nosuchkey'"},
      {"classifier", {{"use_control", 1}}, "classifier config: 'use_control' must be true or false"},
      {"classifier", {{"channels", 0}}, "classifier config: channels must be >= 1"},
      {"classifier", {{"kernel", 4}}, "classifier config: kernel must be odd and >= 1"},
      {"classifier", {{"features", 0}}, "classifier config: features must be >= 1"},
      {"classifier", {{"dropout", 1}}, "classifier config: dropout must be in [0, 1)"},
      {"classifier", {{"style_weight", -1}}, "classifier config: style_weight must be >= 0"},
  };
  for (const auto& c : cases) EXPECT_EQ(error_of(c.family, c.config), c.message) << c.family << " " << c.config;
}

TEST(Options, DefaultsPresetsAndWrittenKeys) {
  const auto ctx = positions_context();
  auto o = MoGlowOptions::from_json({{"family", "moglow"}}, ctx);
  EXPECT_DOUBLE_EQ(o.dropout, 0.95);  // by pose form
  EXPECT_EQ(o.to_json(), (nlohmann::json{{"preset", "default"}, {"num_steps", 8}, {"hidden", 256},
                                         {"lstm_layers", 1}, {"tau", 10}, {"dropout", 0.95}, {"scale_eps", 0.05}}));
  auto paper = MoGlowOptions::from_json({{"preset", "paper"}, {"hidden", 64}}, ctx);
  EXPECT_EQ(paper.num_steps, 16);
  EXPECT_EQ(paper.hidden, 64);  // keys override the preset
  auto labelled = MoGlowOptions::from_json({{"labels", true}, {"lookahead", {5, 10}}}, ctx).to_json();
  EXPECT_EQ(labelled.at("label_dropout"), 0.1);
  EXPECT_EQ(labelled.at("lookahead"), (std::vector<int>{5, 10}));

  EXPECT_EQ(RvaeOptions::from_json(nlohmann::json::object()).to_json(),
            (nlohmann::json{{"encoder_channels", {64, 256}}, {"control_channels", {64, 128}},
                            {"decoder_channels", {128}}, {"latent", 128}, {"kernel", 25}, {"input_dropout", 0.1},
                            {"kl_weight", 1.0}, {"kl_anneal", 0.0}, {"l1", 0.0}, {"test_latents", "first"}}));
  auto cond = RvaeOptions::from_json({{"latent_prior", "conditional"}}).to_json();
  EXPECT_EQ(cond.at("prior_hidden"), 256);
  EXPECT_FALSE(cond.contains("free_running"));
  EXPECT_EQ(ClassifierOptions::from_json(nlohmann::json::object()).to_json(),
            (nlohmann::json{{"channels", 64}, {"kernel", 5}, {"features", 64}, {"dropout", 0.2},
                            {"use_control", true}, {"style_weight", 1.0}}));
}

// Every shipped model's config.json "model" reads and writes back unchanged (dump for dump).
TEST(Options, ShippedModelConfigsRoundTrip) {
  std::set<std::string> seen;  // families
  for (const auto& entry : fs::directory_iterator(fs::path(MOSYN_SOURCE_DIR) / "models")) {
    const auto path = entry.path() / "config.json";
    if (!fs::exists(path)) continue;
    const auto run = io::read_json(path.string());
    const std::string family = run.at("family");
    const auto& model = run.at("model");
    nlohmann::json back;
    if (family == "moglow") {
      back = MoGlowOptions::from_json(model, context_from_json(run.at("context"), path.string())).to_json();
    } else if (family == "rvae") {
      back = RvaeOptions::from_json(model).to_json();
    } else if (family == "classifier") {
      back = ClassifierOptions::from_json(model).to_json();
    } else if (family == "hvrnn") {
      back = HvrnnOptions::from_json(model).to_json();
    } else if (family == "dfn") {
      back = DfnOptions::from_json(model).to_json();
    } else if (family == "mojo") {
      back = MojoOptions::from_json(model).to_json();
    } else {
      continue;
    }
    EXPECT_EQ(back.dump(), model.dump()) << path;
    seen.insert(family);
  }
  EXPECT_EQ(seen, (std::set<std::string>{"classifier", "dfn", "hvrnn", "moglow", "mojo", "rvae"}));
}

// The facility on its own: unknown keys, ignored keys, on-read checks and docs.
TEST(Options, FieldListReadsChecksAndWrites) {
  struct Toy {
    int n = 2;
    std::vector<double> weights = {0.5};
    std::string mode = "a";
  };
  const auto fields = OptionFields<Toy>("toy")
                          .field("n", &Toy::n, "count", at_least(1))
                          .field("weights", &Toy::weights, "weights")
                          .field("mode", &Toy::mode, "mode", one_of({"a", "b", "c"}))
                          .ignore("comment");
  Toy t;
  fields.read({{"n", 3}, {"weights", {1, 2.5}}, {"comment", "free text"}}, &t);
  EXPECT_EQ(t.n, 3);
  EXPECT_EQ(t.weights, (std::vector<double>{1.0, 2.5}));
  EXPECT_EQ(fields.write(t), (nlohmann::json{{"n", 3}, {"weights", {1.0, 2.5}}, {"mode", "a"}}));
  t.mode = "d";
  try {
    fields.check(t);
    ADD_FAILURE() << "a bad mode passed";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "toy config: mode must be \"a\", \"b\" or \"c\", not \"d\"");
  }
  EXPECT_THROW(fields.read({{"weights", {"x"}}}, &t), Error);
  EXPECT_EQ(fields.docs().size(), 3u);
  EXPECT_EQ(fields.docs()[0].first, "n");
}

// The shipped models' training options (train-config.json "train", config.json "train") still load
// and write back the same values; their "model" keys are valid options of the family.
TEST(Options, ShippedTrainConfigsLoad) {
  int seen = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(MOSYN_SOURCE_DIR) / "models")) {
    for (const char* name : {"train-config.json", "config.json"}) {
      const auto path = entry.path() / name;
      if (!fs::exists(path)) continue;
      const auto file = io::read_json(path.string());
      if (!file.contains("train")) continue;
      const TrainOptions o = TrainOptions::from_json(file.at("train"));
      const nlohmann::json back = o.to_json();
      for (const auto& [key, value] : file.at("train").items())
        if (key != "resume" && key != "overwrite") {
          EXPECT_EQ(back.at(key), value) << path << " " << key;
        }
      if (std::string(name) == "train-config.json" && file.contains("model")) {
        const std::string model_name = entry.path().filename().string();
        if (model_name.rfind("moglow", 0) == 0) {
          EXPECT_NO_THROW(MoGlowOptions::from_json(file.at("model"), positions_context())) << path;
        }
        if (model_name.rfind("rvae", 0) == 0) {
          EXPECT_NO_THROW(RvaeOptions::from_json(file.at("model"))) << path;
        }
      }
      ++seen;
    }
  }
  EXPECT_GE(seen, 6);
}

// Training options go through their field list: the same type and value errors as the families'
// options, and named presets resolved before the keys given beside them.
TEST(Options, TrainingFieldsAndPresets) {
  EXPECT_THAT(train_error_of({{"stpes", 10}}), HasSubstr("training config: unknown key 'stpes'"));
  EXPECT_THAT(train_error_of({{"batch", "32"}}), HasSubstr("training config: 'batch' must be an integer"));
  EXPECT_THAT(train_error_of({{"batch", 0}}), HasSubstr("training config: batch must be >= 1"));
  EXPECT_THAT(train_error_of({{"seed", -1}}), HasSubstr("training config: 'seed' must be a non-negative integer"));
  EXPECT_THAT(train_error_of({{"window_sampling", "clips"}}), HasSubstr("window_sampling must be \"windows\" or \"frames\", not \"clips\""));
  EXPECT_THAT(train_error_of({{"speed_balance", 2}}), HasSubstr("speed_balance must be in [0, 1]"));
  EXPECT_THAT(train_error_of({{"model_config", 3}}), HasSubstr("'model_config' must be a JSON object"));
  // The defaults write what the struct holds; resume and overwrite are never written.
  const nlohmann::json defaults = TrainOptions().to_json();
  EXPECT_EQ(defaults.at("steps"), 10000);
  EXPECT_EQ(defaults.at("seed"), 1u);
  EXPECT_FALSE(defaults.contains("resume") || defaults.contains("overwrite") || defaults.contains("preset"));
  EXPECT_EQ(TrainOptions::from_json(defaults).to_json(), defaults);

  // A preset first, then the keys beside it; the resolved values and the preset's name are written.
  const TrainOptions smoke = TrainOptions::from_json({{"preset", "smoke"}, {"batch", 6}});
  EXPECT_EQ(smoke.steps, 2);
  EXPECT_EQ(smoke.val_windows, 8);
  EXPECT_EQ(smoke.batch, 6);
  const nlohmann::json written = smoke.to_json();
  EXPECT_EQ(written.at("preset"), "smoke");
  EXPECT_EQ(TrainOptions::from_json(written).to_json(), written);
  const TrainOptions finetune = TrainOptions::from_json({{"preset", "finetune"}});
  EXPECT_DOUBLE_EQ(finetune.lr, 2e-4);
  EXPECT_TRUE(finetune.keep_checkpoints);
  // A family's own presets need the family; each holds only valid keys.
  const TrainOptions paper = TrainOptions::from_json({{"family", "hvrnn"}, {"preset", "paper"}});
  EXPECT_EQ(paper.batch, 64);
  EXPECT_DOUBLE_EQ(paper.grad_clip, 0.1);
  EXPECT_THAT(train_error_of({{"preset", "paper"}}), HasSubstr("unknown training preset 'paper' (known: finetune, smoke)"));
  EXPECT_THAT(train_error_of({{"family", "dfn"}, {"preset", "fast"}}), HasSubstr("unknown training preset 'fast' for dfn (known: finetune, smoke)"));
  for (const std::string& family : model_families())
    for (const std::string& name : train_preset_names(family)) {
      SCOPED_TRACE(family + " " + name);
      EXPECT_NO_THROW(TrainOptions::from_json({{"family", family}, {"preset", name}}));
    }
}

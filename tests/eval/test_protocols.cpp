// Which eval protocols run for which model traits and options (eval/protocol.h): decided by the
// traits (control taken / generated / ignored, prefix), never by a family name.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/error.h"
#include "eval/protocol.h"

using namespace mosyn;
using Names = std::vector<std::string>;

namespace {

nn::ModelTraits traits(nn::InputUse control, bool prefix, bool labels = false) {
  nn::ModelTraits t;
  t.control = control;
  t.prefix = prefix;
  t.labels = labels;
  return t;
}

eval::EvalOptions everything_on() {
  eval::EvalOptions o;
  o.synthetic_paths = true;
  o.classifier_dir = "some/classifier";
  o.long_horizon_s = 30;
  o.prefix_generation_s = 30;
  o.label_samples = 2;
  return o;
}

}  // namespace

TEST(Protocols, NamesAndOrder) {
  Names names;
  for (const auto& p : eval::all_protocols()) names.push_back(p->name());
  EXPECT_EQ(names, (Names{"locomotion", "paths", "diversity", "joint_errors", "prediction", "body_validity",
                          "recognition", "label_generation", "long_horizon", "prefix_generation"}));
}

TEST(Protocols, DefaultOptionsForAFamilyThatTakesControlAndContinuesAPrefix) {
  const auto t = traits(nn::InputUse::kTakes, true);
  EXPECT_EQ(eval::protocols_for(t, {}),
            (Names{"locomotion", "diversity", "joint_errors", "prediction", "body_validity"}));
  EXPECT_EQ(eval::protocols_for(t, everything_on()),
            (Names{"locomotion", "paths", "diversity", "joint_errors", "prediction", "body_validity", "recognition",
                   "long_horizon", "prefix_generation"}));
  eval::EvalOptions o;
  o.prediction = false;
  o.joint_errors = false;
  EXPECT_EQ(eval::protocols_for(t, o), (Names{"locomotion", "diversity"}));
  o.joint_errors = true;
  o.error_frames.clear();  // no frame: nothing to score
  EXPECT_EQ(eval::protocols_for(t, o), (Names{"locomotion", "diversity"}));
}

TEST(Protocols, GeneratedRootMotionSkipsWhatNeedsAGivenControl) {
  // Dynamic Future Net / MOJO-like: the family makes its own root motion.
  EXPECT_EQ(eval::protocols_for(traits(nn::InputUse::kGenerates, false), everything_on()),
            (Names{"locomotion", "diversity", "recognition", "long_horizon"}));
  EXPECT_EQ(eval::protocols_for(traits(nn::InputUse::kGenerates, true), everything_on()),
            (Names{"locomotion", "diversity", "prediction", "body_validity", "recognition", "long_horizon",
                   "prefix_generation"}));
  EXPECT_EQ(eval::protocols_for(traits(nn::InputUse::kIgnores, true), everything_on()),
            (Names{"locomotion", "diversity", "prediction", "body_validity", "recognition", "long_horizon",
                   "prefix_generation"}));
}

TEST(Protocols, NoPrefixNoPredictionNorJointErrors) {
  EXPECT_EQ(eval::protocols_for(traits(nn::InputUse::kTakes, false, true), everything_on()),
            (Names{"locomotion", "paths", "diversity", "recognition", "label_generation", "long_horizon"}));
}

TEST(Protocols, ApplicabilityOfEachProtocol) {
  for (const auto& p : eval::all_protocols()) {
    SCOPED_TRACE(p->name());
    const bool takes = p->applies_to(traits(nn::InputUse::kTakes, true, true));
    const bool generates = p->applies_to(traits(nn::InputUse::kGenerates, true, true));
    const bool no_prefix = p->applies_to(traits(nn::InputUse::kTakes, false, true));
    const bool no_labels = p->applies_to(traits(nn::InputUse::kTakes, true, false));
    if (p->name() == "label_generation") EXPECT_FALSE(no_labels);
    else EXPECT_TRUE(no_labels);
    EXPECT_TRUE(takes);  // a family that takes control and continues motion has every protocol
    if (p->name() == "paths" || p->name() == "joint_errors") EXPECT_FALSE(generates);
    else EXPECT_TRUE(generates);
    if (p->name() == "prediction" || p->name() == "body_validity" || p->name() == "joint_errors" ||
        p->name() == "prefix_generation")
      EXPECT_FALSE(no_prefix);
    else EXPECT_TRUE(no_prefix);
  }
}

TEST(Protocols, OnlyTheChosenOnesAndUnknownNamesRefused) {
  const auto t = traits(nn::InputUse::kTakes, true);
  eval::EvalOptions o = everything_on();
  o.only_protocols = {"body_validity", "prediction", "paths"};
  EXPECT_EQ(eval::protocols_for(t, o), (Names{"paths", "prediction", "body_validity"}));  // in the usual order
  o.synthetic_paths = false;  // chosen but not enabled: still off
  EXPECT_EQ(eval::protocols_for(t, o), (Names{"prediction", "body_validity"}));
  o.only_protocols = {"predictions"};
  EXPECT_THROW(eval::protocols_for(t, o), Error);
}

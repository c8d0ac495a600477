// ModelContext: the facts about a dataset a model is built for. Kept free of LibTorch so that
// non-torch code (run files, the CLI) can use it.
#pragma once

#include <string>
#include <vector>

#include "core/skeleton.h"
#include "data/dataset.h"
#include "data/representation.h"

namespace mosyn::nn {

// What a model needs to know about the data it is built for.
struct ModelContext {
  int pose_dim = 0;         // D
  int control_dim = 3;      // C
  int num_content = 0;      // size of the content-label vocabulary (0 = unlabelled)
  int num_style = 0;        // size of the style-label vocabulary (0 = unlabelled)
  double fps = 30.0;        // frame rate of the data (frames per second)
  data::PoseForm pose_form = data::PoseForm::kRotations;  // the features' form, for form-dependent defaults
  // The data itself, for families whose networks or losses need it (a forward-kinematics layer
  // with the skeleton's bone offsets, losses in raw units, rotations at known feature slots).
  // Filled by the trainer and load_run from the dataset description and statistics (config.json
  // "dataset", stats.json), so it is not written to config.json's "context"; empty in contexts
  // built by hand (tests, benchmarks): a family that needs it says so when it is missing.
  Skeleton skeleton;
  data::FeatureLayout layout;
  data::DatasetStats stats;
  // The label vocabularies (DatasetInfo::content_labels, style_labels; num_content and num_style
  // entries), for options that name labels (MoGlow's lift_off_labels, heel_label_weights). Empty when built by hand.
  std::vector<std::string> content_labels;
  std::vector<std::string> style_labels;
};

}  // namespace mosyn::nn

// ModelContext: the facts about a dataset a model is built for. Kept free of LibTorch so that
// non-torch code (run files, the CLI) can use it.
#pragma once

#include <string>

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
};

}  // namespace mosyn::nn

// What a model family takes from the caller and what it generates itself, so that sampling,
// evaluation, the viewer and the runtime follow the family without knowing its name. No LibTorch.
#pragma once

namespace mosyn::nn {

// How a family treats one input of generation.
enum class InputUse {
  kIgnores,    // the family neither needs nor produces it
  kTakes,      // the caller gives it (MoGlow's root control)
  kGenerates,  // the family produces it itself (Dynamic Future Net's and MOJO's root motion)
};

const char* to_string(InputUse use);

struct ModelTraits {
  // Root motion, the per-frame control [T, C] (dx, dz metres, dtheta radians: data/control.h).
  // kTakes: SampleRequest::control drives the motion and is returned unchanged; kGenerates: only
  // its shape (B, T) is read and the family returns the root motion it made.
  InputUse control = InputUse::kTakes;
  bool labels = false;     // content / style labels condition the motion (SampleRequest::content, style)
  bool prefix = false;     // continues a given motion (SampleRequest::prefix_pose / prefix_control)
  bool streaming = false;  // frame-by-frame generation with no algorithmic latency (begin_stream)
  // Each character of a batch is computed apart from the others: its motion depends only on its
  // own seed (SampleRequest::seeds), labels, prefix and controls, never on its batch mates, and
  // MotionModel::copy_stream_row moves a character between streams (a runtime adds and removes
  // characters per slot).
  bool independent_rows = false;
  // Frames of the path after frame t that the model reads (MoGlow with look-ahead). Offline
  // sampling gives the real path; a stream gives a prediction made from the input up to t
  // (MotionModel::step_stream with control_ahead), so it stays causal. 0 = none.
  int control_ahead_frames = 0;
  // Seconds of standing that offline sampling generates first and drops when the caller leaves
  // the choice to the family (nn::kFamilyWarmup): families that start from a neutral state need it
  // to settle into a natural pose (MoGlow: the mean pose as history, 1 s); 0 for families whose
  // first frames are already natural. Only for families that take control.
  double default_warmup_s = 0.0;
};

}  // namespace mosyn::nn

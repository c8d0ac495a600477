// Real-time motion generation: one frame per control input, no algorithmic latency.
// Holds everything a stream needs (model, LSTM states, pose history, root pose) for one
// character or a batch of characters stepping together. Works in raw feature units.
// No LibTorch in this header.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/foot_lock.h"
#include "data/root_controller.h"
#include "nn/run.h"
#include "nn/sampling.h"

namespace mosyn::nn {

struct GeneratorOptions {
  std::string checkpoint = "checkpoint.pt";  // file in the run dir
  std::string device = "cpu";
  int threads = 0;          // LibTorch CPU threads; 0 = all cores
  int batch = 1;            // characters stepping together
  std::uint64_t seed = 0;   // noise seed: same seed + controls = same motion
  double temperature = 1.0; // latent standard deviation multiplier
  std::vector<float> prefix_pose;     // optional raw [P, D] (shared by all characters)
  std::vector<float> prefix_control;  // optional raw [P, C]
  // Per-character labels (index into the run's content / style vocabularies, -1 = none): empty =
  // none for everyone, one entry = the same for everyone, else one entry per character. Only for
  // models that take labels (ModelTraits::labels); an unknown index is an error.
  std::vector<int> content, style;
  // Causal shaping of live input (a game pad's sudden starts, stops and turns) towards the
  // Gaussian-smoothed trajectories the model was trained on: each character's root is simulated by
  // a data::RootController whose critically damped filters rise as the training Gaussian does
  // (10-90% in 2.56 sigma: natural angular frequency 1.31 / sigma). The root follows the filtered
  // input, and a model that reads the path ahead reads the controller's prediction of it. < 0 = the
  // run's dataset root_smoothing_s (none for runs on the raw hip trajectory); 0 = off (controls used
  // as given; the path ahead predicted as the current control held).
  double control_smoothing_s = -1.0;
  // Clean feet for users who need them (off by default: the model's raw output): each generated
  // frame is decoded on the run's skeleton at the character's root, its planted ankles pinned by
  // core/foot_lock.h StreamingFootLock, and encoded again, so step() returns foot-locked features.
  bool foot_lock = false;
  FootLockOptions foot_lock_options;
  // Keep the root steps of a family that makes its own root motion as the model makes them, even
  // when the run plants them on the feet (LoadedRun::root_planting, nn/root_planting.h).
  bool raw_root = false;
  int warmup_frames = 0;     // frames of standing generated and dropped at (re)start, so the first
                            // frame is a natural pose (nn/sampling.h SampleExtras::warmup_frames)
};

// One character of a crowd, started in a slot by Generator::add.
struct CharacterOptions {
  std::uint64_t seed = 0;  // its noise: same seed, labels, prefix and controls = same motion
  int content = -1;        // label indices into the run's vocabularies, -1 = none
  int style = -1;
  std::vector<float> prefix_pose;     // optional raw [P, D]: motion it continues
  std::vector<float> prefix_control;  // optional raw [P, C]
};

// What a game engine poses a character with after a step: every joint's rotation relative to its
// parent and the root joint's translation, on the run's skeleton (run().dataset.skeleton: joint
// order, parents, rest offsets in skeleton units; BVH conventions, y up).
struct JointTransforms {
  std::vector<float> rotations_wxyz;  // [J, 4] unit quaternions (w, x, y, z), local to the parent
  Eigen::Vector3d root_translation = Eigen::Vector3d::Zero();  // root joint in the world, skeleton units
};

// Floor position (skeleton units, up coordinate 0) and heading (radians) of a character's root.
struct RootPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double heading_rad = 0.0;
};

// The engine-facing transforms of frame 0 of a motion: its rotations as floats, the root's translation.
JointTransforms joint_transforms_of(const Motion& frame);

class Generator {
 public:
  // Loads run_dir (load_run) and starts a stream. Throws mosyn::Error when the run cannot be
  // loaded or its family cannot generate frame by frame.
  explicit Generator(const std::string& run_dir, const GeneratorOptions& options = {});
  Generator(LoadedRun run, const GeneratorOptions& options);
  ~Generator();
  Generator(Generator&&) noexcept;
  Generator& operator=(Generator&&) noexcept;

  // Advances every character by one frame. control: raw [B, C] row-major (dx, dz metres,
  // dtheta radians of the new frame relative to the previous one), shaped as
  // GeneratorOptions::control_smoothing_s says before the model and the root see it; empty for a
  // family that generates its root motion (ModelTraits::control kGenerates), whose own root motion
  // moves the root then. Returns raw pose [B, D]. Frame t depends on the input up to t only.
  std::vector<float> step(const std::vector<float>& control);

  // Advances every character by one frame steered as a game steers: stick [B, 3] row-major, per
  // character the ground velocity it should reach (x, z metres per second in the world of root():
  // heading 0 faces +z, positive headings turn towards +x; data::StickInput) and the heading it
  // should face (radians). The controller's springs carry the root there (GeneratorOptions::control_smoothing_s);
  // a stick held at zero velocity stands still. Only for families that take control. Returns raw
  // pose [B, D]. Steps by stick and by control may alternate (the root carries on smoothly).
  std::vector<float> step_stick(const std::vector<float>& stick);

  // Restarts the stream (states, history, root poses) with a new seed: character k's seed is
  // row_seed(seed, k) (nn/model.h; character 0's is `seed` itself), every slot active.
  void reset(std::uint64_t seed);

  // Starts character `slot` afresh, replacing whoever was there: its own seed, labels and optional
  // prefix, warmed up for GeneratorOptions::warmup_frames, root at the origin facing heading 0,
  // control shaping and foot lock restarted. From then on its frames are those of a Generator of
  // batch 1 started with the same seed, labels and prefix and given the same controls: they depend
  // on nothing else in the batch, up to float rounding (BLAS kernels round a row differently in
  // matrices of other heights: ~1e-6 relative per frame); in the same slots of the same batch a
  // character replays bit for bit. Costs the prefix and warm-up frames
  // of one character. Throws mosyn::Error for a slot outside [0, batch) or a family whose rows are
  // not independent (ModelTraits::independent_rows).
  void add(int slot, const CharacterOptions& character);
  // Starts character `slot` from character `from_slot` of `warmed` (a Generator of the same loaded
  // run, warmed up or stepped for a while): its stream state, simulated root and last pose, with
  // its own noise seed from then on (MotionModel::reseed_stream_row). A crowd warms a few
  // characters up and starts many from them, instead of warming every one. Throws mosyn::Error for
  // a slot out of range or a family whose rows are not independent.
  void start_from(int slot, const Generator& warmed, int from_slot, std::uint64_t seed);
  // Frees a slot: it keeps being computed (the batch keeps its size and the other characters are
  // unaffected) with zero control, and step() returns zeros for it, until add() fills it again.
  void remove(int slot);
  bool active(int slot) const;

  // The engine-facing pose of character `slot` after the last step (data::decode of its raw pose
  // at its root; for joint-position models the rotations are solved from the positions). Before
  // the first step: the rest pose.
  JointTransforms joint_transforms(int slot) const;
  // The same pose as a one-frame Motion of the run's skeleton (double precision), for callers that
  // process it further (e.g. retarget it onto another rig) before taking its transforms.
  Motion pose_motion(int slot) const;

  int batch() const;
  int pose_dim() const;
  int control_dim() const;
  int frames() const;  // frames generated since the start / reset
  // The control the model saw at the last step, after shaping (or the root motion it generated): raw [B, C].
  const std::vector<float>& last_control() const;
  // Root pose of character b after the frames so far, integrated from the controls.
  const RootPose& root(int b) const;
  const LoadedRun& run() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// n motions played frame by frame through a Generator of batch n (character k seeded
// row_seed(seed, k), as sample_motions seeds its rows): extras' prefix and labels start every
// character; without a prefix, extras.warmup_frames (kFamilyWarmup = the family's default_warmup_s)
// are generated first along the control's first step (its row 1) and dropped, as sample_motions'
// lead-in: for at most kWarmedCharacters characters, from whose states the others start
// (character k from k mod kWarmedCharacters, with its own noise: Generator::start_from), so a crowd
// does not pay the lead-in once per character; then each row of the raw control [T, C] steers in turn as a stick would steer along it
// (Generator::step_stick: the row's world velocity and the heading it leads to), so frame t
// depends on the control up to max(t, 1) only. Steering by stick, the root's world track is the
// control's smoothed, as offline sampling smooths a path (filtering the per-frame deltas instead
// would straighten a zigzag). Returns per character
// the raw poses and the control its root followed (Generator::last_control: the filtered one).
// foot_lock: GeneratorOptions::foot_lock.
constexpr int kWarmedCharacters = 16;
std::vector<SampledMotion> stream_motions(const LoadedRun& run, const std::vector<float>& control, int n,
                                          std::uint64_t seed, double temperature, const SampleExtras& extras,
                                          bool foot_lock = false);

}  // namespace mosyn::nn

// Real-time generation with mosyn::nn::Generator: four characters step together, one frame per
// call, each steered as a game steers (a stick: walk at 1.2 m/s, facing and heading its own way),
// each in its own style when the model takes style labels. Usage: realtime_walk [MODEL_DIR]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "nn/generator.h"
#include "nn/run.h"

int main(int argc, char** argv) try {
  const std::string model_dir = argc > 1 ? argv[1] : "models/moglow-realtime";
  mosyn::nn::GeneratorOptions options;
  options.batch = 4;  // characters stepping together
  options.seed = 42;  // same seed and controls give the same motion
  options.threads = 1;
  options.warmup_frames = 30;  // settle into a natural standing pose before the first frame
  mosyn::nn::LoadedRun run = mosyn::nn::load_run(model_dir, {"checkpoint.pt", "cpu", options.threads});
  std::vector<std::string> styles;  // one per character, from the model's vocabulary
  if (run.traits.labels) {
    const auto& vocabulary = run.dataset.style_labels;
    for (const char* name : {"normal", "elderly", "youthful", "exhausted"}) {
      const auto it = std::find(vocabulary.begin(), vocabulary.end(), name);
      options.style.push_back(it == vocabulary.end() ? -1 : static_cast<int>(it - vocabulary.begin()));
      styles.push_back(it == vocabulary.end() ? "any" : name);
    }
  }
  mosyn::nn::Generator generator(std::move(run), options);
  const double fps = generator.run().dataset.fps;

  std::vector<float> stick(options.batch * 3);  // [B, 3]: vx, vz (m/s, world), heading to face (radians)
  double seconds_per_frame = 0;
  const int frames = static_cast<int>(3 * fps);
  for (int frame = 0; frame < frames; ++frame) {
    for (int b = 0; b < options.batch; ++b) {
      const double facing = 0.5 * b;                          // 0, 0.5, 1, 1.5 rad (0 faces +z)
      stick[3 * b + 0] = static_cast<float>(1.2 * std::sin(facing));  // 1.2 m/s the way it faces
      stick[3 * b + 1] = static_cast<float>(1.2 * std::cos(facing));
      stick[3 * b + 2] = static_cast<float>(facing);
    }
    const auto start = std::chrono::steady_clock::now();
    const std::vector<float> pose = generator.step_stick(stick);  // [B, D]: the next frame of everyone
    seconds_per_frame += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (pose.size() != static_cast<size_t>(options.batch * generator.pose_dim())) return 1;
  }
  for (int b = 0; b < options.batch; ++b) {
    const auto& root = generator.root(b);
    std::printf("character %d (%s): at (%.2f, %.2f) m, heading %.2f rad after %d frames\n", b,
                styles.empty() ? "no style" : styles[b].c_str(),
                root.position.x() * generator.run().dataset.skeleton.meters_per_unit,
                root.position.z() * generator.run().dataset.skeleton.meters_per_unit, root.heading_rad, frames);
  }
  std::printf("%.2f ms per frame for %d characters\n", 1000 * seconds_per_frame / frames, options.batch);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "realtime_walk: %s\n", e.what());
  return 1;
}

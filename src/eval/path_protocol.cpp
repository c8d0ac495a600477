#include "eval/path_protocol.h"

#include <cmath>

#include "data/control.h"
#include "eval/protocols/protocols.h"
#include "nn/sampling.h"

namespace mosyn::eval {

const std::vector<SyntheticPath>& synthetic_paths() {
  static const std::vector<SyntheticPath> kPaths = {
      {"curve", "0,0 0,3 2,5 5,5 7,3", 1.3},     {"zigzag", "0,0 2,2 0,4 2,6 0,8", 1.2},
      {"stop-and-go", "0,0 0,3,2 3,5,2 3,8", 1.3}, {"straight-0.8", "0,0 0,8", 0.8},
      {"straight-1.3", "0,0 0,10", 1.3},          {"straight-1.8", "0,0 0,12", 1.8},
  };
  return kPaths;
}

std::vector<PathPhase> path_phases(const std::vector<float>& control, double fps, double speed_mps) {
  std::vector<PathPhase> out;
  for (size_t t = 0; 3 * t + 2 < control.size(); ++t) {
    const double v = std::hypot(control[3 * t], control[3 * t + 1]) * fps;
    out.push_back(v >= 0.9 * speed_mps ? PathPhase::kSteady : v < 0.05 ? PathPhase::kStanding : PathPhase::kChanging);
  }
  return out;
}

std::vector<MotionPositions> sample_synthetic_paths(const nn::LoadedRun& run, int n, std::uint64_t seed,
                                                    double temperature, int warmup_frames,
                                                    std::vector<std::vector<PathPhase>>* phases) {
  std::vector<MotionPositions> out;
  const nn::SampleExtras extras = detail::walk_extras(run, warmup_frames);
  const auto& paths = synthetic_paths();
  for (size_t i = 0; i < paths.size(); ++i) {
    data::PathOptions po;
    po.speed_mps = paths[i].speed_mps;
    po.fps = run.dataset.fps;
    const std::vector<float> drawn = data::control_from_path(data::parse_path(paths[i].path), po);
    const std::vector<float> control = data::smooth_control(drawn, po.fps, run.dataset.layout.root_smoothing_s);
    const std::vector<PathPhase> phase = path_phases(drawn, po.fps, po.speed_mps);  // as drawn, not smoothed
    for (const auto& motion : nn::sample_motions(run, control, n, seed + i, temperature, extras)) {
      out.push_back(motion_positions(nn::decode_motion(run, motion), 0.0, paths[i].name));
      if (phases) {
        std::vector<PathPhase> p = phase;
        p.resize(static_cast<size_t>(out.back().num_frames), p.empty() ? PathPhase::kStanding : p.back());
        phases->push_back(std::move(p));
      }
    }
  }
  return out;
}

std::vector<MotionPositions> steady_parts(const std::vector<MotionPositions>& along_paths,
                                          const std::vector<std::vector<PathPhase>>& phases, int min_frames) {
  std::vector<MotionPositions> parts;
  for (size_t m = 0; m < along_paths.size() && m < phases.size(); ++m) {
    const MotionPositions& motion = along_paths[m];
    const int frames = std::min(motion.num_frames, static_cast<int>(phases[m].size()));
    for (int t = 0; t < frames;) {
      if (phases[m][t] != PathPhase::kSteady) {
        ++t;
        continue;
      }
      int end = t;
      while (end < frames && phases[m][end] == PathPhase::kSteady) ++end;
      if (end - t >= min_frames) parts.push_back(detail::slice(motion, t, end));
      t = end;
    }
  }
  return parts;
}

}  // namespace mosyn::eval

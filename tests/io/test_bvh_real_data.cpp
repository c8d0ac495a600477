// BVH writing keeps Euler angles continuous (synthetic motions and every shared BVH file), and
// the shared files parse and round-trip.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "core/rotation.h"
#include "io/atomic_file.h"
#include "io/bvh.h"
#include "io_test_util.h"

namespace mosyn::io {
namespace {

namespace fs = std::filesystem;
using testing::expect_same_structure;
constexpr double kPi = 3.14159265358979323846;
constexpr double kRadPerDeg = kPi / 180.0;

// "" when the written angles of every joint with three rotation channels never change between
// two frames by more than following the rotation would; else the first offence, described.
//
// The bound: along the shortest rotation from frame t to t+1 (angle theta), the Euler angles
// move at a rate of at most sqrt(2) / cos(beta) per radian turned (beta the middle angle), and
// |beta| changes by at most the angle turned, so it stays below
// B = (|beta_t| + |beta_t+1| + theta) / 2. The written step (Euclidean, radians) must hence be at
// most sqrt(2) theta / cos(B). Where B is within 1 degree of gimbal lock (or the limb turns
// ~180 degrees in one frame, as in some CMU glitches) no Euler writer can bound the step; there
// each angle must still move by at most 180 degrees (unwrapped).
std::string continuity_problem(const BvhFile& written, const Clip& clip) {
  const size_t nc = static_cast<size_t>(written.num_channels());
  for (int j = 0; j < written.skeleton.num_joints(); ++j) {
    std::vector<int> columns;
    std::string axes;
    const int first = written.first_channel(j);
    const BvhChannelLayout& layout = written.channels[static_cast<size_t>(j)];
    for (size_t k = 0; k < layout.size(); ++k)
      if (is_rotation(layout[k])) {
        columns.push_back(first + static_cast<int>(k));
        axes += static_cast<char>('X' + channel_axis(layout[k]));
      }
    if (columns.size() != 3) continue;
    const EulerOrder order = *parse_euler_order(axes);
    for (int t = 0; t + 1 < written.num_frames; ++t) {
      const Eigen::Quaterniond& q0 = clip.motion.rotation(t, j);
      const Eigen::Quaterniond& q1 = clip.motion.rotation(t + 1, j);
      const double theta = geodesic_angle(q0, q1);
      const double bound_beta =
          (std::abs(euler_from_quat(q0, order)[1]) + std::abs(euler_from_quat(q1, order)[1]) + theta) / 2;
      double step_sq = 0, largest = 0;
      for (int c : columns) {
        const double d = (written.values[(t + 1) * nc + c] - written.values[t * nc + c]) * kRadPerDeg;
        step_sq += d * d;
        largest = std::max(largest, std::abs(d));
      }
      const double step = std::sqrt(step_sq);
      const bool bounded = bound_beta < (90.0 - 1.0) * kRadPerDeg;
      const double allowed = bounded ? std::sqrt(2.0) * theta / std::cos(bound_beta) + 1e-7 : kPi + 1e-7;
      if ((bounded ? step : largest) > allowed)
        return " joint " + written.skeleton.joint_names[static_cast<size_t>(j)] + " frames " + std::to_string(t) + "-" +
               std::to_string(t + 1) + ": angles move " + std::to_string(step / kRadPerDeg) + " deg where the rotation turns " +
               std::to_string(theta / kRadPerDeg) + " deg (allowed " + std::to_string(allowed / kRadPerDeg) + ");";
    }
  }
  return "";
}

// A one-joint clip whose rotation at frame t is rotations[t].
Clip one_joint_clip(const std::vector<Eigen::Quaterniond>& rotations) {
  Clip clip;
  clip.skeleton.joint_names = {"Root"};
  clip.skeleton.parents = {-1};
  clip.skeleton.offsets = {Eigen::Vector3d::Zero()};
  clip.motion.fps = 30;
  clip.motion.num_joints = 1;
  clip.motion.num_frames = static_cast<int>(rotations.size());
  clip.motion.rotations = rotations;
  clip.motion.translations.assign(rotations.size(), Eigen::Vector3d::Zero());
  return clip;
}

// A limb swinging through the region where the principal ZYX solution flips branch (middle angle
// crossing +-90 degrees away from exact gimbal lock), spinning about its own axis for several
// turns, and a one-frame glitch of ~180 degrees: the written angles stay within the bound, the
// file reads back to the same rotations, and a long spin unwraps past +-180 degrees.
TEST(BvhContinuity, BranchCrossingsSpinsAndGlitchesStayContinuous) {
  std::vector<Eigen::Quaterniond> rotations;
  for (int t = 0; t < 240; ++t) {
    const double s = t / 240.0;
    const Eigen::Quaterniond swing(Eigen::AngleAxisd(2.2 * kPi * s, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()));
    const Eigen::Quaterniond spin(Eigen::AngleAxisd(6 * kPi * s, Eigen::Vector3d::UnitZ()));
    rotations.push_back(t == 120 ? Eigen::Quaterniond(Eigen::AngleAxisd(kPi * 0.99, Eigen::Vector3d::UnitX())) * swing * spin
                                 : swing * spin);
  }
  const Clip clip = one_joint_clip(rotations);
  for (const char* order : {"Zrotation Yrotation Xrotation", "Zrotation Xrotation Yrotation", "Xrotation Yrotation Zrotation"}) {
    const std::string text = std::string("HIERARCHY\nROOT Root\n{\nOFFSET 0 0 0\nCHANNELS 3 ") + order +
                             "\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.0333333\n0 0 0\n";
    const BvhFile layout = parse_bvh(text, "layout.bvh");
    Clip with_end = clip;
    with_end.skeleton.end_sites = layout.skeleton.end_sites;
    const BvhFile written = from_clip(with_end, &layout);
    EXPECT_EQ(continuity_problem(written, with_end), "") << order;
    const Clip back = to_clip(parse_bvh(format_bvh(written, 17), "back.bvh"));
    double worst = 0, widest = 0;
    for (size_t i = 0; i < rotations.size(); ++i) worst = std::max(worst, geodesic_angle(back.motion.rotations[i], rotations[i]));
    for (double v : written.values) widest = std::max(widest, std::abs(v));
    EXPECT_LT(worst, 1e-9) << order;
    EXPECT_GT(widest, 360.0) << order << ": three turns of spin unwrap beyond one turn";
  }
}

// The check itself catches the bug it guards against: one frame switched to the other Euler
// solution of the same rotation.
TEST(BvhContinuity, CheckCatchesASingleFrameBranchSwitch) {
  std::vector<Eigen::Quaterniond> rotations;
  for (int t = 0; t < 10; ++t) rotations.push_back(quat_from_euler(Eigen::Vector3d(0.3 + 0.01 * t, 0.2, 0.1), EulerOrder::kZYX));
  const Clip clip = one_joint_clip(rotations);
  BvhFile written = from_clip(clip);
  ASSERT_EQ(continuity_problem(written, clip), "");
  const size_t nc = static_cast<size_t>(written.num_channels());
  double* row = &written.values[5 * nc + 3];  // after the root's position channels: Z Y X
  row[0] += 180, row[1] = 180 - row[1], row[2] += 180;
  EXPECT_NE(continuity_problem(written, clip), "");
}

const char* const kOrders[] = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};

// A one-joint BVH file with three rotation channels in `order` ("ZXY") and the given frames
// (degrees, in channel order); no frames makes a layout template without motion.
BvhFile one_joint_bvh(const std::string& order, const std::vector<Eigen::Vector3d>& frames_deg) {
  std::string text = "HIERARCHY\nROOT Root\n{\nOFFSET 0 0 0\nCHANNELS 3";
  for (char axis : order) text += std::string(" ") + axis + "rotation";
  text += "\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: " + std::to_string(frames_deg.size()) + "\nFrame Time: 0.0333333\n";
  char line[128];
  for (const Eigen::Vector3d& f : frames_deg) {
    std::snprintf(line, sizeof(line), "%.17g %.17g %.17g\n", f[0], f[1], f[2]);
    text += line;
  }
  return parse_bvh(text, order + ".bvh");
}

// Written angles (degrees) of frame t of a one-joint file.
Eigen::Vector3d written_angles(const BvhFile& bvh, int t) {
  return Eigen::Vector3d(bvh.values[3 * static_cast<size_t>(t)], bvh.values[3 * static_cast<size_t>(t) + 1],
                         bvh.values[3 * static_cast<size_t>(t) + 2]);
}

// Largest change of any channel between two consecutive frames of a one-joint file, in degrees.
double largest_step(const BvhFile& bvh, int from_frame = 0) {
  double largest = 0;
  for (int t = from_frame; t + 1 < bvh.num_frames; ++t)
    largest = std::max(largest, (written_angles(bvh, t + 1) - written_angles(bvh, t)).cwiseAbs().maxCoeff());
  return largest;
}

// Largest angle between a file's rotations, read back, and the clip's, in radians.
double round_trip_error(const BvhFile& written, const Clip& clip) {
  const Clip back = to_clip(parse_bvh(format_bvh(written), "back.bvh"));
  double worst = 0;
  for (size_t i = 0; i < clip.motion.rotations.size(); ++i)
    worst = std::max(worst, geodesic_angle(back.motion.rotations[i], clip.motion.rotations[i]));
  return worst;
}

// A joint turning steadily about the first, middle or last axis of each of the six orders, 10
// degrees a frame for 79 frames (790 degrees; about the middle axis through gimbal lock at 90
// and 270): every channel changes by the turn or not at all, and the turning one unwraps past
// +-180 degrees to 790 instead of wrapping or switching branch.
TEST(BvhContinuity, SteadyTurnAboutEachAxisOfEveryOrderMovesByTheTurnOnly) {
  for (const char* order_name : kOrders) {
    const EulerOrder order = *parse_euler_order(order_name);
    const BvhFile layout = one_joint_bvh(order_name, {});
    for (int slot = 0; slot < 3; ++slot) {
      std::vector<Eigen::Quaterniond> rotations;
      for (int t = 0; t < 80; ++t) rotations.push_back(quat_about_axis(euler_axis(order, slot), 10.0 * t * kRadPerDeg));
      Clip clip = one_joint_clip(rotations);
      clip.skeleton.end_sites = layout.skeleton.end_sites;
      const BvhFile written = from_clip(clip, &layout);
      const std::string what = std::string(order_name) + " turning about angle " + std::to_string(slot);
      EXPECT_LE(largest_step(written), 10.0 + 1e-6) << what;
      for (int t = 0; t < 80; ++t) {
        Eigen::Vector3d expected = Eigen::Vector3d::Zero();
        expected[slot] = 10.0 * t;
        EXPECT_LT((written_angles(written, t) - expected).cwiseAbs().maxCoeff(), 1e-6) << what << " frame " << t;
      }
      EXPECT_LT(round_trip_error(written, clip), 1e-6) << what;
    }
  }
}

// Through gimbal lock (middle angle exactly +-90 degrees at frame 5, where only the sum or the
// difference of the outer angles is determined) in every order: the angles are the true ones at
// every other frame, the lock frame splits the change between the outer angles instead of
// lurching one of them, and the rotations read back exactly.
TEST(BvhContinuity, GimbalLockIsPassedWithoutLurchingInEveryOrder) {
  for (const char* order_name : kOrders) {
    const EulerOrder order = *parse_euler_order(order_name);
    const BvhFile layout = one_joint_bvh(order_name, {});
    for (double sign : {1.0, -1.0}) {
      std::vector<Eigen::Vector3d> truth;
      std::vector<Eigen::Quaterniond> rotations;
      for (int t = 0; t < 11; ++t) {
        truth.emplace_back(30 + 2 * t, sign * (80 + 2 * t), 20 - 3 * t);
        rotations.push_back(quat_from_euler(truth.back() * kRadPerDeg, order));
      }
      Clip clip = one_joint_clip(rotations);
      clip.skeleton.end_sites = layout.skeleton.end_sites;
      const BvhFile written = from_clip(clip, &layout);
      const std::string what = std::string(order_name) + (sign > 0 ? " +90" : " -90");
      for (int t = 0; t < 11; ++t) {
        if (t == 5) continue;
        EXPECT_LT((written_angles(written, t) - truth[t]).cwiseAbs().maxCoeff(), 1e-6) << what << " frame " << t;
      }
      const Eigen::Vector3d into_lock = written_angles(written, 5) - written_angles(written, 4);
      EXPECT_NEAR(into_lock[1], truth[5][1] - truth[4][1], 1e-6) << what;
      EXPECT_NEAR(std::abs(into_lock[0]), std::abs(into_lock[2]), 1e-6) << what << ": the outer angles share the change";
      EXPECT_LT(largest_step(written), 10.0) << what << ": true steps are 2 to 3 degrees";
      EXPECT_LT(round_trip_error(written, clip), 1e-6) << what;
    }
  }
}

// Read, write, read: a source whose first frame is a T-pose before a 136 degree jump (as in the
// CMU takes), whose first angle wraps at 180 degrees and which flips to the other Euler branch
// for five frames. Written with the source as template, the jump goes the source's way (the
// nearest triple would be on the other branch, middle angle -143 instead of -37, kept for the
// whole take) and the rest is the continuous motion, unwrapped; the same without the source's
// angles (a template with no frames), from the principal solution. The rotations read back.
TEST(BvhContinuity, ReadWriteReadFollowsTheSourceAtJumpsAndUnwrapsTheRest) {
  std::vector<Eigen::Vector3d> motion = {Eigen::Vector3d::Zero()}, source = {Eigen::Vector3d::Zero()};
  for (int t = 1; t < 40; ++t) {
    const Eigen::Vector3d e(155 + 3 * (t - 1), -37 + 0.5 * (t - 1), -111 + 2 * (t - 1));
    motion.push_back(e);
    Eigen::Vector3d stored = t >= 20 && t < 25 ? Eigen::Vector3d(e[0] + 180, 180 - e[1], e[2] + 180) : e;
    for (int i = 0; i < 3; ++i) stored[i] = std::remainder(stored[i], 360.0);
    source.push_back(stored);
  }
  for (const char* order_name : kOrders) {
    const BvhFile original = one_joint_bvh(order_name, source);
    const Clip clip = to_clip(original);
    ASSERT_GT(geodesic_angle(clip.motion.rotation(0, 0), clip.motion.rotation(1, 0)), kPi / 4) << order_name;
    const BvhFile without_motion = one_joint_bvh(order_name, {});
    for (const BvhFile* layout : {&original, &without_motion}) {
      const std::string what = std::string(order_name) + (layout == &original ? " with the source" : " without");
      const BvhFile written = from_clip(clip, layout);
      for (int t = 0; t < 40; ++t)
        EXPECT_LT((written_angles(written, t) - motion[t]).cwiseAbs().maxCoeff(), 1e-6) << what << " frame " << t;
      EXPECT_LE(largest_step(written, 1), 3.0 + 1e-6) << what;
      EXPECT_LT(round_trip_error(written, clip), 1e-6) << what;
    }
  }
}

// Frame 0 keeps the source's own angles, even off the principal range (first angle 400, middle
// 170 degrees); without them it takes the principal solution (middle angle within +-90).
TEST(BvhContinuity, FrameZeroTakesTheSourcesOwnAnglesElsePrincipal) {
  const std::vector<Eigen::Vector3d> source = {{400, 170, 20}, {401, 171, 21}};
  const BvhFile original = one_joint_bvh("ZXY", source);
  const Clip clip = to_clip(original);
  const BvhFile written = from_clip(clip, &original);
  EXPECT_LT((written_angles(written, 0) - source[0]).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((written_angles(written, 1) - source[1]).cwiseAbs().maxCoeff(), 1e-9);
  const BvhFile layout = one_joint_bvh("ZXY", {});
  const BvhFile principal = from_clip(clip, &layout);
  EXPECT_LE(std::abs(written_angles(principal, 0)[1]), 90.0);
  EXPECT_LT((written_angles(principal, 0) - Eigen::Vector3d(220 - 360, 10, 200 - 360)).cwiseAbs().maxCoeff(), 1e-9);
}

// --- Real data --------------------------------------------------------------------------------

std::vector<fs::path> find_bvh_files(const fs::path& root) {
  std::vector<fs::path> files;
  if (!fs::is_directory(root)) return files;
  for (const auto& entry : fs::recursive_directory_iterator(root))
    if (entry.is_regular_file() && entry.path().extension() == ".bvh") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

const fs::path kDataCache = MOSYN_DATA_CACHE;

// Every shared file parses, converts to a clip, and writes back with continuous Euler angles
// (one pass per file, two threads).
TEST(BvhRealData, EveryFileLoadsAndWritesContinuousAngles) {
  const std::vector<fs::path> cmu = find_bvh_files(kDataCache / "cmu-mocap-subset");
  const std::vector<fs::path> bandai = find_bvh_files(kDataCache / "bandai-namco");
  if (cmu.empty() && bandai.empty()) GTEST_SKIP() << "no unpacked data under " << kDataCache;
  EXPECT_GE(cmu.size(), 80u);
  EXPECT_GE(bandai.size(), 2000u);

  struct Job {
    const fs::path* path;
    bool is_cmu;
  };
  std::vector<Job> jobs;
  for (const fs::path& p : cmu) jobs.push_back({&p, true});
  for (const fs::path& p : bandai) jobs.push_back({&p, false});
  std::vector<std::string> failures(jobs.size());
  std::vector<double> bytes(2, 0.0), parse_seconds(2, 0.0);
  const auto start = std::chrono::steady_clock::now();
  auto work = [&](int worker) {
    for (size_t i = static_cast<size_t>(worker); i < jobs.size(); i += 2) {
      const Job& job = jobs[i];
      try {
        const std::string text = read_file(job.path->string());
        const auto t0 = std::chrono::steady_clock::now();
        const BvhFile bvh = parse_bvh(text, job.path->string());
        parse_seconds[worker] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        bytes[worker] += static_cast<double>(text.size());
        const Skeleton& sk = bvh.skeleton;
        const double fps = 1.0 / bvh.frame_time_s;
        std::string problem;
        if (bvh.num_frames < 1) problem += " no frames;";
        if (job.is_cmu) {
          if (sk.num_joints() != 31) problem += " joints=" + std::to_string(sk.num_joints()) + ";";
          if (std::abs(fps - 120) > 0.01) problem += " fps=" + std::to_string(fps) + ";";
          if (sk.joint_names[0] != "Hips" || bvh.channels[0].size() != 6) problem += " root;";
        } else {
          if (sk.num_joints() < 2 || sk.joint_names[0] != "joint_Root" || sk.joint_names[1] != "Hips") problem += " root;";
          if (std::abs(fps - 30) > 0.01) problem += " fps=" + std::to_string(fps) + ";";
          for (const BvhChannelLayout& c : bvh.channels)
            if (c.size() != 6) problem += " channels;";
        }
        const Clip clip = to_clip(bvh);
        clip.motion.validate();
        // Written back with the file's own layout, the angles follow the rotations continuously.
        problem += continuity_problem(from_clip(clip, &bvh), clip);
        if (!problem.empty()) failures[i] = job.path->string() + ":" + problem;
      } catch (const std::exception& e) {
        failures[i] = e.what();
      }
    }
  };
  std::thread other(work, 1);
  work(0);
  other.join();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  int failed = 0;
  for (const std::string& f : failures)
    if (!f.empty() && failed++ < 20) ADD_FAILURE() << f;
  EXPECT_EQ(failed, 0);
  const double total_bytes = bytes[0] + bytes[1];
  std::printf("[ info ] %zu files, %.0f MB in %.1f s wall (2 threads, read+parse+to_clip+from_clip+check); parse_bvh alone %.0f MB/s per thread\n",
              jobs.size(), total_bytes / 1e6, wall, total_bytes / 1e6 / (parse_seconds[0] + parse_seconds[1]));
}

// Jumps a written file has that its source does not: a rotation channel of a joint with three
// changing between two frames by more than 45 degrees, more than the joint's rotation turns
// there (geodesic angle) and more than the source's angle changes there. Where the rotation
// itself jumps (CMU takes open with a T-pose frame; capture glitches) the angles must jump too,
// but no further than the source's; a branch switch or a 360-degree wrap the writer added moves
// a channel by 180 to 360 degrees. Smaller differences (following a rotation through the
// neighbourhood of gimbal lock, where the source reflects) are held to the continuity bound by
// EveryFileLoadsAndWritesContinuousAngles.
struct NewJumps {
  int channels = 0;            // channels with a new jump
  double largest_deg = 0;      // the largest such jump
  double beyond_turn_deg = 0;  // largest change of a channel beyond its joint's largest turn
  std::string example;
};

NewJumps new_jumps(const BvhFile& source, const Clip& clip, const BvhFile& written) {
  constexpr double kJumpDeg = 45;
  constexpr double kToleranceDeg = 1e-3;  // 9 significant digits written, 4 decimals in the sources
  NewJumps found;
  const size_t nc = static_cast<size_t>(written.num_channels());
  const int frames = written.num_frames;
  for (int j = 0; j < written.skeleton.num_joints(); ++j) {
    std::vector<int> columns;
    const int first = written.first_channel(j);
    const BvhChannelLayout& layout = written.channels[static_cast<size_t>(j)];
    for (size_t k = 0; k < layout.size(); ++k)
      if (is_rotation(layout[k])) columns.push_back(first + static_cast<int>(k));
    if (columns.size() != 3) continue;
    std::vector<double> turn(static_cast<size_t>(std::max(frames - 1, 0)));
    for (int t = 0; t + 1 < frames; ++t)
      turn[t] = geodesic_angle(clip.motion.rotation(t, j), clip.motion.rotation(t + 1, j)) / kRadPerDeg;
    const double largest_turn = turn.empty() ? 0.0 : *std::max_element(turn.begin(), turn.end());
    for (int c : columns) {
      bool jumps = false;
      for (size_t t = 0; t + 1 < static_cast<size_t>(frames); ++t) {
        const double step = std::abs(written.values[(t + 1) * nc + c] - written.values[t * nc + c]);
        const double source_step = std::abs(source.values[(t + 1) * nc + c] - source.values[t * nc + c]);
        found.beyond_turn_deg = std::max(found.beyond_turn_deg, step - largest_turn);
        if (step <= kJumpDeg || step <= std::max(turn[t], source_step) + kToleranceDeg) continue;
        jumps = true;
        if (step <= found.largest_deg) continue;
        found.largest_deg = step;
        found.example = written.skeleton.joint_names[static_cast<size_t>(j)] + " " + to_string(layout[static_cast<size_t>(c - first)]) +
                        " frames " + std::to_string(t) + "-" + std::to_string(t + 1) + ": " +
                        std::to_string(written.values[t * nc + c]) + " -> " + std::to_string(written.values[(t + 1) * nc + c]) +
                        " (source " + std::to_string(source.values[t * nc + c]) + " -> " +
                        std::to_string(source.values[(t + 1) * nc + c]) + ", the joint turns " + std::to_string(turn[t]) + ")";
      }
      found.channels += jumps ? 1 : 0;
    }
  }
  return found;
}

// Every CMU file and every 4th Bandai-Namco file, read, written with its own layout and read
// again: the same rotations, and no channel jumps where neither the rotation nor the source does
// (see NewJumps). Reports how many files do.
TEST(BvhRealData, WrittenFilesGainNoEulerJumps) {
  const std::vector<fs::path> cmu = find_bvh_files(kDataCache / "cmu-mocap-subset");
  const std::vector<fs::path> bandai = find_bvh_files(kDataCache / "bandai-namco");
  if (cmu.empty() && bandai.empty()) GTEST_SKIP() << "no unpacked data under " << kDataCache;
  std::vector<const fs::path*> files;
  for (const fs::path& p : cmu) files.push_back(&p);
  for (size_t i = 0; i < bandai.size(); i += 4) files.push_back(&bandai[i]);
  const size_t num_cmu = cmu.size();

  std::vector<NewJumps> jumps(files.size());
  std::vector<std::string> failures(files.size());
  std::vector<double> worst_angle(files.size(), 0.0);
  auto work = [&](int worker) {
    for (size_t i = static_cast<size_t>(worker); i < files.size(); i += 2) {
      try {
        const BvhFile source = read_bvh(files[i]->string());
        const Clip clip = to_clip(source);
        const BvhFile written = parse_bvh(format_bvh(from_clip(clip, &source)), "written.bvh");
        const Clip back = to_clip(written);
        for (size_t k = 0; k < clip.motion.rotations.size(); ++k)
          worst_angle[i] = std::max(worst_angle[i], geodesic_angle(back.motion.rotations[k], clip.motion.rotations[k]));
        jumps[i] = new_jumps(source, clip, written);
      } catch (const std::exception& e) {
        failures[i] = files[i]->string() + ": " + e.what();
      }
    }
  };
  std::thread other(work, 1);
  work(0);
  other.join();

  int with_jumps[2] = {0, 0}, beyond_turn[2] = {0, 0};
  double largest[2] = {0, 0};
  for (size_t i = 0; i < files.size(); ++i) {
    EXPECT_EQ(failures[i], "");
    EXPECT_LT(worst_angle[i], 1e-6) << *files[i] << ": the written angles are not the same rotations";
    const int set = i < num_cmu ? 0 : 1;
    if (jumps[i].beyond_turn_deg > 1e-3) ++beyond_turn[set];
    if (jumps[i].channels == 0) continue;
    ++with_jumps[set];
    largest[set] = std::max(largest[set], jumps[i].largest_deg);
    ADD_FAILURE() << *files[i] << ": " << jumps[i].channels << " channels jump where neither the rotation nor the source does, worst "
                  << jumps[i].example;
  }
  // The figure before the writer followed the source where a joint jumps: CMU 33 of 81, up to 180 degrees.
  std::printf("[ info ] files gaining Euler jumps: CMU %d of %zu (largest written jump %.1f deg; 33 of 81, 180 deg, when jumps took "
              "the nearest triple), Bandai-Namco %d of %zu sampled (%.1f deg); files where some channel changes more than its "
              "joint ever turns (Euler angles move faster than the rotation off the principal axes, sources too): CMU %d, Bandai-Namco %d\n",
              with_jumps[0], num_cmu, largest[0], with_jumps[1], files.size() - num_cmu, largest[1], beyond_turn[0], beyond_turn[1]);
}

void expect_real_round_trip(const fs::path& path) {
  const BvhFile original = read_bvh(path.string());
  const BvhFile again = parse_bvh(format_bvh(original), "again.bvh");
  expect_same_structure(original, again);
  ASSERT_EQ(again.values.size(), original.values.size());
  for (size_t i = 0; i < original.values.size(); ++i)
    ASSERT_NEAR(again.values[i], original.values[i], 1e-6 * std::max(1.0, std::abs(original.values[i]))) << i;

  const Clip clip = to_clip(original);
  const BvhFile rewritten = from_clip(clip, &original);
  EXPECT_EQ(rewritten.channels, original.channels);
  const Clip back = to_clip(parse_bvh(format_bvh(rewritten), "rewritten.bvh"));
  double worst_angle = 0, worst_translation = 0;
  for (size_t i = 0; i < clip.motion.rotations.size(); ++i) {
    worst_angle = std::max(worst_angle, geodesic_angle(back.motion.rotations[i], clip.motion.rotations[i]));
    worst_translation = std::max(worst_translation, (back.motion.translations[i] - clip.motion.translations[i]).norm());
  }
  EXPECT_LT(worst_angle, 1e-6) << path;
  EXPECT_LT(worst_translation, 1e-4) << path;
  EXPECT_EQ(continuity_problem(rewritten, clip), "") << path;
  // The rewritten angles stay continuous: no jumps of ~360 degrees between frames.
  const size_t nc = static_cast<size_t>(rewritten.num_channels());
  for (size_t t = 1; t < static_cast<size_t>(rewritten.num_frames); ++t)
    for (int j = 0; j < rewritten.skeleton.num_joints(); ++j) {
      size_t c = static_cast<size_t>(rewritten.first_channel(j));
      for (BvhChannel ch : rewritten.channels[static_cast<size_t>(j)]) {
        if (is_rotation(ch)) {
          ASSERT_LT(std::abs(rewritten.values[t * nc + c] - rewritten.values[(t - 1) * nc + c]), 180.0) << path << " t=" << t;
        }
        ++c;
      }
    }
}

TEST(BvhRealData, CmuFileRoundTrips) {
  const std::vector<fs::path> files = find_bvh_files(kDataCache / "cmu-mocap-subset");
  if (files.empty()) GTEST_SKIP() << "no CMU data under " << kDataCache;
  expect_real_round_trip(files.front());
  expect_real_round_trip(files.back());
}

TEST(BvhRealData, BandaiFileRoundTrips) {
  const std::vector<fs::path> files = find_bvh_files(kDataCache / "bandai-namco");
  if (files.empty()) GTEST_SKIP() << "no Bandai-Namco data under " << kDataCache;
  expect_real_round_trip(files.front());
  expect_real_round_trip(files[files.size() / 2]);
}
}  // namespace
}  // namespace mosyn::io

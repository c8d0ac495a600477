// Exported .glb files as other tools see them: the Khronos glTF validator finds no error, warning
// or note (Blender's importer and engines rely on what it checks), and three.js's GLTFLoader in
// headless Chromium (web/src/gltf_probe.js) parses the file, finds a skinned mesh and every
// animation, and poses the joints where our forward kinematics puts them (so the skeleton moves
// as in the BVH). Skipped with a message when node/npm (at build time) or chromium is missing.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "core/kinematics.h"
#include "core/synthetic.h"
#include "io/atomic_file.h"
#include "io/gltf.h"
#include "render/image_io.h"
#include "render/scene.h"

namespace mosyn::render {
namespace {

namespace fs = std::filesystem;

std::string base64(const std::string& bytes) {
  static const char* kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const unsigned n = static_cast<unsigned char>(bytes[i]) << 16 |
                       (i + 1 < bytes.size() ? static_cast<unsigned char>(bytes[i + 1]) << 8 : 0) |
                       (i + 2 < bytes.size() ? static_cast<unsigned char>(bytes[i + 2]) : 0);
    out += kDigits[n >> 18 & 63];
    out += kDigits[n >> 12 & 63];
    out += i + 1 < bytes.size() ? kDigits[n >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? kDigits[n & 63] : '=';
  }
  return out;
}

// Runs the probe page in Chromium and returns what it wrote into <pre id="result">.
std::string run_probe(const std::string& chromium, const fs::path& dir, const std::string& glb,
                      const std::vector<double>& times) {
#ifdef MOSYN_GLTF_PROBE_JS
  const std::string page = (dir / "probe.html").string();
  io::write_file_atomically(page, "<!DOCTYPE html><html><body><pre id=\"result\">pending</pre>"
                                  "<script id=\"mosyn-glb\" type=\"application/octet-stream\" data-times=\"" +
                                      nlohmann::json(times).dump() + "\">" + base64(glb) + "</script><script>" +
                                      io::read_file(MOSYN_GLTF_PROBE_JS) + "</script></body></html>");
  const std::string dom = (dir / "dom.html").string();
  const std::string cmd = "'" + chromium +
                          "' --headless --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader --disable-gpu"
                          " --disable-background-networking --disable-component-update --disable-sync --no-first-run"
                          " --user-data-dir='" + (dir / "profile").string() +
                          "' --virtual-time-budget=5000 --dump-dom 'file://" + page + "' >'" + dom + "' 2>'" +
                          (dir / "chromium.log").string() + "'";
  std::system(cmd.c_str());
  const std::string text = fs::exists(dom) ? io::read_file(dom) : "";
  const std::string open = "<pre id=\"result\">";
  const size_t a = text.find(open), b = text.find("</pre>");
  if (a == std::string::npos || b == std::string::npos) return "no result; see " + (dir / "chromium.log").string();
  return text.substr(a + open.size(), b - a - open.size());
#else
  return "";
#endif
}

TEST(GltfBrowserTest, ThreeJsGltfLoaderPlaysTheSkeletonAsOurForwardKinematics) {
#ifndef MOSYN_GLTF_PROBE_JS
  GTEST_SKIP() << "built without npm: no three.js probe bundle";
#endif
  const std::string chromium = find_on_path("chromium");
  if (chromium.empty()) GTEST_SKIP() << "chromium is not installed (make deps installs it)";
  const fs::path dir = fs::temp_directory_path() / ("mosyn_gltf_browser_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);

  Clip clip{make_synthetic_biped(), {}};
  std::vector<io::GltfMotion> motions;
  for (int i = 0; i < 2; ++i) {
    SyntheticWalkOptions o;
    o.turn_rate_rad_s = 0.7 * i;
    motions.push_back({"walk " + std::to_string(i), make_synthetic_walk(clip.skeleton, 60, 30.0, o)});
  }
  const std::vector<int> frames{0, 17, 45};
  std::vector<double> times;
  for (int k : frames) times.push_back(k / 30.0);
  const std::string text = run_probe(chromium, dir, io::gltf_bytes(clip.skeleton, motions, true), times);
  ASSERT_FALSE(text.empty() || text[0] != '{') << text;
  const nlohmann::json result = nlohmann::json::parse(text);
  EXPECT_EQ(result["skinned_meshes"], 1);
  ASSERT_EQ(result["animations"].size(), 2u);
  double worst = 0, moved = 0;
  for (int a = 0; a < 2; ++a) {
    const auto& anim = result["animations"][a];
    EXPECT_EQ(anim["name"], motions[a].name);
    EXPECT_NEAR(anim["duration"].get<double>(), 59 / 30.0, 1e-4);
    const WorldPoses fk = forward_kinematics(clip.skeleton, motions[a].motion);
    for (size_t s = 0; s < frames.size(); ++s)
      for (int j = 0; j < clip.skeleton.num_joints(); ++j) {
        const auto& p = anim["samples"][s]["nodes"][clip.skeleton.joint_names[j]];
        ASSERT_TRUE(p.is_array()) << clip.skeleton.joint_names[j];
        const Eigen::Vector3d got(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
        worst = std::max(worst, (got - fk.position(frames[s], j) * 0.01).norm());
        if (s > 0) {
          const auto& p0 = anim["samples"][0]["nodes"][clip.skeleton.joint_names[j]];
          moved = std::max(moved, (got - Eigen::Vector3d(p0[0].get<double>(), p0[1].get<double>(),
                                                         p0[2].get<double>())).norm());
        }
      }
  }
  EXPECT_LT(worst, 1e-4) << "metres between three.js's joints and our FK";
  EXPECT_GT(moved, 0.5) << "the skeleton moves (a 1.3 m/s walk over 1.5 s)";
  if (!HasFailure() && !std::getenv("MOSYN_KEEP_TEST_FILES")) fs::remove_all(dir);
}

// A Z-up skeleton in centimetres, .glb and .gltf, three motions of different lengths.
TEST(GltfBrowserTest, KhronosValidatorFindsNoIssue) {
#ifndef MOSYN_GLTF_VALIDATOR
  GTEST_SKIP() << "built without npm: no glTF validator";
#else
  const fs::path dir = fs::temp_directory_path() / ("mosyn_gltf_validator_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  Clip clip{make_synthetic_biped(), {}};
  std::vector<io::GltfMotion> motions;
  for (int i = 0; i < 3; ++i) {
    SyntheticWalkOptions o;
    o.turn_rate_rad_s = 0.5 * i;
    o.noise_rad = 0.1;
    motions.push_back({"walk " + std::to_string(i), make_synthetic_walk(clip.skeleton, 20 + 30 * i, 30.0, o)});
  }
  clip.skeleton.up_axis = 2;
  const std::string glb = (dir / "walks.glb").string(), gltf = (dir / "walks.gltf").string();
  io::write_gltf(glb, clip.skeleton, motions);
  io::write_gltf(gltf, clip.skeleton, motions);
  const std::string report = (dir / "report.jsonl").string();
  const std::string cmd = std::string("'") + MOSYN_NODE + "' '" + MOSYN_GLTF_VALIDATOR + "' '" + glb + "' '" + gltf +
                          "' >'" + report + "' 2>&1";
  const int status = std::system(cmd.c_str());
  const std::string text = fs::exists(report) ? io::read_file(report) : "";
  EXPECT_EQ(status, 0) << text;
  EXPECT_NE(text.find("\"errors\":0,\"warnings\":0,\"infos\":0,\"messages\":[]"), std::string::npos) << text;
  if (!HasFailure()) fs::remove_all(dir);
#endif
}

}  // namespace
}  // namespace mosyn::render

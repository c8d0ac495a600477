// The live page's WebSocket protocol: JSON text messages, parsed and validated here (no sockets),
// so the server and its tests share one definition. Full description: src/serve/README.md.
//
// Client -> server (one JSON object per text message, at most kMaxMessageBytes, unknown keys refused):
//   {"type":"stick", "character":k, "vx":x, "vz":z, "facing":h}
//       as a game steers: the ground velocity (m/s, world x and z, |v| <= max_speed) the character
//       should reach and the heading (radians, 0 faces +z, + turns towards +x) it should face;
//       holds until the next stick or input (nn::Generator::step_stick).
//   {"type":"input", "character":k, "forward":f, "turn":t, "speed":s}
//       f, t in [-1, 1] (forward/back, left/right; +turn turns left), s in [0, max_speed] m/s
//       (optional: the last speed stays); holds until the next input.
//   {"type":"style", "character":k, "style":"name"|null, "content":"name"|null}
//       restarts character k in that style / content where it stands (labels the model has).
//   {"type":"add", "style":..., "content":...}   a new character (both labels optional)
//   {"type":"remove", "character":k}
// Server -> client: "hello" once (skeleton, labels, fps, limits), "frame" at the run's frame rate,
// "added" after an add, "error" for a refused message (built by hello_json, frame_json, ...).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/error.h"
#include "nn/run.h"

namespace mosyn::serve {

constexpr size_t kMaxMessageBytes = 4096;  // a client message never needs more than a few hundred

// What the server accepts: the bounds a message is checked against.
struct Limits {
  int max_characters = 4;        // character ids are 0..max_characters-1
  double max_speed_mps = 3.0;    // walking to running; beyond it the models have no data
  double turn_rate_rad_s = 1.6;  // heading change per second at turn = +-1
};

// A message the client sent that the protocol does not allow: what() says what is wrong, to be
// sent back in an "error" message.
class ProtocolError : public Error {
 public:
  using Error::Error;
};

enum class MessageType { kInput, kStyle, kAdd, kRemove, kStick };

// One parsed, validated client message. Fields not used by a type keep their defaults.
struct ClientMessage {
  MessageType type = MessageType::kInput;
  int character = 0;                 // input, style, remove: in [0, max_characters)
  double forward = 0, turn = 0;      // input: in [-1, 1]
  std::optional<double> speed_mps;   // input: in [0, max_speed_mps] when given
  double velocity_x_mps = 0, velocity_z_mps = 0, facing_rad = 0;  // stick: world velocity and facing
  // style, add: label names; std::nullopt = not given (add: none; style: keep), "" = none (JSON null).
  std::optional<std::string> style, content;
};

// Parses and validates one text message. Throws ProtocolError for anything else: over
// kMaxMessageBytes, not JSON, not an object, an unknown type or key, a missing or mistyped field,
// a number out of range or not finite, a label name over 64 bytes.
ClientMessage parse_client_message(const std::string& text, const Limits& limits);

// The model's control for one frame from a held input: [dx, dz, dtheta] (metres sideways and
// forward in the character's own ground frame, radians, +dtheta turns left; data/control.h), i.e.
// forward * speed / fps metres forward and turn * turn_rate / fps radians per frame.
std::array<float, 3> control_from_input(double forward, double turn, double speed_mps, double turn_rate_rad_s,
                                        double fps);

// Index of `name` in a label vocabulary; "" -> -1 (none). Throws ProtocolError naming the known
// labels when the name is not in it, or when the vocabulary is empty (the model takes no labels).
int label_index(const std::vector<std::string>& vocabulary, const std::string& name, const std::string& kind);

// {"type":"hello", "family", "fps", "joints" [J], "parents" [J], "offsets_m" [J][3] (rest offsets in
// metres), "styles" [..], "contents" [..] (empty when the model takes no labels), "colors"
// ["#rrggbb" per character id], "max_characters", "max_speed_mps", "turn_rate_rad_s"}.
std::string hello_json(const nn::LoadedRun& run, const Limits& limits);

// One character's state after a frame, world coordinates in metres (y up).
struct CharacterFrame {
  int id = 0;
  Eigen::Vector3d root_m = Eigen::Vector3d::Zero();  // floor projection of the root (y = 0)
  double heading_rad = 0;                            // 0 faces +z, positive turns left
  Eigen::Vector3d hips_m = Eigen::Vector3d::Zero();  // the root joint's translation
  std::vector<float> rotations_wxyz;                 // [J, 4] local rotations (w, x, y, z)
  std::vector<Eigen::Vector3d> positions_m;          // [J] joint world positions; empty = not sent
  std::string style, content;                        // label names, "" = none
};

// {"type":"frame", "frame":n, "time_s", "characters":[{"id", "root" [3], "heading", "hips" [3],
// "rotations" [J][4], "positions" [J][3] (when given), "style", "content"}]}; lengths rounded to
// 10 micrometres, rotations to 1e-5.
std::string frame_json(long frame, double time_s, const std::vector<CharacterFrame>& characters);

// {"type":"error", "message"} and {"type":"added", "character"}.
std::string error_json(const std::string& message);
std::string added_json(int character);

}  // namespace mosyn::serve

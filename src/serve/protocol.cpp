#include "serve/protocol.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "render/canvas.h"

namespace mosyn::serve {
namespace {

using nlohmann::json;

constexpr size_t kMaxLabelBytes = 64;

// The keys each type allows ("type" included): anything else is refused, so a misspelt field is an
// error rather than a silently ignored one.
const std::set<std::string>& allowed_keys(MessageType type) {
  static const std::set<std::string> kInput{"type", "character", "forward", "turn", "speed"};
  static const std::set<std::string> kStyle{"type", "character", "style", "content"};
  static const std::set<std::string> kAdd{"type", "style", "content"};
  static const std::set<std::string> kRemove{"type", "character"};
  static const std::set<std::string> kStick{"type", "character", "vx", "vz", "facing"};
  switch (type) {
    case MessageType::kStick: return kStick;
    case MessageType::kInput: return kInput;
    case MessageType::kStyle: return kStyle;
    case MessageType::kAdd: return kAdd;
    case MessageType::kRemove: return kRemove;
  }
  return kInput;
}

MessageType message_type(const json& j) {
  const auto it = j.find("type");
  if (it == j.end() || !it->is_string()) throw ProtocolError("a message needs a \"type\" string");
  const std::string& t = it->get_ref<const std::string&>();
  if (t == "input") return MessageType::kInput;
  if (t == "style") return MessageType::kStyle;
  if (t == "add") return MessageType::kAdd;
  if (t == "remove") return MessageType::kRemove;
  if (t == "stick") return MessageType::kStick;
  throw ProtocolError("unknown message type (known: stick, input, style, add, remove)");
}

// A required or optional finite number in [lo, hi].
std::optional<double> number(const json& j, const char* key, double lo, double hi, bool required) {
  const auto it = j.find(key);
  if (it == j.end()) {
    if (required) throw ProtocolError(std::string("\"") + key + "\" is missing");
    return std::nullopt;
  }
  if (!it->is_number()) throw ProtocolError(std::string("\"") + key + "\" must be a number");
  const double v = it->get<double>();
  if (!std::isfinite(v) || v < lo || v > hi)
    throw ProtocolError(std::string("\"") + key + "\" must be in [" + json(lo).dump() + ", " + json(hi).dump() + "]");
  return v;
}

int character(const json& j, const Limits& limits) {
  const auto it = j.find("character");
  if (it == j.end()) throw ProtocolError("\"character\" is missing");
  if (!it->is_number_integer() || it->get<long long>() < 0 || it->get<long long>() >= limits.max_characters)
    throw ProtocolError("\"character\" must be an integer in [0, " + std::to_string(limits.max_characters) + ")");
  return static_cast<int>(it->get<long long>());
}

// A label: absent -> nullopt, null -> "" (none), else a short string.
std::optional<std::string> label(const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end()) return std::nullopt;
  if (it->is_null()) return std::string();
  if (!it->is_string() || it->get_ref<const std::string&>().size() > kMaxLabelBytes)
    throw ProtocolError(std::string("\"") + key + "\" must be a label name (a string of at most 64 bytes) or null");
  return it->get<std::string>();
}

json rounded(const Eigen::Vector3d& v, double scale) {
  return json::array({std::round(v.x() * scale) / scale, std::round(v.y() * scale) / scale,
                      std::round(v.z() * scale) / scale});
}

}  // namespace

ClientMessage parse_client_message(const std::string& text, const Limits& limits) {
  if (text.size() > kMaxMessageBytes)
    throw ProtocolError("message of " + std::to_string(text.size()) + " bytes; at most " +
                        std::to_string(kMaxMessageBytes));
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) throw ProtocolError("not JSON");
  if (!j.is_object()) throw ProtocolError("a message must be a JSON object");
  ClientMessage m;
  m.type = message_type(j);
  const auto& keys = allowed_keys(m.type);
  for (const auto& item : j.items())
    if (!keys.count(item.key())) throw ProtocolError("unknown key \"" + item.key().substr(0, 32) + "\"");
  switch (m.type) {
    case MessageType::kStick: {
      m.character = character(j, limits);
      m.velocity_x_mps = *number(j, "vx", -limits.max_speed_mps, limits.max_speed_mps, true);
      m.velocity_z_mps = *number(j, "vz", -limits.max_speed_mps, limits.max_speed_mps, true);
      m.facing_rad = *number(j, "facing", -1e3, 1e3, true);
      if (std::hypot(m.velocity_x_mps, m.velocity_z_mps) > limits.max_speed_mps)
        throw ProtocolError("the stick's speed hypot(vx, vz) must be at most " + json(limits.max_speed_mps).dump() +
                            " m/s");
      break;
    }
    case MessageType::kInput:
      m.character = character(j, limits);
      m.forward = *number(j, "forward", -1, 1, true);
      m.turn = *number(j, "turn", -1, 1, true);
      m.speed_mps = number(j, "speed", 0, limits.max_speed_mps, false);
      break;
    case MessageType::kStyle:
      m.character = character(j, limits);
      m.style = label(j, "style");
      m.content = label(j, "content");
      break;
    case MessageType::kAdd:
      m.style = label(j, "style");
      m.content = label(j, "content");
      break;
    case MessageType::kRemove:
      m.character = character(j, limits);
      break;
  }
  return m;
}

std::array<float, 3> control_from_input(double forward, double turn, double speed_mps, double turn_rate_rad_s,
                                        double fps) {
  return {0.0f, static_cast<float>(forward * speed_mps / fps), static_cast<float>(turn * turn_rate_rad_s / fps)};
}

int label_index(const std::vector<std::string>& vocabulary, const std::string& name, const std::string& kind) {
  if (name.empty()) return -1;
  for (size_t i = 0; i < vocabulary.size(); ++i)
    if (vocabulary[i] == name) return static_cast<int>(i);
  if (vocabulary.empty()) throw ProtocolError("this model takes no " + kind + " labels");
  std::string known;
  for (const auto& v : vocabulary) known += (known.empty() ? "" : ", ") + v;
  throw ProtocolError("unknown " + kind + " (known: " + known + ")");
}

std::string hello_json(const nn::LoadedRun& run, const Limits& limits) {
  const auto& sk = run.dataset.skeleton;
  const double mpu = sk.meters_per_unit > 0 ? sk.meters_per_unit : 1.0;
  json offsets = json::array();
  for (const auto& o : sk.offsets) offsets.push_back(rounded(o * mpu, 1e5));
  json colors = json::array();
  for (int k = 0; k < limits.max_characters; ++k) colors.push_back(render::format_color(render::motion_color(k)));
  const bool labels = run.traits.labels;
  json j{{"type", "hello"},
         {"family", run.family},
         {"fps", run.dataset.fps},
         {"joints", sk.joint_names},
         {"parents", sk.parents},
         {"offsets_m", std::move(offsets)},
         {"styles", labels ? run.dataset.style_labels : std::vector<std::string>{}},
         {"contents", labels ? run.dataset.content_labels : std::vector<std::string>{}},
         {"colors", std::move(colors)},
         {"max_characters", limits.max_characters},
         {"max_speed_mps", limits.max_speed_mps},
         {"turn_rate_rad_s", limits.turn_rate_rad_s}};
  return j.dump();
}

std::string frame_json(long frame, double time_s, const std::vector<CharacterFrame>& characters) {
  json list = json::array();
  for (const auto& c : characters) {
    json rotations = json::array();
    for (size_t i = 0; i + 3 < c.rotations_wxyz.size(); i += 4) {
      json q = json::array();
      for (size_t k = 0; k < 4; ++k) q.push_back(std::round(c.rotations_wxyz[i + k] * 1e5) / 1e5);
      rotations.push_back(std::move(q));
    }
    json jc{{"id", c.id},
            {"root", rounded(c.root_m, 1e5)},
            {"heading", std::round(c.heading_rad * 1e5) / 1e5},
            {"hips", rounded(c.hips_m, 1e5)},
            {"rotations", std::move(rotations)},
            {"style", c.style},
            {"content", c.content}};
    if (!c.positions_m.empty()) {
      json positions = json::array();
      for (const auto& p : c.positions_m) positions.push_back(rounded(p, 1e5));
      jc["positions"] = std::move(positions);
    }
    list.push_back(std::move(jc));
  }
  return json{{"type", "frame"}, {"frame", frame}, {"time_s", std::round(time_s * 1e4) / 1e4}, {"characters", std::move(list)}}
      .dump();
}

// A message may quote what the client sent, which may be cut inside a UTF-8 sequence: replaced.
std::string error_json(const std::string& message) {
  return json{{"type", "error"}, {"message", message}}.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string added_json(int character) { return json{{"type", "added"}, {"character", character}}.dump(); }

}  // namespace mosyn::serve

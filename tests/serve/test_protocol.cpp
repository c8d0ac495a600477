// The live protocol's parsing and validation (serve/protocol.h): what the server accepts, what it
// refuses (malformed, oversized, out of range, not finite), and the messages it builds.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "serve/protocol.h"

namespace mosyn::serve {
namespace {

const Limits kLimits{};  // 4 characters, 3 m/s

TEST(Protocol, AcceptsEveryMessageType) {
  ClientMessage m = parse_client_message(R"({"type":"input","character":1,"forward":0.5,"turn":-1,"speed":2})", kLimits);
  EXPECT_EQ(m.type, MessageType::kInput);
  EXPECT_EQ(m.character, 1);
  EXPECT_DOUBLE_EQ(m.forward, 0.5);
  EXPECT_DOUBLE_EQ(m.turn, -1);
  ASSERT_TRUE(m.speed_mps.has_value());
  EXPECT_DOUBLE_EQ(*m.speed_mps, 2);
  m = parse_client_message(R"({"type":"input","character":0,"forward":0,"turn":0})", kLimits);
  EXPECT_FALSE(m.speed_mps.has_value());  // the last speed stays
  m = parse_client_message(R"({"type":"style","character":3,"style":"elderly","content":null})", kLimits);
  EXPECT_EQ(m.type, MessageType::kStyle);
  EXPECT_EQ(*m.style, "elderly");
  EXPECT_EQ(*m.content, "");  // null: none
  m = parse_client_message(R"({"type":"add"})", kLimits);
  EXPECT_EQ(m.type, MessageType::kAdd);
  EXPECT_FALSE(m.style.has_value());
  m = parse_client_message(R"({"type":"remove","character":2})", kLimits);
  EXPECT_EQ(m.type, MessageType::kRemove);
  EXPECT_EQ(m.character, 2);
}

TEST(Protocol, AStickIsAWorldVelocityAndAFacing) {
  const ClientMessage m =
      parse_client_message(R"({"type":"stick","character":2,"vx":-1.2,"vz":0.5,"facing":-1.9})", kLimits);
  EXPECT_EQ(m.type, MessageType::kStick);
  EXPECT_EQ(m.character, 2);
  EXPECT_DOUBLE_EQ(m.velocity_x_mps, -1.2);
  EXPECT_DOUBLE_EQ(m.velocity_z_mps, 0.5);
  EXPECT_DOUBLE_EQ(m.facing_rad, -1.9);
  for (const char* text : {R"({"type":"stick","character":0,"vx":2.5,"vz":2.5,"facing":0})",  // 3.5 m/s
                           R"({"type":"stick","character":0,"vx":0,"vz":0})",
                           R"({"type":"stick","character":0,"vx":0,"vz":0,"facing":"north"})",
                           R"({"type":"stick","character":0,"vx":1e999,"vz":0,"facing":0})",
                           R"({"type":"stick","character":0,"vx":0,"vz":0,"facing":0,"forward":1})",
                           R"({"type":"stick","character":9,"vx":0,"vz":0,"facing":0})"})
    EXPECT_THROW(parse_client_message(text, kLimits), ProtocolError) << text;
}

TEST(Protocol, RefusesMalformedMessages) {
  for (const char* text : {"", "{", "not json", "[1,2]", "42", "null", R"("input")", R"({})", R"({"type":7})",
                           R"({"type":"jump"})", R"({"type":"input","forward":1,"turn":0})",
                           R"({"type":"input","character":0,"forward":"1","turn":0})",
                           R"({"type":"input","character":0,"forward":1})",
                           R"({"type":"input","character":0,"forward":1,"turn":0,"extra":1})",
                           R"({"type":"add","character":0})", R"({"type":"style","character":0,"style":5})",
                           R"({"type":"remove","character":"0"})", R"({"type":"input","character":0,"forward":NaN,"turn":0})"})
    EXPECT_THROW(parse_client_message(text, kLimits), ProtocolError) << text;
}

TEST(Protocol, RefusesValuesOutOfRangeOrNotFinite) {
  for (const char* text : {R"({"type":"input","character":0,"forward":1.01,"turn":0})",
                           R"({"type":"input","character":0,"forward":0,"turn":-2})",
                           R"({"type":"input","character":0,"forward":0,"turn":0,"speed":-0.1})",
                           R"({"type":"input","character":0,"forward":0,"turn":0,"speed":3.5})",
                           R"({"type":"input","character":0,"forward":1e999,"turn":0})",
                           R"({"type":"input","character":0,"forward":-1e999,"turn":0})",
                           R"({"type":"input","character":4,"forward":0,"turn":0})",
                           R"({"type":"input","character":-1,"forward":0,"turn":0})",
                           R"({"type":"input","character":0.5,"forward":0,"turn":0})",
                           R"({"type":"input","character":18446744073709551615,"forward":0,"turn":0})",
                           R"({"type":"remove","character":99999999999999999999999})"})
    EXPECT_THROW(parse_client_message(text, kLimits), ProtocolError) << text;
  const std::string long_label = R"({"type":"add","style":")" + std::string(65, 'a') + "\"}";
  EXPECT_THROW(parse_client_message(long_label, kLimits), ProtocolError);
}

TEST(Protocol, RefusesHugeAndDeeplyNestedMessages) {
  const std::string huge = R"({"type":"add","style":")" + std::string(kMaxMessageBytes, 'x') + "\"}";
  try {
    parse_client_message(huge, kLimits);
    FAIL() << "a message over the limit was accepted";
  } catch (const ProtocolError& e) {
    EXPECT_NE(std::string(e.what()).find("bytes"), std::string::npos) << e.what();
  }
  const std::string nested = std::string(2000, '[') + std::string(2000, ']');  // under the size limit
  EXPECT_THROW(parse_client_message(nested, kLimits), ProtocolError);
}

TEST(Protocol, ControlFromInputIsPerFrameInTheHeadingFrame) {
  const auto u = control_from_input(1.0, 0.5, 1.5, 1.6, 30.0);
  EXPECT_FLOAT_EQ(u[0], 0.0f);                  // no sideways step
  EXPECT_FLOAT_EQ(u[1], 1.5f / 30.0f);          // metres forward per frame
  EXPECT_FLOAT_EQ(u[2], 0.5f * 1.6f / 30.0f);   // radians per frame, positive turns left
  const auto back = control_from_input(-1.0, 0, 1.0, 1.6, 30.0);
  EXPECT_LT(back[1], 0.0f);
}

TEST(Protocol, LabelsResolveAgainstTheVocabulary) {
  const std::vector<std::string> styles{"normal", "elderly"};
  EXPECT_EQ(label_index(styles, "elderly", "style"), 1);
  EXPECT_EQ(label_index(styles, "", "style"), -1);
  try {
    label_index(styles, "sneaky", "style");
    FAIL();
  } catch (const ProtocolError& e) {
    EXPECT_NE(std::string(e.what()).find("normal, elderly"), std::string::npos) << e.what();
  }
  EXPECT_THROW(label_index({}, "normal", "style"), ProtocolError);
}

TEST(Protocol, ServerMessagesAreJson) {
  CharacterFrame c;
  c.id = 2;
  c.root_m = {1.234567, 0, -2.0};
  c.heading_rad = 0.5;
  c.rotations_wxyz = {1, 0, 0, 0, 0.7071068f, 0.7071068f, 0, 0};
  c.positions_m = {{0, 1, 0}, {0.1, 0.5, 0.0}};
  c.style = "elderly";
  const auto j = nlohmann::json::parse(frame_json(7, 0.2333, {c}));
  EXPECT_EQ(j["type"], "frame");
  EXPECT_EQ(j["frame"], 7);
  ASSERT_EQ(j["characters"].size(), 1u);
  const auto& jc = j["characters"][0];
  EXPECT_EQ(jc["id"], 2);
  EXPECT_NEAR(jc["root"][0].get<double>(), 1.23457, 1e-9);
  EXPECT_EQ(jc["rotations"].size(), 2u);
  EXPECT_EQ(jc["rotations"][1].size(), 4u);
  EXPECT_EQ(jc["positions"].size(), 2u);
  EXPECT_EQ(jc["style"], "elderly");
  c.positions_m.clear();  // positions are optional
  EXPECT_FALSE(nlohmann::json::parse(frame_json(8, 0.3, {c}))["characters"][0].contains("positions"));
  // An error quoting a cut UTF-8 sequence stays valid JSON.
  const auto e = nlohmann::json::parse(error_json("unknown key \"\xc3\""));
  EXPECT_EQ(e["type"], "error");
  EXPECT_EQ(nlohmann::json::parse(added_json(3))["character"], 3);
}

TEST(Protocol, HelloDescribesTheTestModel) {
  const nn::LoadedRun run = nn::load_run(std::string(MOSYN_SOURCE_DIR) + "/tests/models/moglow", {"checkpoint.pt", "cpu", 1});
  const auto j = nlohmann::json::parse(hello_json(run, kLimits));
  EXPECT_EQ(j["type"], "hello");
  EXPECT_EQ(j["fps"], run.dataset.fps);
  const size_t joints = run.dataset.skeleton.joint_names.size();
  EXPECT_EQ(j["joints"].size(), joints);
  EXPECT_EQ(j["parents"].size(), joints);
  EXPECT_EQ(j["offsets_m"].size(), joints);
  EXPECT_EQ(j["styles"].size(), run.traits.labels ? run.dataset.style_labels.size() : 0u);
  EXPECT_EQ(j["colors"].size(), 4u);
  EXPECT_EQ(j["max_speed_mps"], kLimits.max_speed_mps);
}

}  // namespace
}  // namespace mosyn::serve

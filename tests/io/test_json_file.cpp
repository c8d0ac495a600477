#include "io/json_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/atomic_file.h"

namespace mosyn::io {
namespace {

namespace fs = std::filesystem;

TEST(JsonFile, WriteReadRoundTrip) {
  const fs::path dir = fs::temp_directory_path() / ("mosyn_test_io_json_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = (dir / "a.json").string();
  const nlohmann::json value = {{"fps", 30.0}, {"names", {"Hips", "Spine"}}, {"nested", {{"k", 1}}}};
  write_json(path, value);
  EXPECT_EQ(read_json(path), value);
  const std::string text = read_file(path);
  EXPECT_EQ(text.back(), '\n');
  EXPECT_EQ(format_json(value, -1), value.dump() + "\n");
  fs::remove_all(dir);
}

TEST(JsonFile, SyntaxErrorsGiveFileAndLine) {
  try {
    parse_json("{\n  \"a\": 1,\n  \"b\": ]\n}\n", "cfg.json");
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.file(), "cfg.json");
    EXPECT_EQ(e.line(), 3) << e.what();
    EXPECT_NE(std::string(e.what()).find("invalid JSON"), std::string::npos);
  }
  EXPECT_THROW(parse_json("", "empty.json"), ParseError);
  EXPECT_THROW(parse_json("{\"a\": 1", "cut.json"), ParseError);
  EXPECT_THROW(read_json("/nonexistent_mosyn/a.json"), Error);
  EXPECT_THROW(format_json(nlohmann::json("\xff\xfe")), Error);  // invalid UTF-8
}

// A number beyond double range is valid JSON syntax that nlohmann refuses with out_of_range (not
// parse_error); it escaped as a bare nlohmann exception naming no file (found by the bad-numbers
// test of stats.json; the json_config fuzz harness reports the same input as a crash).
TEST(JsonFile, NumberOverflowGivesFileAndLine) {
  for (const std::string& number : {std::string("1e999"), std::string("-1e400")}) {
    try {
      parse_json("{\n  \"pose_mean\": [0.5,\n    " + number + "]\n}\n", "stats.json");
      ADD_FAILURE() << "no error for " << number;
    } catch (const ParseError& e) {
      EXPECT_EQ(e.file(), "stats.json");
      EXPECT_EQ(e.line(), 3) << e.what();
      EXPECT_NE(std::string(e.what()).find(number), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace mosyn::io

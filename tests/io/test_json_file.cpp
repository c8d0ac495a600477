#include "io/json_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/json_number.h"

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

// Found by fuzz_json_config: a float far outside int's range where an integer is expected (a
// skeleton's parents) was cast, which is undefined behaviour. json_get checks before converting.
TEST(JsonNumber, IntegersAreCheckedBeforeConversion) {
  using nlohmann::json;
  EXPECT_EQ(json_get<int>(json(3.0)), 3);
  EXPECT_EQ(json_get<int>(json(-7)), -7);
  EXPECT_EQ(json_get<int>(json(2147483647)), 2147483647);
  EXPECT_EQ(json_get<int>(json(-2147483648.0)), -2147483647 - 1);
  EXPECT_THROW(json_get<int>(json(2147483648.0)), json::out_of_range);
  EXPECT_THROW(json_get<int>(json(-1.2222e63)), json::out_of_range);
  EXPECT_THROW(json_get<int>(json(2.5)), json::out_of_range);
  EXPECT_THROW(json_get<int>(json(std::int64_t{1} << 40)), json::out_of_range);
  EXPECT_THROW(json_get<std::uint64_t>(json(-1)), json::out_of_range);
  EXPECT_THROW(json_get<std::uint64_t>(json(1.9e19)), json::out_of_range);
  EXPECT_EQ(json_get<std::uint64_t>(json(18446744073709551615ull)), 18446744073709551615ull);
  EXPECT_THROW(json_get<int>(json("3")), json::type_error);
  EXPECT_EQ(json_get<std::vector<int>>(json::parse("[-1, 0, 1.0]")), (std::vector<int>{-1, 0, 1}));
  EXPECT_THROW(json_get<std::vector<int>>(json::parse("[-1, -1.2222e63]")), json::out_of_range);
  EXPECT_DOUBLE_EQ(json_get<double>(json(1e300)), 1e300);  // non-integers pass unchanged
  EXPECT_EQ(json_value(json::parse("{\"n\": 4}"), "n", 0), 4);
  EXPECT_EQ(json_value(json::parse("{}"), "n", 9), 9);
  EXPECT_THROW(json_value(json::parse("{\"n\": 1e30}"), "n", 0), json::out_of_range);
}

}  // namespace
}  // namespace mosyn::io

#include "io/json_file.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/atomic_file.h"

namespace mosyn::io {

nlohmann::json parse_json(const std::string& text, const std::string& file_name_for_errors) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is 1-based and may point one past the end; count the lines before it.
    const size_t end = std::min(text.size(), e.byte > 0 ? static_cast<size_t>(e.byte - 1) : size_t{0});
    const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(end), '\n'));
    std::string message = e.what();
    // Drop nlohmann's "[json.exception.parse_error.101] parse error at line 1, column 2: " prefix.
    const size_t colon = message.find(": ");
    if (colon != std::string::npos) message = message.substr(colon + 2);
    throw ParseError(file_name_for_errors, line, "invalid JSON: " + message);
  } catch (const nlohmann::json::exception& e) {
    // Valid syntax the parser still refuses, e.g. a number beyond double range ("1e999": out_of_range
    // 406, "number overflow parsing '1e999'"); name the line of the quoted token when it is found.
    std::string message = e.what();
    const size_t bracket = message.find("] ");
    if (bracket != std::string::npos) message = message.substr(bracket + 2);
    int line = 0;
    const size_t open = message.find('\''), close = message.rfind('\'');
    if (open != std::string::npos && close > open + 1) {
      const size_t at = text.find(message.substr(open + 1, close - open - 1));
      if (at != std::string::npos)
        line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    }
    throw ParseError(file_name_for_errors, line, "invalid JSON: " + message);
  }
}

nlohmann::json read_json(const std::string& path) { return parse_json(read_file(path), path); }

std::string format_json(const nlohmann::json& value, int indent) {
  try {
    return value.dump(indent) + "\n";
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("cannot serialise JSON: ") + e.what());
  }
}

void write_json(const std::string& path, const nlohmann::json& value, int indent) {
  write_file_atomically(path, format_json(value, indent));
}

}  // namespace mosyn::io

// JSON files (dataset descriptions, statistics, run configurations, metrics), read with
// file:line errors and written atomically.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>

namespace mosyn::io {

// Parses JSON text. Throws mosyn::ParseError(file_name_for_errors, line, message) with the line
// of the syntax error.
nlohmann::json parse_json(const std::string& text, const std::string& file_name_for_errors);

// Reads and parses a JSON file. Throws mosyn::Error naming the path when it cannot be read.
nlohmann::json read_json(const std::string& path);

// Serialises value (indent spaces per level; -1 for one compact line) followed by a newline.
// Throws mosyn::Error when a string is not valid UTF-8.
std::string format_json(const nlohmann::json& value, int indent = 2);

// format_json written atomically (io/atomic_file.h).
void write_json(const std::string& path, const nlohmann::json& value, int indent = 2);

}  // namespace mosyn::io

#include "core/error.h"

namespace mosyn {

static std::string format_location(const std::string& file, int line, const std::string& message) {
  if (line > 0) return file + ":" + std::to_string(line) + ": " + message;
  return file + ": " + message;
}

ParseError::ParseError(std::string file, int line, const std::string& message)
    : Error(format_location(file, line, message)), file_(std::move(file)), line_(line) {}

}  // namespace mosyn

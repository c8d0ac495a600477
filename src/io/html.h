// Small helpers for the HTML pages mosyn writes (viewer, reports).
#pragma once

#include <string>

namespace mosyn::io {

// Text safe inside HTML element content and quoted attribute values: & < > " ' escaped.
std::string escape_html(const std::string& text);

}  // namespace mosyn::io

// File-name helpers shared by the library and the CLI.
#pragma once

#include <string>

namespace mosyn::io {

// Lower-case extension without the dot ("bvh" for "x/Walk.BVH"), "" when there is none.
std::string extension_of(const std::string& path);

}  // namespace mosyn::io

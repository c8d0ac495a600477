// Helpers shared by the io tests.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>

namespace mosyn::io::testing {

// A fresh empty directory for one test, unique to this process.
inline std::filesystem::path make_temp_dir(const std::string& name) {
  std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mosyn_test_io_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace mosyn::io::testing

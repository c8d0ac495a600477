// Splitting one fuzz input into the files of a directory (dataset or run directories).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace mosyn::fuzz {

// Files of a directory input are separated by this line (seed corpora are made by
// fuzz/make_corpus.py).
inline const std::string kFileSeparator = "\n--mosyn-fuzz-file--\n";

// The input cut at each separator into at most `count` parts (missing parts are empty; the last
// part takes the rest).
inline std::vector<std::string> split_input(const uint8_t* data, size_t size, size_t count) {
  const std::string all(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> parts;
  size_t begin = 0;
  while (parts.size() + 1 < count) {
    const size_t at = all.find(kFileSeparator, begin);
    if (at == std::string::npos) break;
    parts.push_back(all.substr(begin, at - begin));
    begin = at + kFileSeparator.size();
  }
  parts.push_back(all.substr(begin));
  parts.resize(count);
  return parts;
}

// A scratch directory for this process, emptied of the given names' previous content.
inline std::filesystem::path scratch_dir(const std::string& name) {
  static const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mosyn_fuzz_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

// Writes (or, for an empty part when skip_empty, removes) each file.
inline void write_files(const std::filesystem::path& dir, const std::vector<std::string>& names,
                        const std::vector<std::string>& contents) {
  for (size_t i = 0; i < names.size(); ++i) {
    const std::filesystem::path p = dir / names[i];
    if (contents[i].empty()) {
      std::filesystem::remove(p);
      continue;
    }
    std::ofstream(p, std::ios::binary | std::ios::trunc) << contents[i];
  }
}

}  // namespace mosyn::fuzz

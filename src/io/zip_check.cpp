#include "io/zip_check.h"

#include <zip.h>

#include <memory>
#include <vector>

#include "core/error.h"

namespace mosyn::io {

namespace {

struct ArchiveCloser {
  void operator()(zip_t* z) const { zip_discard(z); }
};
struct FileCloser {
  void operator()(zip_file_t* f) const { zip_fclose(f); }
};

std::string zip_message(zip_error_t* error) {
  const std::string m = zip_error_strerror(error);
  zip_error_fini(error);
  return m;
}

}  // namespace

void check_zip_integrity(const std::string& bytes, const std::string& name) {
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* source = zip_source_buffer_create(bytes.data(), bytes.size(), 0, &error);
  if (!source) throw Error(name + ": cannot read the archive: " + zip_message(&error));
  std::unique_ptr<zip_t, ArchiveCloser> archive(zip_open_from_source(source, ZIP_RDONLY | ZIP_CHECKCONS, &error));
  if (!archive) {
    zip_source_free(source);
    throw Error(name + ": damaged file (not a consistent ZIP archive: " + zip_message(&error) + ")");
  }
  zip_error_fini(&error);
  const zip_int64_t entries = zip_get_num_entries(archive.get(), 0);
  std::vector<char> buffer(1 << 16);
  for (zip_int64_t i = 0; i < entries; ++i) {
    const char* entry = zip_get_name(archive.get(), static_cast<zip_uint64_t>(i), 0);
    const std::string entry_name = entry ? entry : "#" + std::to_string(i);
    std::unique_ptr<zip_file_t, FileCloser> file(zip_fopen_index(archive.get(), static_cast<zip_uint64_t>(i), 0));
    if (!file)
      throw Error(name + ": damaged file (entry '" + entry_name + "': " + zip_strerror(archive.get()) + ")");
    zip_int64_t got;
    while ((got = zip_fread(file.get(), buffer.data(), buffer.size())) > 0) {
    }
    // libzip compares the CRC-32 and size once an entry is read to its end.
    if (got < 0)
      throw Error(name + ": damaged file (entry '" + entry_name + "': " + zip_file_strerror(file.get()) + ")");
  }
}

}  // namespace mosyn::io

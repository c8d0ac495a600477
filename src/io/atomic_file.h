// Whole-file reading and atomic file writing, shared by every layer that saves files
// (BVH, NPY, CSV, JSON, checkpoints, dataset caches).
//
// Atomic writes go to a temporary file in the destination's directory ("<path>.tmp.<pid>.<n>"),
// are flushed to disk, and are then renamed over the destination. Readers therefore see either
// the old file or the complete new one, never a partial file; a failed or abandoned write
// leaves the old file untouched and removes the temporary file. A destination that exists and is
// not a regular file (/dev/null, /dev/stdout, a named pipe) is written directly instead: renaming
// over it would replace the device or pipe with a plain file.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace mosyn::io {

// Default cap for read_file: 4 GiB, far above any single motion or model file.
constexpr std::uint64_t kDefaultMaxFileBytes = std::uint64_t{4} << 30;

// Reads a whole file as bytes (binary, no newline translation). Throws mosyn::Error naming the
// path when the file cannot be opened or read, is not a regular file, or is larger than
// max_bytes.
std::string read_file(const std::string& path, std::uint64_t max_bytes = kDefaultMaxFileBytes);

// Replaces the file at path with bytes atomically (see above). Throws mosyn::Error naming the
// path when the directory is not writable, the disk is full, or the rename fails; the old file
// is then intact.
void write_file_atomically(const std::string& path, const std::string& bytes);

// Streaming form of write_file_atomically for large outputs: write() appends to a temporary
// file, commit() renames it over the destination. If the writer is destroyed without commit()
// (for example because an exception unwinds past it) the temporary file is removed and the
// destination is left as it was. Not copyable; movable.
//
//   AtomicFileWriter out(path);
//   out.write(header);
//   for (...) out.write(chunk.data(), chunk.size());
//   out.commit();
class AtomicFileWriter {
 public:
  // Creates the temporary file. Throws mosyn::Error naming path when that is impossible.
  explicit AtomicFileWriter(const std::string& path);
  ~AtomicFileWriter();
  AtomicFileWriter(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter& operator=(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  // Appends bytes (buffered). Throws mosyn::Error on a write failure or after commit()/abort().
  void write(const void* data, std::size_t num_bytes);
  void write(const std::string& bytes) { write(bytes.data(), bytes.size()); }

  // Flushes, syncs and renames the temporary file over the destination. Throws mosyn::Error on
  // failure (the temporary file is then removed and the destination untouched). Call once.
  void commit();

  // Discards everything written so far and removes the temporary file; the destination is
  // untouched. Safe to call more than once. Never throws.
  void abort() noexcept;

  const std::string& path() const { return path_; }
  // The temporary file currently being written ("" once committed or aborted).
  const std::string& temp_path() const { return temp_path_; }

 private:
  void flush_buffer();

  std::string path_;
  std::string temp_path_;
  int fd_ = -1;
  bool direct_ = false;  // writing straight into a device or pipe (no temporary file)
  std::string buffer_;
};

}  // namespace mosyn::io

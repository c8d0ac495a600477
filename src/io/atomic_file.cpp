#include "io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

#include "core/error.h"

namespace mosyn::io {
namespace {

std::string errno_text(int err) { return std::strerror(err); }

// Unique within the process (counter) and across processes (pid).
std::string make_temp_path(const std::string& path) {
  static std::atomic<unsigned long> counter{0};
  return path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter.fetch_add(1));
}

constexpr std::size_t kBufferBytes = std::size_t{1} << 20;

}  // namespace

std::string read_file(const std::string& path, std::uint64_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(path + ": cannot open for reading: " + errno_text(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw Error(path + ": cannot stat: " + errno_text(errno));
  if (S_ISDIR(st.st_mode)) throw Error(path + ": is a directory, expected a file");
  if (!S_ISREG(st.st_mode)) throw Error(path + ": is not a regular file");
  const std::uint64_t size = static_cast<std::uint64_t>(st.st_size);
  if (size > max_bytes)
    throw Error(path + ": file is " + std::to_string(size) + " bytes, more than the limit of " +
                std::to_string(max_bytes) + " bytes");
  std::string bytes(static_cast<std::size_t>(size), '\0');
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::read(fd, &bytes[done], bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw Error(path + ": read failed: " + errno_text(errno));
    }
    if (n == 0) break;  // file shrank while reading
    done += static_cast<std::size_t>(n);
  }
  bytes.resize(done);
  return bytes;
}

void write_file_atomically(const std::string& path, const std::string& bytes) {
  AtomicFileWriter writer(path);
  writer.write(bytes);
  writer.commit();
}

AtomicFileWriter::AtomicFileWriter(const std::string& path) : path_(path) {
  if (path.empty()) throw Error("cannot write a file with an empty path");
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    if (S_ISDIR(st.st_mode)) throw Error(path + ": is a directory, expected a file name");
    fd_ = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd_ < 0) throw Error(path + ": cannot open for writing: " + errno_text(errno));
    direct_ = true;
    buffer_.reserve(kBufferBytes);
    return;
  }
  temp_path_ = make_temp_path(path);
  // 0666 filtered by the umask, like any ordinary new file.
  fd_ = ::open(temp_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd_ < 0) {
    const int err = errno;
    temp_path_.clear();
    throw Error(path + ": cannot create a temporary file for writing: " + errno_text(err));
  }
  buffer_.reserve(kBufferBytes);
}

AtomicFileWriter::~AtomicFileWriter() { abort(); }

AtomicFileWriter::AtomicFileWriter(AtomicFileWriter&& other) noexcept
    : path_(std::move(other.path_)),
      temp_path_(std::exchange(other.temp_path_, std::string())),
      fd_(std::exchange(other.fd_, -1)),
      direct_(other.direct_),
      buffer_(std::move(other.buffer_)) {}

AtomicFileWriter& AtomicFileWriter::operator=(AtomicFileWriter&& other) noexcept {
  if (this != &other) {
    abort();
    path_ = std::move(other.path_);
    temp_path_ = std::exchange(other.temp_path_, std::string());
    fd_ = std::exchange(other.fd_, -1);
    direct_ = other.direct_;
    buffer_ = std::move(other.buffer_);
  }
  return *this;
}

void AtomicFileWriter::flush_buffer() {
  std::size_t done = 0;
  while (done < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      abort();
      throw Error(path_ + ": write failed: " + errno_text(err));
    }
    done += static_cast<std::size_t>(n);
  }
  buffer_.clear();
}

void AtomicFileWriter::write(const void* data, std::size_t num_bytes) {
  if (fd_ < 0) throw Error(path_ + ": write after the file was committed or abandoned");
  const char* bytes = static_cast<const char*>(data);
  if (buffer_.size() + num_bytes > kBufferBytes) {
    flush_buffer();
    if (num_bytes >= kBufferBytes) {  // large chunk: bypass the buffer
      buffer_.assign(bytes, num_bytes);
      flush_buffer();
      return;
    }
  }
  buffer_.append(bytes, num_bytes);
}

void AtomicFileWriter::commit() {
  if (fd_ < 0) throw Error(path_ + ": commit after the file was committed or abandoned");
  flush_buffer();
  if (direct_) {  // a device or pipe: nothing to sync or rename
    const int closed = ::close(fd_);
    fd_ = -1;
    if (closed != 0) throw Error(path_ + ": cannot close: " + errno_text(errno));
    return;
  }
  if (::fsync(fd_) != 0) {
    const int err = errno;
    abort();
    throw Error(path_ + ": cannot sync to disk: " + errno_text(err));
  }
  if (::close(fd_) != 0) {
    const int err = errno;
    fd_ = -1;
    abort();
    throw Error(path_ + ": cannot close: " + errno_text(err));
  }
  fd_ = -1;
  if (std::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    const int err = errno;
    abort();
    throw Error(path_ + ": cannot replace the file: " + errno_text(err));
  }
  temp_path_.clear();
  // Make the rename itself durable; failure here does not undo the (already visible) write.
  const size_t slash = path_.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : path_.substr(0, slash));
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    ::fsync(dir_fd);
    ::close(dir_fd);
  }
}

void AtomicFileWriter::abort() noexcept {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  if (!temp_path_.empty()) {
    ::unlink(temp_path_.c_str());
    temp_path_.clear();
  }
  buffer_.clear();
}

}  // namespace mosyn::io

#include "io/atomic_file.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <thread>

#include "core/error.h"
#include "io_test_util.h"

namespace mosyn::io {
namespace {

namespace fs = std::filesystem;

using testing::make_temp_dir;

// Everything written into a named pipe until the writer closes it.
std::string read_fifo(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  std::string out;
  char buf[256];
  for (ssize_t n; fd >= 0 && (n = ::read(fd, buf, sizeof buf)) > 0;) out.append(buf, static_cast<size_t>(n));
  if (fd >= 0) ::close(fd);
  return out;
}

size_t count_entries(const fs::path& dir) {
  size_t n = 0;
  for (const auto& entry : fs::directory_iterator(dir)) n += 1 + 0 * entry.is_regular_file();
  return n;
}

TEST(AtomicFile, WritesAndReadsBytesExactly) {
  const fs::path dir = make_temp_dir("atomic_rw");
  const std::string path = (dir / "a.bin").string();
  const std::string bytes("line1\r\nline2\n\0\xff tail", 20);
  write_file_atomically(path, bytes);
  EXPECT_EQ(read_file(path), bytes);
  write_file_atomically(path, "replaced");
  EXPECT_EQ(read_file(path), "replaced");
  write_file_atomically(path, "");
  EXPECT_EQ(read_file(path), "");
  EXPECT_EQ(count_entries(dir), 1u);  // no temporary file left
  fs::remove_all(dir);
}

TEST(AtomicFile, ReadFileErrorsNameThePath) {
  const fs::path dir = make_temp_dir("atomic_read");
  const std::string missing = (dir / "missing.txt").string();
  try {
    read_file(missing);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_file(dir.string()), Error);  // a directory
  const std::string path = (dir / "big.txt").string();
  write_file_atomically(path, std::string(1000, 'x'));
  EXPECT_EQ(read_file(path, 1000).size(), 1000u);
  try {
    read_file(path, 999);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("limit"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(AtomicFile, StreamingWriterCommitsLargeOutput) {
  const fs::path dir = make_temp_dir("atomic_stream");
  const std::string path = (dir / "big.bin").string();
  std::string expected;
  {
    AtomicFileWriter out(path);
    EXPECT_FALSE(fs::exists(path));  // nothing visible before commit
    EXPECT_TRUE(fs::exists(out.temp_path()));
    for (int i = 0; i < 300; ++i) {
      const std::string chunk(static_cast<size_t>(1000 + i * 37), static_cast<char>('a' + i % 26));
      out.write(chunk);
      expected += chunk;
    }
    const std::string large(3u << 20, 'L');  // larger than the internal buffer
    out.write(large.data(), large.size());
    expected += large;
    out.commit();
    EXPECT_TRUE(out.temp_path().empty());
    EXPECT_THROW(out.write("more"), Error);
  }
  EXPECT_EQ(read_file(path), expected);
  EXPECT_EQ(count_entries(dir), 1u);
  fs::remove_all(dir);
}

TEST(AtomicFile, ThrowingWriterLeavesOldContentAndNoTempFile) {
  const fs::path dir = make_temp_dir("atomic_throw");
  const std::string path = (dir / "data.bin").string();
  write_file_atomically(path, "old content");
  try {
    AtomicFileWriter out(path);
    out.write("new content, part 1");
    out.write(std::string(2u << 20, 'x'));  // forces bytes onto disk
    throw std::runtime_error("writer failed midway");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(read_file(path), "old content");
  EXPECT_EQ(count_entries(dir), 1u);
  {
    AtomicFileWriter out(path);
    out.write("abandoned");
    out.abort();
    out.abort();
  }
  EXPECT_EQ(read_file(path), "old content");
  EXPECT_EQ(count_entries(dir), 1u);
  fs::remove_all(dir);
}

TEST(AtomicFile, MovedWriterOwnsTheTemporaryFile) {
  const fs::path dir = make_temp_dir("atomic_move");
  const std::string path = (dir / "m.txt").string();
  AtomicFileWriter a(path);
  a.write("hello ");
  AtomicFileWriter b(std::move(a));
  b.write("world");
  b.commit();
  EXPECT_EQ(read_file(path), "hello world");
  EXPECT_EQ(count_entries(dir), 1u);
  fs::remove_all(dir);
}

TEST(AtomicFile, UnwritableDirectoryGivesAClearError) {
  const std::string path = "/nonexistent_mosyn_dir/sub/file.txt";
  try {
    write_file_atomically(path, "x");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_THROW(write_file_atomically("", "x"), Error);
}

// Devices and pipes are written in place: renaming over /dev/null would replace the device with
// a plain file (as `mosyn eval --out /dev/null` once did).
TEST(AtomicFile, DevicesAndPipesAreWrittenInPlace) {
  write_file_atomically("/dev/null", "discarded");
  struct stat st {};
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));

  const std::string fifo = (std::filesystem::temp_directory_path() / ("mosyn_fifo_" + std::to_string(::getpid()))).string();
  ::unlink(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string got;
  std::thread reader([&] { got = read_fifo(fifo); });
  write_file_atomically(fifo, "through the pipe");
  reader.join();
  EXPECT_EQ(got, "through the pipe");
  ASSERT_EQ(::stat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  ::unlink(fifo.c_str());
  EXPECT_THROW(write_file_atomically(std::filesystem::temp_directory_path().string(), "x"), Error);
}

// A full disk while writing: the write fails with an error naming the file, the old content
// stays under the final name and no temporary file is left behind. Shown with a 64 KiB tmpfs
// (needs root to mount; skipped otherwise) and, everywhere, with a file-size limit (RLIMIT_FSIZE
// makes write(2) fail with EFBIG once the file would pass it, the same error path as ENOSPC).
void expect_failed_write_keeps_old_file(const fs::path& dir) {
  const std::string path = (dir / "data.bin").string();
  write_file_atomically(path, "old content");
  try {
    write_file_atomically(path, std::string(3u << 20, 'x'));
    ADD_FAILURE() << "writing 3 MiB did not fail";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_file(path), "old content");
  EXPECT_EQ(count_entries(dir), 1u);
}

TEST(AtomicFile, FullDiskIsAnErrorAndNeverACorruptFile) {
  const fs::path dir = make_temp_dir("atomic_full");
  if (::mount("tmpfs", dir.c_str(), "tmpfs", 0, "size=64k") == 0) {
    expect_failed_write_keeps_old_file(dir);
    EXPECT_EQ(::umount(dir.c_str()), 0);
  } else {
    std::printf("[ info ] tmpfs mount not permitted here; only the file-size-limit case runs\n");
  }
  rlimit saved{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &saved), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = saved;
  small.rlim_cur = 64 * 1024;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  expect_failed_write_keeps_old_file(dir);
  ::setrlimit(RLIMIT_FSIZE, &saved);
  std::signal(SIGXFSZ, old_handler);
  // A device that is always full.
  if (fs::exists("/dev/full")) {
    EXPECT_THROW(write_file_atomically("/dev/full", "x"), Error);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mosyn::io

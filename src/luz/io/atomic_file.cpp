#include "luz/io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "luz/io/error.h"
#include "luz/io/image.h"

namespace luz {

namespace fs = std::filesystem;

namespace {

// The named temporary in flight, for remove_pending_temporary (a signal
// handler may read it at any moment: written only while g_pending is false).
char g_pending_name[4096];
std::atomic<bool> g_pending{false};
std::atomic<unsigned> g_counter{0};

void set_pending(const std::string& name) {
  if (name.size() >= sizeof g_pending_name) return;
  std::memcpy(g_pending_name, name.c_str(), name.size() + 1);
  g_pending.store(true);
}
void clear_pending() { g_pending.store(false); }

std::string directory_of(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

// A short hidden name of its own in `path`'s directory, so that any name the
// directory accepts for the file also fits the temporary.
std::string temporary_name(const std::string& path) {
  return (fs::path(directory_of(path)) /
          (".luz-" + std::to_string(::getpid()) + "-" + std::to_string(g_counter.fetch_add(1)) + ".part" +
           lower_extension(path)))
      .string();
}

}  // namespace

std::string follow_symlinks(const std::string& path) {
  fs::path p = path;
  std::error_code ec;
  for (int depth = 0; depth < 40 && fs::is_symlink(fs::symlink_status(p, ec)); ++depth) {
    const fs::path t = fs::read_symlink(p, ec);
    if (ec) break;
    p = t.is_absolute() ? t : p.parent_path() / t;
  }
  return p.string();
}

AtomicFile::AtomicFile(const std::string& path) : path_(path), target_(follow_symlinks(path)) {
  const std::string dir = directory_of(target_);
  fd_ = ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
  if (fd_ >= 0) {
    unnamed_ = true;
    return;
  }
  // Not every file system has O_TMPFILE; a missing or unwritable directory
  // fails the same way with a named file, with the system's reason.
  temp_ = temporary_name(target_);
  set_pending(temp_);
  fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd_ < 0) {
    const int err = errno;
    temp_.clear();
    clear_pending();
    fail("cannot create a file in '" + dir + "'", err);
  }
}

AtomicFile::~AtomicFile() { discard(); }

void AtomicFile::discard() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (!temp_.empty()) {
    ::unlink(temp_.c_str());
    temp_.clear();
    clear_pending();
  }
}

void AtomicFile::fail(const std::string& what, int err) {
  discard();
  throw InputError(path_, 0, "cannot write: " + what + ": " + std::strerror(err));
}

void AtomicFile::write(const void* data, size_t size) {
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd_, p, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail("write failed", n < 0 ? errno : EIO);
    p += n;
    size -= size_t(n);
  }
}

void AtomicFile::commit() {
  if (::fsync(fd_) != 0) fail("flush failed", errno);
  if (unnamed_) {
    temp_ = temporary_name(target_);
    set_pending(temp_);
    const std::string self = "/proc/self/fd/" + std::to_string(fd_);
    if (::linkat(AT_FDCWD, self.c_str(), AT_FDCWD, temp_.c_str(), AT_SYMLINK_FOLLOW) != 0) {
      const int err = errno;
      temp_.clear();
      clear_pending();
      fail("cannot name the file", err);
    }
  }
  if (::rename(temp_.c_str(), target_.c_str()) != 0) fail("cannot rename into place", errno);
  temp_.clear();
  clear_pending();
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) throw InputError(path_, 0, std::string("cannot write: ") + std::strerror(errno));
  // The rename itself reaches the disk with the directory.
  const int dfd = ::open(directory_of(target_).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

void write_file_atomically(const std::string& path, const void* data, size_t size) {
  AtomicFile f(path);
  f.write(data, size);
  f.commit();
}

void probe_writable(const std::string& path) {
  const std::string target = follow_symlinks(path);
  const std::string dir = directory_of(target);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(path, 0, "the directory '" + dir + "' does not exist");
  if (fs::is_directory(target, ec)) throw InputError(path, 0, "is a directory");
  // The directory must take new files: the output is renamed into it.
  { AtomicFile probe(path); }
  struct stat st;
  if (::stat(target.c_str(), &st) == 0) {
    // Renamed over, so its own permissions do not matter; a device or a pipe
    // would be replaced, not written to.
    if (!S_ISREG(st.st_mode)) throw InputError(path, 0, "is not a regular file");
    return;
  }
  // The name itself (its length, its characters) must suit the file system.
  const int fd = ::open(target.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) throw InputError(path, 0, std::string("cannot be created: ") + std::strerror(errno));
  ::close(fd);
  ::unlink(target.c_str());
}

void remove_pending_temporary() noexcept {
  if (g_pending.load()) ::unlink(g_pending_name);
}

}  // namespace luz

// Files written whole or not at all. The bytes go to an unnamed file
// (Linux's O_TMPFILE) in the destination's directory, are flushed to disk,
// and only then take the final name by a link and a rename: no reader ever
// sees a partial file, and a kill at any moment leaves no temporary behind
// (where the file system lacks O_TMPFILE, a hidden named temporary, removed
// on every error). A destination that is a symbolic link is written through
// to its target, not replaced.
#pragma once

#include <cstddef>
#include <string>

namespace luz {

// A symbolic link's final target (links followed up to 40 deep; a dangling
// link gives the path it names); any other path as it is.
std::string follow_symlinks(const std::string& path);

class AtomicFile {
 public:
  // Throws InputError(path, 0, "cannot write: ...") on every failure.
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();  // without commit(): nothing of the file remains
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(const void* data, size_t size);
  // Flushes to disk and gives the file its name (replacing any file there).
  void commit();

 private:
  [[noreturn]] void fail(const std::string& what, int err);
  void discard();
  std::string path_, target_, temp_;  // temp_: the named temporary, when one exists
  int fd_ = -1;
  bool unnamed_ = false;  // O_TMPFILE
};

void write_file_atomically(const std::string& path, const void* data, size_t size);

// Checks, before any work, that `path` can be written as AtomicFile writes
// it: its directory exists and takes new files, and its name is valid there
// (a probe file is created and removed; an existing file is opened for
// writing, untouched). Throws InputError(path, 0, problem).
void probe_writable(const std::string& path);

// Removes the named temporary that a commit has in flight, if any:
// async-signal-safe, for a signal handler about to _exit.
void remove_pending_temporary() noexcept;

}  // namespace luz

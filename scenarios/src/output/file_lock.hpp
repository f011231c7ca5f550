#pragma once
// A run's claim on the files it writes: a lock on its output and its checkpoint, held while it
// lives, so that a second run is refused instead of cutting and interleaving the first one's
// rows (two resumes of one checkpoint did; so did a run given another live run's --out). The
// lock is an open-file-description lock (fcntl F_OFD_SETLK, Linux 3.15): it belongs to the open
// file, not to the process, so HDF5 closing its own descriptors of the file does not drop it (a
// POSIX record lock would go), it does not meet HDF5's own flock, and two in one process (a
// Python session running twice) exclude each other. Advisory: it keeps out nonholo runs and
// programs that ask (fcntl and lockf), not a plain write.
#include <string>

namespace nonholo::scenarios {

class FileLock {
 public:
  FileLock() = default;
  // Locks the file at `path` for writing. An empty lock (held() false) when there is no regular
  // file there (none, /dev/null, a FIFO: many runs may share one), when it cannot be opened, or
  // when its file system has no such locks: the run goes on unguarded, as before. Throws std::invalid_argument naming the file and what it is to this
  // run (`role`: "output", "checkpoint") when another holds it.
  static FileLock take(const std::string& path, const std::string& role);
  FileLock(FileLock&& other) noexcept;
  FileLock& operator=(FileLock&& other) noexcept;
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  ~FileLock();  // lets go

  bool held() const { return fd_ >= 0; }

 private:
  explicit FileLock(int fd) : fd_(fd) {}
  int fd_ = -1;
};

}  // namespace nonholo::scenarios

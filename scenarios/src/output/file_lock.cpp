// Locks on the files a run writes (file_lock.hpp).
#include "output/file_lock.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <stdexcept>
#include <utility>

namespace nonholo::scenarios {

FileLock FileLock::take(const std::string& path, const std::string& role) {
  // For writing where it can be (a write lock); read-only otherwise, where a read lock still
  // meets a writer's.
  bool writable = true;
  int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0 && (errno == EACCES || errno == EROFS)) {
    writable = false;
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  }
  if (fd < 0) return FileLock();
  struct stat st = {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {  // /dev/null, a FIFO: many runs may share one
    ::close(fd);
    return FileLock();
  }
  struct flock lock = {};
  lock.l_type = writable ? F_WRLCK : F_RDLCK;
  lock.l_whence = SEEK_SET;  // the whole file, however long it grows
  if (::fcntl(fd, F_OFD_SETLK, &lock) == 0) return FileLock(fd);
  const int error = errno;
  ::close(fd);
  if (error == EAGAIN || error == EACCES)
    throw std::invalid_argument("'" + path + "' is in use: another nonholo run is writing it (as its " + role +
                                "; a run resumed from the same checkpoint, or one given the same file, is still "
                                "going), and two runs cannot write one file; wait for that run to end, or give "
                                "another path");
  return FileLock();  // no such locks here (ENOLCK, EINVAL): unguarded
}

FileLock::FileLock(FileLock&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}

FileLock& FileLock::operator=(FileLock&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

FileLock::~FileLock() {
  if (fd_ >= 0) ::close(fd_);
}

}  // namespace nonholo::scenarios

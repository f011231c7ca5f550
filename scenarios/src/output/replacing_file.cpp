// Files written whole or not at all (replacing_file.hpp).
#include "output/replacing_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <system_error>

namespace nonholo::scenarios {
namespace {

// The file a path names, links followed as far as they exist (a new file: its canonical place).
std::string target_of(const std::string& path) {
  std::error_code error;
  const auto resolved = std::filesystem::weakly_canonical(path, error);
  return error ? path : resolved.string();
}

// fsync a file or a directory by path: what a rename makes durable.
void sync_path(const std::string& path, bool directory) {
  const int fd = ::open(path.c_str(), (directory ? O_RDONLY | O_DIRECTORY : O_RDONLY) | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("error writing '" + path + "': cannot open it to flush: " + std::strerror(errno));
  const int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) throw std::runtime_error("error writing '" + path + "': fsync failed: " + std::strerror(errno));
}

}  // namespace

ReplacingFile::ReplacingFile(const std::string& path) : target_(target_of(path)) {
  // What opening the target for writing would have refused, it refuses still (a rename would
  // replace a file one may not write, and fail on a directory only at the end).
  std::error_code error;
  if (std::filesystem::is_directory(target_, error))
    throw std::invalid_argument("cannot open '" + path + "' for writing: it is a directory");
  if (::access(target_.c_str(), F_OK) == 0 && ::access(target_.c_str(), W_OK) != 0)
    throw std::invalid_argument("cannot open '" + path + "' for writing: " + std::strerror(errno));
  const std::filesystem::path target(target_);
  const std::string stem = (target.parent_path() / ("." + target.filename().string() + ".")).string();
  // open(O_CREAT | O_EXCL | O_NOFOLLOW) of a random name, as mkstemp does, but with mode 0666
  // less the umask, as any new output gets (mkstemp makes 0600).
  static const char kLetters[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
  std::random_device random;
  int fd = -1;
  for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    std::string name = stem;
    for (int k = 0; k < 6; ++k) name += kLetters[random() % (sizeof kLetters - 1)];
    fd = ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd >= 0) temporary_ = name;
    else if (errno != EEXIST) break;
  }
  if (fd < 0)
    throw std::invalid_argument("cannot open '" + path + "' for writing: " + std::strerror(errno) +
                                " (it is written beside, in its directory, then renamed over)");
  ::close(fd);
}

ReplacingFile::~ReplacingFile() {
  if (!committed_) ::unlink(temporary_.c_str());
}

void ReplacingFile::commit() {
  sync_path(temporary_, false);  // (a throw leaves the temporary to the destructor)
  if (std::rename(temporary_.c_str(), target_.c_str()) != 0) {
    const int error = errno;
    ::unlink(temporary_.c_str());
    committed_ = true;
    throw std::runtime_error("error writing '" + target_ + "': cannot rename '" + temporary_ +
                             "' over it: " + std::strerror(error));
  }
  committed_ = true;
  const std::string directory = std::filesystem::path(target_).parent_path().string();
  sync_path(directory.empty() ? "." : directory, true);
}

}  // namespace nonholo::scenarios

#pragma once
// A file written whole or not at all: the new contents go to a temporary beside the target (a
// fresh random name opened with O_EXCL | O_NOFOLLOW, so never an existing file nor a planted
// link), which is renamed over the target once complete. Until then the target keeps what it held
// (a batch that died emptied an existing --out; a link planted at ck.h5.tmp made the checkpoint
// overwrite the link's target).
#include <string>

namespace nonholo::scenarios {

class ReplacingFile {
 public:
  // Makes the temporary (mode 0666 less the umask, as any new file) in the directory of
  // `path`'s target: links followed, so a link to a file replaces that file and stays a link.
  // Throws std::invalid_argument naming `path` when it cannot (a directory one cannot write), or
  // when the target is a directory or a file one may not write (as opening it would).
  explicit ReplacingFile(const std::string& path);
  ReplacingFile(const ReplacingFile&) = delete;
  ReplacingFile& operator=(const ReplacingFile&) = delete;
  ~ReplacingFile();  // removes the temporary unless committed

  const std::string& temporary() const { return temporary_; }
  // Flushes the temporary to disk and renames it over the target (then syncs the directory);
  // throws std::runtime_error naming the target on failure (the temporary removed).
  void commit();

 private:
  std::string target_, temporary_;
  bool committed_ = false;
};

}  // namespace nonholo::scenarios

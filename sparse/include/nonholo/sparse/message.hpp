#pragma once
/// @file
/// A fixed-size, printf-formatted message: failure details from the hot path without
/// allocating.
#include <cstdarg>
#include <cstdio>

namespace nonholo::sparse {

/// A message of at most 511 characters (longer ones are cut).
class Message {
 public:
  /// Formats the message as vsnprintf does.
  void vset(const char* format, va_list args) { std::vsnprintf(text_, sizeof text_, format, args); }
  void clear() { text_[0] = '\0'; }  ///< the message becomes ""
  const char* c_str() const { return text_; }  ///< the message, NUL-terminated

 private:
  char text_[512] = "";
};

}  // namespace nonholo::sparse

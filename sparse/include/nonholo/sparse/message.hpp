#pragma once
// A fixed-size, printf-formatted message: failure details from the hot path without
// allocating.
#include <cstdarg>
#include <cstdio>

namespace nonholo::sparse {

class Message {
 public:
  void vset(const char* format, va_list args) { std::vsnprintf(text_, sizeof text_, format, args); }
  void clear() { text_[0] = '\0'; }
  const char* c_str() const { return text_; }

 private:
  char text_[512] = "";
};

}  // namespace nonholo::sparse

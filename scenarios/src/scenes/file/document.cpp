// A scene file's text as a JSON document (document.hpp): its size and nesting checked before
// parsing, then nlohmann's SAX parser into a document that refuses a key given twice.
#include "scenes/file/document.hpp"

#include <nonholo/scenarios/scene_file.hpp>

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace nonholo::scenarios::scene_file {
namespace {

std::string line_and_column(const std::string& text, std::size_t byte) {
  std::size_t line = 1, column = 1;
  for (std::size_t i = 0; i < byte && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

[[noreturn]] void fail_at(const std::string& name, const std::string& text, std::size_t byte, const std::string& what) {
  throw std::invalid_argument(name + ": " + line_and_column(text, byte) + ": " + what);
}

// Refuses nesting deeper than kMaxSceneDepth before anything is built from the text, so
// no recursive operation on the document can exhaust the stack. Brackets count only
// outside strings.
void check_depth(const std::string& text, const std::string& name) {
  int depth = 0;
  bool in_string = false, escaped = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxSceneDepth)
        fail_at(name, text, i, "arrays and objects nested deeper than " + std::to_string(kMaxSceneDepth) +
                                   " levels (a scene file needs 5)");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;  // an unbalanced one is the parser's syntax error
    }
  }
}

// Builds the document as json::parse would, but refuses a key given twice in one object
// (json::parse keeps the last silently), naming the object's path.
class DocumentBuilder : public nlohmann::json_sax<json> {
 public:
  DocumentBuilder(const std::string& name, const std::string& text) : name_(name), text_(text) {}
  json take() { return std::move(root_); }

  bool null() override { return add(json(nullptr)); }
  bool boolean(bool v) override { return add(json(v)); }
  bool number_integer(number_integer_t v) override { return add(json(v)); }
  bool number_unsigned(number_unsigned_t v) override { return add(json(v)); }
  bool number_float(number_float_t v, const string_t&) override { return add(json(v)); }
  bool string(string_t& v) override { return add(json(std::move(v))); }
  bool binary(binary_t& v) override { return add(json::binary(std::move(v))); }
  bool start_object(std::size_t) override { return open(json::object()); }
  bool start_array(std::size_t) override { return open(json::array()); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }
  bool key(string_t& k) override {
    if (frames_.back().node->contains(k)) {
      const std::string where = path();
      throw std::invalid_argument(shown(name_ + ": " + (where.empty() ? "(top level)" : where) + ": duplicate key '" +
                                        k + "' (each key may appear once in an object)"));
    }
    key_ = std::move(k);
    return true;
  }
  bool parse_error(std::size_t byte, const std::string& token, const nlohmann::detail::exception& e) override {
    if (e.id == 406)  // "number overflow parsing '1e999'"; byte is the end of the token
      fail_at(name_, text_, byte >= token.size() ? byte - token.size() : 0,
              "the number " + token + " is not a finite double");
    // e.what() is "[json.exception.parse_error.101] parse error at line L, column C: ..."
    const std::string what = e.what();
    const auto colon = what.find(": ", what.find("parse error"));
    fail_at(name_, text_, byte > 0 ? byte - 1 : 0, colon == std::string::npos ? what : what.substr(colon + 2));
  }

 private:
  struct Frame {
    json* node;
    std::string key;    // its key in the parent object ...
    std::size_t index;  // ... or its index in the parent array
  };
  // Places v in the open array or object (or makes it the root); returns where it went.
  json* place(json&& v) {
    if (frames_.empty()) {
      root_ = std::move(v);
      return &root_;
    }
    json& parent = *frames_.back().node;
    if (parent.is_array()) {
      parent.push_back(std::move(v));
      return &parent.back();
    }
    return &(parent[key_] = std::move(v));
  }
  bool add(json&& v) {
    place(std::move(v));
    return true;
  }
  bool open(json&& v) {
    const bool in_array = !frames_.empty() && frames_.back().node->is_array();
    const std::size_t index = in_array ? frames_.back().node->size() : 0;
    std::string key = frames_.empty() || in_array ? std::string() : key_;
    frames_.push_back({place(std::move(v)), std::move(key), index});
    return true;
  }
  bool close() {
    frames_.pop_back();
    return true;
  }
  // The path of the innermost open object, as the Reader spells it: bodies[2].position.
  std::string path() const {
    std::string out;
    for (std::size_t i = 1; i < frames_.size(); ++i) {
      if (frames_[i - 1].node->is_array()) out += "[" + std::to_string(frames_[i].index) + "]";
      else out += (out.empty() ? "" : ".") + frames_[i].key;
    }
    return out;
  }

  const std::string& name_;
  const std::string& text_;
  json root_;
  std::vector<Frame> frames_;
  std::string key_;
};

}  // namespace

std::string read_file(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw std::invalid_argument(path + ": cannot be read: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) {
    const char* kind = S_ISDIR(st.st_mode)    ? "a directory"
                       : S_ISCHR(st.st_mode)  ? "a character device"
                       : S_ISBLK(st.st_mode)  ? "a block device"
                       : S_ISFIFO(st.st_mode) ? "a FIFO (named pipe)"
                       : S_ISSOCK(st.st_mode) ? "a socket"
                                              : "not a regular file";
    throw std::invalid_argument(path + ": is " + std::string(kind) + "; a scene file must be a regular file");
  }
  const auto too_large = [&](const std::string& size) {
    throw std::invalid_argument(path + ": is " + size + "; a scene file may be at most " +
                                std::to_string(kMaxSceneFileBytes) + " bytes (" +
                                std::to_string(kMaxSceneFileBytes >> 20) + " MiB)");
  };
  if (static_cast<unsigned long long>(st.st_size) > kMaxSceneFileBytes) too_large(std::to_string(st.st_size) + " bytes");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(path + ": cannot be read: " + std::strerror(errno));
  std::string text;
  text.reserve(static_cast<std::size_t>(st.st_size));
  char chunk[1 << 16];
  while (in.read(chunk, sizeof chunk) || in.gcount() > 0) {
    text.append(chunk, static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxSceneFileBytes) too_large("over " + std::to_string(kMaxSceneFileBytes) + " bytes (it grew while being read)");
  }
  if (in.bad()) throw std::invalid_argument(path + ": cannot be read: " + std::strerror(errno));
  return text;
}

json parse_document(const std::string& text, const std::string& path) {
  if (text.size() > kMaxSceneFileBytes)
    throw std::invalid_argument(path + ": the text is " + std::to_string(text.size()) + " bytes; a scene file may be at most " +
                                std::to_string(kMaxSceneFileBytes) + " bytes");
  // nlohmann's lexer takes a NUL byte for the end of the input: what follows it was ignored.
  if (const auto nul = text.find('\0'); nul != std::string::npos) {
    const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(nul), '\n');
    throw std::invalid_argument(path + ": line " + std::to_string(line) + " has a NUL byte (byte " +
                                std::to_string(nul + 1) + " of " + std::to_string(text.size()) +
                                "): a scene file is UTF-8 text, and the parser would have stopped there, ignoring "
                                "the rest; remove it (a file saved in UTF-16, or a binary file, has them)");
  }
  check_depth(text, path);
  DocumentBuilder builder(path, text);
  json::sax_parse(text, &builder);  // throws std::invalid_argument on any error
  return builder.take();
}

}  // namespace nonholo::scenarios::scene_file

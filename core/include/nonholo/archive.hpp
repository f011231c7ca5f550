#pragma once
/// @file
/// Bytes for checkpoints (and a batch's rows between MPI ranks): the exact values of a state
/// (every double bit for bit), written in one order and read back in the same. Not a file format
/// by itself: a checkpoint file wraps the bytes with what they belong to (the library's format
/// version, the scene, the options) and checks that before reading (scenarios/checkpoint).
/// Native byte order; a checkpoint is for the machine kind that wrote it.
#include <nonholo/state.hpp>

#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

namespace nonholo {

/// Writes values as bytes, appended in call order; InArchive reads them back.
class OutArchive {
 public:
  /// Appends x: numbers as their bytes (a bool as an int), texts and vectors as their size
  /// (a long) and then their contents, an enumeration as a long.
  ///@{
  void operator()(double x) { raw(&x, sizeof x); }
  void operator()(long x) { raw(&x, sizeof x); }
  void operator()(int x) { raw(&x, sizeof x); }
  void operator()(bool x) { (*this)(static_cast<int>(x)); }
  void operator()(const std::string& s);
  void operator()(ConstVecRef v);
  void operator()(const std::vector<double>& v);
  void operator()(const std::vector<std::string>& v);
  template <class E, std::enable_if_t<std::is_enum_v<E>, int> = 0>
  void operator()(E x) {
    (*this)(static_cast<long>(x));
  }
  ///@}
  /// A vector of n zeros, as operator()(ConstVecRef) writes one.
  void zeros(Eigen::Index n);
  /// A label, read back and compared: a reader out of step fails at the first label it meets.
  void tag(const char* label) { (*this)(std::string(label)); }

  const std::string& bytes() const { return bytes_; }  ///< everything written so far

 private:
  void raw(const void* p, std::size_t n) {
    if (n > 0) bytes_.append(static_cast<const char*>(p), n);  // (an empty vector's data() may be null)
  }
  std::string bytes_;
};

/// Reads back, in the same order, what an OutArchive wrote.
/// Throws std::runtime_error naming what was being read when the bytes end early, a size
/// differs from the one expected, or a label does not match; the message starts with `context`.
class InArchive {
 public:
  /// Reads `bytes`, which must outlive the archive (it keeps a reference).
  explicit InArchive(const std::string& bytes, const char* context = "checkpoint") : bytes_(bytes), context_(context) {}
  /// Reads the next value into x, as OutArchive wrote it.
  ///@{
  void operator()(double& x) { raw(&x, sizeof x, "a number"); }
  void operator()(long& x) { raw(&x, sizeof x, "an integer"); }
  void operator()(int& x) { raw(&x, sizeof x, "an integer"); }
  void operator()(bool& x);
  void operator()(std::string& s);
  void operator()(std::vector<double>& v);  ///< resized to the stored size
  void operator()(std::vector<std::string>& v);
  template <class E, std::enable_if_t<std::is_enum_v<E>, int> = 0>
  void operator()(E& x) {
    long stored = 0;
    (*this)(stored);
    x = static_cast<E>(stored);
  }
  ///@}
  /// Into a vector of the size it already has (sized by the model): a different size is refused.
  void operator()(VecRef v);
  /// Into a vector of any size (resized to the stored one).
  void resize_into(Vector& v);
  /// Reads a label written by OutArchive::tag and throws unless it is `label`.
  void tag(const char* label);
  bool done() const { return at_ == bytes_.size(); }  ///< whether every byte has been read

 private:
  void raw(void* p, std::size_t n, const char* what);
  long count(const char* what, std::size_t each);  // a stored size that fits in what is left
  [[noreturn]] void fail(const std::string& why) const;
  const std::string& bytes_;
  const char* context_;
  std::size_t at_ = 0;
};

/// Every field of a State (its vectors must already have the model's sizes when loading).
///@{
void save(OutArchive& a, const State& s);
void load(InArchive& a, State& s);
///@}

}  // namespace nonholo

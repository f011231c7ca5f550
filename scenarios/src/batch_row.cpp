#include "batch_row.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace nonholo::scenarios {
namespace {

// A field added to RunSummary must be added to fields() below, or MPI batches would lose it:
// this fails to compile until then (the size on x86-64 Linux, libstdc++).
static_assert(sizeof(void*) != 8 || sizeof(RunSummary) == 528,
              "RunSummary changed: add the new field to fields() in batch_row.cpp, then update this size");

class Writer {
 public:
  template <class T>
  void operator()(const T& x) {
    static_assert(std::is_arithmetic_v<T> || std::is_enum_v<T>);
    bytes.append(reinterpret_cast<const char*>(&x), sizeof x);
  }
  void operator()(const std::string& s) {
    (*this)(static_cast<std::uint64_t>(s.size()));
    bytes += s;
  }
  template <class T>
  void operator()(const std::vector<T>& v) {
    (*this)(static_cast<std::uint64_t>(v.size()));
    for (const T& x : v) (*this)(x);
  }
  std::string bytes;
};

class Reader {
 public:
  explicit Reader(const std::string& b) : bytes(b) {}
  template <class T>
  void operator()(T& x) {
    static_assert(std::is_arithmetic_v<T> || std::is_enum_v<T>);
    std::memcpy(&x, take(sizeof x), sizeof x);
  }
  void operator()(std::string& s) {
    const std::size_t n = size();
    s.assign(take(n), n);
  }
  template <class T>
  void operator()(std::vector<T>& v) {
    v.resize(size());
    for (T& x : v) (*this)(x);
  }
  bool done() const { return at == bytes.size(); }

 private:
  std::size_t size() {
    std::uint64_t n = 0;
    (*this)(n);
    if (n > bytes.size()) throw std::logic_error("batch row: corrupt bytes");
    return static_cast<std::size_t>(n);
  }
  const char* take(std::size_t n) {
    if (bytes.size() - at < n) throw std::logic_error("batch row: truncated bytes");
    const char* p = bytes.data() + at;
    at += n;
    return p;
  }
  const std::string& bytes;
  std::size_t at = 0;
};

// Every field of RunSummary, in one order for both directions.
template <class Archive, class Summary>
void fields(Archive& a, Summary& s) {
  a(s.scene), a(s.method), a(s.backend), a(s.hitch), a(s.restart), a(s.order), a(s.composition), a(s.bodies);
  a(s.status), a(s.message), a(s.steps), a(s.dt), a(s.t_final), a(s.wall_s), a(s.ns_per_step);
  a(s.ns_per_body_step), a(s.energy_rel_err_max), a(s.energy_post_rel_err_max), a(s.residual_max), a(s.gap_max);
  a(s.residual_rel_max);
  a(s.restarts), a(s.parasitic_max), a(s.has_work), a(s.work), a(s.energy_balance_err_max), a(s.warning);
  a(s.rhs_evaluations), a(s.factorizations), a(s.error_estimate), a(s.extent), a(s.accuracy), a(s.stability_ratio);
  a(s.tol), a(s.adaptive_steps), a(s.rejected);
  a(s.has_momentum), a(s.has_error_estimate);
  a(s.momentum_drift_max), a(s.rotation), a(s.legendre_iterations_max);
}

}  // namespace

std::string pack_row(const Row& row, bool whole_state) {
  Writer w;
  fields(w, row.summary);
  w(row.values);
  const auto shown = whole_state ? row.final_q.size() : std::min<Eigen::Index>(3, row.final_q.size());
  w(std::vector<double>(row.final_q.data(), row.final_q.data() + shown));
  w(row.names);
  w(row.error);
  w(whole_state);
  if (whole_state) {
    w(std::vector<double>(row.final_p.data(), row.final_p.data() + row.final_p.size()));
    w(row.coordinates);
    w(row.velocities);
  }
  return std::move(w.bytes);
}

std::string pack_summary(const RunSummary& summary) {
  Writer w;
  fields(w, summary);
  return std::move(w.bytes);
}

RunSummary unpack_summary(const std::string& bytes) {
  Reader r(bytes);
  RunSummary s;
  fields(r, s);
  if (!r.done()) throw std::logic_error("run summary: trailing bytes");
  return s;
}

Row unpack_row(const std::string& bytes) {
  Reader r(bytes);
  Row row;
  fields(r, row.summary);
  r(row.values);
  std::vector<double> q;
  r(q);
  row.final_q = Eigen::Map<const Vector>(q.data(), static_cast<Eigen::Index>(q.size()));
  r(row.names);
  r(row.error);
  bool whole_state = false;
  r(whole_state);
  if (whole_state) {
    std::vector<double> p;
    r(p);
    row.final_p = Eigen::Map<const Vector>(p.data(), static_cast<Eigen::Index>(p.size()));
    r(row.coordinates);
    r(row.velocities);
  }
  if (!r.done()) throw std::logic_error("batch row: trailing bytes");
  return row;
}

}  // namespace nonholo::scenarios

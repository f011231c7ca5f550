// The bytes of checkpoints (archive.hpp): raw values in one order, sizes and labels checked on
// the way back.
#include <nonholo/archive.hpp>

#include <cstring>
#include <stdexcept>

namespace nonholo {

void OutArchive::operator()(const std::string& s) {
  (*this)(static_cast<long>(s.size()));
  bytes_ += s;
}

void OutArchive::operator()(ConstVecRef v) {
  (*this)(static_cast<long>(v.size()));
  raw(v.data(), sizeof(double) * static_cast<std::size_t>(v.size()));
}

void OutArchive::zeros(Eigen::Index n) {
  (*this)(static_cast<long>(n));
  bytes_.append(sizeof(double) * static_cast<std::size_t>(n), '\0');  // +0.0 is all zero bits
}

void OutArchive::operator()(const std::vector<double>& v) {
  (*this)(Eigen::Map<const Vector>(v.data(), static_cast<Eigen::Index>(v.size())));
}

void OutArchive::operator()(const std::vector<std::string>& v) {
  (*this)(static_cast<long>(v.size()));
  for (const std::string& s : v) (*this)(s);
}

void InArchive::fail(const std::string& why) const { throw std::runtime_error(std::string(context_) + ": " + why); }

void InArchive::raw(void* p, std::size_t n, const char* what) {
  if (bytes_.size() - at_ < n)
    fail(std::string("the bytes end early (reading ") + what + " at byte " + std::to_string(at_) + " of " +
         std::to_string(bytes_.size()) + ")");
  if (n > 0) std::memcpy(p, bytes_.data() + at_, n);  // (an empty vector's data() may be null)
  at_ += n;
}

long InArchive::count(const char* what, std::size_t each) {
  long n = 0;
  (*this)(n);
  if (n < 0 || static_cast<std::size_t>(n) > (bytes_.size() - at_) / each)
    fail(std::string("a ") + what + " of " + std::to_string(n) + " entries does not fit in what is left");
  return n;
}

void InArchive::operator()(bool& x) {
  int i = 0;
  (*this)(i);
  x = i != 0;
}

void InArchive::operator()(std::string& s) {
  const long n = count("text", 1);
  s.assign(bytes_.data() + at_, static_cast<std::size_t>(n));
  at_ += static_cast<std::size_t>(n);
}

void InArchive::operator()(VecRef v) {
  long n = 0;
  (*this)(n);
  if (n != v.size())
    fail("a vector of " + std::to_string(n) + " entries where the model has " + std::to_string(v.size()));
  raw(v.data(), sizeof(double) * static_cast<std::size_t>(n), "a vector");
}

void InArchive::resize_into(Vector& v) {
  v.resize(count("vector", sizeof(double)));
  raw(v.data(), sizeof(double) * static_cast<std::size_t>(v.size()), "a vector");
}

void InArchive::operator()(std::vector<double>& v) {
  v.resize(static_cast<std::size_t>(count("vector", sizeof(double))));
  raw(v.data(), sizeof(double) * v.size(), "a vector");
}

void InArchive::operator()(std::vector<std::string>& v) {
  v.resize(static_cast<std::size_t>(count("list of texts", sizeof(long))));
  for (std::string& s : v) (*this)(s);
}

void InArchive::tag(const char* label) {
  std::string found;
  (*this)(found);
  if (found != label) fail(std::string("expected the part '") + label + "', found '" + found + "'");
}

namespace {
// Every field of a State, in one order for both directions (S: State or const State);
// `multipliers` reads or writes lambda and force.
template <class Archive, class S, class Multipliers>
void state_fields(Archive& a, S& s, Multipliers multipliers) {
  a.tag("state");
  a(s.t), a(s.grid.t0), a(s.grid.h), a(s.grid.k);
  a(s.q), a(s.p);
  multipliers();
  a(s.steps), a(s.restarts);
  a(s.watch.next_step), a(s.watch.last_step), a(s.watch.last_amplitude), a(s.watch.floor);
  a(s.target_energy);
}
// A field added to State must be added above: this fails to compile until then (x86-64 sizes).
static_assert(sizeof(void*) != 8 || sizeof(State) == 152, "State changed: add the new field to state_fields()");
}  // namespace

void save(OutArchive& a, const State& s) {
  state_fields(a, s, [&] { a(s.lambda), a(s.force); });
}
void load(InArchive& a, State& s) {
  state_fields(a, s, [&] { a(s.lambda), a(s.force); });
}

}  // namespace nonholo

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

void InArchive::raw(void* p, std::size_t n, const char* what) {
  if (bytes_.size() - at_ < n)
    throw std::runtime_error(std::string("checkpoint: the bytes end early (reading ") + what + " at byte " +
                             std::to_string(at_) + " of " + std::to_string(bytes_.size()) + ")");
  if (n > 0) std::memcpy(p, bytes_.data() + at_, n);  // (an empty vector's data() may be null)
  at_ += n;
}

void InArchive::operator()(bool& x) {
  int i = 0;
  (*this)(i);
  x = i != 0;
}

void InArchive::operator()(std::string& s) {
  long n = 0;
  (*this)(n);
  if (n < 0 || static_cast<std::size_t>(n) > bytes_.size() - at_)
    throw std::runtime_error("checkpoint: a text of " + std::to_string(n) + " bytes does not fit in what is left");
  s.assign(bytes_.data() + at_, static_cast<std::size_t>(n));
  at_ += static_cast<std::size_t>(n);
}

void InArchive::operator()(VecRef v) {
  long n = 0;
  (*this)(n);
  if (n != v.size())
    throw std::runtime_error("checkpoint: a vector of " + std::to_string(n) + " entries where the model has " +
                             std::to_string(v.size()));
  raw(v.data(), sizeof(double) * static_cast<std::size_t>(n), "a vector");
}

void InArchive::resize_into(Vector& v) {
  long n = 0;
  (*this)(n);
  if (n < 0 || static_cast<std::size_t>(n) > (bytes_.size() - at_) / sizeof(double))
    throw std::runtime_error("checkpoint: a vector of " + std::to_string(n) + " entries does not fit in what is left");
  v.resize(n);
  raw(v.data(), sizeof(double) * static_cast<std::size_t>(n), "a vector");
}

void InArchive::tag(const char* label) {
  std::string found;
  (*this)(found);
  if (found != label)
    throw std::runtime_error(std::string("checkpoint: expected the part '") + label + "', found '" + found + "'");
}

namespace {
// Every field of a State, in one order for both directions (S: State or const State).
template <class Archive, class S>
void state_fields(Archive& a, S& s) {
  a.tag("state");
  a(s.t), a(s.grid.t0), a(s.grid.h), a(s.grid.k);
  a(s.q), a(s.p), a(s.lambda), a(s.force);
  a(s.steps), a(s.restarts);
  a(s.watch.next_step), a(s.watch.last_step), a(s.watch.last_amplitude), a(s.watch.floor);
  a(s.target_energy);
}
// A field added to State must be added above: this fails to compile until then (x86-64 sizes).
static_assert(sizeof(void*) != 8 || sizeof(State) == 152, "State changed: add the new field to state_fields()");
}  // namespace

void save(OutArchive& a, const State& s) { state_fields(a, s); }
void load(InArchive& a, State& s) { state_fields(a, s); }

}  // namespace nonholo

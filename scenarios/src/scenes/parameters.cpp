// Named scene parameters (parameters.hpp): NAME=VALUE assignments, their range checks, and parse_number.
#include <nonholo/scenarios/parameters.hpp>

#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace nonholo::scenarios {

Parameters::Parameters(std::string scene, std::vector<ParameterSpec> specs)
    : scene_(std::move(scene)), specs_(std::move(specs)) {
  for (const auto& s : specs_) values_.push_back(s.default_value);
}

int Parameters::index_of(const std::string& name) const {
  for (std::size_t i = 0; i < specs_.size(); ++i)
    if (specs_[i].name == name) return static_cast<int>(i);
  return -1;
}

void Parameters::set(const std::string& name, double value) {
  const int i = index_of(name);
  if (i < 0) {
    std::ostringstream os;
    os << "unknown parameter '" << name << "' for scene '" << scene_ << "' (parameters:";
    for (std::size_t k = 0; k < specs_.size(); ++k) os << (k ? ", " : " ") << specs_[k].name;
    os << ")";
    throw std::invalid_argument(os.str());
  }
  if (!std::isfinite(value)) {
    std::ostringstream os;
    os << "parameter " << name << " = " << value << " is not finite";
    throw std::invalid_argument(os.str());
  }
  values_[i] = value;
}

void Parameters::assign(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw std::invalid_argument("--set '" + assignment + "': expected NAME=VALUE");
  const std::string name = assignment.substr(0, eq);
  const std::string text = assignment.substr(eq + 1);
  if (index_of(name) < 0) set(name, 0.0);  // throws the unknown-parameter message
  set(name, parse_number(text, "--set " + assignment));
}

double Parameters::operator[](const std::string& name) const {
  const int i = index_of(name);
  if (i < 0) throw std::logic_error("scene '" + scene_ + "' reads undeclared parameter '" + name + "'");
  return values_[i];
}

long Parameters::whole(const std::string& name, long lo, long hi) const {
  const double v = (*this)[name];
  if (v == std::floor(v) && v >= static_cast<double>(lo) && v <= static_cast<double>(hi))
    return static_cast<long>(v);
  std::ostringstream os;
  os << scene_ << ": parameter " << name << " = " << v << " must be a whole number from " << lo
     << " to " << hi;
  throw std::invalid_argument(os.str());
}

double Parameters::within(const std::string& name, double lo, double hi) const {
  const double v = (*this)[name];
  if (v >= lo && v <= hi) return v;
  std::ostringstream os;
  os << scene_ << ": parameter " << name << " = " << v << " must lie in [" << lo << ", " << hi << "]";
  throw std::invalid_argument(os.str());
}

double Parameters::positive(const std::string& name, bool allow_zero) const {
  const double v = (*this)[name];
  if (v > 0.0 || (allow_zero && v == 0.0)) return v;
  std::ostringstream os;
  os << scene_ << ": parameter " << name << " = " << v << " must be "
     << (allow_zero ? "non-negative" : "positive");
  throw std::invalid_argument(os.str());
}

double parse_number(const std::string& text, const std::string& context) {
  double value = 0.0;
  const char* first = text.data();
  const char* last = first + text.size();
  if (!text.empty() && *first == '+') ++first;  // from_chars rejects a leading '+'
  const auto [ptr, ec] = std::from_chars(first, last, value);
  if (text.empty() || ec == std::errc::invalid_argument || ptr != last)
    throw std::invalid_argument(context + ": '" + text + "' is not a number");
  if (ec == std::errc::result_out_of_range)
    throw std::invalid_argument(context + ": '" + text + "' is out of the range of a double");
  if (!std::isfinite(value))
    throw std::invalid_argument(context + ": '" + text + "' is not finite");
  return value;
}

}  // namespace nonholo::scenarios

// A run's stop conditions (stop_watch.hpp): the built-in ones parsed, each checked when due, and
// the first time it held found by bisection on the interpolant between its last two checks.
#include "run/stop_watch.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace nonholo::scenarios {
namespace {

std::string without_spaces(const std::string& text) {
  std::string out;
  for (const char c : text)
    if (!std::isspace(static_cast<unsigned char>(c))) out += c;
  return out;
}

std::string one_word(const std::string& name) {
  std::string out = name;
  for (char& c : out)
    if (std::isspace(static_cast<unsigned char>(c))) c = '_';
  return out;
}

[[noreturn]] void refuse(const std::string& text, const std::string& why) {
  throw std::invalid_argument("--stop-when '" + text + "': " + why);
}

// The first few coordinate names, for a message.
std::string some_names(const Model& model) {
  std::ostringstream os;
  const int n = model.num_configuration(), shown = std::min(n, 6);
  for (int i = 0; i < shown; ++i) os << (i ? ", " : "") << model.coordinate_name(i);
  if (n > shown) os << ", ... (" << n << " in all)";
  return os.str();
}

// The entries of theta in q of consecutive planar bodies (a chain's hitch angles).
std::vector<std::pair<int, int>> consecutive_headings(const Model& model) {
  std::vector<std::pair<int, int>> pairs;
  for (int b = 0; b + 1 < model.num_bodies(); ++b)
    if (model.body(b).kind == BodyKind::Planar && model.body(b + 1).kind == BodyKind::Planar)
      pairs.emplace_back(model.body(b).q_offset + 2, model.body(b + 1).q_offset + 2);
  return pairs;
}

}  // namespace

StopCondition built_in_stop_condition(const Model& model, const std::string& text) {
  const std::string t = without_spaces(text);
  const auto op = t.find_first_of("<>");
  if (op == std::string::npos || op == 0 || op + 1 == t.size())
    refuse(text, "give NAME>VALUE or NAME<VALUE: a coordinate, hitch-angle or gap, and a number");
  const std::string name = t.substr(0, op), number = t.substr(op + 1);
  const bool above = t[op] == '>';
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(number.c_str(), &end);
  if (end != number.c_str() + number.size() || errno == ERANGE || !std::isfinite(value))
    refuse(text, "'" + number + "' is not a finite number");
  StopCondition c;
  c.name = t;
  if (name == "hitch-angle" || name == "gap") {
    if (!above) refuse(text, name + " stops a run when it grows beyond a bound: give " + name + ">VALUE");
    if (!(value >= 0.0)) refuse(text, name + " is at least 0: give a bound of 0 or more");
  }
  if (name == "hitch-angle") {
    auto pairs = consecutive_headings(model);
    if (pairs.empty()) refuse(text, "hitch-angle needs two consecutive planar bodies; this model has none");
    c.holds = [pairs = std::move(pairs), value](double, ConstVecRef q) {
      double largest = 0.0;
      for (const auto& [a, b] : pairs) largest = std::max(largest, std::abs(std::remainder(q[a] - q[b], 2.0 * M_PI)));
      return largest > value;
    };
  } else if (name == "gap") {
    if (model.num_holonomic() == 0) refuse(text, "gap needs holonomic constraints (hitches); this model has none");
    auto g = std::make_shared<Vector>(Vector::Zero(model.num_holonomic()));  // sized once, shared by copies
    c.holds = [&model, g, value](double, ConstVecRef q) {
      model.gap(q, *g);
      return g->lpNorm<Eigen::Infinity>() > value;
    };
  } else {
    int index = -1;
    for (int i = 0; i < model.num_configuration() && index < 0; ++i)
      if (model.coordinate_name(i) == name) index = i;
    if (index < 0)
      refuse(text, "no coordinate '" + name + "' in the model (its coordinates: " + some_names(model) +
                       "; or hitch-angle, gap)");
    c.holds = [index, value, above](double, ConstVecRef q) { return above ? q[index] > value : q[index] < value; };
  }
  return c;
}

StopWatch::StopWatch(const Model& model, const RunConfig& config)
    : hermite_(model.num_configuration() == model.num_velocities()) {
  for (const std::string& text : config.stop_when) conditions_.push_back(built_in_stop_condition(model, text));
  for (std::size_t i = 0; i < config.stop_conditions.size(); ++i) {
    StopCondition c = config.stop_conditions[i];
    c.name = c.name.empty() ? "condition-" + std::to_string(i) : one_word(c.name);
    if (!c.holds) throw std::invalid_argument("stop condition " + c.name + ": it has no function");
    if (c.every < 1)
      throw std::invalid_argument("stop condition " + c.name + ": every = " + std::to_string(c.every) +
                                  " must be at least 1");
    conditions_.push_back(std::move(c));
  }
  for (const StopCondition& c : conditions_) {
    auto same = [&c](const Checked& g) { return g.every == c.every; };
    const auto it = std::find_if(checked_.begin(), checked_.end(), same);
    group_.push_back(static_cast<int>(it - checked_.begin()));
    if (it == checked_.end()) checked_.push_back({c.every, std::numeric_limits<double>::quiet_NaN(), {}, {}});
  }
  if (!conditions_.empty()) between_.resize(model.num_configuration());
}

bool StopWatch::holds(const StopCondition& c, double t, ConstVecRef q) {
  try {
    return c.holds(t, q);
  } catch (const std::exception& e) {
    failure_ = "the stop condition " + c.name + " failed at t = " + std::to_string(t) + ": " + e.what();
  } catch (...) {
    failure_ = "the stop condition " + c.name + " failed at t = " + std::to_string(t) + ": an unknown exception";
  }
  return false;
}

void StopWatch::remember(Checked& c, double t, ConstVecRef q, ConstVecRef v) {
  c.t = t;
  c.q = q;  // sized at the first check, then copied into
  c.v = v;
}

bool StopWatch::check_start(double t, ConstVecRef q, ConstVecRef v) {
  for (const StopCondition& c : conditions_) {
    if (holds(c, t, q)) {
      fired_ = c.name;
      t_stop_ = t;
      return true;
    }
    if (!failure_.empty()) return true;
  }
  for (Checked& g : checked_) remember(g, t, q, v);
  return false;
}

bool StopWatch::check(long k, bool last, double t, ConstVecRef q, ConstVecRef v) {
  auto due = [k, last](const Checked& g) { return last || k % g.every == 0; };
  // Of several that hold, the one that held first.
  for (std::size_t i = 0; i < conditions_.size(); ++i) {
    const Checked& left = checked_[static_cast<std::size_t>(group_[i])];
    if (!due(left)) continue;
    const StopCondition& c = conditions_[i];
    if (holds(c, t, q)) {
      const double when = first_time(c, left, t, q, v);
      if (!failure_.empty()) return true;
      if (fired_.empty() || when < t_stop_) {
        fired_ = c.name;
        t_stop_ = when;
      }
    }
    if (!failure_.empty()) return true;
  }
  if (!fired_.empty()) return true;
  for (Checked& g : checked_)
    if (due(g)) remember(g, t, q, v);
  return false;
}

// Bisection between the last check (where it did not hold) and now (where it holds) on q(s),
// s = (tau - t0) / h: cubic Hermite, (1+2s)(1-s)^2 q0 + s(1-s)^2 h v0 + s^2(3-2s) q1 + s^2(s-1) h v1
// (exact for a motion at most cubic in time, a uniform one among them), or linear in q.
double StopWatch::first_time(const StopCondition& c, const Checked& left, double t, ConstVecRef q, ConstVecRef v) {
  if (std::isnan(left.t) || left.q.size() != q.size()) return t;
  const double t0 = left.t, h = t - t0;
  double lo = t0, hi = t;
  for (int iteration = 0; iteration < 200; ++iteration) {
    const double mid = lo + 0.5 * (hi - lo);
    if (!(mid > lo && mid < hi)) break;  // the interval is down to adjacent doubles
    const double s = (mid - t0) / h;
    if (hermite_) {
      const double r = 1.0 - s;
      between_ = (1.0 + 2.0 * s) * r * r * left.q + s * r * r * h * left.v + s * s * (3.0 - 2.0 * s) * q +
                 s * s * (s - 1.0) * h * v;
    } else {
      between_ = (1.0 - s) * left.q + s * q;
    }
    if (holds(c, mid, between_))
      hi = mid;
    else if (!failure_.empty())
      return hi;
    else
      lo = mid;
  }
  return hi;
}

void StopWatch::save(OutArchive& a) const {
  a.tag("stop-watch");
  a(static_cast<long>(checked_.size()));
  for (const Checked& g : checked_) a(g.every), a(g.t), a(g.q), a(g.v);
}

void StopWatch::load(InArchive& a) {
  a.tag("stop-watch");
  long groups = 0;
  a(groups);
  if (groups != static_cast<long>(checked_.size()))
    throw std::runtime_error("checkpoint: saved with " + std::to_string(groups) +
                             " kinds of stop condition check (by how often they are checked), this run has " +
                             std::to_string(checked_.size()) + ": give the conditions the run was given");
  for (Checked& g : checked_) {
    long every = 0;
    a(every), a(g.t);
    a.resize_into(g.q);
    a.resize_into(g.v);
    if (every != g.every)
      throw std::runtime_error("checkpoint: a stop condition checked every " + std::to_string(every) +
                               " steps where this run's is every " + std::to_string(g.every));
  }
}

}  // namespace nonholo::scenarios

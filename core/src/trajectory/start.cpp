// Consistent initial states (start.hpp): from a velocity projected onto D(q0), or from two points (q0, q1),
// after checking the inputs and that the model's callbacks fill their outputs.
#include <nonholo/start.hpp>

#include <nonholo/dynamics.hpp>
#include <nonholo/sparse/big_buffer.hpp>

#include "model/element_set.hpp"
#include "step/dynamics_internal.hpp"
#include "step/rigid/drift.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <sstream>
#include <stdexcept>

namespace nonholo {
namespace {

// A configuration (n_q entries, `configuration`) or a velocity (n_v): its size and finiteness.
void check_vector(const char* what, ConstVecRef v, const Model& model, bool configuration) {
  const int n = configuration ? model.num_configuration() : model.num_velocities();
  if (v.size() != n) {
    std::ostringstream os;
    os << "start: expected " << n << " entries in " << what << " (one per "
       << (model.has_rigid_bodies() ? (configuration ? "configuration entry" : "velocity entry") : "coordinate")
       << "), got " << v.size();
    throw std::invalid_argument(os.str());
  }
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) {
      std::ostringstream os;
      os << "start: " << what << "[" << i << "] (" << (configuration ? model.coordinate_name(i) : model.velocity_name(i))
         << ") is " << v[i];
      throw std::invalid_argument(os.str());
    }
}

// Each rigid body's quaternion in q divided by its norm, in place: refused unless its norm is
// within 1e-6 of 1 (a rotation given by mistake, or not at all, is not silently made one).
void normalise_quaternions(const char* what, VecRef q, const Model& model) {
  for (const RigidBlock& r : model.rigid_bodies()) {
    const double norm = q.segment<4>(r.q).norm();
    if (!(std::abs(norm - 1.0) <= 1e-6)) {
      auto name = [&](int k) { return model.coordinate_name(r.q + k); };
      std::ostringstream os;
      os.precision(17);
      os << "start: " << what << ": the quaternion of rigid body " << r.body << " (" << name(0) << ", " << name(1)
         << ", " << name(2) << ", " << name(3) << ") has norm " << norm
         << "; give a unit quaternion (w, x, y, z), for example axis_angle_quaternion(axis, angle)";
      throw std::invalid_argument(os.str());
    }
    q.segment<4>(r.q) /= norm;
  }
}

// The same into a copy.
Vector unit_quaternions(const char* what, ConstVecRef q, const Model& model) {
  Vector out = q;
  normalise_quaternions(what, out, model);
  return out;
}

void check(Status status, const Workspace& ws, const char* doing) {
  if (status == Status::Ok) return;
  throw std::invalid_argument(std::string("start: ") + doing + ": " + to_string(status) + ": " + ws.message());
}

State allocate_state(const Model& model, double t0, ConstVecRef q0) {
  State s;
  s.t = t0;
  s.q.resize(q0.size());  // written whole below: no zero fill
  sparse::advise_huge_pages(s.q.data(), sizeof(double) * static_cast<std::size_t>(q0.size()));
  s.q = q0;
  sparse::zero_buffer(s.p, model.num_velocities());
  sparse::zero_buffer(s.force, model.num_velocities());
  sparse::zero_buffer(s.lambda, model.num_one_forms());
  return s;
}

void check_time(double t0) {
  if (!std::isfinite(t0)) {
    std::ostringstream os;
    os << "start: initial time t0 = " << t0 << " is not finite";
    throw std::invalid_argument(os.str());
  }
}

// A workspace scratch vector of this size, or (if the workspace has none that size) `local`
// resized: the checks below reuse the workspace's buffers instead of allocating their own
// (a million-body chain would otherwise allocate and touch some 150 MB more at its start).
Vector& sized_buffer(Vector& buffer, Vector& local, Eigen::Index size) {
  if (buffer.size() == size) return buffer;
  local.resize(size);
  return local;
}

// The symmetry generators at q0 (check_callbacks_fill): each fills its entries (a local one:
// its body's, leaving the others zero), J(q0, xi) = |xi|^2 where J is given, and xi in D(q0)
// (mu(q0) in ws.mu_values).
template <class Complain>
void check_generators(const Model& model, const Workspace& ws, ConstVecRef q0, Complain&& complain) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const int n = model.num_velocities();
  auto names = [&model](int i) { return std::string(model.velocity_name(i)); };
  const bool rows = model.num_one_forms() > 0;
  const auto& pattern = model.one_form_pattern();
  // The rows through each column (only for local generators): CSC of the pattern.
  std::vector<int> col_ptr, col_rows, marked;
  const bool local = std::any_of(model.momentum_maps().begin(), model.momentum_maps().end(),
                                 [](const NamedMomentumMap& m) { return m.generator && m.body >= 0; });
  if (rows && local) {
    col_ptr.assign(static_cast<std::size_t>(n) + 1, 0);
    for (int k = 0; k < pattern.nnz(); ++k) ++col_ptr[static_cast<std::size_t>(pattern.col_idx[k]) + 1];
    for (int c = 0; c < n; ++c) col_ptr[static_cast<std::size_t>(c) + 1] += col_ptr[static_cast<std::size_t>(c)];
    col_rows.resize(static_cast<std::size_t>(pattern.nnz()));
    std::vector<int> next(col_ptr.begin(), col_ptr.end() - 1);
    for (int r = 0; r < pattern.rows; ++r)
      for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k)
        col_rows[static_cast<std::size_t>(next[static_cast<std::size_t>(pattern.col_idx[k])]++)] = r;
    marked.assign(static_cast<std::size_t>(pattern.rows), -1);
  }
  Vector xi = Vector::Zero(n);
  int index = -1;
  for (const NamedMomentumMap& map : model.momentum_maps()) {
    ++index;
    if (!map.generator) continue;
    int first = 0, last = n;
    if (map.body >= 0) {
      first = model.body(map.body).offset;
      last = first + model.body(map.body).size;
    }
    xi.segment(first, last - first).setConstant(nan);
    map.generator(q0, xi);
    for (int i = first; i < last; ++i)
      if (std::isnan(xi[i]))
        complain("symmetry '" + map.name + "': its generator left entry " + std::to_string(i) + " (" + names(i) +
                 ") unset or NaN at q0" + (map.body >= 0 ? " (a local generator writes all of its body's entries)" : ""));
    const double j_xi = map.map(q0, xi), xi_xi = xi.segment(first, last - first).squaredNorm();
    if (!(std::abs(j_xi - xi_xi) <= 1e-12 * xi_xi + 1e-300)) {
      std::ostringstream os;
      os.precision(17);
      os << "symmetry '" << map.name << "': its momentum map is not <xi(q), p>: at q0, J(q0, xi) = " << j_xi
         << " but |xi|^2 = " << xi_xi;
      complain(os.str());
    }
    if (rows) {
      const double size = xi.segment(first, last - first).lpNorm<Eigen::Infinity>();
      auto check_row = [&](int r) {
        double sum = 0.0, row_norm = 0.0;
        for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k) {
          sum += ws.mu_values[k] * xi[pattern.col_idx[k]];
          row_norm += std::abs(ws.mu_values[k]);
        }
        if (std::abs(sum) > 1e-10 * row_norm * size) {
          std::ostringstream os;
          os << "symmetry '" << map.name << "': its generator xi(q0) does not lie in D(q0): " << model.describe_row(r)
             << " gives mu xi = " << sum << " (a horizontal symmetry's generator satisfies every constraint; declare "
             << "other conserved quantities with momentum_map)";
          complain(os.str());
        }
      };
      if (map.body >= 0) {
        for (int c = first; c < last; ++c)
          for (int k = col_ptr[static_cast<std::size_t>(c)]; k < col_ptr[static_cast<std::size_t>(c) + 1]; ++k) {
            const int r = col_rows[static_cast<std::size_t>(k)];
            if (marked[static_cast<std::size_t>(r)] == index) continue;
            marked[static_cast<std::size_t>(r)] = index;
            check_row(r);
          }
      } else {
        for (int r = 0; r < pattern.rows; ++r) check_row(r);
      }
    }
    xi.segment(first, last - first).setZero();
    if (map.body < 0) xi.setZero();
  }
}

// Each callback, evaluated once at (t0, q0) into NaN-filled output, must fill every entry:
// one that fills too few values would otherwise leave the previous call's numbers there and
// go unseen (debug builds also NaN-fill mu before every evaluation, workspace.cpp). The
// outputs go to the workspace's scratch buffers (clobbered; the one-form cache is untouched).
// Rows from elements have the library's values, bias and gaps, which fill every entry: not
// checked (three passes over mu and two over the rows, for a large chain's start).
void check_callbacks_fill(const Model& model, Workspace& ws, double t0, ConstVecRef q0) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const int n = model.num_velocities();
  auto names = [&model](int i) { return std::string(model.velocity_name(i)); };  // for messages
  auto complain = [](const std::string& what) { throw std::invalid_argument("start: " + what); };
  Vector local, local2;
  const bool element_rows = model.has_elements() && model.element_set()->num_rows() > 0;
  ws.forget_one_forms();  // the start evaluates mu afresh
  const bool generators = std::any_of(model.momentum_maps().begin(), model.momentum_maps().end(),
                                      [](const NamedMomentumMap& m) { return static_cast<bool>(m.generator); });
  if (model.num_one_forms() > 0 && element_rows && generators) model.one_form_values(q0, ws.mu_values);
  if (model.num_one_forms() > 0 && !element_rows) {
    // Into the one-form cache itself (forgotten): no second copy of mu is needed
    // (WorkspaceOptions::dla_steps); the symmetry generators' check below reads it.
    Vector& mu = ws.mu_values;
    mu.setConstant(nan);
    model.one_form_values(q0, mu);
    const auto& pattern = model.one_form_pattern();
    for (int r = 0; r < pattern.rows; ++r)
      for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k)
        if (std::isnan(mu[k]))
          complain("one_form_values left value " + std::to_string(k) + " (" + model.describe_row(r) + ", column " +
                   names(pattern.col_idx[k]) + ") unset or NaN at q0: it must fill all " +
                   std::to_string(pattern.nnz()) + " values, row by row in the order of each row's columns");
    if (model.has_analytic_bias()) {
      Vector& bias = sized_buffer(ws.scratch_m, local, model.num_one_forms());
      Vector& zero = sized_buffer(ws.scratch_n2, local2, n);
      bias.setConstant(nan);
      zero.setZero();
      model.analytic_bias(q0, zero, bias);
      for (int r = 0; r < model.num_one_forms(); ++r)
        if (std::isnan(bias[r]))
          complain("one_form_bias left entry " + std::to_string(r) + " (" + model.describe_row(r) +
                   ") unset or NaN at q0 with qdot = 0");
    }
  }
  // Symmetry generators: every entry filled (a local one's: its body's), and in D(q0) (mu(q0)
  // is in the workspace's cache). One buffer for all; a local generator is checked on its
  // body's entries and the rows that reach them: a chain of N balls checks its N spins in O(N).
  if (generators) check_generators(model, ws, q0, complain);
  if (model.num_holonomic() > 0 && !element_rows) {
    Vector& g = sized_buffer(ws.gap, local, model.num_holonomic());
    g.setConstant(nan);
    model.gap(q0, g);
    for (int j = 0; j < g.size(); ++j)
      if (std::isnan(g[j]))
        complain("gap left entry " + std::to_string(j) + " (" + model.describe_row(model.holonomic_rows()[j]) +
                 ") unset or NaN at q0");
  }
  if (model.has_applied_force()) {
    Vector& f = sized_buffer(ws.applied, local, n);
    Vector& work = sized_buffer(ws.scratch_n, local2, n);
    f.setConstant(nan);
    work.setConstant(nan);
    model.applied_force(t0, q0, f, work);
    for (int i = 0; i < n; ++i)
      if (std::isnan(f[i]))
        complain(std::string(model.has_external_force() ? "the external force or the potential gradient"
                                                        : "the potential gradient") +
                 " left entry " + std::to_string(i) + " (" + names(i) + ") unset or NaN at q0");
  }
}

// The holonomic rows hold at q0: an open hitch (a gap of 6 was accepted, and the first step
// then advised a smaller step, where scene files refuse it) is refused, naming the row.
void check_gaps_closed(const Model& model, Workspace& ws, ConstVecRef q0, double max_gap) {
  if (model.num_holonomic() == 0 || !(max_gap < std::numeric_limits<double>::infinity())) return;
  if (!(max_gap >= 0.0))
    throw std::invalid_argument("start_from_velocity: StartOptions::max_gap = " + std::to_string(max_gap) +
                                " must be at least 0 (infinity: the first step closes any gap)");
  Vector local;
  Vector& g = sized_buffer(ws.gap, local, model.num_holonomic());
  model.gap(q0, g);
  const double bound = max_gap * (1.0 + q0.lpNorm<Eigen::Infinity>());
  Eigen::Index worst = 0;
  const double largest = g.cwiseAbs().maxCoeff(&worst);
  if (largest <= bound) return;
  std::ostringstream os;
  os << "start_from_velocity: a holonomic row is open at q0: " << model.describe_row(model.holonomic_rows()[worst])
     << " has gap " << g[worst] << ", above max_gap " << max_gap << " x (1 + |q0|_inf) = " << bound
     << ": place the bodies so that the hitch's points meet (the first step would close the gap with a velocity "
        "kick of 2 gap / h), or set StartOptions::max_gap to infinity to let it";
  throw std::invalid_argument(os.str());
}

}  // namespace

State start_from_velocity(const Model& model, Workspace& ws, double t0, ConstVecRef q0,
                          ConstVecRef v_guess, const StartOptions& options) {
  const BusyEntry entry(ws.busy_flag());
  require_held(entry, "start_from_velocity");
  check_time(t0);
  check_vector("q0", q0, model, true);
  check_vector("the velocity guess", v_guess, model, false);
  State s = allocate_state(model, t0, q0);  // q0's quaternions normalised in s.q: no copy of q0 besides
  normalise_quaternions("q0", s.q, model);
  check_callbacks_fill(model, ws, t0, s.q);
  check_gaps_closed(model, ws, s.q, options.max_gap);

  model.mass().multiply(v_guess.data(), s.p.data());
  check(detail::project_momentum(model, ws, s.q, s.p, s.p, options.min_pivot_ratio), ws,
        "projecting the velocity onto D(q0)");

  // The velocity M^-1 p~_0 is held in s.force until the force itself is computed, and the
  // workspace's scratch serves below (no state-sized temporaries: a million-body chain's start
  // would touch 48 MB more).
  Vector& v = s.force;
  model.inverse_mass().multiply(s.p.data(), v.data());
  if (options.multiplier == InitialMultiplier::Continuous)
    check(detail::constraint_multiplier(model, ws, t0, s.q, v, s.lambda, options.min_pivot_ratio), ws,
          "computing the continuous multiplier at q0");

  Vector local;
  Vector& scratch = sized_buffer(ws.scratch_n, local, model.num_velocities());
  if (model.has_applied_force())
    model.applied_force(t0, s.q, s.force, scratch);
  else
    s.force.setZero();
  if (model.num_one_forms() > 0) {
    check(ws.evaluate_one_forms(s.q), ws, "evaluating the one-forms at q0");
    model.mu_transpose_times(ws.mu_values.data(), s.lambda.data(), scratch.data());
    s.force += scratch;
  }
  return s;
}

State start_from_two_points(const Model& model, Workspace& ws, double t0, ConstVecRef q0_given,
                            ConstVecRef q1_given, double h, double tolerance, RotationLagrangian rotation) {
  const BusyEntry entry(ws.busy_flag());
  require_held(entry, "start_from_two_points");
  check_time(t0);
  check_vector("q0", q0_given, model, true);
  check_vector("q1", q1_given, model, true);
  const Vector q0 = unit_quaternions("q0", q0_given, model), q1 = unit_quaternions("q1", q1_given, model);
  check_callbacks_fill(model, ws, t0, q0);
  if (!(h > 0.0) || !std::isfinite(h)) {
    std::ostringstream os;
    os << "start: step size h = " << h << " must be positive and finite";
    throw std::invalid_argument(os.str());
  }
  State s = allocate_state(model, t0, q0);
  const int n = model.num_velocities();
  Vector scratch(n);
  if (model.has_rigid_bodies()) {  // the discrete Legendre transform of (q0, q1)
    detail::discrete_momentum(model, rotation, q0, q1, h, s.p);
  } else {
    Vector dq = (q1 - q0) / h;
    model.mass().multiply(dq.data(), s.p.data());
  }
  if (model.has_applied_force()) {
    model.applied_force(t0, s.q, s.force, scratch);
    s.p -= 0.5 * h * s.force;
  }

  // (q0, q1) in M0  <=>  mu(q0) M^-1 p~_0 = 0, checked row by row against the row's
  // scale |mu_a|_1 |M^-1 p~_0|_inf so that the test does not depend on units.
  if (model.num_one_forms() > 0) {
    check(ws.evaluate_one_forms(s.q), ws, "evaluating the one-forms at q0");
    for (int k = 0; k < model.num_one_form_values(); ++k)
      if (!std::isfinite(ws.mu_values[k])) {
        std::ostringstream os;
        os << "start: the one-forms at q0 are not finite (value " << k << " is " << ws.mu_values[k] << ")";
        throw std::invalid_argument(os.str());
      }
    Vector v(n);
    model.inverse_mass().multiply(s.p.data(), v.data());
    const double speed = v.lpNorm<Eigen::Infinity>();
    const auto& pattern = model.one_form_pattern();
    for (int r = 0; r < pattern.rows; ++r) {
      double sum = 0.0, row_norm = 0.0;
      for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k) {
        sum += ws.mu_values[k] * v[pattern.col_idx[k]];
        row_norm += std::abs(ws.mu_values[k]);
      }
      if (std::abs(sum) > tolerance * row_norm * speed) {
        std::ostringstream os;
        os << "start: (q0, q1) is not in M0: " << model.describe_row(r) << " gives mu(q0) M^-1 p0 = " << sum
           << ", more than " << tolerance << " times |mu_" << r << "|_1 |M^-1 p0|_inf = " << row_norm * speed;
        throw std::invalid_argument(os.str());
      }
    }
  }
  return s;  // lambda~_0 = 0, force = f(t0, q0)
}

}  // namespace nonholo

// What to watch along a trajectory (diagnostics.hpp): energies of p~ and of the post-momentum, residual, gaps
// (or the step's own measurements: diagnose_step), the external forces' power and the momentum maps.
#include <nonholo/diagnostics.hpp>

#include <cmath>
#include <limits>

#include "step/rigid/drift.hpp"

namespace nonholo {

double kinetic_energy(const Model& model, ConstVecRef p, VecRef scratch) {
  model.inverse_mass().multiply(p.data(), scratch.data());
  return 0.5 * p.dot(scratch);
}

namespace {

Diagnostics diagnose_held(const Model& model, Workspace& ws, const State& s, double h, RotationLagrangian rotation) {
  Diagnostics d;
  const double v_now = model.potential(s.q);
  d.energy = kinetic_energy(model, s.p, ws.scratch_n) + v_now;

  // p_{k-1/2} = p~_k - (h/2) force_k, and q_{k-1} = q_k - h M^-1 p_{k-1/2}.
  ws.scratch_n2 = s.p - 0.5 * h * s.force;
  d.energy_post = kinetic_energy(model, ws.scratch_n2, ws.scratch_n);
  if (model.has_potential()) {
    if (model.has_rigid_bodies()) {  // q_{k-1} through the rigid bodies' Legendre transforms
      d.energy_post += 0.5 * (detail::previous_potential(model, rotation, h, s.q, ws.scratch_n2, ws.scratch_n,
                                                         ws.scratch_q) +
                              v_now);
    } else {
      ws.scratch_n2 = s.q - h * ws.scratch_n;
      d.energy_post += 0.5 * (model.potential(ws.scratch_n2) + v_now);
    }
  }

  if (model.num_holonomic() > 0) {
    model.gap(s.q, ws.gap);
    d.gap = ws.gap.lpNorm<Eigen::Infinity>();
  }
  if (model.num_one_forms() > 0) {
    if (ws.evaluate_one_forms(s.q) != Status::Ok) {
      d.residual = std::numeric_limits<double>::quiet_NaN();
      return d;
    }
    model.inverse_mass().multiply(s.p.data(), ws.scratch_n.data());
    model.mu_times(ws.mu_values.data(), ws.scratch_n.data(), ws.scratch_m.data());
    d.residual = std::isfinite(ws.scratch_m.sum()) ? ws.scratch_m.lpNorm<Eigen::Infinity>()
                                                   : std::numeric_limits<double>::quiet_NaN();
  }
  return d;
}

}  // namespace

Diagnostics diagnose(const Model& model, Workspace& ws, const State& s, double h) {
  return diagnose(model, ws, s, h, ws.rotation());
}

Diagnostics diagnose(const Model& model, Workspace& ws, const State& s, double h, RotationLagrangian rotation) {
  const BusyEntry entry(ws.busy_flag());
  require_held(entry, "diagnose");
  return diagnose_held(model, ws, s, h, rotation);
}

Diagnostics diagnose_step(const Model& model, Workspace& ws, const State& s, double h) {
  return diagnose_step(model, ws, s, h, ws.rotation());
}

Diagnostics diagnose_step(const Model& model, Workspace& ws, const State& s, double h, RotationLagrangian rotation) {
  const BusyEntry entry(ws.busy_flag());
  require_held(entry, "diagnose_step");
  const auto& f = ws.step_diagnostics;
  if (f.q == nullptr || f.q != s.q.data() || f.steps != s.steps) return diagnose_held(model, ws, s, h, rotation);
  Diagnostics d;
  d.energy = f.energy;
  d.energy_post = f.energy_post;
  d.residual = f.residual;
  d.gap = f.gap;
  return d;
}

double external_power(const Model& model, Workspace& ws, const State& s) {
  if (!model.has_external_force()) return 0.0;
  const BusyEntry entry(ws.busy_flag());
  require_held(entry, "external_power");
  model.external_force(s.t, s.q, ws.scratch_n);
  model.inverse_mass().multiply(s.p.data(), ws.scratch_n2.data());
  return ws.scratch_n.dot(ws.scratch_n2);
}

void evaluate_momentum_maps(const Model& model, const State& s, VecRef out) {
  const auto& maps = model.momentum_maps();
  for (std::size_t i = 0; i < maps.size(); ++i) out[static_cast<Eigen::Index>(i)] = maps[i].map(s.q, s.p);
}

}  // namespace nonholo

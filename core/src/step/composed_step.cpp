// Orders 4, 6 and 8 (composition.hpp): a composed step of size H is the plain steps
// Phi_{c_i H}, i = 1 ... 2s, each arriving at its own time t + (c_1 + ... + c_i) H, followed at the composed
// step's end by the measurement of the period-2 mode and (as RattleOptions::restart asks) the
// energy projection of p~ and the restart lambda~ <- lambda_s. The coefficients c_i are the
// tables of base/composition.cpp.
#include <nonholo/composition.hpp>

#include <nonholo/diagnostics.hpp>

#include <cmath>
#include <limits>

#include "base/callback_guard.hpp"
#include "base/option_checks.hpp"
#include "step/rattle_internal.hpp"
#include "step/restart_internal.hpp"

namespace nonholo {
namespace detail {
namespace {

// The state at the composed step's start, kept in the workspace (no allocation).
void save(Workspace& ws, const State& s) {
  ws.saved_q = s.q;
  ws.saved_p = s.p;
  ws.saved_lambda = s.lambda;
  ws.saved_force = s.force;
}

void restore(Workspace& ws, State& s, double t) {
  s.t = t;
  s.q.swap(ws.saved_q);
  s.p.swap(ws.saved_p);
  s.lambda.swap(ws.saved_lambda);
  s.force.swap(ws.saved_force);
}

// At the composed step's end (the last substep left mu(q), C(q) and f(t, q) in ws.applied):
// the energy projection (no external forces), the measurement, and the restart.
Status control_at_boundary(const Model& model, Workspace& ws, State& s, const RattleOptions& o, double h_last,
                           double target, bool& restarted) {
  const RestartOptions& r = o.restart;
  restarted = r.mode == RestartMode::Auto || (r.mode == RestartMode::Periodic && (s.steps + 1) % r.every == 0);
  const bool measure = r.monitor_every > 0;
  if (model.num_one_forms() == 0 || (!restarted && !measure)) return Status::Ok;
  Status status = Status::Ok;
  if (restarted && !model.has_external_force() && (status = project_energy(model, ws, s.q, s.p, target)) != Status::Ok)
    return status;
  if ((status = continuous_multiplier_at(model, ws, s.q, s.p, ws.applied)) != Status::Ok) return status;
  if (measure) ws.parasitic = parasitic_of(model, ws, s.p, s.lambda, std::abs(h_last), false);
  if (restarted) {
    s.lambda = ws.lambda_s;
    model.mu_transpose_times(ws.mu_values.data(), s.lambda.data(), s.force.data());
    if (model.has_applied_force()) s.force += ws.applied;
  }
  return Status::Ok;
}

}  // namespace

Status composed_step(const Model& model, Workspace& ws, State& s, const RattleOptions& o) {
  CompositionScheme scheme;
  find_composition(o.order, o.composition, scheme);  // a pair step() has checked
  if (ws.saved_q.size() != s.q.size())
    return ws.fail(Status::MethodNotApplicable,
                   "the workspace was built without room for composed steps: build it with "
                   "WorkspaceOptions::composed_steps = true");
  const double t0 = s.t, H = o.h, t_end = s.grid.next(s.t, H);
  double target = s.target_energy;
  save(ws, s);

  bool restarted = false;
  ws.parasitic = std::numeric_limits<double>::quiet_NaN();
  // A callback that throws in a later substep is restored from like any failed substep.
  const Status status = guard_callbacks(ws, [&] {
    if (std::isnan(target) && !model.has_external_force())
      target = kinetic_energy(model, s.p, ws.scratch_n) + model.potential(s.q);
    double elapsed = 0.0;  // c_1 + ... + c_i
    double h = 0.0;
    Status st = Status::Ok;
    for (int i = 0; i < scheme.steps && st == Status::Ok; ++i) {
      h = scheme.c[i] * H;
      elapsed += scheme.c[i];
      st = advance(model, ws, s, o, h, i + 1 == scheme.steps ? t_end : t0 + elapsed * H, nullptr);
    }
    if (st == Status::Ok) st = control_at_boundary(model, ws, s, o, h, target, restarted);
    return st;
  });
  if (status != Status::Ok) {
    restore(ws, s, t0);
    return status;
  }
  ws.restarted = restarted;
  if (restarted) ++s.restarts;
  s.grid.advance();
  ++s.steps;
  s.target_energy = target;
  ws.clear_message();
  return Status::Ok;
}

}  // namespace detail
}  // namespace nonholo

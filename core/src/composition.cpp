// Orders 4 and 6 (composition.hpp, DESIGN.md section 9): a composed step of size H is the
// double steps Psi_{gamma_i H} = Phi_{gamma_i H/2} o Phi_{gamma_i H/2}, i = 1 ... s, each plain
// substep arriving at its own time t + (gamma_1 + ... + gamma_i) H, followed at the composed
// step's end by the measurement of the period-2 mode and (as RattleOptions::restart asks) the
// energy projection of p~ and the restart lambda~ <- lambda_s.
#include <nonholo/composition.hpp>

#include <nonholo/diagnostics.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "callback_guard.hpp"
#include "rattle_internal.hpp"
#include "restart_internal.hpp"

namespace nonholo {
namespace {

// Yoshida's triple jump and Suzuki's fractal: gamma = 1 / (k - k^(1/3)) for the outer stages
// and 1 - (k - 1) gamma in the middle (k = 2, 4).
const double kTripleJump[3] = {1.3512071919596576340, -1.7024143839193152681, 1.3512071919596576340};
const double kSuzuki5[5] = {0.41449077179437573714, 0.41449077179437573714, -0.65796308717750294857,
                            0.41449077179437573714, 0.41449077179437573714};
// Yoshida (1990), solution A: w3 w2 w1 w0 w1 w2 w3 with w0 = 1 - 2 (w1 + w2 + w3).
const double kYoshida7[7] = {0.78451361047755726382, 0.23557321335935813368, -1.17767998417887100695,
                             1.31518632068391121889, -1.17767998417887100695, 0.23557321335935813368,
                             0.78451361047755726382};
// Kahan and Li (1997), s9odr6a (Hairer, Lubich and Wanner, Geometric Numerical Integration, V.3).
const double kKahanLi9[9] = {0.39216144400731413928,  0.33259913678935943860, -0.70624617255763935981,
                             0.082213596293550800230, 0.79854399093482996340, 0.082213596293550800230,
                             -0.70624617255763935981, 0.33259913678935943860, 0.39216144400731413928};

}  // namespace

const char* to_string(Composition c) {
  switch (c) {
    case Composition::Auto: return "auto";
    case Composition::TripleJump: return "triple-jump";
    case Composition::Suzuki5: return "suzuki5";
    case Composition::Yoshida7: return "yoshida7";
    case Composition::KahanLi9: return "kahan-li9";
  }
  return "unknown";
}

Composition composition_from_string(const std::string& name) {
  for (Composition c : {Composition::Auto, Composition::TripleJump, Composition::Suzuki5, Composition::Yoshida7,
                        Composition::KahanLi9})
    if (name == to_string(c)) return c;
  throw std::invalid_argument("unknown composition '" + name +
                              "' (valid: auto, triple-jump, suzuki5 (order 4), yoshida7, kahan-li9 (order 6))");
}

namespace detail {

bool find_composition(int order, Composition c, CompositionScheme& scheme) {
  if (order != 2 && order != 4 && order != 6) return false;
  if (c == Composition::Auto) c = order == 4 ? Composition::Suzuki5 : order == 6 ? Composition::KahanLi9 : c;
  switch (c) {
    case Composition::Auto: scheme = {c, 2, 0, nullptr}; return true;
    case Composition::TripleJump:
    case Composition::Suzuki5:
      if (order != 4) return false;
      scheme = c == Composition::TripleJump ? CompositionScheme{c, 4, 3, kTripleJump} : CompositionScheme{c, 4, 5, kSuzuki5};
      return true;
    case Composition::Yoshida7:
    case Composition::KahanLi9:
      if (order != 6) return false;
      scheme = c == Composition::Yoshida7 ? CompositionScheme{c, 6, 7, kYoshida7} : CompositionScheme{c, 6, 9, kKahanLi9};
      return true;
  }
  return false;
}

}  // namespace detail

CompositionScheme composition_scheme(int order, Composition c) {
  if (order != 2 && order != 4 && order != 6)
    throw std::invalid_argument("order = " + std::to_string(order) + " must be 2, 4 or 6");
  CompositionScheme scheme;
  if (!detail::find_composition(order, c, scheme))
    throw std::invalid_argument(std::string("composition ") + to_string(c) + " is not of order " +
                                std::to_string(order) + " (order 4: triple-jump, suzuki5; order 6: yoshida7, kahan-li9)");
  return scheme;
}

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
    double elapsed = 0.0;  // gamma_1 + ... + gamma_i
    double h = 0.0;
    Status st = Status::Ok;
    for (int i = 0; i < scheme.stages && st == Status::Ok; ++i) {
      h = 0.5 * scheme.gamma[i] * H;
      const bool last = i + 1 == scheme.stages;
      st = advance(model, ws, s, o, h, t0 + (elapsed + 0.5 * scheme.gamma[i]) * H, nullptr);
      elapsed += scheme.gamma[i];
      if (st == Status::Ok) st = advance(model, ws, s, o, h, last ? t_end : t0 + elapsed * H, nullptr);
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

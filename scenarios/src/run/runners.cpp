// The runners behind `nonholo run --method` (runners.hpp): reflection (plain, composed or adaptive), DLA, the
// implicit form, RK4 and ARKODE, each from the consistent start (of a scene or a model built in code); make_runner picks one by name.
#include "run/runners.hpp"

#include "run/run_checks.hpp"

#include <nonholo/dla.hpp>
#include <nonholo/implicit.hpp>
#include <nonholo/start.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace nonholo::scenarios {
namespace {

void announce(const SetupPhase& phase, const char* what) {
  if (phase) phase(what);
}

// relative_residual of v at q with the workspace's mu(q) (evaluated unless it holds it).
double relative_residual_at(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef v) {
  if (model.num_one_forms() == 0) return 0.0;
  if (ws.evaluate_one_forms(q) != Status::Ok) return std::numeric_limits<double>::quiet_NaN();
  return relative_residual(model.one_form_pattern(), ws.mu_values.data(), v);
}

// The workspace's counters that the summary reports (the rest of it is scratch and caches).
void save_counters(OutArchive& a, const Workspace& ws) { a(ws.factorizations), a(ws.legendre_iterations), a(ws.parasitic); }
void load_counters(InArchive& a, Workspace& ws) { a(ws.factorizations), a(ws.legendre_iterations), a(ws.parasitic); }

// The reflection runner's workspace: composed steps' room only for orders above 2, no DLA
// copy of mu, the step's threads (the accuracy check's shadow steps on it too).
WorkspaceOptions reflection_workspace(const MethodChoice& c) {
  WorkspaceOptions o;
  o.backend = c.backend;
  o.composed_steps = c.rattle.order > 2;
  o.dla_steps = false;
  o.threads = c.threads;
  return o;
}

// The state a method starts from: the caller's (its restarts counted afresh: the summary's are
// this run's), or the consistent start from q0 and the velocity guess v0.
State consistent_start(const Model& model, Workspace& ws, const RunStart& start) {
  if (!start.state) return start_from_velocity(model, ws, start.t0, start.q0, start.v0);
  State s = *start.state;
  s.restarts = 0;
  return s;
}

class ReflectionRunner final : public Runner {
 public:
  ReflectionRunner(const Model& model, const RunStart& start, const MethodChoice& c, const SetupPhase& phase)
      : model_(model), ws_(model, reflection_workspace(c)), options_(c.rattle) {
    announce(phase, "starting");
    state_ = consistent_start(model, ws_, start);
    if (c.adaptive_on()) stepper_ = std::make_unique<AdaptiveStepper>(model, c.rattle, c.adaptive);
    if (c.accuracy_every > 0) {  // its shadow made now: set-up, not the first step, pays for it
      watch_ = std::make_unique<AccuracyWatch>(ws_, c.rattle, c.accuracy_every);
      watch_->prepare();
    }
  }
  Status advance(double t_next) override {
    if (stepper_) {  // pairs of adaptive steps, the last landing on t_next
      Status status = Status::Ok;
      while (status == Status::Ok && state_.t < t_next) {
        if (stop_ && stop_()) return Status::Interrupted;  // an interval may hold any number of pairs
        if ((status = stepper_->step(model_, ws_, state_, t_next)) != Status::Ok) break;
        const double pairs = (t_next - state_.t) / (2.0 * stepper_->last_step());
        if (pairs > kMaxRunSteps)
          return ws_.fail(Status::StepSizeTooSmall,
                          "at the step size the tolerance asks for (h = %.3g at t = %.17g), reaching t = %.17g "
                          "would take about %.3g pairs of steps, more than the %.0e a run may take: raise --tol, "
                          "or shorten --t-end or --dt (the output interval)",
                          stepper_->last_step(), state_.t, t_next, pairs, kMaxRunSteps);
      }
      return status;
    }
    if (!watch_) return step(model_, ws_, state_, options_);
    watch_->before_step(state_);
    const Status status = step(model_, ws_, state_, options_);
    if (status == Status::Ok) watch_->after_step(state_);
    return status;
  }
  const DoublingEstimate* accuracy() const override { return watch_ ? &watch_->estimate() : nullptr; }
  double t() const override { return state_.t; }
  ConstVecRef q() const override { return state_.q; }
  // Composed steps restart lambda~ at their end: the post-momentum of a composed step is not
  // defined (nor an invariant), so energy_post is NaN there; nor is it one for adaptive steps
  // of order 2, whose post-momentum belongs to a step size that changes.
  Diagnostics diagnostics() override {
    // The fused chain step computed them in its sweeps (diagnose_step); others diagnose here.
    Diagnostics d = diagnose_step(model_, ws_, state_, options_.h, options_.rotation);
    if (options_.order > 2 || stepper_) d.energy_post = std::numeric_limits<double>::quiet_NaN();
    return d;
  }
  void momentum_maps(VecRef out) override { evaluate_momentum_maps(model_, state_, out); }
  ConstVecRef p() override { return state_.p; }
  std::string message() const override { return ws_.message(); }
  std::string backend() const override { return ws_.backend_name(); }
  int threads() const override { return ws_.threads(); }
  void set_team(int threads) override {
    ws_.set_team(threads);  // the watch's shadow steps on ws_ too
  }
  double parasitic() const override { return ws_.parasitic; }
  long restarts() const override { return state_.restarts; }
  long legendre_iterations() const override { return ws_.legendre_iterations; }
  // Into the workspace's velocity scratch (written by a step before it is read): no n_v vector
  // of the runner's own (24 MB for a million-body chain). Valid until the next advance().
  ConstVecRef velocity() override {
    model_.inverse_mass().multiply(state_.p.data(), ws_.velocity.data());
    return ws_.velocity;
  }
  double relative_residual() override { return relative_residual_at(model_, ws_, state_.q, velocity()); }
  long factorizations() const override { return ws_.factorizations; }
  long internal_steps() const override { return stepper_ ? stepper_->accepted() : -1; }
  long rejected() const override { return stepper_ ? stepper_->rejected() : -1; }
  Workspace* workspace() override { return &ws_; }
  void save(OutArchive& a) const override {
    a.tag("reflection");
    nonholo::save(a, state_);
    save_counters(a, ws_);
    a(static_cast<bool>(watch_)), a(static_cast<bool>(stepper_));
    if (watch_) watch_->save(a);
    if (stepper_) stepper_->save(a);
    ws_.save_held(a);
  }
  void load(InArchive& a) override {
    a.tag("reflection");
    nonholo::load(a, state_);
    load_counters(a, ws_);
    bool watch = false, stepper = false;
    a(watch), a(stepper);
    if (watch != static_cast<bool>(watch_) || stepper != static_cast<bool>(stepper_))
      throw std::runtime_error("checkpoint: written with the accuracy check or adaptive steps where this run has "
                               "not (or the other way round)");
    if (watch_) {
      watch_->load(a);
      watch_->rebind(state_);
    }
    if (stepper_) stepper_->load(a);
    ws_.load_held(a, options_.min_pivot_ratio);
  }

 private:
  const Model& model_;
  Workspace ws_;
  RattleOptions options_;
  State state_;
  std::unique_ptr<AdaptiveStepper> stepper_;
  std::unique_ptr<AccuracyWatch> watch_;
};

class DlaRunner final : public Runner {
 public:
  DlaRunner(const Model& model, const RunStart& start, const MethodChoice& c, DlaConstraint constraint, const SetupPhase& phase)
      : model_(model), ws_(model, {c.backend, false}) {
    options_.h = c.rattle.h;
    options_.constraint = constraint;
    validate(options_);
    announce(phase, "starting");
    state_ = dla_start(consistent_start(model, ws_, start), options_.h);
  }
  Status advance(double) override { return dla_step(model_, ws_, state_, options_); }
  double t() const override { return state_.t; }
  ConstVecRef q() const override { return state_.q; }
  // The energy of the last step's momentum p_{k-1/2}, with V averaged over its ends; the
  // residual of the continuous constraint at q_k for that step's velocity.
  Diagnostics diagnostics() override {
    Diagnostics d;
    d.energy = kinetic_energy(model_, state_.p, ws_.scratch_n);
    if (model_.has_potential()) {
      ws_.scratch_n2 = state_.q - options_.h * ws_.scratch_n;  // scratch_n holds M^-1 p
      d.energy += 0.5 * (model_.potential(ws_.scratch_n2) + model_.potential(state_.q));
    }
    d.energy_post = d.energy;
    if (model_.num_one_forms() > 0) {
      ws_.evaluate_one_forms(state_.q);
      model_.inverse_mass().multiply(state_.p.data(), ws_.scratch_n.data());
      model_.mu_times(ws_.mu_values.data(), ws_.scratch_n.data(), ws_.scratch_m.data());
      d.residual = ws_.scratch_m.lpNorm<Eigen::Infinity>();
    }
    if (model_.num_holonomic() > 0) {
      model_.gap(state_.q, ws_.gap);
      d.gap = ws_.gap.lpNorm<Eigen::Infinity>();
    }
    return d;
  }
  void momentum_maps(VecRef out) override {
    const auto& maps = model_.momentum_maps();
    for (std::size_t i = 0; i < maps.size(); ++i) out[static_cast<Eigen::Index>(i)] = maps[i].map(state_.q, state_.p);
  }
  ConstVecRef p() override { return state_.p; }
  ConstVecRef velocity() override {
    model_.inverse_mass().multiply(state_.p.data(), velocity_.data());
    return velocity_;
  }
  double relative_residual() override { return relative_residual_at(model_, ws_, state_.q, velocity()); }
  std::string message() const override { return ws_.message(); }
  std::string backend() const override { return ws_.backend_name(); }
  long factorizations() const override { return ws_.factorizations; }
  void save(OutArchive& a) const override {
    a.tag("dla");
    a(state_.t), a(state_.grid.t0), a(state_.grid.h), a(state_.grid.k), a(state_.q), a(state_.p);
    a(state_.newton_iterations);
    save_counters(a, ws_);
    ws_.save_held(a);
  }
  void load(InArchive& a) override {
    a.tag("dla");
    a(state_.t), a(state_.grid.t0), a(state_.grid.h), a(state_.grid.k), a(state_.q), a(state_.p);
    a(state_.newton_iterations);
    load_counters(a, ws_);
    ws_.load_held(a, options_.min_pivot_ratio);
  }

 private:
  const Model& model_;
  Workspace ws_;
  DlaOptions options_;
  DlaState state_;
  Vector velocity_ = Vector::Zero(model_.num_velocities());
};

// The general implicit form, for models with a configuration-dependent metric.
class ImplicitRunner final : public Runner {
 public:
  ImplicitRunner(const Model& model, const RunStart& start, const MethodChoice& c, const SetupPhase& phase)
      : model_(model), ws_(model) {
    options_.h = c.rattle.h;
    options_.min_pivot_ratio = c.rattle.min_pivot_ratio;
    options_.restart = c.rattle.restart;
    announce(phase, "starting");
    if (start.state)
      throw std::invalid_argument("a start from a State: this model's metric depends on q (the implicit general form "
                                  "has a state of its own); start it from q0 and v0");
    state_ = implicit_start(model_, ws_, start.t0, start.q0, start.v0, options_);
    average_.setZero(model_.num_coordinates());
    reflected_.setZero(model_.num_coordinates());
  }
  Status advance(double) override { return implicit_step(model_, ws_, state_, options_); }
  double t() const override { return state_.t; }
  ConstVecRef q() const override { return state_.q; }
  // energy of the average momentum P* p+, energy_post of the arriving momentum p+, both with
  // M(q_k); the residual of the average momentum.
  Diagnostics diagnostics() override {
    Diagnostics d;
    if (ws_.reflect(state_.q, state_.p, average_, reflected_, 0.0) != Status::Ok) {
      d.energy = d.energy_post = d.residual = std::numeric_limits<double>::quiet_NaN();
      return d;
    }
    velocity_ = ws_.metric_llt.solve(average_);  // reflect() factorised M(q_k)
    const double v = model_.potential(state_.q);
    d.energy = ws_.kinetic_energy(state_.q, average_) + v;
    d.energy_post = ws_.kinetic_energy(state_.q, state_.p) + v;
    if (model_.num_one_forms() > 0) {
      ws_.y = ws_.metric_llt.solve(average_);
      d.residual = (ws_.mu * ws_.y).lpNorm<Eigen::Infinity>();
    }
    return d;
  }
  void momentum_maps(VecRef out) override {
    const auto& maps = model_.momentum_maps();
    for (std::size_t i = 0; i < maps.size(); ++i) out[static_cast<Eigen::Index>(i)] = maps[i].map(state_.q, state_.p);
  }
  ConstVecRef p() override { return state_.p; }
  ConstVecRef velocity() override { return velocity_; }
  // Row by row of the dense mu(q_k) the diagnostics left in the workspace.
  double relative_residual() override {
    if (model_.num_one_forms() == 0) return 0.0;
    const double v_max = velocity_.lpNorm<Eigen::Infinity>();
    if (!(v_max > 0.0)) return v_max == 0.0 ? 0.0 : std::numeric_limits<double>::quiet_NaN();
    double worst = 0.0;
    for (Eigen::Index i = 0; i < ws_.mu.rows(); ++i) {
      const double norm = ws_.mu.row(i).lpNorm<1>();
      const double rel = norm > 0.0 ? std::abs(ws_.mu.row(i).dot(velocity_)) / (norm * v_max) : 0.0;
      if (!(rel <= worst)) worst = rel;
    }
    return worst;
  }
  std::string message() const override { return ws_.message(); }
  std::string backend() const override { return "dense-implicit"; }
  double parasitic() const override { return ws_.parasitic; }
  long restarts() const override { return state_.restarts; }
  void save(OutArchive& a) const override {
    a.tag("implicit");
    a(state_.t), a(state_.grid.t0), a(state_.grid.h), a(state_.grid.k), a(state_.q), a(state_.p);
    a(state_.newton_iterations), a(state_.steps), a(state_.restarts);
    a(state_.watch.next_step), a(state_.watch.last_step), a(state_.watch.last_amplitude), a(state_.watch.floor);
    a(ws_.parasitic), a(velocity_);
  }
  void load(InArchive& a) override {
    a.tag("implicit");
    a(state_.t), a(state_.grid.t0), a(state_.grid.h), a(state_.grid.k), a(state_.q), a(state_.p);
    a(state_.newton_iterations), a(state_.steps), a(state_.restarts);
    a(state_.watch.next_step), a(state_.watch.last_step), a(state_.watch.last_amplitude), a(state_.watch.floor);
    a(ws_.parasitic), a(velocity_);
  }

 private:
  const Model& model_;
  ImplicitWorkspace ws_;
  ImplicitOptions options_;
  ImplicitState state_;
  Vector average_, reflected_;
  Vector velocity_ = Vector::Zero(model_.num_velocities());
};

// The velocity of the consistent start, M^-1 p~_0, in D(q0).
Vector started_velocity(const Model& model, const RunStart& start, sparse::Backend backend, const SetupPhase& phase) {
  Workspace ws(model, {backend, false});
  announce(phase, "starting");
  const State s = consistent_start(model, ws, start);
  Vector v(s.p.size());
  model.inverse_mass().multiply(s.p.data(), v.data());
  return v;
}

reference::Options with_backend(const MethodChoice& c) {
  reference::Options o = c.reference;
  o.backend = c.backend;
  return o;
}

class ReferenceRunner final : public Runner {
 public:
  ReferenceRunner(const Model& model, const RunStart& start, reference::Method method, const MethodChoice& c, const SetupPhase& phase)
      : model_(model),
        method_(method),
        integrator_(model, method, with_backend(c), start.state ? start.state->t : start.t0,
                    start.state ? start.state->q : start.q0, started_velocity(model, start, c.backend, phase)),
        p_(model.num_coordinates()) {
    // RK4 (fixed steps of --dt, one per output interval): the accuracy check's shadow is one
    // RK4 step of 2 dt from the same state. ARKODE controls its own local error: no check.
    if (method == reference::Method::Rk4 && c.accuracy_every > 0) {
      estimate_ = std::make_unique<DoublingEstimate>(model.num_configuration(), 4, c.accuracy_every);
      shadow_.setZero(model.num_configuration() + model.num_velocities());
    }
  }
  Status advance(double t_next) override {
    if (!estimate_) return integrator_.advance_to(t_next);
    const Eigen::Index nq = model_.num_configuration(), nv = model_.num_velocities();
    const double h = t_next - integrator_.t();
    if (estimate_->due()) {
      estimate_->include(solver_q());
      const Status s = integrator_.rk4_trial(2.0 * h, shadow_);
      if (s == Status::Ok)
        estimate_->started();
      else
        estimate_->failed(integrator_.t(), to_string(s), integrator_.ode().workspace().message());
    }
    const Status status = integrator_.advance_to(t_next);
    if (status == Status::Ok && estimate_->stepped(integrator_.t(), solver_q())) {
      const Eigen::Map<const Vector> y(integrator_.y(), nq + nv);
      estimate_->sample(integrator_.t(), h, (shadow_.head(nq) - y.head(nq)).lpNorm<Eigen::Infinity>(),
                        (shadow_.tail(nv) - y.tail(nv)).lpNorm<Eigen::Infinity>(),
                        y.tail(nv).lpNorm<Eigen::Infinity>(), y.head(nq).lpNorm<Eigen::Infinity>());
    }
    return status;
  }
  const DoublingEstimate* accuracy() const override { return estimate_.get(); }
  double t() const override { return integrator_.t(); }
  ConstVecRef q() const override { return integrator_.q(); }
  Diagnostics diagnostics() override {
    auto& ode = integrator_.ode();
    Diagnostics d;
    d.energy = ode.energy(integrator_.y());
    d.energy_post = std::numeric_limits<double>::quiet_NaN();  // no post-momentum
    d.residual = ode.residual(integrator_.y());
    d.gap = ode.gap(integrator_.y());
    return d;
  }
  void momentum_maps(VecRef out) override {
    model_.mass().multiply(integrator_.v().data(), p_.data());
    const auto& maps = model_.momentum_maps();
    for (std::size_t i = 0; i < maps.size(); ++i)
      out[static_cast<Eigen::Index>(i)] = maps[i].map(integrator_.q(), p_);
  }
  ConstVecRef p() override {
    model_.mass().multiply(integrator_.v().data(), p_.data());
    return p_;
  }
  ConstVecRef velocity() override { return integrator_.v(); }
  // At the solver's own q (the one residual() reads).
  double relative_residual() override {
    const Eigen::Map<const Vector> q(integrator_.y(), model_.num_configuration());
    return relative_residual_at(model_, integrator_.ode().workspace(), q, integrator_.v());
  }
  std::string message() const override { return integrator_.message(); }
  std::string backend() const override {
    return integrator_.ode().workspace().backend_name();
  }
  long rhs_evaluations() const override { return integrator_.rhs_evaluations(); }
  long internal_steps() const override { return method_ == reference::Method::Rk4 ? -1 : integrator_.steps(); }
  // Without the accuracy check's shadow steps (one evaluation, one factorisation each).
  long factorizations() const override {
    return integrator_.ode().workspace().factorizations - integrator_.trial_evaluations();
  }
  void save(OutArchive& a) const override {
    a.tag("reference");
    integrator_.save(a);
    a(static_cast<bool>(estimate_));
    if (estimate_) estimate_->save(a), a(shadow_);
  }
  void load(InArchive& a) override {
    a.tag("reference");
    integrator_.load(a);
    bool estimate = false;
    a(estimate);
    if (estimate != static_cast<bool>(estimate_))
      throw std::runtime_error("checkpoint: written with the accuracy check where this run has none (or the other way)");
    if (estimate_) {
      estimate_->load(a), a(shadow_);
      estimate_->rebind(solver_q());
    }
  }

 private:
  // The solver's own configuration (quaternions as integrated), in place in its state.
  ConstVecRef solver_q() const { return Eigen::Map<const Vector>(integrator_.y(), model_.num_configuration()); }
  const Model& model_;
  reference::Method method_;
  reference::Integrator integrator_;
  Vector p_;
  std::unique_ptr<DoublingEstimate> estimate_;
  Vector shadow_;  // the shadow step's y
};

}  // namespace

Companion companion_of(const MethodChoice& c) {
  Companion out;
  out.choice = c;
  out.choice.rattle.h = 0.5 * c.rattle.h;
  out.choice.reference.h = 0.5 * c.reference.h;
  out.choice.reference.tol = std::max(1e-15, 1e-2 * c.reference.tol);
  if (c.method.rfind("arkode", 0) == 0) return out;
  const int p = c.method == "reflection" ? c.rattle.order : c.method == "rk4" ? 4 : 2;
  out.scale = std::ldexp(1.0, p) / (std::ldexp(1.0, p) - 1.0);
  return out;
}

Companion check_companion_of(const MethodChoice& c) {
  Companion out;
  out.choice = c;
  out.choice.accuracy_every = 0;
  const double doubled = std::ldexp(1.0, c.method == "rk4" ? 4 : c.rattle.order);  // 2^p
  out.stride = 2;
  if (c.adaptive_on()) {
    const bool looser = c.adaptive.tol <= 0.05;
    out.choice.adaptive.tol = (looser ? 10.0 : 0.1) * c.adaptive.tol;
    out.ratio = looser ? 10.0 : 0.1;  // (2^p where the output intervals cap the steps: RunLoop)
    out.stride = looser ? 2 : 1;
    return out;
  }
  out.choice.rattle.h = 2.0 * c.rattle.h;
  out.choice.reference.h = 2.0 * c.reference.h;
  out.ratio = doubled;
  return out;
}

std::unique_ptr<Runner> make_runner(const Model& model, const RunStart& start, const MethodChoice& c, const SetupPhase& phase) {
  if (c.rattle.order != 2 && c.method != "reflection")
    throw std::invalid_argument("--order " + std::to_string(c.rattle.order) +
                                " applies to the reflection method only (method " + c.method + ")");
  if (c.rattle.order != 2 && model.has_configuration_metric())
    throw std::invalid_argument("--order " + std::to_string(c.rattle.order) +
                                " composes the explicit step, which needs a constant metric; this model's "
                                "depends on q (the implicit general form is of order 2)");
  if (c.adaptive_on() && model.has_configuration_metric())
    throw std::invalid_argument("--tol: adaptive steps take the explicit step, which needs a constant metric; this "
                                "model's depends on q (the implicit general form takes fixed steps)");
  announce(phase, "analysing C");
  if (model.has_configuration_metric()) {
    if (c.method == "reflection") return std::make_unique<ImplicitRunner>(model, start, c, phase);
    throw std::invalid_argument("method " + c.method +
                                " needs a constant metric; this model's depends on q (use reflection, "
                                "the implicit general form)");
  }
  if (c.method == "reflection") return std::make_unique<ReflectionRunner>(model, start, c, phase);
  if (c.method == "dla-midpoint") return std::make_unique<DlaRunner>(model, start, c, DlaConstraint::Midpoint, phase);
  if (c.method == "dla-left") return std::make_unique<DlaRunner>(model, start, c, DlaConstraint::Left, phase);
  reference::Method method;
  try {
    method = reference::method_from_string(c.method);
  } catch (const std::invalid_argument&) {
    throw std::invalid_argument("unknown method '" + c.method +
                                "' (valid: reflection, dla-midpoint, dla-left, rk4, arkode-dp5, arkode-verner, "
                                "arkode-fehlberg8)");
  }
  return std::make_unique<ReferenceRunner>(model, start, method, c, phase);
}

}  // namespace nonholo::scenarios

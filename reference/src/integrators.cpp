// The reference integrators (integrators.hpp): fixed-step RK4, their names and options, and
// checkpoints (RK4 only); ARKODE's explicit pairs are arkode_solver.cpp's.
#include <nonholo/reference/integrators.hpp>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace nonholo::reference {

const char* to_string(Method method) {
  switch (method) {
    case Method::Rk4: return "rk4";
    case Method::ArkodeDp5: return "arkode-dp5";
    case Method::ArkodeVerner: return "arkode-verner";
    case Method::ArkodeFehlberg8: return "arkode-fehlberg8";
  }
  return "unknown";
}

Method method_from_string(const std::string& name) {
  for (Method m : {Method::Rk4, Method::ArkodeDp5, Method::ArkodeVerner, Method::ArkodeFehlberg8})
    if (name == to_string(m)) return m;
  throw std::invalid_argument("unknown reference method '" + name +
                              "' (valid: rk4, arkode-dp5, arkode-verner, arkode-fehlberg8)");
}

void validate(const Options& o) {
  auto fail = [](const char* what, double value, const char* rule) {
    std::ostringstream os;
    os << what << " = " << value << " " << rule;
    throw std::invalid_argument(os.str());
  };
  if (!(o.h > 0.0) || !std::isfinite(o.h)) fail("step size h", o.h, "must be positive and finite");
  if (!(o.tol >= 1e-15) || !(o.tol < 1.0)) fail("tolerance", o.tol, "must lie in [1e-15, 1)");
  if (o.max_steps < 1) fail("max_steps", static_cast<double>(o.max_steps), "must be at least 1");
}

Integrator::Integrator(const Model& model, Method method, const Options& options, double t0,
                       ConstVecRef q0, ConstVecRef v0)
    : ode_(model, {options.backend, false}), method_(method), options_(options), t_(t0) {
  validate(options);
  const int n = model.num_velocities(), nq = model.num_configuration();
  if (q0.size() != nq || v0.size() != n) {
    std::ostringstream os;
    os << "reference integrator: expected " << nq << " coordinates and " << n << " velocities, got " << q0.size()
       << " and " << v0.size();
    throw std::invalid_argument(os.str());
  }
  y_.resize(nq + n);
  y_ << q0, v0;
  for (Vector* v : {&k1_, &k2_, &k3_, &k4_, &tmp_}) v->setZero(nq + n);
  if (model.has_rigid_bodies()) q_unit_.setZero(nq);
  if (method == Method::Rk4) return;

  start_arkode(t0);
}

Integrator::~Integrator() = default;


ConstVecRef Integrator::q() const {
  const Model& model = ode_.model();
  if (!model.has_rigid_bodies()) return y_.head(model.num_configuration());
  // The quaternions the solver carries drift off the unit sphere by its error: report unit ones.
  q_unit_ = y_.head(model.num_configuration());
  for (const RigidBlock& r : model.rigid_bodies()) q_unit_.segment<4>(r.q).normalize();
  return q_unit_;
}
ConstVecRef Integrator::v() const { return y_.tail(ode_.model().num_velocities()); }

Status Integrator::fail(Status status, const std::string& why) {
  message_ = why;
  return status;
}

Status Integrator::rk4_step(double h) {
  const double* y = y_.data();
  Status s;
  if ((s = ode_.rate(t_, y, k1_.data())) != Status::Ok) return s;
  tmp_ = y_ + (0.5 * h) * k1_;
  if ((s = ode_.rate(t_ + 0.5 * h, tmp_.data(), k2_.data())) != Status::Ok) return s;
  tmp_ = y_ + (0.5 * h) * k2_;
  if ((s = ode_.rate(t_ + 0.5 * h, tmp_.data(), k3_.data())) != Status::Ok) return s;
  tmp_ = y_ + h * k3_;
  if ((s = ode_.rate(t_ + h, tmp_.data(), k4_.data())) != Status::Ok) return s;
  rhs_ += 4;
  tmp_ = y_ + (h / 6.0) * (k1_ + 2.0 * k2_ + 2.0 * k3_ + k4_);
  if (options_.project && (s = ode_.project(tmp_.data())) != Status::Ok) return s;
  if (!std::isfinite(tmp_.sum())) return Status::NonFiniteState;
  y_.swap(tmp_);
  t_ += h;
  ++steps_;
  return Status::Ok;
}

Status Integrator::rk4_trial(double h, Vector& y_out) {
  const BusyEntry entry(busy_);
  if (!entry.held()) return Status::WorkspaceBusy;
  if (method_ != Method::Rk4) return Status::MethodNotApplicable;
  y_out = y_;
  y_.swap(y_out);  // rk4_step works on y_: step the copy in its place, then put both back
  const double t = t_;
  const long steps = steps_, rhs = rhs_;
  const Status s = rk4_step(h);
  y_.swap(y_out);
  t_ = t;
  steps_ = steps;
  trial_rhs_ += rhs_ - rhs;
  rhs_ = rhs;
  return s;
}

Status Integrator::advance_to(double t) {
  const BusyEntry entry(busy_);
  if (!entry.held()) return Status::WorkspaceBusy;
  if (!(t > t_)) return fail(Status::InvalidStepSize, "advance_to: the target time must lie after t");
  if (method_ == Method::Rk4) {
    // Whole steps of h; the last one shortened to land on t (not when within round-off).
    while (t - t_ > 1e-12 * std::max(1.0, std::abs(t))) {
      const double h = std::min(options_.h, t - t_);
      const Status s = rk4_step(h);
      if (s != Status::Ok) return fail(s, std::string("RK4 step from t = ") + std::to_string(t_) +
                                              " failed: " + ode_.workspace().message());
    }
    t_ = t;
    return Status::Ok;
  }
  return arkode_advance(t);
}

namespace {
void refuse_arkode(Method method) {
  if (method != Method::Rk4)
    throw std::runtime_error(std::string("checkpoint: ") + to_string(method) +
                             ": ARKODE keeps its step-size controller's history inside SUNDIALS, which cannot save "
                             "it: a resumed run would not be the same trajectory (checkpoints work for reflection, "
                             "dla-*, rk4)");
}
}  // namespace

void Integrator::save(OutArchive& a) const {
  refuse_arkode(method_);
  a.tag("rk4");
  a(t_), a(y_), a(steps_), a(rhs_), a(trial_rhs_), a(ode_.workspace().factorizations);
  ode_.workspace().save_held(a);
}

void Integrator::load(InArchive& a) {
  refuse_arkode(method_);
  a.tag("rk4");
  a(t_), a(y_), a(steps_), a(rhs_), a(trial_rhs_), a(ode_.workspace().factorizations);
  ode_.workspace().load_held(a, 0.0);  // (a projected step leaves C(q) for the next evaluation)
}

}  // namespace nonholo::reference

// The ARKODE methods of the reference integrator (integrators.hpp): SUNDIALS' ARKStep with an
// explicit table on the index-reduced equations (CMake option NONHOLO_WITH_ARKODE; without it,
// arkode_missing.cpp refuses them).
#include <nonholo/reference/integrators.hpp>

#include <arkode/arkode_arkstep.h>
#include <arkode/arkode_butcher_erk.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>

#include <stdexcept>
#include <string>

namespace nonholo::reference {

// ARKODE on the index-reduced equations, through ARKStep with an explicit table only.
// (ERKStep of SUNDIALS 6.4.1, Debian's, integrates the Verner 6(5) table at order 3: with a
// fixed step on y'' = -y its error falls by 8 per halving, against 70 for ARKStep with the
// same table and for the table applied by hand. ARKStep gives both tables their order.)
// The right-hand side and the projection reach the Integrator through the user data; a
// failure there is unrecoverable for ARKODE and is reported with the library's message.
struct Integrator::Arkode {
  SUNContext context = nullptr;
  N_Vector y = nullptr;
  void* memory = nullptr;
  ARKodeButcherTable table = nullptr;
  Integrator* owner = nullptr;
  Status failure = Status::Ok;

  ~Arkode() {
    if (memory) ARKStepFree(&memory);
    if (table) ARKodeButcherTable_Free(table);
    if (y) N_VDestroy(y);
    if (context) SUNContext_Free(&context);
  }

  static int rhs(realtype t, N_Vector y, N_Vector ydot, void* data) {
    auto* self = static_cast<Arkode*>(data);
    ++self->owner->rhs_;
    const Status s = self->owner->ode_.rate(t, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot));
    if (s == Status::Ok) return 0;
    self->failure = s;
    return -1;
  }
  static int project(realtype, N_Vector y, void* data) {
    auto* self = static_cast<Arkode*>(data);
    const Status s = self->owner->ode_.project(N_VGetArrayPointer(y));
    if (s == Status::Ok) return 0;
    self->failure = s;
    return -1;
  }
};

void Integrator::ArkodeDeleter::operator()(Arkode* arkode) const { delete arkode; }

// The solver on y_ (in place), from t0, with the method's table, the tolerances and the projection.
void Integrator::start_arkode(double t0) {
  const int n = static_cast<int>(y_.size());
  arkode_.reset(new Arkode());
  Arkode& a = *arkode_;
  a.owner = this;
  auto check = [](bool ok, const char* what) {
    if (!ok) throw std::runtime_error(std::string("ARKODE: ") + what + " failed");
  };
  check(SUNContext_Create(nullptr, &a.context) == 0, "SUNContext_Create");
  a.y = N_VMake_Serial(n, y_.data(), a.context);  // ARKODE works on y_ in place
  check(a.y != nullptr, "N_VMake_Serial");
  a.memory = ARKStepCreate(Arkode::rhs, nullptr, t0, a.y, a.context);
  check(a.memory != nullptr, "ARKStepCreate");
  a.table = ARKodeButcherTable_LoadERK(method_ == Method::ArkodeDp5       ? ARKODE_DORMAND_PRINCE_7_4_5
                                       : method_ == Method::ArkodeFehlberg8 ? ARKODE_FEHLBERG_13_7_8
                                                                         : ARKODE_VERNER_8_5_6);
  check(a.table != nullptr, "ARKodeButcherTable_LoadERK");
  check(ARKStepSetTables(a.memory, a.table->q, a.table->p, nullptr, a.table) == ARK_SUCCESS, "ARKStepSetTables");
  check(ARKStepSetUserData(a.memory, &a) == ARK_SUCCESS, "ARKStepSetUserData");
  check(ARKStepSStolerances(a.memory, options_.tol, options_.tol) == ARK_SUCCESS, "ARKStepSStolerances");
  check(ARKStepSetMaxNumSteps(a.memory, options_.max_steps) == ARK_SUCCESS, "ARKStepSetMaxNumSteps");
  if (options_.project)
    check(ARKStepSetPostprocessStepFn(a.memory, Arkode::project) == ARK_SUCCESS, "ARKStepSetPostprocessStepFn");
}

Status Integrator::arkode_advance(double t) {
  // A stop time at every output: ARKODE's interpolated outputs were measured 100 times less
  // accurate than its steps (sleigh, tol 1e-8: 2.3e-6 against 2.7e-8 at t = 10, with the
  // Lagrange or the Hermite interpolant), so it lands on t. The price: its step cannot exceed
  // the output interval (the run warns when that capped it, docs/results/speed-against-error.md).
  Arkode& a = *arkode_;
  a.failure = Status::Ok;
  ARKStepSetStopTime(a.memory, t);
  realtype reached = t_;
  const int flag = ARKStepEvolve(a.memory, t, a.y, &reached, ARK_NORMAL);
  long n_steps = 0;
  ARKStepGetNumSteps(a.memory, &n_steps);
  steps_ = n_steps;
  t_ = reached;
  if (flag < 0) {
    const Status s = a.failure != Status::Ok ? a.failure : Status::OdeSolverFailure;
    return fail(s, std::string("ARKODE stopped at t = ") + std::to_string(reached) + ": " +
                       ARKStepGetReturnFlagName(flag) +
                       (a.failure != Status::Ok ? std::string(": ") + ode_.workspace().message()
                                                : std::string(": loosen --tol, or the equations are singular "
                                                              "or stiff here (try the reflection method)")));
  }
  return Status::Ok;
}

}  // namespace nonholo::reference

#pragma once
/// @file
/// What a step reports. The hot path never throws: a failed step returns one of these and
/// leaves the State exactly as it was; Workspace::message() has the detail.
namespace nonholo {

/// The outcome of a step or a run; to_string() gives its name.
enum class Status {
  Ok,                   ///< success
  InvalidStepSize,      ///< h not positive and finite
  SizeMismatch,         ///< state vectors do not have the model's sizes
  WorkspaceMismatch,    ///< the workspace was built for another model
  NonFiniteOneForms,    ///< mu(q) has NaN or Inf entries
  NonFiniteState,       ///< the new q, p or lambda would not be finite
  DependentOneForms,    ///< C singular: the one-forms are linearly dependent here
  NearlyDependentOneForms,  ///< a pivot of C below the tolerance (e.g. a jackknifing train)
  LinearSolverFailure,  ///< the sparse solver failed (memory, size, invalid input)
  GapNotConverged,      ///< holonomic mode: g(q_{k+1}) = 0 not reached within the iterations
  OdeSolverFailure,     ///< a reference ODE solver gave up (ARKODE: too much work, error test)
  NewtonNotConverged,   ///< an implicit step's Newton iteration did not converge
  MethodNotApplicable,  ///< e.g. an explicit method on a model with a configuration metric
  InvalidInput,         ///< a batch trajectory whose set-up was refused (message says why)
  RestartFailed,        ///< a multiplier restart could not keep the energy (restart.hpp)
  InvalidOptions,       ///< the step's options break a rule (the message names the field)
  CallbackFailed,       ///< a model callback threw; the message has its text
  UnstableStepSize,     ///< h at or beyond the explicit method's stability limit (stability.hpp)
  BlewUp,               ///< a run's energy error passed 50%, a constraint bound or its diagnostics overflowed
  Interrupted,          ///< a run stopped by SIGINT (the command-line tool)
  LegendreNotSolved,    ///< a rigid body's discrete Legendre transform has no solution (h |Omega| too large)
  Inaccurate,           ///< a run whose estimated error exceeds its accuracy tolerance (results kept)
  WorkspaceBusy,        ///< another call is using the workspace (busy_flag.hpp); its message is that call's
  PrecisionLoss,        ///< a run's coordinates are so large that a step's displacement is below their ulp
  StepSizeTooSmall,     ///< adaptive steps: the error test failed down to the smallest step allowed
  Stopped,              ///< a run ended by one of its stop conditions (results kept)
};
/// The last enumerator (for loops over all of them, the Python enum's).
inline constexpr Status kLastStatus = Status::Stopped;

/// The status's name as the summary line prints it: "ok", "gap-not-converged", ...
const char* to_string(Status status);

}  // namespace nonholo

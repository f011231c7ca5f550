// The step statuses' names (status.hpp), and require_held's refusal of a busy workspace (busy_flag.hpp).
#include <nonholo/busy_flag.hpp>
#include <nonholo/status.hpp>

#include <stdexcept>
#include <string>

namespace nonholo {

const char* to_string(Status status) {
  switch (status) {
    case Status::Ok: return "ok";
    case Status::InvalidStepSize: return "invalid-step-size";
    case Status::SizeMismatch: return "size-mismatch";
    case Status::WorkspaceMismatch: return "workspace-mismatch";
    case Status::NonFiniteOneForms: return "non-finite-one-forms";
    case Status::NonFiniteState: return "non-finite-state";
    case Status::DependentOneForms: return "dependent-one-forms";
    case Status::NearlyDependentOneForms: return "nearly-dependent-one-forms";
    case Status::LinearSolverFailure: return "linear-solver-failure";
    case Status::GapNotConverged: return "gap-not-converged";
    case Status::OdeSolverFailure: return "ode-solver-failure";
    case Status::NewtonNotConverged: return "newton-not-converged";
    case Status::MethodNotApplicable: return "method-not-applicable";
    case Status::InvalidInput: return "invalid-input";
    case Status::RestartFailed: return "restart-failed";
    case Status::InvalidOptions: return "invalid-options";
    case Status::CallbackFailed: return "callback-failed";
    case Status::UnstableStepSize: return "unstable-step-size";
    case Status::BlewUp: return "blew-up";
    case Status::Interrupted: return "interrupted";
    case Status::LegendreNotSolved: return "legendre-not-solved";
    case Status::Inaccurate: return "inaccurate";
    case Status::WorkspaceBusy: return "workspace-busy";
    case Status::PrecisionLoss: return "precision-loss";
    case Status::StepSizeTooSmall: return "step-size-too-small";
    case Status::Stopped: return "stopped";
  }
  return "unknown";
}

void require_held(const BusyEntry& entry, const char* call) {
  if (!entry.held())
    throw std::invalid_argument(std::string("workspace-busy: ") + call +
                                ": the workspace is in use by another call (another thread, or a model callback "
                                "inside a step on it): give each thread its own workspace, and do not step or "
                                "start on a workspace from its own model's callbacks");
}

}  // namespace nonholo

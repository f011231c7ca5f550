#pragma once
// The reflection integrator of Ferraro, Iglesias and Martin de Diego for a constant metric:
// the explicit nonholonomic RATTLE of DESIGN.md section 2, one factorisation of
// C = mu M^-1 mu^T per step. With f = 0 it is exactly p_{k+1/2} = (P - Q)*_{q_k} p_{k-1/2}.
#include <nonholo/model.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

namespace nonholo {

struct RattleOptions {
  double h = 0.01;  // time step
  // Smallest accepted pivot of C relative to its diagonal (squared sine of the angle between
  // a one-form and the span of the others). Below it the step refuses: nearly dependent
  // one-forms would make lambda meaningless.
  double min_pivot_ratio = 1e-12;
};

// Throws std::invalid_argument with the offending value.
void validate(const RattleOptions& options);

// One step t_k -> t_k + h. Never throws and never allocates. On failure the state is left
// exactly as it was and ws.message() says why.
Status step(const Model& model, Workspace& ws, State& state, const RattleOptions& options);

}  // namespace nonholo

#pragma once
/// @file
/// The reflection integrator of Ferraro, Iglesias and Martin de Diego for a constant metric:
/// the explicit nonholonomic RATTLE of docs/design.md §2, one factorisation of
/// C = mu M^-1 mu^T per step. With f = 0 it is exactly p_{k+1/2} = (P - Q)*_{q_k} p_{k-1/2}.
/// One method, two names: "the reflection method" in the docs, on the command line and in Python,
/// RATTLE (the step it computes) in the code: rattle.hpp, RattleOptions, core/src/step/rattle.cpp
/// (docs/layout.md).
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

#include <string>

namespace nonholo {

/// One step t_k -> t_k + h (composed when options.order > 2), then (as options.restart asks) the measurement of the parasitic
/// amplitude and a restart at t_{k+1}. Never throws and never allocates. On failure the state
/// is left exactly as it was and ws.message() says why and what would help. On success the
/// state's vectors have been swapped with workspace buffers (see State), ws.parasitic holds the
/// amplitude measured at t_{k+1} (NaN when not measured) and ws.restarted whether the step
/// restarted (then state.restarts was incremented).
Status step(const Model& model, Workspace& ws, State& state, const RattleOptions& options);

}  // namespace nonholo

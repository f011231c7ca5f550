#pragma once
// The plain step without its argument checks, for the composed step (composed_step.cpp).
#include <nonholo/rattle.hpp>

namespace nonholo::detail {

// One plain step of signed size h from s.t, arriving at time t_next (the forces see it), then,
// when `watch` is given, the control of the period-2 mode that step() does. Commits s.t, q, p,
// lambda and force on success (not steps, restarts or watch); on failure the state is unchanged.
Status advance(const Model& model, Workspace& ws, State& s, const RattleOptions& options, double h, double t_next,
               ModeWatch* watch);

// One composed step of H = options.h (composition.hpp); the state is unchanged on failure.
Status composed_step(const Model& model, Workspace& ws, State& s, const RattleOptions& options);

}  // namespace nonholo::detail

#pragma once
// dynamics.hpp's functions without taking the workspace (busy_flag.hpp): for the integrators
// and starts that already hold it.
#include <nonholo/model.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

namespace nonholo::detail {

Status one_form_bias(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef qdot, VecRef bias);
Status constraint_bias(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef qdot, VecRef bias);
Status project_momentum(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p, VecRef p_out,
                        double min_pivot_ratio);
Status constraint_multiplier(const Model& model, Workspace& ws, double t, ConstVecRef q, ConstVecRef qdot,
                             VecRef lambda, double min_pivot_ratio);

}  // namespace nonholo::detail

#pragma once
// The drift of the reflection step as a per-body operation, for models with rigid bodies
// (the flat models keep rattle.cpp's single loop): a planar or general body moves by
// q + h M^-1 p and carries p unchanged; a rigid body's orientation moves by the W its discrete
// Legendre transform gives (legendre.hpp), R <- R W, renormalised, and its momentum arrives as
// W^T p_Omega; its centre moves as a flat body's. Also the gyroscopic term of the continuous
// equations, and the step back to q_{k-1} that the potential's average needs.
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

namespace nonholo::detail {

// q_out = the configuration a step of signed size h reaches from q with post-momentum p
// (velocity = M^-1 p), p_out = the pre-momentum there (may be null: not wanted). Returns -1,
// or the index of the first rigid body whose transform has no solution (q_out, p_out then
// partly written). `iterations`: the most Newton iterations any body took.
int drift(const Model& model, RotationLagrangian rotation, double h, const double* q, const double* p,
          const double* velocity, double* q_out, double* p_out, int& iterations);

// The step's drift on a workspace: from q with ws.p_half to ws.q_next and ws.p_arrive, then
// ws.velocity = M^-1 ws.p_arrive; ws.legendre_iterations is raised to the Newton iterations
// taken. With `kick`, ws.p_half = kick->p + (h/2) kick->force first (the step's half kick, in
// the same pass where it can). Status::LegendreNotSolved (naming the body, h |Omega| and t)
// when a body's transform has no solution.
Status rigid_drift(const Model& model, Workspace& ws, ConstVecRef q, double h, RotationLagrangian rotation,
                   double t, const State* kick = nullptr);

// The potential at the configuration a step of size h came from: q_{k-1}, reached from q by a
// step of -h with the pre-momentum p_minus (velocity v_minus = M^-1 p_minus), into q_prev
// (n_q entries). NaN when a rigid body's transform back has no solution.
double previous_potential(const Model& model, RotationLagrangian rotation, double h, ConstVecRef q,
                          ConstVecRef p_minus, ConstVecRef v_minus, VecRef q_prev);

// The post-momentum at q0 of a step of size h that lands on q1 (the discrete Legendre
// transform of (q0, q1)): M (q1 - q0) / h on flat blocks and translations, legendre_momentum
// for the orientations. Throws std::invalid_argument when a body turns by more than 90 degrees.
void discrete_momentum(const Model& model, RotationLagrangian rotation, ConstVecRef q0, ConstVecRef q1, double h,
                       VecRef p);

}  // namespace nonholo::detail

#pragma once
/// @file
/// Consistent initial states for the reflection integrator (docs/design.md §2, start-up).
/// These are set-up calls: they throw std::invalid_argument with a precise message on bad
/// input (sizes, non-finite values, (q0, q1) outside M0, one-forms dependent at q0 — the
/// message names the row and its label).
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>
#include <nonholo/state.hpp>
#include <nonholo/workspace.hpp>

namespace nonholo {

/// What lambda~_0 a start from a velocity sets.
enum class InitialMultiplier {
  Continuous,  ///< lambda~_0 = lambda(0) of the index-reduced equations (the accurate choice)
  Zero,        ///< lambda~_0 = 0 (about 16 times the error on the sleigh; for comparison)
};

/// The options of start_from_velocity().
struct StartOptions {
  InitialMultiplier multiplier = InitialMultiplier::Continuous;  ///< how lambda~_0 is set
  double min_pivot_ratio = 1e-12;  ///< smallest accepted pivot of C(q0) relative to its diagonal
  /// Largest accepted |gap| of a holonomic row (a closed hitch) at q0, relative to 1 + |q0|_inf,
  /// as scene files check theirs. An open hitch is refused: the first step would close it with a
  /// velocity kick of 2 gap / h. Infinity lets the step close any gap.
  double max_gap = 1e-9;
};

/// Projects the velocity guess M-orthogonally onto D(q0): p~_0 = P* M v_guess, then sets
/// lambda~_0 as asked. q0 has n_q entries, v_guess n_v (a rigid body: Omega in the body frame,
/// then the centre's velocity); each rigid body's quaternion must have norm 1 to within 1e-6
/// and is normalised. Holonomic rows must hold at q0 (StartOptions::max_gap).
State start_from_velocity(const Model& model, Workspace& ws, double t0, ConstVecRef q0,
                          ConstVecRef v_guess, const StartOptions& options = {});

/// The paper's start from (q0, q1) in M0 (its Remark in section 5): p~_0 = M (q1 - q0)/h -
/// (h/2) f(t0, q0), lambda~_0 = 0, so that the first step lands exactly on q1. Throws if
/// a row of mu(q0) M^-1 p~_0 = 0 fails by more than tolerance |mu_a|_1 |M^-1 p~_0|_inf.
/// With rigid bodies the post-momentum is the discrete Legendre transform of (q0, q1) for
/// `rotation` (the step's RattleOptions::rotation must be the same for it to land on q1).
State start_from_two_points(const Model& model, Workspace& ws, double t0, ConstVecRef q0,
                            ConstVecRef q1, double h, double tolerance = 1e-10,
                            RotationLagrangian rotation = RotationLagrangian::MoserVeselov);

}  // namespace nonholo

#pragma once
// The horizontal symmetries of rolling balls (docs/guide/rigid-bodies.md), as generators in velocity
// space for ModelBuilder::symmetry: each ball's spin about the vertical through its centre, and
// all balls rolling together about a horizontal space axis. Both lie in the rolling (and rod)
// constraints' distribution, so their momentum maps are exact invariants of the scheme.
#include <nonholo/types.hpp>

#include <vector>

namespace nonholo::scenarios {

// Where a ball's entries are: its quaternion at q[q], its Omega at v[v], its centre's velocity
// (2 or 3 entries) at v[v + 3].
struct BallSlots {
  int q, v;
  int translation = 2;  ///< its centre's velocity entries
};

// Omega = gamma = R^T e3 on this ball, nothing else moves: J = p_Omega . gamma (the generator,
// and J computed directly from the ball's own entries). The generator writes the ball's own
// entries only: declare it local to the ball (ModelBuilder::symmetry's `body`).
SymmetryGenerator vertical_spin(BallSlots ball);
MomentumMap vertical_spin_value(BallSlots ball);
// Every ball turning at unit rate about the horizontal space axis e_j (j = 0: x, 1: y) and
// rolling with it: Omega_i = R_i^T e_j, xdot_i = r e_j x e3.
SymmetryGenerator rolling(std::vector<BallSlots> balls, double radius, int j);

}  // namespace nonholo::scenarios

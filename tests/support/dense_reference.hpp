#pragma once
// A second, deliberately naive implementation of the scheme with dense matrices: full M
// assembled from the blocks and inverted densely, mu scattered into a dense m x n matrix,
// C solved by a pivoting LU. Shares only the model's callbacks with the library.
#include <nonholo/model.hpp>
#include <nonholo/state.hpp>

#include <Eigen/Dense>

namespace nonholo::testing {

Eigen::MatrixXd dense_mass(const Model& model);
Eigen::MatrixXd dense_one_forms(const Model& model, ConstVecRef q);
Vector dense_applied_force(const Model& model, double t, ConstVecRef q);

// p - mu^T C^-1 mu M^-1 p.
Vector dense_project(const Model& model, ConstVecRef q, ConstVecRef p);
// C lambda = -bias - mu M^-1 f with the model's analytic bias.
Vector dense_multiplier(const Model& model, double t, ConstVecRef q, ConstVecRef qdot);
// (P - Q)* at q, as a dense n x n matrix acting on momenta.
Eigen::MatrixXd dense_reflection(const Model& model, ConstVecRef q);
// docs/design.md section 2, line by line.
void dense_rattle_step(const Model& model, State& state, double h);

}  // namespace nonholo::testing

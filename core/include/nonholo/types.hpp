#pragma once
/// @file
/// Vector types and the callback signatures a Model is built from. q has the model's n_q
/// entries; velocities (qdot), momenta, forces, gradients and the columns of mu have n_v
/// (nonholo/model.hpp; equal unless the model has 3-D rigid bodies).
#include <nonholo/build_config.hpp>

#include <Eigen/Core>
#include <functional>

namespace nonholo {

using Vector = Eigen::VectorXd;  ///< a dense vector of doubles
using VecRef = Eigen::Ref<Eigen::VectorXd>;  ///< a vector to write into (a Vector or a contiguous segment)
using ConstVecRef = Eigen::Ref<const Eigen::VectorXd>;  ///< a vector to read

/// Values of the one-forms mu(q), row by row, in the order of each row's columns as
/// declared in the pattern (nnz values). Must be a pure function of q (it is called from
/// several threads and its result may be cached).
using OneFormValues = std::function<void(ConstVecRef q, VecRef values)>;
/// The bias term (d/dt mu(q(t))) qdot, one entry per row: sum_ij d mu_ai / d q_j qdot_j qdot_i.
using OneFormBias = std::function<void(ConstVecRef q, ConstVecRef qdot, VecRef bias)>;
using Potential = std::function<double(ConstVecRef q)>;  ///< the potential energy V(q)
/// The gradient has n_v entries; for a rigid body its angular part is the left-trivialised
/// derivative (d/ds V(R exp(s hat(e_i))) at s = 0), the negative of the body-frame torque.
using PotentialGradient = std::function<void(ConstVecRef q, VecRef gradient)>;
/// Generalised external forces / controls F(t, q); must write all n_v entries (a rigid body:
/// the torque in its body frame, then the force on its centre in space).
using ExternalForce = std::function<void(double t, ConstVecRef q, VecRef force)>;
/// The gaps g(q) of the holonomic constraints (hitches), one entry per holonomic row, in
/// the order the rows were declared. Those rows of mu must be the gradients dg/dq.
using ConstraintGap = std::function<void(ConstVecRef q, VecRef gap)>;
/// A configuration-dependent metric M(q) (dense n x n, SPD) and its partial derivative
/// dM/dq_i, for systems whose kinetic energy is not constant in the chosen coordinates (the
/// sleigh in contact-point coordinates). Integrated by the implicit general form only.
///@{
using MatRef = Eigen::Ref<Eigen::MatrixXd>;  ///< a dense matrix to write into
using MetricValue = std::function<void(ConstVecRef q, MatRef metric)>;
using MetricDerivative = std::function<void(ConstVecRef q, int i, MatRef derivative)>;
///@}
/// A scalar momentum map J(q, p), for example <p, xi_Q(q)> for a symmetry xi.
using MomentumMap = std::function<double(ConstVecRef q, ConstVecRef p)>;
/// The generator xi(q) of a horizontal symmetry in velocity space (n_v entries; for a rigid
/// body left-trivialised: the body-frame angular velocity, then the centre's velocity), lying
/// in the constraint distribution D(q): its momentum map is J = <xi(q), p>.
using SymmetryGenerator = std::function<void(ConstVecRef q, VecRef xi)>;

}  // namespace nonholo

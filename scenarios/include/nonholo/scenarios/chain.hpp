#pragma once
/// @file
/// Chains of Chaplygin sleighs (docs/design.md §5): body i has centre C_i, heading theta_i,
/// a blade a_i behind the centre, a rear hitch at C_i - d_i e(theta_i) joined to the front
/// hitch of body i+1 at C_{i+1} + f_{i+1} e(theta_{i+1}). Each hitch is a holonomic
/// constraint g_i = 0 (two rows of mu, declared with ModelBuilder::add_holonomic_row).
/// Rows are ordered body by body (blade i, hitch i x, hitch i y), so C is banded.
#include <nonholo/scenarios/scene.hpp>

#include <functional>
#include <vector>

namespace nonholo::scenarios {

/// Largest chain the scenes build (CHOLMOD runs with int indices; the factor has ~12 N entries).
inline constexpr long kMaxChainBodies = 10'000'000;

/// One sleigh of the chain.
struct ChainBody {
  /// Mass m, inertia I about the centre of mass, blade a behind the centre, rear hitch d behind
  /// and front hitch f ahead of it (see chain.hpp).
  ///@{
  double m = 1.0, I = 1.0, a = 0.2, d = 0.5, f = 0.5;
  ///@}
};

/// A chain to build (build_chain()).
struct ChainSpec {
  std::vector<ChainBody> bodies;  ///< front (body 0) to rear
  bool hitched = true;  ///< false: independent sleighs, coupled only by the springs
  double k = 0.0;       ///< torsional springs V = (k/2) sum (theta_i - theta_{i+1})^2
  /// Initial velocity guess: body 0 moves with forward speed v0 and turn rate omega0, the
  /// others rest; the start projects it M-orthogonally onto D(q_0).
  ///@{
  double v0 = 1.0, omega0 = 0.5;
  ///@}
  /// Drive of body 0 (either may be empty): a force along its heading and a torque.
  ///@{
  std::function<double(double t)> lead_force, lead_torque;
  ///@}
};

/// Throws std::invalid_argument for an empty chain or a non-positive m, I, d or f.
SceneSetup build_chain(const ChainSpec& spec);

}  // namespace nonholo::scenarios

#pragma once
/// @file
/// Orders 4, 6 and 8 by composition (README "Higher order"). The plain step Phi_h = R o phi_h is
/// an involution R of lambda~ after a map phi_h near the identity; Phi is symmetric, so
/// R phi_h R = phi*_h and two plain steps of sizes h1, h2 are phi*_h2 o phi_h1. An even,
/// palindromic sequence of plain steps of sizes c_1 H, ..., c_2s H is therefore a composition of
/// a first-order map and its adjoint, and the order conditions of composition and splitting
/// methods apply (Hairer, Lubich and Wanner, Geometric Numerical Integration, II.5 and V.3).
/// The classical tables compose the symmetric double step Psi_{gamma H} = Phi_{gamma H/2} o
/// Phi_{gamma H/2}: their plain steps are c = (gamma_1/2, gamma_1/2, gamma_2/2, ...).
/// lambda~ is carried from one plain step to the next; the period-2 mode's measurement, the
/// energy projection and the restart happen at the composed step's end only.
/// RattleOptions::order (and RattleOptions::composition) select it; step() then advances by H = options.h.
#include <string>

namespace nonholo {

/// The composition of plain steps that makes a step of order 4, 6 or 8 (RattleOptions::composition).
enum class Composition {
  /// the default for the order: none for 2, BlanesMoan4 for 4, BlanesMoan6 for 6,
  /// KahanLi17 for 8 (README "Higher order": each measured the most accurate per
  /// factorisation of its order on the sleigh and the 10-body chain);
  Auto,
  TripleJump,   ///< order 4, 3 double steps (Yoshida's triple jump; one coefficient is -1.70);
  Suzuki5,      ///< order 4, 5 double steps (Suzuki's fractal);
  Yoshida7,     ///< order 6, 7 double steps (Yoshida 1990, solution A);
  KahanLi9,     ///< order 6, 9 double steps (Kahan and Li 1997, s9odr6a);
  BlanesMoan4,  ///< order 4, 12 plain steps (Blanes and Moan 2002, splitting S4 with 6 stages);
  BlanesMoan6,  ///< order 6, 20 plain steps (Blanes and Moan 2002, splitting S6 with 10 stages);
  McLachlan15,  ///< order 8, 15 double steps (McLachlan 1995, s15odr8);
  KahanLi17     ///< order 8, 17 double steps (Kahan and Li 1997, s17odr8a).
};
const char* to_string(Composition composition);  ///< "auto", "triple-jump", "suzuki5", ...
/// Throws std::invalid_argument naming the valid choices.
Composition composition_from_string(const std::string& name);
/// The compositions of each order, for messages: "order 4: triple-jump, suzuki5, ...; order 6: ...".
std::string composition_choices();

/// A composed step of size H: `steps` plain steps of sizes c[0] H, ..., c[steps-1] H
/// (palindromic, summing to 1), each one factorisation.
struct CompositionScheme {
  Composition composition;  ///< the scheme's name (never Auto once resolved, except for order 2)
  int order;        ///< 2, 4, 6 or 8
  int steps;        ///< 0 for the plain step (order 2, Auto)
  const double* c;  ///< steps coefficients, c[i] = c[steps-1-i]
};

/// The scheme that `composition` (resolved for `order` when Auto) names. Throws
// std::invalid_argument when order is not 2, 4, 6 or 8, or the composition has another order.
CompositionScheme composition_scheme(int order, Composition composition = Composition::Auto);

}  // namespace nonholo

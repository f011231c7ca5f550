#pragma once
// Orders 4 and 6 by composition (DESIGN.md section 9, README "Higher order"). The plain step
// Phi_h is not near the identity in lambda~ (the period-2 mode), so composing it directly
// stalls at order 4; the double step Psi_H = Phi_{H/2} o Phi_{H/2} is symmetric and near the
// identity, and Psi_{gamma_1 H} o ... o Psi_{gamma_s H} reaches the composition's order.
// RattleOptions::order (and ::composition) select it; step() then advances by H = options.h.
#include <string>

namespace nonholo {

//   Auto        the default for the order: none for 2, Suzuki5 for 4, KahanLi9 for 6;
//   TripleJump  order 4, 3 stages (Yoshida's triple jump; one coefficient is -1.70);
//   Suzuki5     order 4, 5 stages (Suzuki's fractal; smaller error constant than TripleJump);
//   Yoshida7    order 6, 7 stages (Yoshida's solution A);
//   KahanLi9    order 6, 9 stages (Kahan and Li's s9odr6a; measured more accurate per
//               factorisation than Yoshida7, README "Higher order").
enum class Composition { Auto, TripleJump, Suzuki5, Yoshida7, KahanLi9 };
const char* to_string(Composition composition);  // "auto", "triple-jump", "suzuki5", ...
// Throws std::invalid_argument naming the valid choices.
Composition composition_from_string(const std::string& name);

// The coefficients gamma_1 ... gamma_s of a composition (symmetric, summing to 1).
struct CompositionScheme {
  Composition composition;
  int order;
  int stages;           // s: a composed step takes 2 s plain steps (factorisations)
  const double* gamma;  // s coefficients, gamma_i = gamma_{s+1-i}
};

// The scheme that `composition` (resolved for `order` when Auto) names. Throws
// std::invalid_argument when order is not 2, 4 or 6, or the composition has another order.
// Order 2 with Auto is the plain step, reported as stages = 0.
CompositionScheme composition_scheme(int order, Composition composition = Composition::Auto);

}  // namespace nonholo

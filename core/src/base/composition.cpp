// The composition tables of orders 4, 6 and 8 (composition.hpp): each scheme's substep
// coefficients c_i, the names and defaults of the schemes, and the lookups the options and the
// composed step (step/composed_step.cpp) use.
#include <nonholo/composition.hpp>

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "base/option_checks.hpp"

namespace nonholo {
namespace {

// Tables of double steps Psi_{gamma H}: plain steps (gamma_1/2, gamma_1/2, gamma_2/2, ...).
template <std::size_t S>
constexpr std::array<double, 2 * S> halved(const std::array<double, S>& gamma) {
  std::array<double, 2 * S> c{};
  for (std::size_t i = 0; i < S; ++i) c[2 * i] = c[2 * i + 1] = 0.5 * gamma[i];
  return c;
}

// A symmetric splitting e^{a_1 A} e^{b_1 B} ... e^{b_m B} e^{a_{m+1} A} as a composition of
// a first-order map and its adjoint (Hairer, Lubich and Wanner, II.5, eq. (5.6) with the roles
// of a and b as there): c_1 = a_1, c_2i = b_i - c_2i-1, c_2i+1 = a_i+1 - c_2i. Its first half
// is computed; the rounding of the differences would break the second's symmetry.
template <std::size_t M>
constexpr std::array<double, 2 * M> from_splitting(const std::array<double, M + 1>& a,
                                                   const std::array<double, M>& b) {
  std::array<double, 2 * M> c{};
  c[0] = a[0];
  for (std::size_t i = 1; i < M; ++i) c[i] = (i % 2 ? b[i / 2] : a[i / 2]) - c[i - 1];
  for (std::size_t i = 0; i < M; ++i) c[2 * M - 1 - i] = c[i];  // the second half: the mirror, exactly
  return c;
}

// Yoshida's triple jump and Suzuki's fractal: gamma = 1 / (k - k^(1/3)) for the outer stages
// and 1 - (k - 1) gamma in the middle (k = 2, 4).
constexpr auto kTripleJump = halved<3>({1.3512071919596576340, -1.7024143839193152681, 1.3512071919596576340});
constexpr double kS = 0.41449077179437573714;
constexpr auto kSuzuki5 = halved<5>({kS, kS, -0.65796308717750294857, kS, kS});
// Yoshida (1990), solution A: w3 w2 w1 w0 w1 w2 w3 with w0 = 1 - 2 (w1 + w2 + w3).
constexpr auto kYoshida7 =
    halved<7>({0.78451361047755726382, 0.23557321335935813368, -1.17767998417887100695, 1.31518632068391121889,
               -1.17767998417887100695, 0.23557321335935813368, 0.78451361047755726382});
// Kahan and Li (1997), s9odr6a (Hairer, Lubich and Wanner, V.3.2).
constexpr auto kKahanLi9 =
    halved<9>({0.39216144400731413928, 0.33259913678935943860, -0.70624617255763935981, 0.082213596293550800230,
               0.79854399093482996340, 0.082213596293550800230, -0.70624617255763935981, 0.33259913678935943860,
               0.39216144400731413928});
// McLachlan (1995), s15odr8 (Hairer, Lubich and Wanner, V.3.2).
constexpr double kM1 = 0.74167036435061295345, kM2 = -0.40910082580003159400, kM3 = 0.19075471029623837995,
                 kM4 = -0.57386247111608226666, kM5 = 0.29906418130365592384, kM6 = 0.33462491824529818378,
                 kM7 = 0.31529309239676659663;
constexpr auto kMcLachlan15 = halved<15>({kM1, kM2, kM3, kM4, kM5, kM6, kM7, -0.79688793935291635402, kM7, kM6,
                                          kM5, kM4, kM3, kM2, kM1});
// Kahan and Li (1997), s17odr8a (Hairer, Lubich and Wanner, V.3.2).
constexpr double kK1 = 0.13020248308889008088, kK2 = 0.56116298177510838456, kK3 = -0.38947496264484728641,
                 kK4 = 0.15884190655515560090, kK5 = -0.39590389413323757734, kK6 = 0.18453964097831570709,
                 kK7 = 0.25837438768632204729, kK8 = 0.29501172360931029887;
constexpr auto kKahanLi17 = halved<17>({kK1, kK2, kK3, kK4, kK5, kK6, kK7, kK8, -0.60550853383003451170, kK8, kK7,
                                        kK6, kK5, kK4, kK3, kK2, kK1});
// Blanes and Moan (2002), J. Comput. Appl. Math. 142, 313-330, Table 2: the general
// (non-Nystrom) symmetric splittings S4 (m = 6) and S6 (m = 10).
constexpr double kA1 = 0.0792036964311957, kA2 = 0.353172906049774, kA3 = -0.0420650803577195;
constexpr double kB1 = 0.209515106613362, kB2 = -0.143851773179818, kB3 = 0.5 - (kB1 + kB2);
constexpr auto kBlanesMoan4 = from_splitting<6>({kA1, kA2, kA3, 1.0 - 2.0 * (kA1 + kA2 + kA3), kA3, kA2, kA1},
                                                {kB1, kB2, kB3, kB3, kB2, kB1});
constexpr double kC1 = 0.0502627644003922, kC2 = 0.413514300428344, kC3 = 0.0450798897943977,
                 kC4 = -0.188054853819569, kC5 = 0.541960678450780, kC6 = 1.0 - 2.0 * (kC1 + kC2 + kC3 + kC4 + kC5);
constexpr double kD1 = 0.148816447901042, kD2 = -0.132385865767784, kD3 = 0.067307604692185,
                 kD4 = 0.432666402578175, kD5 = 0.5 - (kD1 + kD2 + kD3 + kD4);
constexpr auto kBlanesMoan6 = from_splitting<10>({kC1, kC2, kC3, kC4, kC5, kC6, kC5, kC4, kC3, kC2, kC1},
                                                 {kD1, kD2, kD3, kD4, kD5, kD5, kD4, kD3, kD2, kD1});

struct Entry {
  Composition composition;
  int order;
  int steps;
  const double* c;
};
template <std::size_t N>
constexpr Entry entry(Composition composition, int order, const std::array<double, N>& c) {
  return {composition, order, static_cast<int>(N), c.data()};
}
const Entry kTable[] = {
    entry(Composition::TripleJump, 4, kTripleJump),   entry(Composition::Suzuki5, 4, kSuzuki5),
    entry(Composition::BlanesMoan4, 4, kBlanesMoan4), entry(Composition::Yoshida7, 6, kYoshida7),
    entry(Composition::KahanLi9, 6, kKahanLi9),       entry(Composition::BlanesMoan6, 6, kBlanesMoan6),
    entry(Composition::McLachlan15, 8, kMcLachlan15), entry(Composition::KahanLi17, 8, kKahanLi17),
};

Composition default_for(int order) {
  switch (order) {
    case 4: return Composition::BlanesMoan4;
    case 6: return Composition::BlanesMoan6;
    case 8: return Composition::KahanLi17;
    default: return Composition::Auto;
  }
}

bool valid_order(int order) { return order == 2 || order == 4 || order == 6 || order == 8; }

}  // namespace

const char* to_string(Composition c) {
  switch (c) {
    case Composition::Auto: return "auto";
    case Composition::TripleJump: return "triple-jump";
    case Composition::Suzuki5: return "suzuki5";
    case Composition::Yoshida7: return "yoshida7";
    case Composition::KahanLi9: return "kahan-li9";
    case Composition::BlanesMoan4: return "blanes-moan4";
    case Composition::BlanesMoan6: return "blanes-moan6";
    case Composition::McLachlan15: return "mclachlan15";
    case Composition::KahanLi17: return "kahan-li17";
  }
  return "unknown";
}

std::string composition_choices() {
  std::string text;
  for (int order : {4, 6, 8}) {
    text += (order == 4 ? "order " : "; order ") + std::to_string(order) + ":";
    const char* sep = " ";
    for (const Entry& e : kTable)
      if (e.order == order) {
        text += sep;
        text += to_string(e.composition);
        if (e.composition == default_for(order)) text += " (auto)";
        sep = ", ";
      }
  }
  return text;
}

Composition composition_from_string(const std::string& name) {
  if (name == "auto") return Composition::Auto;
  for (const Entry& e : kTable)
    if (name == to_string(e.composition)) return e.composition;
  throw std::invalid_argument("unknown composition '" + name + "' (valid: auto; " + composition_choices() + ")");
}

namespace detail {

bool find_composition(int order, Composition c, CompositionScheme& scheme) {
  if (!valid_order(order)) return false;
  if (c == Composition::Auto) c = default_for(order);
  if (c == Composition::Auto) {
    scheme = {c, 2, 0, nullptr};
    return true;
  }
  for (const Entry& e : kTable)
    if (e.composition == c) {
      scheme = {c, e.order, e.steps, e.c};
      return e.order == order;
    }
  return false;
}

}  // namespace detail

CompositionScheme composition_scheme(int order, Composition c) {
  if (!valid_order(order))
    throw std::invalid_argument("order = " + std::to_string(order) + " must be 2, 4, 6 or 8");
  CompositionScheme scheme;
  if (!detail::find_composition(order, c, scheme))
    throw std::invalid_argument(std::string("composition ") + to_string(c) + " is not of order " +
                                std::to_string(order) + " (" + composition_choices() + ")");
  return scheme;
}

}  // namespace nonholo

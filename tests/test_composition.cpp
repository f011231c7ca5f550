// Orders 4 and 6 by composing the double step (composition.hpp, docs/design.md section 9): the
// coefficient tables against the order conditions; the orders measured against the sleigh's
// exact solution and against tight ARKODE references on a chain (both hitch modes), a driven
// train and a controlled snakeboard; the energy of p~, the constraints and the snakeboard's
// rotor momentum over long runs; the symmetry of the composition; what a failed composed
// step leaves; the cost in factorisations.
#include <nonholo/composition.hpp>
#include <nonholo/diagnostics.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/reference/integrators.hpp>
#include <nonholo/scenarios/exact_solutions.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include "support/driven_particle.hpp"
#include "support/scenes.hpp"
#include "support/expect_error.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <tuple>

namespace nonholo {
namespace {

using testing::scene;

RattleOptions composed(int order, double H, HitchMode hitch = HitchMode::Holonomic, const char* restart = "auto") {
  RattleOptions o;
  o.h = H;
  o.order = order;
  o.hitch = hitch;
  set_restart(o.restart, restart);
  return o;
}

using testing::reference_at;

// q at T after whole composed steps of H.
Vector configuration_at(const scenarios::SceneSetup& setup, const RattleOptions& o, double T) {
  return testing::state_at(setup, o, T).q;
}

// Error ratio between H and H/2 against `truth`.
double ratio(const scenarios::SceneSetup& setup, int order, double H, HitchMode hitch, ConstVecRef truth, double T,
             const char* label) {
  const double e1 = (configuration_at(setup, composed(order, H, hitch), T) - truth).lpNorm<Eigen::Infinity>();
  const double e2 = (configuration_at(setup, composed(order, H / 2, hitch), T) - truth).lpNorm<Eigen::Infinity>();
  std::cout << label << " order " << order << " hitch " << to_string(hitch) << ": error " << e1 << " at H = " << H
            << ", " << e2 << " at H/2, ratio " << e1 / e2 << "\n";
  return e1 / e2;
}

const Composition kAll[] = {Composition::TripleJump, Composition::Suzuki5,     Composition::BlanesMoan4,
                             Composition::Yoshida7,   Composition::KahanLi9,    Composition::BlanesMoan6,
                             Composition::McLachlan15, Composition::KahanLi17};

int order_of(Composition c) {
  for (int order : {4, 6, 8}) {
    try {
      return composition_scheme(order, c).order;
    } catch (const std::invalid_argument&) {
    }
  }
  return 0;
}

// An independent test bed for the tables: a splitting of H = T(p) + V(q) with two degrees of
// freedom and a kinetic term that is not quadratic (so no Nystrom simplification holds), whose
// two flows are exact. phi_h = flow_T(h) o flow_V(h) is a first-order method and phi*_h =
// flow_V(h) o flow_T(h) its adjoint; plain step i of a composition is phi (i even) or phi* (i
// odd), as the reflection step's plain steps are (composition.hpp). In long double, so that
// the tables' own rounding (1e-16) is what limits the errors.
using Pair = Eigen::Matrix<long double, 4, 1>;  // q1, q2, p1, p2

void flow_t(Pair& y, long double h) {
  const long double p1 = y[2], p2 = y[3];
  y[0] += h * (p1 + 0.2L * p1 * p2 * p2 + 0.1L * p1 * p1 * p1);
  y[1] += h * (p2 + 0.2L * p1 * p1 * p2);
}
void flow_v(Pair& y, long double h) {
  const long double q1 = y[0], q2 = y[1];
  y[2] -= h * (std::sin(q1) - 0.3L * std::sin(q1 - q2));
  y[3] -= h * (std::sin(q2) + 0.3L * std::sin(q1 - q2) + 0.5L * q2 * q2);
}

Pair compose(const CompositionScheme& s, Pair y, long double H, int steps) {
  for (int n = 0; n < steps; ++n)
    for (int i = 0; i < s.steps; ++i) {
      const long double h = static_cast<long double>(s.c[i]) * H;
      if (i % 2 == 0) {
        flow_v(y, h);
        flow_t(y, h);
      } else {
        flow_t(y, h);
        flow_v(y, h);
      }
    }
  return y;
}

// Palindromic tables summing to 1, a symmetric method (Psi_-H o Psi_H = id), and the order
// measured on the splitting: the differences between runs with n, 2n, 4n and 8n steps to T = 2
// fall by 2^p (their ratio within 12 %).
TEST(Composition, TablesHaveTheirOrderOnAnIndependentSplitting) {
  const Pair y0(0.6L, -0.4L, 0.8L, 0.5L);
  for (Composition c : kAll) {
    const CompositionScheme s = composition_scheme(order_of(c), c);
    long double sum = 0.0L;
    for (int i = 0; i < s.steps; ++i) {
      EXPECT_EQ(s.c[i], s.c[s.steps - 1 - i]) << to_string(c);
      sum += s.c[i];
    }
    EXPECT_NEAR(static_cast<double>(sum), 1.0, 4e-16) << to_string(c);
    EXPECT_EQ(s.steps % 2, 0) << to_string(c);

    const Pair back = compose(s, compose(s, y0, 0.3L, 1), -0.3L, 1);
    EXPECT_LT(static_cast<double>((back - y0).cwiseAbs().maxCoeff()), 1e-17) << to_string(c);

    const int n = s.order == 4 ? 8 : 4;
    const long double T = 2.0L;
    const Pair y1 = compose(s, y0, T / n, n), y2 = compose(s, y0, T / (2 * n), 2 * n),
               y3 = compose(s, y0, T / (4 * n), 4 * n), y4 = compose(s, y0, T / (8 * n), 8 * n);
    const double d1 = static_cast<double>((y1 - y2).cwiseAbs().maxCoeff());
    const double d2 = static_cast<double>((y2 - y3).cwiseAbs().maxCoeff());
    const double d3 = static_cast<double>((y3 - y4).cwiseAbs().maxCoeff());
    const double expected = std::pow(2.0, s.order);
    std::cout << to_string(c) << " order " << s.order << ": differences " << d1 << ", " << d2 << ", " << d3
              << ", ratios " << d1 / d2 << ", " << d2 / d3 << "\n";
    EXPECT_NEAR(d2 / d3, expected, 0.12 * expected) << to_string(c);
  }
}

TEST(Composition, DefaultsAndRefusals) {
  EXPECT_EQ(composition_scheme(4).composition, Composition::BlanesMoan4);
  EXPECT_EQ(composition_scheme(6).composition, Composition::BlanesMoan6);
  EXPECT_EQ(composition_scheme(8).composition, Composition::KahanLi17);
  EXPECT_EQ(composition_scheme(2).steps, 0);
  EXPECT_EQ(composition_scheme(6).steps, 20);
  EXPECT_EQ(composition_scheme(8).steps, 34);
  for (Composition c : kAll) EXPECT_EQ(composition_from_string(to_string(c)), c);
  testing::expect_error([] { composition_scheme(3); }, "order = 3 must be 2, 4, 6 or 8");
  testing::expect_error([] { composition_scheme(4, Composition::KahanLi9); },
                        "kahan-li9 is not of order 4 (order 4: triple-jump, suzuki5, blanes-moan4 (auto); order 6:");
  testing::expect_error([] { composition_from_string("rk"); }, "valid: auto; order 4: triple-jump");
  RattleOptions o;
  o.order = 5;
  testing::expect_error([&] { validate(o); }, "order = 5");
}

// Against the exact solution: errors at T = 10 in the ratios 16, 64 and 256.
TEST(Composition, OrdersFourSixAndEightOnTheSleigh) {
  const auto setup = scene("sleigh");
  const scenarios::SleighExact ex(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
  const double T = 10.0;
  const auto centre = ex.positions({T});
  const Vector truth = Eigen::Vector3d(centre[0][0], centre[0][1], ex.heading(T));
  EXPECT_NEAR(ratio(setup, 4, 0.2, HitchMode::Holonomic, truth, T, "sleigh"), 16.0, 1.0);
  EXPECT_NEAR(ratio(setup, 6, 0.4, HitchMode::Holonomic, truth, T, "sleigh"), 64.0, 6.0);
  EXPECT_NEAR(ratio(setup, 8, 0.4, HitchMode::Holonomic, truth, T, "sleigh"), 256.0, 30.0);
  // The other tables of each order (the defaults above): Suzuki's and Kahan and Li's
  // compositions of double steps, McLachlan's of order 8.
  for (const auto& [order, c, H] : {std::tuple{4, Composition::Suzuki5, 0.2}, std::tuple{6, Composition::KahanLi9, 0.4},
                                     std::tuple{8, Composition::McLachlan15, 0.4}}) {
    RattleOptions o1 = composed(order, H), o2 = composed(order, H / 2);
    o1.composition = o2.composition = c;
    const double e1 = (configuration_at(setup, o1, T) - truth).lpNorm<Eigen::Infinity>();
    const double e2 = (configuration_at(setup, o2, T) - truth).lpNorm<Eigen::Infinity>();
    std::cout << "sleigh " << to_string(c) << ": error " << e1 << " at H = " << H << ", " << e2 << " at H/2, ratio "
              << e1 / e2 << "\n";
    const double expected = std::pow(2.0, order);
    EXPECT_NEAR(e1 / e2, expected, 0.12 * expected) << to_string(c);
  }
}

// A 10-body chain in both hitch modes against ARKODE at 1e-14 (whose own error, about 1e-13
// here, is below 1% of the smallest error compared).
TEST(Composition, OrdersFourSixAndEightOnAChainInBothHitchModes) {
  const auto setup = scene("sleigh_chain", {"bodies=10"});
  const double T = 10.0;
  const Vector truth = reference_at(setup, T);
  for (HitchMode hitch : {HitchMode::OneForm, HitchMode::Holonomic}) {
    EXPECT_NEAR(ratio(setup, 4, 0.2, hitch, truth, T, "chain"), 16.0, 1.0);
    EXPECT_NEAR(ratio(setup, 6, 0.4, hitch, truth, T, "chain"), 64.0, 6.0);
    // Order 8 has no clean pair of step sizes on the chain in double precision: its differences
    // q_H - q_H/2 (which need no reference) still approach 2^8 where they reach round-off. At
    // T = 20 with H = 0.5, 0.25, 0.125 the ratio of successive differences measured 203 (one-form)
    // and 178 (holonomic), 55 and 63 at order 6; so the check is only that it is clearly above
    // order 7 and not beyond 8 (128 < ratio < 300), the position iteration tightened below them.
    RattleOptions o = composed(8, 0.5, hitch);
    o.gap_tolerance = 1e-15;
    const Vector q1 = configuration_at(setup, o, 2 * T);
    o.h /= 2;
    const Vector q2 = configuration_at(setup, o, 2 * T);
    o.h /= 2;
    const Vector q3 = configuration_at(setup, o, 2 * T);
    const double d1 = (q1 - q2).lpNorm<Eigen::Infinity>(), d2 = (q2 - q3).lpNorm<Eigen::Infinity>();
    std::cout << "chain order 8 " << to_string(hitch) << ": differences at T = 20 " << d1 << ", " << d2 << ", ratio "
              << d1 / d2 << "\n";
    EXPECT_GT(d1 / d2, 128.0) << to_string(hitch);
    EXPECT_LT(d1 / d2, 300.0) << to_string(hitch);
  }
}

// With external forces every substep sees its own time: a driven train (force and steering
// torque depend on t) and the snakeboard under sinusoidal rider and axle torques.
TEST(Composition, HigherOrdersWithForces) {
  struct Case {
    const char* label;
    scenarios::SceneSetup setup;
    double H4, H6, tol;  // ARKODE at 1e-14 fails its error test on the snakeboard
  };
  const std::vector<Case> cases{
      {"driven train", scene("wheeled_train", {"bodies=5", "force_amp=0.5", "steer=0.05", "steer_omega=2"}), 0.2, 0.4, 1e-14},
      // The paper's controlled run (nonholo wp): rider and axle torques from rest.
      {"controlled snakeboard",
       scene("snakeboard", {"v0=0", "psi_dot0=0", "phi_dot0=0", "phi0=-0.5", "u_psi_amp=-0.2", "u_phi_amp=0.04",
                            "u_psi_omega=2", "u_phi_omega=2", "u_psi_phase=1.5707963267948966",
                            "u_phi_phase=1.5707963267948966"}),
       0.2, 0.4, 1e-13}};
  const double T = 10.0;
  for (const Case& c : cases) {
    const Vector truth = reference_at(c.setup, T, c.tol);
    EXPECT_NEAR(ratio(c.setup, 4, c.H4, HitchMode::Holonomic, truth, T, c.label), 16.0, 1.0) << c.label;
    EXPECT_NEAR(ratio(c.setup, 6, c.H6, HitchMode::Holonomic, truth, T, c.label), 64.0, 6.0) << c.label;
    // Order 8 has no clean pair here: from H = 0.4 the error ratios are 1100 (train) and 400
    // (snakeboard), pre-asymptotic; from H = 0.2 the errors reach the reference's. The
    // differences q_H - q_H/2 from H = 0.2 need no reference and fall by 100 (train) and 154
    // (snakeboard); the next pair is at round-off (1e-13). Checked: clearly beyond order 6's 64.
    RattleOptions o = composed(8, c.H4);
    o.gap_tolerance = 1e-15;
    Vector q[3];
    for (Vector& qi : q) {
      qi = configuration_at(c.setup, o, T);
      o.h /= 2;
    }
    const double d1 = (q[0] - q[1]).lpNorm<Eigen::Infinity>(), d2 = (q[1] - q[2]).lpNorm<Eigen::Infinity>();
    std::cout << c.label << " order 8: differences " << d1 << ", " << d2 << ", ratio " << d1 / d2 << "\n";
    EXPECT_GT(d1 / d2, 85.0) << c.label;
    EXPECT_LT(d1 / d2, 300.0) << c.label;
  }
}

// With f = 0 every composed step restores the energy of p~ (with a potential, of p~ and q):
// round-off over 10^5 composed steps, the constraints of p~ at round-off too, and with the
// snakeboard's horizontal symmetry the rotor momentum exact.
TEST(Composition, EnergyConstraintsAndMomentumStayExactOverLongRuns) {
  struct Case {
    const char* label;
    scenarios::SceneSetup setup;
    int order;
    double H;
    long steps;
  };
  const std::vector<Case> cases{
      {"sleigh", scene("sleigh"), 6, 0.1, 100000},
      {"sleigh", scene("sleigh"), 8, 0.2, 100000},
      {"particle", scene("particle"), 4, 0.1, 100000},
      {"snakeboard", scene("snakeboard"), 6, 0.05, 100000},
      {"spring chain (potential)", scene("sleigh_chain", {"bodies=3", "k=1"}), 4, 0.05, 20000}};
  for (const Case& c : cases) {
    const Model& model = c.setup.model;
    Workspace ws(model);
    State s = start_from_velocity(model, ws, 0.0, c.setup.q0, c.setup.v0);
    const RattleOptions o = composed(c.order, c.H);
    const double e0 = diagnose(model, ws, s, o.h).energy;
    Vector j0(model.momentum_maps().size()), j(j0.size());
    evaluate_momentum_maps(model, s, j0);
    double energy = 0.0, residual = 0.0, momentum = 0.0;
    for (long k = 0; k < c.steps; ++k) {
      ASSERT_EQ(step(model, ws, s, o), Status::Ok) << c.label << ": " << ws.message();
      if (k % 16 != 15) continue;
      const Diagnostics d = diagnose(model, ws, s, o.h);
      energy = std::max(energy, std::abs(d.energy - e0) / e0);
      residual = std::max(residual, d.residual);
      evaluate_momentum_maps(model, s, j);
      if (j.size() > 0) momentum = std::max(momentum, (j - j0).lpNorm<Eigen::Infinity>());
    }
    std::cout << c.label << " order " << c.order << ", " << c.steps << " composed steps to t = " << s.t
              << ": energy " << energy << ", residual " << residual << ", momentum " << momentum << "\n";
    EXPECT_LE(energy, 1e-14) << c.label;
    EXPECT_LE(residual, 1e-14) << c.label;
    EXPECT_LE(momentum, 1e-14) << c.label;
    EXPECT_EQ(s.restarts, c.steps) << c.label;  // Auto restarts at every composed step
  }
}

// The composition is symmetric on (q, p~, lambda~) (no restarts: RestartMode::Never): run K
// composed steps, reverse the momentum (with f = 0, Psi_{-H} = R Psi_H R for R(q, p, lambda) =
// (q, -p, lambda)), run K more and reverse again: back to the start at round-off. In holonomic
// mode q and p~ return to the position iteration's tolerance, but lambda~ does not: on the way
// back the first half kick needs no gap correction and the second recovers lambda~ + dlambda.
TEST(Composition, ComposedStepIsSymmetric) {
  for (HitchMode hitch : {HitchMode::OneForm, HitchMode::Holonomic}) {
    for (int order : {4, 6, 8}) {
      const auto setup = scene("sleigh_chain", {"bodies=5"});
      const Model& model = setup.model;
      Workspace ws(model);
      State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
      const State start = s;
      RattleOptions o = composed(order, 0.1, hitch, "0");
      o.gap_tolerance = 1e-14;  // the position iteration's own tolerance would show (1e-12)
      for (int k = 0; k < 50; ++k) ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
      EXPECT_GT((s.q - start.q).norm(), 1.0);
      s.p = -s.p;
      for (int k = 0; k < 50; ++k) ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
      s.p = -s.p;
      const double dq = (s.q - start.q).lpNorm<Eigen::Infinity>(), dp = (s.p - start.p).lpNorm<Eigen::Infinity>();
      const double dl = (s.lambda - start.lambda).lpNorm<Eigen::Infinity>();
      std::cout << "order " << order << " " << to_string(hitch) << ": back to the start within q " << dq << ", p "
                << dp << ", lambda " << dl << "\n";
      EXPECT_LE(dq, 1e-12);
      EXPECT_LE(dp, 1e-12);
      if (hitch == HitchMode::OneForm) {
        EXPECT_LE(dl, 1e-11);
      }
    }
  }
}

// A composed step that fails in a middle substep leaves the state exactly as it was; the time
// each substep sees is t + (c_1 + ... + c_i) H, and the cost is one factorisation a plain step.
TEST(Composition, FailedStepLeavesTheStateAndSubstepsSeeTheirTimes) {
  std::vector<double> seen;  // the times at which the force is evaluated
  double fail_after = 1e300;
  const Model model = testing::driven_particle([&](double t, ConstVecRef, VecRef f) {
    seen.push_back(t);
    f.setZero();
    f[1] = t > fail_after ? std::numeric_limits<double>::quiet_NaN() : std::sin(t);
  });
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 0));
  RattleOptions o = composed(4, 0.3);
  ASSERT_EQ(step(model, ws, s, o), Status::Ok);
  const CompositionScheme scheme = composition_scheme(4);
  seen.clear();
  const long before = ws.factorizations;
  ASSERT_EQ(step(model, ws, s, o), Status::Ok);
  EXPECT_EQ(ws.factorizations - before, scheme.steps);
  ASSERT_EQ(seen.size(), static_cast<std::size_t>(scheme.steps));  // one per substep
  double elapsed = 0.0;
  for (int i = 0; i < scheme.steps; ++i) {
    elapsed += scheme.c[i];
    EXPECT_NEAR(seen[static_cast<std::size_t>(i)], 0.3 + elapsed * 0.3, 1e-15);
  }
  EXPECT_EQ(seen.back(), 0.6);
  EXPECT_EQ(s.t, 0.6);

  const State kept = s;
  fail_after = 0.75;  // inside the third step, after its first substeps
  EXPECT_EQ(step(model, ws, s, o), Status::NonFiniteState);
  EXPECT_THAT(ws.message(), ::testing::HasSubstr("NaN or Inf"));
  EXPECT_EQ(s.t, kept.t);
  EXPECT_EQ(s.q, kept.q);
  EXPECT_EQ(s.p, kept.p);
  EXPECT_EQ(s.lambda, kept.lambda);
  EXPECT_EQ(s.force, kept.force);
  EXPECT_EQ(s.steps, kept.steps);
  EXPECT_EQ(s.restarts, kept.restarts);
  fail_after = 1e300;
  EXPECT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();

  Workspace lean(model, {sparse::Backend::Auto, false});
  EXPECT_EQ(step(model, lean, s, o), Status::MethodNotApplicable);
  EXPECT_THAT(lean.message(), ::testing::HasSubstr("composed_steps = true"));
  o.order = 3;
  EXPECT_EQ(step(model, ws, s, o), Status::InvalidOptions);
  EXPECT_THAT(ws.message(), ::testing::HasSubstr("order = 3 must be 2, 4, 6 or 8"));
}

}  // namespace
}  // namespace nonholo

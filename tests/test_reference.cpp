// The reference integrators of the index-reduced equations against the exact solutions of
// docs/design.md section 6: RK4 is of order 4; ARKODE's adaptive Dormand-Prince and Verner pairs (6(5), 8(7))
// follow their tolerance; projection keeps the constraints (and hitches) to round-off.
#include <nonholo/reference/integrators.hpp>
#include <nonholo/scenarios/exact_solutions.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "support/expect_error.hpp"

namespace nonholo {
namespace {

using reference::Integrator;
using reference::Method;

struct Sleigh {
  scenarios::SceneSetup setup;
  scenarios::SleighExact exact;
  Vector v0;
  Sleigh()
      : setup(scenarios::find_scene("sleigh").build(scenarios::find_scene("sleigh").defaults())),
        exact(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0) {
    Workspace ws(setup.model);
    const State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
    v0.resize(s.p.size());  // the started velocity M^-1 p~_0, in D(q0)
    setup.model.inverse_mass().multiply(s.p.data(), v0.data());
  }
};

// Max over t = 1, 2, ..., T of the error in (x, y, theta) against the exact sleigh.
double sleigh_error(Method method, reference::Options o, double t_end, long* rhs = nullptr,
                    double* residual = nullptr) {
  Sleigh s;
  Integrator integ(s.setup.model, method, o, 0.0, s.setup.q0, s.v0);
  double err = 0.0, res = 0.0;
  for (int k = 1; k <= static_cast<int>(t_end); ++k) {
    EXPECT_EQ(integ.advance_to(k), Status::Ok) << integ.message();
    err = std::max(err, (Eigen::Vector3d(integ.q()) - s.exact.configuration(k)).lpNorm<Eigen::Infinity>());
    res = std::max(res, integ.ode().residual(integ.y()));
  }
  if (rhs) *rhs = integ.rhs_evaluations();
  if (residual) *residual = res;
  return err;
}

TEST(Reference, Rk4IsFourthOrderOnTheSleigh) {
  reference::Options o;
  o.h = 0.04;
  const double e1 = sleigh_error(Method::Rk4, o, 10);
  o.h = 0.02;
  const double e2 = sleigh_error(Method::Rk4, o, 10);
  std::cout << "[reference] rk4 sleigh T=10: error " << e1 << " (h=0.04), " << e2 << " (h=0.02), ratio "
            << e1 / e2 << "\n";
  EXPECT_NEAR(e1 / e2, 16.0, 1.6);
  EXPECT_LT(e1, 1e-5);
}

TEST(Reference, ArkodeFollowsItsTolerance) {
  long tight_rhs[3] = {0, 0, 0};
  for (Method m : {Method::ArkodeDp5, Method::ArkodeVerner, Method::ArkodeFehlberg8}) {
    double previous = 1.0;
    long previous_rhs = 0;
    for (double tol : {1e-6, 1e-8, 1e-10}) {
      reference::Options o;
      o.tol = tol;
      long rhs = 0;
      const double e = sleigh_error(m, o, 10, &rhs);
      std::cout << "[reference] " << reference::to_string(m) << " tol " << tol << ": error " << e
                << ", " << rhs << " evaluations\n";
      EXPECT_LT(e, 100 * tol) << reference::to_string(m);
      EXPECT_LT(e, previous);
      EXPECT_GT(rhs, previous_rhs) << "tighter tolerance, more work";
      previous = e;
      previous_rhs = rhs;
    }
    tight_rhs[m == Method::ArkodeDp5 ? 0 : m == Method::ArkodeVerner ? 1 : 2] = previous_rhs;
  }
  // The sixth-order pair must need fewer evaluations than the fifth-order one at 1e-10 (it
  // did not through ERKStep of SUNDIALS 6.4.1, which ran the Verner table at order 3), and
  // the eighth-order pair fewer than the sixth.
  EXPECT_LT(tight_rhs[1], tight_rhs[0]);
  EXPECT_LT(tight_rhs[2], tight_rhs[1]);
}

TEST(Reference, ProjectionKeepsTheConstraint) {
  reference::Options o;
  o.h = 0.05;
  double free_residual = 0.0, projected_residual = 0.0;
  sleigh_error(Method::Rk4, o, 10, nullptr, &free_residual);
  o.project = true;
  const double e = sleigh_error(Method::Rk4, o, 10, nullptr, &projected_residual);
  std::cout << "[reference] rk4 h=0.05 residual |mu v|: " << free_residual << " free, " << projected_residual
            << " projected (error " << e << ")\n";
  EXPECT_GT(free_residual, 1e-9);
  EXPECT_LT(projected_residual, 1e-15);
  EXPECT_LT(e, 1e-4);
}

TEST(Reference, ProjectionClosesTheHitches) {
  const auto& info = scenarios::find_scene("sleigh_chain");
  auto p = info.defaults();
  p.set("bodies", 6);
  const auto setup = info.build(p);
  Workspace ws(setup.model);
  const State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  Vector v0(s.p.size());
  setup.model.inverse_mass().multiply(s.p.data(), v0.data());
  for (bool project : {false, true}) {
    reference::Options o;
    o.tol = 1e-6;
    o.project = project;
    Integrator integ(setup.model, Method::ArkodeDp5, o, 0.0, setup.q0, v0);
    ASSERT_EQ(integ.advance_to(10.0), Status::Ok) << integ.message();
    const double gap = integ.ode().gap(integ.y()), residual = integ.ode().residual(integ.y());
    std::cout << "[reference] arkode-dp5 tol 1e-6, 6-body chain, T=10, project=" << project
              << ": gap " << gap << ", residual " << residual << "\n";
    if (project) {
      EXPECT_LT(gap, 1e-12);
      EXPECT_LT(residual, 1e-13);
    } else {
      EXPECT_GT(gap, 1e-9);
    }
  }
}

TEST(Reference, BadOptionsAndNamesAreRefused) {
  reference::Options o;
  o.tol = 0.0;
  testing::expect_error([&] { reference::validate(o); }, "tolerance = 0 must lie in [1e-15, 1)");
  o = reference::Options{};
  o.h = -1;
  testing::expect_error([&] { reference::validate(o); }, "step size h = -1 must be positive and finite");
  testing::expect_error([] { reference::method_from_string("euler"); },
                        "unknown reference method 'euler' (valid: rk4, arkode-dp5, arkode-verner, arkode-fehlberg8)");
  Sleigh s;
  testing::expect_error([&] { Integrator(s.setup.model, Method::Rk4, {}, 0.0, Vector::Zero(2), s.v0); },
                        "expected 3 coordinates and 3 velocities, got 2 and 3");
}

}  // namespace
}  // namespace nonholo

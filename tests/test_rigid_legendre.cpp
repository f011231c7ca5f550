// The discrete Legendre transforms of every rotation Lagrangian solve for every physical body
// up to h |Omega| = 1 (docs/design.md section 10.2): random momenta on turned and diagonal
// anisotropic inertias, each solution checked against the closed-form inverse map; the scenes run
// with each Lagrangian on those bodies at dt 0.01 and 0.001; and where the transform truly has no
// solution, the step the message advises works.
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/rigid_body.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/start.hpp>

#include "step/rigid/legendre.hpp"
#include "support/scenes.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

namespace nonholo {
namespace {

constexpr RotationLagrangian kLagrangians[] = {RotationLagrangian::MoserVeselov, RotationLagrangian::MoserVeselovF,
                                               RotationLagrangian::Exponential};

RigidBlock block_of(const Eigen::Matrix3d& inertia) {
  RigidBlock b;
  b.inertia = inertia;
  b.inverse_inertia = inertia.inverse();
  b.isotropic = false;
  return b;
}

// 20 000 momenta per body and Lagrangian, h |Omega| spread log-uniformly over [1e-4, 1], half of
// them from a random Omega and half from a random p (Omega along the small moments), inertias
// turned at random for half of them: the shapes where Newton used to cycle at round-off.
TEST(RigidLegendre, EveryLagrangianSolvesEveryBodyShapeUpToHOmegaOne) {
  std::mt19937 random(36);
  std::normal_distribution<double> normal;
  std::vector<testing::BodyShape> shapes = testing::body_shapes();
  shapes.push_back({"1:10:10.5", Eigen::Vector3d(1.0, 10.0, 10.5).asDiagonal().toDenseMatrix()});
  for (const auto& shape : shapes) {
    for (RotationLagrangian rotation : kLagrangians) {
      int failures = 0, iterations_max = 0;
      double worst = 0.0, first_failure = 2.0;
      for (int k = 0; k < 20000; ++k) {
        Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
        if (k % 2)
          turn = Eigen::Quaterniond(Eigen::Vector4d(normal(random), normal(random), normal(random), normal(random)).normalized())
                     .toRotationMatrix();
        const RigidBlock b = block_of(turn * shape.inertia * turn.transpose());
        Eigen::Vector3d omega(normal(random), normal(random), normal(random));
        if (k % 4 < 2) omega = b.inverse_inertia * omega;
        const double h_omega = std::pow(10.0, -4.0 + 4.0 * (k % 500) / 499.0);
        omega *= h_omega / omega.norm();
        const double h = 0.01;
        const Eigen::Vector3d p = b.inertia * omega / h;
        Eigen::Vector4d w;
        int iterations = 0;
        if (!detail::solve_legendre(rotation, b, h, p, w, iterations)) {
          ++failures;
          first_failure = std::min(first_failure, h_omega);
          continue;
        }
        iterations_max = std::max(iterations_max, iterations);
        // The inverse map, in closed form: p from W (relative to |p| and the spread of I).
        const Eigen::Vector3d back = detail::legendre_momentum(rotation, b, h, w);
        worst = std::max(worst, (back - p).norm() / p.norm());
      }
      std::printf("%s, %s: %d of 20000 not solved (first at h |Omega| %.3g), at most %d iterations, inverse map "
                  "within %.3g\n",
                  shape.name, to_string(rotation), failures, failures ? first_failure : 0.0, iterations_max, worst);
      EXPECT_EQ(failures, 0) << shape.name << ", " << to_string(rotation);
      EXPECT_LE(worst, 1e-11) << shape.name << ", " << to_string(rotation);
    }
  }
}

// An isotropic body takes the closed forms (no Newton): each W maps back to its momentum by the
// inverse map, up to the fold of Moser-Veselov (h |p| = J: a quarter turn, sin a = 1) and a quarter
// turn for the other two; past them, no solution. Moser-Veselov's unnormalised quaternion (the
// drift's, legendre.hpp) is W's direction.
TEST(RigidLegendre, IsotropicClosedFormsInvertToTheirMomentum) {
  std::mt19937 random(7);
  std::normal_distribution<double> normal;
  for (double j : {0.4, 2.0, 1e-3}) {
    RigidBlock b = block_of(j * Eigen::Matrix3d::Identity());
    b.isotropic = true;
    const double h = 0.01;
    for (RotationLagrangian rotation : kLagrangians) {
      double worst = 0.0;
      for (int k = 0; k < 2000; ++k) {
        const Eigen::Vector3d dir = Eigen::Vector3d(normal(random), normal(random), normal(random)).normalized();
        const double h_p = j * std::pow(10.0, -4.0 + 3.99 * (k % 500) / 499.0);  // h |p| / J up to 0.98
        const Eigen::Vector3d p = dir * (h_p / h);
        Eigen::Vector4d w;
        int iterations = -1;
        ASSERT_TRUE(detail::solve_legendre(rotation, b, h, p, w, iterations)) << to_string(rotation) << " " << h_p / j;
        EXPECT_EQ(iterations, 0);
        EXPECT_NEAR(w.norm(), 1.0, 4e-16);
        worst = std::max(worst, (detail::legendre_momentum(rotation, b, h, w) - p).norm() / p.norm());
        if (rotation == RotationLagrangian::MoserVeselov) {
          Eigen::Vector4d u;
          ASSERT_TRUE(detail::isotropic_moser_veselov(j, h * p, u));
          EXPECT_LE((u / u.norm() - w).lpNorm<Eigen::Infinity>(), 4e-16);
        }
      }
      std::printf("isotropic J = %g, %s: inverse map within %.3g\n", j, to_string(rotation), worst);
      EXPECT_LE(worst, 1e-13) << to_string(rotation);
      // Past the fold (Moser-Veselov: h |p| > J) or a quarter turn (h |p| > (pi / 2) J): none.
      Eigen::Vector4d w;
      int iterations = 0;
      const double beyond = rotation == RotationLagrangian::MoserVeselov ? 1.001 : 1.58;
      EXPECT_FALSE(detail::solve_legendre(rotation, b, h, Eigen::Vector3d(0.0, beyond * j / h, 0.0), w, iterations));
      EXPECT_FALSE(detail::solve_legendre(rotation, b, h, Eigen::Vector3d(0.0, NAN, 1.0), w, iterations));
    }
  }
}

TEST(RigidLegendre, EveryLagrangianRunsTheScenesOnEveryBodyShape) {
  for (const char* name : {"suslov", "veselova", "chaplygin_ball"}) {
    for (const auto& shape : testing::body_shapes()) {
      for (RotationLagrangian rotation : kLagrangians) {
        for (double dt : {0.01, 0.001}) {
          scenarios::RunConfig config;
          config.scene = name;
          config.assignments = testing::inertia_sets(shape.inertia);
          config.rotation = to_string(rotation);
          config.dt = dt;
          config.t_end = 5.0;
          config.accuracy = 0.0;  // the steps alone
          const auto summary = scenarios::run_scene(config);
          EXPECT_EQ(summary.status, Status::Ok)
              << name << ", " << shape.name << ", " << to_string(rotation) << ", dt " << dt << ": " << summary.message;
        }
      }
    }
  }
}

// Beyond its range the transform has no solution: the message says which step works, and that
// step does. A rod spinning about an axis across it at 150 rad/s, for each Lagrangian.
TEST(RigidLegendre, TheAdvisedStepClearsTheFailure) {
  for (RotationLagrangian rotation : kLagrangians) {
    ModelBuilder b;
    RigidBody body;
    body.inertia = Eigen::Vector3d(1.0, 10.0, 10.5).asDiagonal();
    b.add_rigid_body(body);
    b.add_body_axis_constraint({0, Eigen::Vector3d::UnitX()});
    const Model model = b.build();
    Workspace ws(model);
    RattleOptions o;
    o.h = 0.02;
    o.rotation = rotation;
    const State start = start_from_velocity(model, ws, 0.0, Vector(Eigen::Vector4d(1, 0, 0, 0)),
                                            Vector(Eigen::Vector3d(0, 90, 120)));
    State s = start;
    ASSERT_EQ(step(model, ws, s, o), Status::LegendreNotSolved) << to_string(rotation);
    const std::string message = ws.message();
    const auto at = message.find("reduce the step size to ");
    ASSERT_NE(at, std::string::npos) << message;
    o.h = std::stod(message.substr(at + 24));
    std::printf("%s: %s\n", to_string(rotation), message.c_str());
    s = start;
    for (int k = 0; k < 1000; ++k) ASSERT_EQ(step(model, ws, s, o), Status::Ok) << to_string(rotation) << ": " << ws.message();
  }
}

}  // namespace
}  // namespace nonholo

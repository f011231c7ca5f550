// Masses and lengths the step cannot represent are refused by the builder with their bounds
// (they used to fail at the start as "non-finite-one-forms ... reduce the step size"), and
// everything inside the bounds gives the same trajectory as unit masses, scaled.
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene_file.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/expect_error.hpp"

namespace nonholo {
namespace {

using testing::expect_error;

TEST(BuilderScales, MassesWhoseInverseOrRoundOffIsNotNormalAreRefused) {
  expect_error([] { ModelBuilder().add_planar_body({"x", "y", "theta"}, 1e-320, 1.0); },
               "body 0 (x, y, theta): mass m = 9.99989e-321 is below 1.00208e-292: a mass or moment of inertia, its "
               "inverse and their round-off must be normal doubles (from 1.00208e-292 to 9.9792e+291), or its "
               "inverse overflows; choose units that bring the masses nearer 1");
  // Well-conditioned blocks: the conditioning check alone let these through.
  expect_error([] { ModelBuilder().add_planar_body({"x", "y", "theta"}, 1e-320, 1e-320); }, "mass m = 9.99989e-321 is below");
  expect_error([] { ModelBuilder().add_planar_body({"x", "y", "theta"}, 1e308, 1e308); },
               "mass m = 1e+308 is above 9.9792e+291: a mass or moment of inertia, its inverse and their round-off "
               "must be normal doubles (from 1.00208e-292 to 9.9792e+291), or the step's products with its inverse "
               "underflow");
  expect_error([] { ModelBuilder().add_body({"z"}, Eigen::Matrix<double, 1, 1>(1e-320)); },
               "body 0 (z): mass block: smallest eigenvalue = 9.99989e-321 is below 1.00208e-292");
  RigidBody top;
  top.inertia = 1e-300 * Eigen::Matrix3d::Identity();
  expect_error([&] { ModelBuilder().add_rigid_body(top); },
               "rigid body 0: inertia: smallest principal moment = 1e-300 is below 1.00208e-292");
  top.inertia.setIdentity();
  top.mass = 1e300;
  top.translation = 2;
  expect_error([&] { ModelBuilder().add_rigid_body(top); }, "rigid body 0: mass m = 1e+300 is above 9.9792e+291");
  top.translation = 0;  // a fixed point: the mass plays no part
  EXPECT_EQ(ModelBuilder().add_rigid_body(top), 0);
  // Both ends in range but 10^583 apart: the digits lost come from logarithms, not from the
  // overflowing ratio (which gave -9223372036854775808).
  expect_error([] { ModelBuilder().add_body({"x", "y"}, Eigen::Vector2d(1e-291, 1e291).asDiagonal().toDenseMatrix()); },
               "condition number inf (above 1e+12): solves with it would lose about 582 of double precision's 16");
}

// A hitched chain of three sleighs with every mass and inertia multiplied by `scale`: the
// trajectory does not depend on it in exact arithmetic.
Vector chain_after(double scale, int steps) {
  ModelBuilder b;
  for (int i = 0; i < 3; ++i) b.add_planar_body({"x" + std::to_string(i), "y" + std::to_string(i), "t" + std::to_string(i)}, scale, scale);
  for (int i = 0; i < 3; ++i) b.add_knife_edge({i, 0.2});
  for (int i = 0; i < 2; ++i) b.add_hitch({i, i + 1, 0.5, 0.5});
  const Model model = std::move(b).build();
  Workspace ws(model);
  Vector q0 = Vector::Zero(9), v0 = Vector::Zero(9);
  q0[3] = -1.0;
  q0[6] = -2.0;
  v0 << 1.0, 0.1, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0;
  State s = start_from_velocity(model, ws, 0.0, q0, v0);
  for (int k = 0; k < steps; ++k) EXPECT_EQ(step(model, ws, s, {0.01}), Status::Ok) << ws.message();
  return s.q;
}

TEST(BuilderScales, MassesNearTheBoundsGiveTheUnitTrajectory) {
  // Not at the bounds: the rows' inverse effective masses (entries of C) must be in range too.
  const Vector unit = chain_after(1.0, 200);
  for (double scale : {1e-290, 1e290}) EXPECT_LT((chain_after(scale, 200) - unit).cwiseAbs().maxCoeff(), 1e-12) << scale;
}

TEST(BuilderScales, LengthsBeyondTheRoundOffOrRangeOfTheRowsAreRefused) {
  const auto sleigh = [](double m, double inertia, double a) {
    ModelBuilder b;
    b.add_planar_body({"x", "y", "theta"}, m, inertia);
    b.add_knife_edge({0, a});
  };
  expect_error([&] { sleigh(1.0, 1.0, 1e308); },
               "knife edge on body 0: offset a = 1e+308 is 1e+308 times the body's radius of gyration sqrt(I/m) = 1: "
               "the constraint's entries on the centre's velocity would fall below the round-off of its entry on the "
               "turning rate (a ratio above 2^52 = 4.5036e+15), so it would act on the turning rate alone; use at most "
               "4.5036e+15 (2^52 radii of gyration)");
  sleigh(1.0, 1.0, -1e15);  // correct runs with offsets of 1e15 exist (issue 23)
  // The bound is in radii of gyration: 1e-6 for I = 1e-12 m.
  expect_error([&] { sleigh(1.0, 1e-12, 1e10); }, "offset a = 1e+10 is 1e+16 times the body's radius of gyration");
  sleigh(1.0, 1e-12, 1e9);
  // Within 2^52 radii, but C's entry 1e15^2 / 1e-290 overflows.
  expect_error([&] { sleigh(1e-290, 1e-290, 1e15); },
               "offset a = 1e+15 makes the constraint's inverse effective mass, its entry of C = mu M^-1 mu^T, inf, above "
               "9.9792e+291 (the bound of inverse masses, for the same reason)");
  expect_error(
      [] {
        ModelBuilder b;
        b.add_planar_body({"x0", "y0", "t0"}, 1.0, 1.0);
        b.add_planar_body({"x1", "y1", "t1"}, 1.0, 1e-6);
        b.add_hitch({0, 1, 0.5, 1e13});
      },
      "hitch of bodies 0 and 1: front offset f (on the front body) = 1e+13 is 1e+16 times the body's radius of gyration");
  RigidBody ball;
  ball.translation = 2;
  expect_error(
      [&] {
        ModelBuilder b;
        b.add_rolling_ball({b.add_rigid_body(ball), 1e20});
      },
      "rolling ball on body 0: radius = 1e+20 is 1e+20 times the body's radius of gyration");
  ball.translation = 3;
  expect_error(
      [&] {
        ModelBuilder b;
        b.add_rigid_body(ball);
        b.add_rigid_body(ball);
        b.add_rod({0, 1, 1e200});
      },
      "rod joining bodies 0 and 1: length = 1e+200 squared is inf, outside [1.00208e-292, 9.9792e+291]: the rod's gap "
      "(|x1 - x2|^2 - l^2) / (2 l) would overflow");
}

TEST(BuilderScales, SceneFilesNameTheKey) {
  const std::string text = R"({"bodies": [{"mass": 1, "inertia": 1, "position": [0, 0], "velocity": [1, 0]}],
                               "constraints": [{"type": "knife_edge", "body": 0, "offset": 1e308}]})";
  const auto info = scenarios::parse_scene_text(text, "far.json");
  expect_error([&] { info.build(info.defaults()); }, "far.json: constraints[0]: knife edge on body 0: offset a = 1e+308");
  const auto tiny = scenarios::parse_scene_text(
      R"({"bodies": [{"mass": 1e-320, "inertia": 1e-320, "position": [0, 0], "velocity": [1, 0]}]})", "tiny.json");
  expect_error([&] { tiny.build(tiny.defaults()); }, "tiny.json: bodies[0]: body 0 (x0, y0, theta0): mass m = 9.99989e-321");
}

}  // namespace
}  // namespace nonholo

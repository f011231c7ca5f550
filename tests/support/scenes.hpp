#pragma once
// The tests' ways into the built-in scenes: a scene with some parameters set, its state after
// whole steps, and a tight ARKODE reference of the same start (header-only: the support library
// itself links the core alone).
#include <nonholo/rattle.hpp>
#include <nonholo/reference/integrators.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace nonholo::testing {

// The scene `name` with its defaults and then the NAME=VALUE assignments `sets`.
inline scenarios::SceneSetup scene(const std::string& name, const std::vector<std::string>& sets = {}) {
  const auto& info = scenarios::find_scene(name);
  auto p = info.defaults();
  for (const auto& s : sets) p.assign(s);
  return info.build(p);
}

// A 3-D scene's inertia parameters I11 ... I23 for the symmetric matrix `inertia`, to 17 digits.
inline std::vector<std::string> inertia_sets(const Eigen::Matrix3d& inertia) {
  std::vector<std::string> sets;
  const char* names[] = {"I11", "I22", "I33", "I12", "I13", "I23"};
  const int rows[] = {0, 1, 2, 0, 0, 1}, cols[] = {0, 1, 2, 1, 2, 2};
  for (int k = 0; k < 6; ++k) {
    char text[64];
    std::snprintf(text, sizeof text, "%s=%.17g", names[k], inertia(rows[k], cols[k]));
    sets.emplace_back(text);
  }
  return sets;
}

// The body shapes of the 3-D tests: principal moments turned by R = rot((1, 1, 1), 0.7), a
// non-diagonal inertia (moments 1:2:3), and the diagonal plate 1:10:11 and needle 1:100:100.
struct BodyShape {
  const char* name;
  Eigen::Matrix3d inertia;
};
inline std::vector<BodyShape> body_shapes() {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 1, 1).normalized()).toRotationMatrix();
  return {{"1:2:3 rotated", r * Eigen::Vector3d(1, 2, 3).asDiagonal() * r.transpose()},
          {"plate 1:10:11", Eigen::Vector3d(0.1, 1.0, 1.1).asDiagonal().toDenseMatrix()},
          {"needle 1:100:100", Eigen::Vector3d(0.01, 1.0, 1.0).asDiagonal().toDenseMatrix()}};
}

// The state after whole steps of o.h (composed steps for order 4, 6) from the scene's start to
// T; a failed step is a test failure (and ends the run there).
inline State state_at(const scenarios::SceneSetup& setup, const RattleOptions& o, double T) {
  Workspace ws(setup.model);
  State s = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
  const long steps = std::lround(T / o.h);
  for (long k = 0; k < steps; ++k) {
    const Status status = step(setup.model, ws, s, o);
    EXPECT_EQ(status, Status::Ok) << ws.message();
    if (status != Status::Ok) break;
  }
  EXPECT_NEAR(s.t, setup.t0 + T, 1e-12);
  return s;
}

// q at t0 + T from ARKODE (Verner 6(5)) on the index-reduced equations, from the scene's
// consistent start, at tolerance tol.
inline Vector reference_at(const scenarios::SceneSetup& setup, double T, double tol = 1e-14) {
  Workspace ws(setup.model);
  const State s = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
  Vector v0(s.p.size());
  setup.model.inverse_mass().multiply(s.p.data(), v0.data());
  reference::Options ro;
  ro.tol = tol;
  reference::Integrator ref(setup.model, reference::Method::ArkodeVerner, ro, setup.t0, s.q, v0);
  EXPECT_EQ(ref.advance_to(setup.t0 + T), Status::Ok) << ref.message();
  return ref.q();
}

}  // namespace nonholo::testing

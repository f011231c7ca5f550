#pragma once
// The tests' ways into the built-in scenes: a scene with some parameters set, its state after
// whole steps, and a tight ARKODE reference of the same start (header-only: the support library
// itself links the core alone).
#include <nonholo/rattle.hpp>
#include <nonholo/reference/integrators.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gtest/gtest.h>

#include <cmath>
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

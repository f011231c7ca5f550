#pragma once
// The invariants of a 3-D scene watched over many steps: the post-momentum energy (or, with
// forces, the discrete work identity), the momentum maps, the constraint residual, the
// quaternions' norms and Veselova's integral (header-only, for test_rigid_step and
// test_rigid_restart).
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/rigid_body.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace nonholo::testing {

// Veselova's integral F = |I Omega|^2 - (I Omega . gamma)^2, evaluated with the pre-momentum
// p_- = p~ - (h/2) force at q_k (the reflection changes p only along gamma, and W^T turns p and
// gamma alike: exact in the scheme).
inline double veselova_integral(const State& s, double h) {
  const Eigen::Vector3d p = (s.p - 0.5 * h * s.force).head<3>();
  const Eigen::Vector3d gamma = quaternion_matrix(s.q.head<4>()).row(2).transpose();
  return p.squaredNorm() - std::pow(p.dot(gamma), 2);
}

// The largest deviations seen. maps: max_k |J(k) - J(0)|_inf; maps_rel: that over |J(0)|_inf.
struct Watch {
  double energy_post = 0, residual = 0, norm = 0, maps = 0, maps_rel = 0, veselova = 0, work = 0;
  long restarts = 0;
};

// `steps` steps of a scene from its start, each followed by diagnose().
inline Watch watch(const scenarios::SceneSetup& setup, const RattleOptions& o, long steps) {
  const Model& model = setup.model;
  Workspace ws(model);
  State s = start_from_velocity(model, ws, setup.t0, setup.q0, setup.v0);
  const double h = o.h;
  const Diagnostics d0 = diagnose(model, ws, s, h);
  Vector j0(model.momentum_maps().size()), j(model.momentum_maps().size());
  evaluate_momentum_maps(model, s, j0);
  const double f0 = veselova_integral(s, h);
  double work = 0.0, power = external_power(model, ws, s);
  Watch w;
  for (long k = 0; k < steps; ++k) {
    const Status status = step(model, ws, s, o);
    EXPECT_EQ(status, Status::Ok) << ws.message();
    if (status != Status::Ok) break;
    const Diagnostics d = diagnose(model, ws, s, h);
    work += h * power;  // E_post(k + 1/2) - E_post(k - 1/2) = h F_k^T M^-1 p~_k
    power = external_power(model, ws, s);
    w.energy_post = std::max(w.energy_post, std::abs(d.energy_post - d0.energy_post - work) /
                                                std::max(std::abs(d0.energy_post), std::abs(work)));
    w.residual = std::max(w.residual, d.residual);
    for (const RigidBlock& r : model.rigid_bodies()) w.norm = std::max(w.norm, std::abs(s.q.segment<4>(r.q).norm() - 1.0));
    evaluate_momentum_maps(model, s, j);
    w.maps = std::max(w.maps, (j - j0).lpNorm<Eigen::Infinity>());
    w.veselova = std::max(w.veselova, std::abs(veselova_integral(s, h) - f0) / f0);
  }
  if (j0.size() > 0 && j0.lpNorm<Eigen::Infinity>() > 0.0) w.maps_rel = w.maps / j0.lpNorm<Eigen::Infinity>();
  w.work = work;
  w.restarts = s.restarts;
  return w;
}

}  // namespace nonholo::testing

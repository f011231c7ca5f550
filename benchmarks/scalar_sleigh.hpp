#pragma once
// The floor of docs/design.md section 7 for one small body: the same scheme for the sleigh
// (m = I = 1, a = 0.2, h = 0.01) written out with scalars. Shared by bench_step and bench_batch.
#include <nonholo/state.hpp>

#include <cmath>

namespace nonholo::bench {

// The floor: the same scheme for the sleigh written out with scalars.
struct ScalarSleigh {
  double m, inertia, a, h;
  double x, y, th, px, py, pth, fx, fy, fth;
  void step() {
    const double hh = 0.5 * h;
    const double qx = px + hh * fx, qy = py + hh * fy, qth = pth + hh * fth;  // p_{k+1/2}
    const double vx = qx / m, vy = qy / m, vth = qth / inertia;
    x += h * vx;
    y += h * vy;
    th += h * vth;
    const double s = std::sin(th), c = std::cos(th);
    const double gram = 1.0 / m + a * a / inertia;  // s^2 + c^2 = 1 folded in
    const double lambda = -(2.0 / h) * (s * vx - c * vy + a * vth) / gram;
    fx = s * lambda;
    fy = -c * lambda;
    fth = a * lambda;
    px = qx + hh * fx;
    py = qy + hh * fy;
    pth = qth + hh * fth;
  }
};

inline ScalarSleigh scalar_from(const State& s) {
  return {1.0, 1.0, 0.2, 0.01, s.q[0], s.q[1], s.q[2], s.p[0], s.p[1], s.p[2], s.force[0], s.force[1], s.force[2]};
}

}  // namespace nonholo::bench

#include <nonholo/scenarios/chain.hpp>

#include <nonholo/model_builder.hpp>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace nonholo::scenarios {
namespace {

void check_body(const ChainBody& b, std::size_t i) {
  auto positive = [&](const char* what, double v) {
    if (v > 0.0 && std::isfinite(v)) return;
    std::ostringstream os;
    os << "chain body " << i << ": " << what << " = " << v << " must be positive and finite";
    throw std::invalid_argument(os.str());
  };
  positive("m", b.m);
  positive("I", b.I);
  positive("d", b.d);
  positive("f", b.f);
  if (!std::isfinite(b.a)) throw std::invalid_argument("chain body " + std::to_string(i) + ": a is not finite");
}

}  // namespace

SceneSetup build_chain(const ChainSpec& spec) {
  const int n_bodies = static_cast<int>(spec.bodies.size());
  if (n_bodies == 0) throw std::invalid_argument("chain: no bodies");
  for (int i = 0; i < n_bodies; ++i) check_body(spec.bodies[i], static_cast<std::size_t>(i));
  const std::vector<ChainBody> bodies = spec.bodies;
  const bool hitched = spec.hitched && n_bodies > 1;

  ModelBuilder b;
  for (int i = 0; i < n_bodies; ++i) {
    const std::string s = std::to_string(i);
    b.add_planar_body({"x" + s, "y" + s, "theta" + s}, bodies[i].m, bodies[i].I);
  }
  // Body i: blade row, then (if it has a successor) the hitch rows x and y.
  for (int i = 0; i < n_bodies; ++i) {
    const int x = 3 * i, y = x + 1, th = x + 2;
    b.add_one_form({x, y, th});
    if (hitched && i + 1 < n_bodies) {
      b.add_holonomic_row({x, th, x + 3, th + 3});
      b.add_holonomic_row({y, th, y + 3, th + 3});
    }
  }
  // Values per body: 3 for the blade, 8 for the hitch to the next body (if any).
  const int stride = hitched ? 11 : 3;

  // One sin/cos per body. Blade i: [sin, -cos, a_i] on (x_i, y_i, theta_i). Hitch i:
  // g = C_i - d_i e_i - C_{i+1} - f_{i+1} e_{i+1}, rows dg_x = [1, d_i s_i, -1, f s_{i+1}] on
  // (x_i, theta_i, x_{i+1}, theta_{i+1}) and dg_y = [1, -d_i c_i, -1, -f c_{i+1}].
  b.one_form_values([bodies, n_bodies, hitched, stride](ConstVecRef q, VecRef mu) {
    const double* qp = q.data();
    double* v = mu.data();
    for (int i = 0; i < n_bodies; ++i) {
      const double s = std::sin(qp[3 * i + 2]), c = std::cos(qp[3 * i + 2]);
      double* row = v + static_cast<std::ptrdiff_t>(stride) * i;
      row[0] = s;
      row[1] = -c;
      row[2] = bodies[i].a;
      if (!hitched) continue;
      if (i + 1 < n_bodies) {
        row[3] = 1.0;
        row[4] = bodies[i].d * s;
        row[5] = -1.0;
        row[7] = 1.0;
        row[8] = -bodies[i].d * c;
        row[9] = -1.0;
      }
      if (i > 0) {
        double* prev = row - stride;
        prev[6] = bodies[i].f * s;
        prev[10] = -bodies[i].f * c;
      }
    }
  });
  // d/dt of the rows along qdot: blade theta'(c x' + s y'); hitch x: d_i c_i theta_i'^2 +
  // f c_{i+1} theta_{i+1}'^2; hitch y: the same with sines.
  b.one_form_bias([bodies, n_bodies, hitched](ConstVecRef q, ConstVecRef v, VecRef bias) {
    const int per_body = hitched ? 3 : 1;
    for (int i = 0; i < n_bodies; ++i) {
      const double s = std::sin(q[3 * i + 2]), c = std::cos(q[3 * i + 2]);
      const double w = v[3 * i + 2];
      double* out = bias.data() + per_body * i;
      out[0] = w * (c * v[3 * i] + s * v[3 * i + 1]);
      if (!hitched) continue;
      if (i + 1 < n_bodies) {
        out[1] = bodies[i].d * c * w * w;
        out[2] = bodies[i].d * s * w * w;
      }
      if (i > 0) {
        out[1 - per_body] += bodies[i].f * c * w * w;
        out[2 - per_body] += bodies[i].f * s * w * w;
      }
    }
  });
  if (hitched)
    b.gap([bodies, n_bodies](ConstVecRef q, VecRef g) {
      // g_i = rear hitch of i minus front hitch of i+1; one sin/cos per body.
      double s0 = std::sin(q[2]), c0 = std::cos(q[2]);
      for (int i = 0; i + 1 < n_bodies; ++i) {
        const double s1 = std::sin(q[3 * i + 5]), c1 = std::cos(q[3 * i + 5]);
        const double d = bodies[i].d, f = bodies[i + 1].f;
        g[2 * i] = q[3 * i] - d * c0 - q[3 * i + 3] - f * c1;
        g[2 * i + 1] = q[3 * i + 1] - d * s0 - q[3 * i + 4] - f * s1;
        s0 = s1;
        c0 = c1;
      }
    });

  if (spec.k != 0.0) {
    const double k = spec.k;
    b.potential(
        [k, n_bodies](ConstVecRef q) {
          double v = 0.0;
          for (int i = 0; i + 1 < n_bodies; ++i) {
            const double diff = q[3 * i + 2] - q[3 * i + 5];
            v += 0.5 * k * diff * diff;
          }
          return v;
        },
        [k, n_bodies](ConstVecRef q, VecRef grad) {
          grad.setZero();
          for (int i = 0; i + 1 < n_bodies; ++i) {
            const double t = k * (q[3 * i + 2] - q[3 * i + 5]);
            grad[3 * i + 2] += t;
            grad[3 * i + 5] -= t;
          }
        });
  }
  if (spec.lead_force || spec.lead_torque) {
    const auto force = spec.lead_force, torque = spec.lead_torque;
    b.external_force([force, torque](double t, ConstVecRef q, VecRef out) {
      out.setZero();
      if (force) {
        const double f = force(t);
        out[0] = f * std::cos(q[2]);
        out[1] = f * std::sin(q[2]);
      }
      if (torque) out[2] = torque(t);
    });
  }

  SceneSetup setup{b.build(), 0.0, Vector::Zero(3 * n_bodies), Vector::Zero(3 * n_bodies)};
  // Straight along -x, hitches closed: x_{i+1} = x_i - d_i - f_{i+1}.
  for (int i = 1; i < n_bodies; ++i)
    setup.q0[3 * i] = setup.q0[3 * (i - 1)] - bodies[i - 1].d - bodies[i].f;
  // Body 0 as the single sleigh: centre velocity (v0 + i a omega0) e^{i theta}, theta = 0.
  setup.v0[0] = spec.v0;
  setup.v0[1] = bodies[0].a * spec.omega0;
  setup.v0[2] = spec.omega0;
  return setup;
}

}  // namespace nonholo::scenarios

// The general callbacks of an element model: every row evaluated by its own element from its
// own bodies' coordinates (x, y, theta at a planar body's offset; the elements on rigid bodies
// in rigid_elements.cpp).
#include "model/element_set.hpp"

#include <cmath>

namespace nonholo::detail {

void ElementSet::values(ConstVecRef q, VecRef mu) const {
  const double* x = q.data();
  double* out = mu.data();
  if (ball_chain) {  // ball by ball, without the row table (rigid_row_values' arithmetic: the same bits)
    ball_chain_values(x, out);
    return;
  }
  for (std::size_t r = 0, n = num_rows(); r < n; ++r) {
    double* v = out + value_start(r);
    const ElementRow row = this->row(r);
    if (row.rigid()) {
      rigid_row_values(*this, row, x, v);
      continue;
    }
    if (row.kind == ElementRow::Knife) {
      const KnifeEdge& e = knife_edges[row.element];
      const double th = x[q_offset(e.body) + 2];
      v[0] = std::sin(th);
      v[1] = -std::cos(th);
      v[2] = e.a;
      continue;
    }
    // Hitch rows on (x_r, theta_r, x_f, theta_f), resp. y: [1, d s_r, -1, f s_f] and
    // [1, -d c_r, -1, -f c_f].
    const Hitch& h = hitches[row.element];
    const double tr = x[q_offset(h.rear) + 2], tf = x[q_offset(h.front) + 2];
    v[0] = 1.0;
    v[2] = -1.0;
    if (row.kind == ElementRow::HitchX) {
      v[1] = h.d * std::sin(tr);
      v[3] = h.f * std::sin(tf);
    } else {
      v[1] = -h.d * std::cos(tr);
      v[3] = -h.f * std::cos(tf);
    }
  }
}

void ElementSet::bias(ConstVecRef q, ConstVecRef qdot, VecRef bias) const {
  for (std::size_t r = 0, n = num_rows(); r < n; ++r) {
    const ElementRow row = this->row(r);
    if (row.rigid()) {
      bias[static_cast<Eigen::Index>(r)] = rigid_row_bias(*this, row, q.data(), qdot.data());
      continue;
    }
    if (row.kind == ElementRow::Knife) {
      const int b = knife_edges[row.element].body, o = v_offset(b);
      const double th = q[q_offset(b) + 2], w = qdot[o + 2];
      bias[static_cast<Eigen::Index>(r)] = w * (std::cos(th) * qdot[o] + std::sin(th) * qdot[o + 1]);
      continue;
    }
    const Hitch& h = hitches[row.element];
    const int orr = v_offset(h.rear), of = v_offset(h.front);
    const int qr = q_offset(h.rear) + 2, qf = q_offset(h.front) + 2;
    const double wr = qdot[orr + 2], wf = qdot[of + 2];
    const bool x = row.kind == ElementRow::HitchX;
    const double er = x ? std::cos(q[qr]) : std::sin(q[qr]);
    const double ef = x ? std::cos(q[qf]) : std::sin(q[qf]);
    bias[static_cast<Eigen::Index>(r)] = h.d * er * wr * wr + h.f * ef * wf * wf;
  }
}

void ElementSet::gap(ConstVecRef q, VecRef g) const {
  Eigen::Index j = 0;
  if (ball_chain) {  // the rods, rod b between the centres at 6b + 4 and 6b + 10 (rigid_row_gap's arithmetic)
    const double* x = q.data();
    for (std::size_t b = 0; b < rods.size(); ++b, x += 6) {
      const double length = rods[b].length;
      double s = 0.0;
      for (int i = 0; i < 2; ++i) s += (x[4 + i] - x[10 + i]) * (x[4 + i] - x[10 + i]);
      g[j++] = (s - length * length) / (2.0 * length);
    }
    return;
  }
  for (std::size_t r = 0, n = num_rows(); r < n; ++r) {
    const ElementRow row = this->row(r);
    if (!row.holonomic()) continue;
    if (row.rigid()) {
      g[j++] = rigid_row_gap(*this, row, q.data());
      continue;
    }
    const Hitch& h = hitches[row.element];
    const int orr = q_offset(h.rear), of = q_offset(h.front);
    if (row.kind == ElementRow::HitchX)
      g[j++] = q[orr] - h.d * std::cos(q[orr + 2]) - q[of] - h.f * std::cos(q[of + 2]);
    else
      g[j++] = q[orr + 1] - h.d * std::sin(q[orr + 2]) - q[of + 1] - h.f * std::sin(q[of + 2]);
  }
}

double ElementSet::potential(ConstVecRef q) const {
  double v = 0.0;
  for (const TorsionalSpring& s : springs) {
    const double diff = q[q_offset(s.first) + 2] - q[q_offset(s.second) + 2] - s.rest;
    v += 0.5 * s.k * diff * diff;
  }
  return v;
}

void ElementSet::gradient(ConstVecRef q, VecRef grad) const {
  grad.setZero();
  for (const TorsionalSpring& s : springs) {
    const int a = v_offset(s.first) + 2, b = v_offset(s.second) + 2;
    const double t = s.k * (q[q_offset(s.first) + 2] - q[q_offset(s.second) + 2] - s.rest);
    grad[a] += t;
    grad[b] -= t;
  }
}

void ElementSet::force(double t, ConstVecRef q, VecRef out) const {
  out.setZero();
  for (const Thrust& th : thrusts) {
    const int o = v_offset(th.body), oq = q_offset(th.body);
    if (th.force) {
      const double f = th.force(t);
      out[o] += f * std::cos(q[oq + 2]);
      out[o + 1] += f * std::sin(q[oq + 2]);
    }
    if (th.torque) out[o + 2] += th.torque(t);
  }
  if (has_rigid_forces()) rigid_forces(*this, t, q.data(), out.data());
}

std::string ElementSet::describe(std::size_t r) const {
  const ElementRow e = row(r);
  const auto k = static_cast<std::size_t>(e.element);
  if (e.kind == ElementRow::Knife && k < knife_edges.size())
    return "the knife edge on body " + std::to_string(knife_edges[k].body);
  if ((e.kind == ElementRow::HitchX || e.kind == ElementRow::HitchY) && k < hitches.size())
    return "the hitch with rear body " + std::to_string(hitches[k].rear) + " and front body " +
           std::to_string(hitches[k].front) + (e.kind == ElementRow::HitchX ? ", its x row" : ", its y row");
  if (e.kind == ElementRow::Rod && k < rods.size())
    return "the rod between body " + std::to_string(rods[k].first) + " and body " + std::to_string(rods[k].second);
  return "";
}

}  // namespace nonholo::detail

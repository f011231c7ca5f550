// The period-2 mode's measurement (restart.cpp's continuous_multiplier_at and parasitic_of)
// for the state a fused chain step just produced, in two passes over the bodies instead of
// some ten passes over mu, C and the state, which cost 1.6 fused steps at 10^5 bodies
// (one-form chain measured at every step: 15.5 against 6.0 ms per step unmeasured).
//
// forward, body b+1 entering: v = M^-1 p of it; group b's rows (from the sin/cos the sweep
//   left) get the right-hand side -(bias + mu M^-1 f) and are forward-substituted;
// backward, group g leaving: back substitution gives lambda_s; body g+1 then has all its
//   multipliers: mu^T (lambda~ - lambda_s (+ dlambda/2)) on it and its share of the mode's
//   and the momentum's norms.
#include <nonholo/rattle.hpp>

#include <cmath>
#include <limits>

#include "chain_rows.hpp"
#include "chain_sweep.hpp"
#include "element_set.hpp"

namespace nonholo::detail {
namespace {

template <int KD>
Status measure(const Model& model, Workspace& ws, const double* p, const double* lambda, double h, bool gap_offset,
               double& amplitude) {
  const ElementSet& set = *model.element_set();
  const ChainBody* body = set.chain.data();
  const int n_bodies = static_cast<int>(set.chain.size());
  sparse::BandedLdlt& band = *ws.banded();
  const double* sc = ws.chain_sincos.data();
  const double* fa = model.has_applied_force() ? ws.applied.data() : nullptr;
  const double* gm = ws.gap_multiplier.data();
  double* v = ws.velocity.data();
  double* ls = ws.lambda_s.data();
  auto next_sc = [&](int b) { return b + 1 < n_bodies ? sc + 2 * b + 2 : sc + 2 * b; };

  // Forward: rhs = -(bias + mu M^-1 f) row by row, forward-substituted into lambda_s.
  for (int c = 0; c < 3; ++c) v[c] = (&body[0].wx)[c] * p[c];
  int row = 0;
  for (int b = 0; b < n_bodies; ++b) {
    const ChainBody& cb = body[b];
    if (b + 1 < n_bodies)
      for (int c = 0; c < 3; ++c) v[3 * b + 3 + c] = (&body[b + 1].wx)[c] * p[3 * b + 3 + c];
    Group g;
    group_rows(cb, sc + 2 * b, next_sc(b), g, nullptr);
    double bias[3];
    group_bias(cb, sc + 2 * b, next_sc(b), v + 3 * b, b + 1 < n_bodies ? v + 3 * b + 3 : v + 3 * b, bias);
    for (int j = 0; j < g.rows; ++j) {
      double r = bias[j];
      if (fa) {
        const double* wn = b + 1 < n_bodies ? &body[b + 1].wx : &cb.wx;
        for (int c = 0; c < 3; ++c) {
          r += g.u[j][c] * (&cb.wx)[c] * fa[3 * b + c];
          if (b + 1 < n_bodies) r += g.v[j][c] * wn[c] * fa[3 * b + 3 + c];
        }
      }
      ls[row + j] = -r;
      band.template forward_row<KD>(row + j, ls);
    }
    row += g.rows;
  }

  // Backward: lambda_s, then the mode mu^T (lambda~ - lambda_s) body by body.
  double mode = 0.0, momentum = 0.0, finite = 0.0;
  Group later;
  int later_first = row;
  auto finish_body = [&](int b, const Group& own, int own_first, const Group* before, int before_first) {
    double g3[3] = {0.0, 0.0, 0.0};
    auto add = [&](const double (*rows)[3], int count, int first) {
      for (int j = 0; j < count; ++j) {
        const int r = first + j;
        const double d = lambda[r] - ls[r] + (gap_offset ? 0.5 * gm[r] : 0.0);
        for (int c = 0; c < 3; ++c) g3[c] += rows[j][c] * d;
      }
    };
    add(own.u, own.rows, own_first);
    if (before) add(before->v, before->rows, before_first);
    const ChainBody& cb = body[b];
    for (int c = 0; c < 3; ++c) {
      mode += (&cb.wx)[c] * g3[c] * g3[c];
      momentum += p[3 * b + c] * v[3 * b + c];
    }
  };
  for (int b = n_bodies - 1; b >= 0; --b) {
    Group g;
    group_rows(body[b], sc + 2 * b, next_sc(b), g, nullptr);
    const int first = later_first - g.rows;
    for (int r = later_first - 1; r >= first; --r) {
      band.template backward_row<KD>(r, ls);
      finite += ls[r];
    }
    if (b + 1 < n_bodies) finish_body(b + 1, later, later_first, &g, first);
    later = g;
    later_first = first;
  }
  finish_body(0, later, later_first, nullptr, 0);

  if (!std::isfinite(finite))
    return ws.fail(Status::NonFiniteState,
                   "the continuous multiplier is not finite (the bias or the force is NaN or Inf): "
                   "check the model's bias and forces, or reduce the step size");
  if (!(momentum > 0.0))
    amplitude = mode > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
  else
    amplitude = 0.5 * h * std::sqrt(mode / momentum);
  return Status::Ok;
}

}  // namespace

Status chain_measure(const Model& model, Workspace& ws, const double* p, const double* lambda, double h,
                     bool gap_offset, double& amplitude) {
  const FlushSubnormals flush(model.num_bodies() >= kFlushSubnormalsFrom);
  switch (ws.banded()->bandwidth()) {
    case 0: return measure<0>(model, ws, p, lambda, h, gap_offset, amplitude);
    case 4: return measure<4>(model, ws, p, lambda, h, gap_offset, amplitude);
    default: return measure<-1>(model, ws, p, lambda, h, gap_offset, amplitude);
  }
}

}  // namespace nonholo::detail

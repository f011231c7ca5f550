// Holonomic mode's position corrections (rattle.cpp's enforce_gaps) on a chain split over
// threads: C(q_k) dlambda = scale [g; 0] solved with the partitioned factorisation the step to
// q_k left. Each thread kicks, drifts, corrects and measures the gaps of its own bodies and
// substitutes its own rows (chain_passes.cpp's work on a partition, body by body in the same
// operations); the separators' rows are solved, and their gaps taken, between the jobs on
// the calling thread. The last partition works from the chain's end with its rows in tail_x
// (chain_partitions_tail.cpp): x's rows of its bodies are not used.
#include "base/thread_team.hpp"
#include "step/chain/chain_partitions.hpp"
#include "step/chain/chain_sweep.hpp"
#include "step/chain/gap_rows.hpp"

namespace nonholo::detail {
namespace {

// The gaps of the separators' hitches (their bodies are in two partitions) into their rows
// of x (scale g, as the partitions' own); the largest into worst.
void separator_gaps(const ChainBodies& body, const ChainPartitions& cp, const double* qn, const double* sc,
                    double scale, double* x, double& worst) {
  for (int j = 0; j + 1 < cp.parts; ++j) {
    const int b = cp.first[j + 1] - 1;
    double gx, gy;
    hitch_gap_xy(body[b], qn + 3 * b, sc + 2 * b, gx, gy);
    track_worst(gx, gy, worst);
    x[3 * b + 1] = scale * gx;
    x[3 * b + 2] = scale * gy;
  }
}

// The partitions' largest gaps in partition order (NaN wins), then the separators'.
double worst_gap(const Model& model, Workspace& ws, double scale, double* x) {
  const ChainPartitions& cp = *ws.partitions();
  double worst = 0.0;
  for (const auto& part : cp.part) merge_worst(part.worst, worst);
  separator_gaps(model.element_set()->chain_bodies(), cp, ws.q_next.data(), ws.chain_sincos.data(), scale, x, worst);
  return worst;
}

}  // namespace

double chain_gap_forward_parted(const Model& model, Workspace& ws, const State& st, double h, double scale, double* y,
                                double& size) {
  ChainPartitions& cp = *ws.partitions();
  const ChainBodies body = model.element_set()->chain_bodies();
  const int n_bodies = body.size(), parts = cp.parts;
  sparse::BandedLdlt& band = *ws.banded();
  const double *q = st.q.data(), *p = st.p.data(), *force = st.force.data();
  double *qn = ws.q_next.data(), *ph = ws.p_half.data();
  ws.forget_sincos();  // they are q_{k+1}'s from here on
  double* sc = ws.chain_sincos.data();
  auto job = [&](TeamMember& member) {
    const FlushSubnormals flush;  // per thread (chain_partitions.cpp)
    const int team = member.size();
    for (int j = member.index(); j < parts; j += team) {
      ChainPartitions::Part& out = cp.part[j];
      double worst = 0.0, largest = 0.0, left[2] = {0.0, 0.0};
      if (is_tail(cp, j)) {  // from the chain's end, in tail_x
        tail_gap_forward(body, cp, q, p, force, h, scale, ph, qn, sc, worst, largest);
        out.worst = worst;
        out.largest = largest;
        continue;
      }
      const PartRows rows(band, cp, j, n_bodies);
      kick_drift_body(body, rows.b0, q, p, force, h, ph, qn, sc, largest);
      for (int b = rows.b0; b < rows.b1; ++b) {
        const int r = 3 * b;
        y[r] = 0.0;
        if (b + 1 < rows.b1) {  // the hitch to the next body, this partition's (else: the separator's)
          kick_drift_body(body, b + 1, q, p, force, h, ph, qn, sc, largest);
          double gx, gy;
          hitch_gap_xy(body[b], qn + r, sc + 2 * b, gx, gy);
          track_worst(gx, gy, worst);
          y[r + 1] = scale * gx;
          y[r + 2] = scale * gy;
        }
        rows.forward(b, y, left, out.right_y);
      }
      out.left_y[0] = left[0], out.left_y[1] = left[1];
      out.worst = worst;
      out.largest = largest;
    }
  };
  ThreadPool::run(ws.team(), job);
  double largest = 0.0;
  for (const auto& part : cp.part) largest = std::max(largest, part.largest);
  size = largest;
  return worst_gap(model, ws, scale, y);
}

void chain_forward_substitute_parted(Workspace& ws, double* y) {
  ChainPartitions& cp = *ws.partitions();
  sparse::BandedLdlt& band = *ws.banded();
  const int parts = cp.parts, n_bodies = cp.first[parts];
  auto job = [&](TeamMember& member) {
    const FlushSubnormals flush;
    const int team = member.size();
    for (int j = member.index(); j < parts; j += team)
      is_tail(cp, j) ? tail_forward_substitute(cp, n_bodies) : forward_partition(band, cp, j, n_bodies, y);
  };
  ThreadPool::run(ws.team(), job);
}

double chain_correct_backward_parted(const Model& model, Workspace& ws, double* x, double h, double scale) {
  ChainPartitions& cp = *ws.partitions();
  const ChainBodies body = model.element_set()->chain_bodies();
  const int n_bodies = body.size(), parts = cp.parts;
  sparse::BandedLdlt& band = *ws.banded();
  const double* so = ws.chain_sincos_prev.data();  // sin/cos of q_k: the rows of mu(q_k)
  double *ph = ws.p_half.data(), *qn = ws.q_next.data(), *sc = ws.chain_sincos.data();
  // The separators' multipliers first: every partition's back substitution reads them.
  for (int j = 0; j + 1 < parts; ++j) {
    const int r = 3 * (cp.first[j + 1] - 1) + 1;
    for (int a = 0; a < 2; ++a) cp.block[j].rhs[a] = x[r + a] - cp.part[j].right_y[a] - cp.part[j + 1].left_y[a];
  }
  solve_separators(cp, x);
  auto job = [&](TeamMember& member) {
    const FlushSubnormals flush;
    const int team = member.size();
    for (int j = member.index(); j < parts; j += team) {
      const int b0 = cp.first[j], b1 = cp.first[j + 1];
      double worst = 0.0;
      // Body c has all its multipliers; the separator's rows (the next partition reads them)
      // keep theirs. c goes down: its next gap (to c+1) needs c+1 corrected, and it overwrites
      // its rows, which the substitution of the bodies before no longer reads.
      auto finish = [&](int c) { correct_and_measure(body, c, c + 1 < b1, so, h, scale, ph, qn, sc, x, worst); };
      if (is_tail(cp, j)) {  // from the chain's end, in tail_x
        tail_correct_backward(body, cp, so, h, scale, ph, qn, sc, x, worst);
      } else {
        const Unborder unborder(cp, j, x);
        for (int b = b1 - 1; b >= b0; --b) {
          back_substitute_body(band, b, n_bodies, b == b1 - 1, x, unborder);
          if (b + 1 < b1) finish(b + 1);
        }
        finish(b0);
      }
      cp.part[j].worst = worst;
    }
  };
  ThreadPool::run(ws.team(), job);
  return worst_gap(model, ws, scale, x);
}

}  // namespace nonholo::detail

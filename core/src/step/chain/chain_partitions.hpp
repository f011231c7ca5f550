#pragma once
// The common chain (ElementSet::hitched_chain) split over threads (chain_partitions.cpp,
// docs/design.md "One chain on several threads"): partition j owns the bodies
// [first[j], first[j+1]); the hitch of its last body, whose two rows alone couple it to the
// next partition, is the separator s_j. Each thread factorises its partition's other rows in
// the band (natural order, as on one thread); the rows of the partition's left separator are
// carried as a border (their L against each of its rows, 2 per row); the separators' Schur
// complement, block tridiagonal with 2x2 blocks, is factorised by one thread. The last
// partition is factorised from the chain's tail instead (chain_partitions_tail.cpp), in a band
// of its own order (in the chain band's last rows) and without a border: for two threads, a
// factorisation from both ends.
#include <nonholo/rattle.hpp>

#include <memory>
#include <vector>

#include <nonholo/sparse/banded_ldlt.hpp>

#include "step/chain/sweep_common.hpp"

namespace nonholo::detail {

// The common chain's band: rows 3b (knife edge), 3b+1, 3b+2 (hitch b -> b+1), half-bandwidth 4.
inline constexpr int kChainBandwidth = 4;

// The rows a chain's band holds beyond its own for the tail partition's band to live in it:
// the tail's rows of the band are unused while the chain is split (the tail is factorised in
// its own order), and the tail's band has two rows more (its copy of its left separator's).
inline constexpr int kTailSpareRows = 2;

struct ChainPartitions {
  // `parts` partitions of at least 2 bodies each (callers check: WorkspaceOptions::threads),
  // for a chain with `thrusts` thrusts. The tail's band lives in `band`'s last rows when it
  // has kTailSpareRows spare rows (60 MB less for a million-body chain on 2 threads), else in
  // storage of its own. `band` serves only one of the two at a time: a serial factorisation
  // overwrites the tail's rows, and marks the factorisation not partitioned.
  // tail_x is scratch within a call (a step, a solve, a measurement): `shared_tail_x`, when given,
  // is another ChainPartitions' of the same chain that never runs at the same time (the accuracy
  // check's shadow's is the run's: 12 MB less for a million-body chain).
  ChainPartitions(int bodies, int parts, int thrusts, sparse::BandedLdlt* band = nullptr,
                  double* shared_tail_x = nullptr);
  ChainPartitions(const ChainPartitions&) = delete;  // tail_x may point into tail_storage
  ChainPartitions& operator=(const ChainPartitions&) = delete;

  int parts;
  std::vector<int> first;       // parts + 1 body boundaries
  std::vector<double> border;   // L(s, r) for the left separator s of r's partition (x, y; 2 per row)
  // The last partition, from the tail: body b's rows are rows 3k (its knife edge) and 3k+1,
  // 3k+2 (the hitch b-1 -> b, negated) of `tail`, k = N-1-b; rows 3n-2, 3n-1 (n = its bodies)
  // its left separator's. tail_x: a vector in that order.
  int tail_first;
  std::unique_ptr<sparse::BandedLdlt> tail;
  double* tail_x = nullptr;
  std::vector<double> tail_storage;  // tail_x's, unless shared
  std::vector<double> thrust_values;  // Forward::thrust_values: each thrust's force and torque at t_{k+1}

  // What partition j hands to the separators' system and to the step's sums, one cache line
  // apart (threads write them).
  struct alignas(64) Part {
    double right_schur[3] = {};  // its rows' Schur complement on the right separator (xx, xy, yy)
    double right_y[2] = {};      // sum_c L(s, c) y_c over its rows c, for the right separator
    double left_schur[3] = {};   // the same for the left separator (its border)
    double left_y[2] = {};
    double cross[2][2] = {};     // -(the Schur block between its left and right separators)
    sparse::PivotLog pivots;
    BlockSum kinetic, kinetic_post;
    double potential_old = 0.0, potential_new = 0.0, check = 0.0, residual = 0.0, gap = 0.0;
    // The mode's measurement (chain_partitions_measure.cpp): |y|^2_D over its rows, |p_-|^2 and
    // the kicks in M^-1 over its bodies, and the right separator's rows of r.
    double mode = 0.0, arriving = 0.0, kicks = 0.0, right_r[2] = {};
    // Holonomic mode's passes (chain_partitions_passes.cpp): the largest |gap| of its own
    // hitches and the largest |q_next| of its bodies.
    double worst = 0.0, largest = 0.0;
  };
  std::vector<Part> part;

  // The separators' block LDL^T: D'_j^-1 (xx, xy, yy) and the coupling U_j to s_{j+1}.
  struct Block {
    double inverse[3] = {};
    double up[2][2] = {};
    double rhs[2] = {};  // the reduced right-hand side during a solve
  };
  std::vector<Block> block;
};

// Partition [b0, b1)'s rows in the band as the partitioned factorisation orders them: the
// forward substitution of body g's rows (its knife edge's; its hitch's, unless that is the
// right separator, whose partial sum goes to `right`), the border's sums into `left`.
struct PartRows {
  sparse::BandedLdlt& band;
  const double* lb;
  int n_bodies, b0, b1;
  bool first, last;

  PartRows(sparse::BandedLdlt& b, const ChainPartitions& cp, int j, int bodies)
      : band(b), lb(cp.border.data()), n_bodies(bodies), b0(cp.first[j]), b1(cp.first[j + 1]), first(j == 0),
        last(j + 1 == cp.parts) {}
  // The tail partition's rows, of n bodies, in its band (numbered from the tail): a first
  // partition whose right separator is the tail's left one.
  PartRows(sparse::BandedLdlt& tail, int bodies, int n)
      : band(tail), lb(nullptr), n_bodies(bodies), b0(0), b1(n), first(true), last(false) {}

  bool separator(int g) const { return g == b1 - 1 && !last; }
  // Whether body g has hitch rows of this partition's own.
  bool hitch_rows(int g) const { return g + 1 < n_bodies && !separator(g); }

  void forward(int g, double* y, double* left, double* right) const {
    first ? forward<true>(g, y, left, right) : forward<false>(g, y, left, right);
  }
  // First: partition 0's (no border), fixed at compile time in the sweeps' loops.
  template <bool First>
  void forward(int g, double* y, double* left, double* right) const {
    constexpr int KD = kChainBandwidth;
    sparse::BandedLdlt& bd = band;
    const int r = 3 * g;
    const bool start = g == b0;
    if (First)
      g >= 2 ? bd.forward_interior_row<KD, 2>(r, y) : bd.forward_row<KD>(r, y);
    else if (!start)
      bd.forward_interior_row<KD, 2>(r, y);
    sum<First>(r, y, left);
    if (g + 1 >= n_bodies) return;
    if (separator(g)) {
      const double* rx = bd.row(r + 1);
      const double* ry = bd.row(r + 2);
      right[0] = rx[1] * y[r - 2] + rx[2] * y[r - 1] + rx[3] * y[r];
      right[1] = ry[0] * y[r - 2] + ry[1] * y[r - 1] + ry[2] * y[r];
      return;
    }
    if (First && g < 2) {
      bd.forward_row<KD>(r + 1, y);
      bd.forward_row<KD>(r + 2, y);
    } else if (start && !First) {
      bd.forward_interior_row<KD, 3>(r + 1, y);
      bd.forward_interior_row<KD, 2>(r + 2, y);
    } else {
      bd.forward_interior_row<KD, 1>(r + 1, y);
      bd.forward_interior_row<KD, 0>(r + 2, y);
    }
    sum<First>(r + 1, y, left);
    sum<First>(r + 2, y, left);
  }
  template <bool First>
  void sum(int r, const double* y, double* left) const {
    if (First) return;
    left[0] += lb[2 * static_cast<std::ptrdiff_t>(r)] * y[r];
    left[1] += lb[2 * static_cast<std::ptrdiff_t>(r) + 1] * y[r];
  }
};

// The tail partition's forward substitution of x's rows (in its order, back into x's), its
// partial sums for its left separator in its part's left_y; the back substitution of its rows
// (its separator's x known); after forward_tail, sum y^2 / D over its own rows (the mode's
// measurement). chain_partitions_tail.cpp.
void forward_tail(ChainPartitions& cp, int n_bodies, double* x);
void backward_tail(ChainPartitions& cp, int n_bodies, double* x);
double tail_mode(const ChainPartitions& cp, int n_bodies);
// The tail partition's share of the step (PartSweep's in chain_partitions.cpp, from the tail).
bool tail_sweep_forward(const Model& model, Workspace& ws, const State& st, double h, double t_next, bool kicked,
                        double min_pivot_ratio);
void tail_sweep_backward(const Model& model, Workspace& ws, double h);
// Holonomic mode's passes on the tail (chain_partitions_passes.cpp's), its rows of the passes'
// vector kept in tail_x throughout: the gaps' pass (kick, drift, gaps, forward substitution;
// worst and largest as kick_drift_body and track_worst keep them), a forward substitution, and
// the back substitution with each body's correction and next gaps (x: the separator's rows).
void tail_gap_forward(const ChainBodies& body, ChainPartitions& cp, const double* q, const double* p,
                      const double* force, double h, double scale, double* ph, double* qn, double* sc, double& worst,
                      double& largest);
void tail_forward_substitute(ChainPartitions& cp, int n_bodies);
void tail_correct_backward(const ChainBodies& body, ChainPartitions& cp, const double* so, double h, double scale,
                           double* ph, double* qn, double* sc, const double* x, double& worst);
inline bool is_tail(const ChainPartitions& cp, int j) { return j + 1 == cp.parts && cp.parts > 1; }

// Partition j's forward substitution of x (PartRows' order), its partial sums for the
// separators in part[j].left_y and right_y.
inline void forward_partition(sparse::BandedLdlt& band, ChainPartitions& cp, int j, int n_bodies, double* x) {
  if (is_tail(cp, j)) return forward_tail(cp, n_bodies, x);
  const PartRows rows(band, cp, j, n_bodies);
  double* left = cp.part[j].left_y;
  left[0] = left[1] = 0.0;
  for (int g = rows.b0; g < rows.b1; ++g) rows.forward(g, x, left, cp.part[j].right_y);
}

// The border's term taken off row r of partition j in a back substitution (nothing on the
// first partition), the left separator's x known.
struct Unborder {
  const double* lb;
  const double* xs;  // the left separator's x (null: partition 0)
  Unborder(const ChainPartitions& cp, int j, const double* x)
      : lb(cp.border.data()), xs(j == 0 ? nullptr : x + 3 * cp.first[j] - 2) {}
  void operator()(double* x, int r) const {
    if (xs) x[r] -= lb[2 * static_cast<std::ptrdiff_t>(r)] * xs[0] + lb[2 * static_cast<std::ptrdiff_t>(r) + 1] * xs[1];
  }
};

// Back substitution of body b's rows (its hitch rows unless they are the separator, whose
// multipliers are known), the border's term taken off each (`unborder`); rows after body b+1's
// are read only away from the chain's end, so a partition reads no other partition's rows.
// (U: Unborder, or a callable that skips it where the partition is known to be the first.)
template <class U = Unborder>
inline void back_substitute_body(sparse::BandedLdlt& band, int b, int n_bodies, bool separator, double* x,
                                 const U& unborder) {
  const int r = 3 * b;
  if (!separator && b + 1 < n_bodies) {
    if (b + 3 < n_bodies) {
      band.backward_interior_row<kChainBandwidth, 3>(r + 2, x);
      unborder(x, r + 2);
      band.backward_interior_row<kChainBandwidth, 4>(r + 1, x);
    } else {
      band.backward_row<kChainBandwidth>(r + 2, x);
      unborder(x, r + 2);
      band.backward_row<kChainBandwidth>(r + 1, x);
    }
    unborder(x, r + 1);
  }
  if (b + 3 < n_bodies || separator)
    band.backward_interior_row<kChainBandwidth, 2>(r, x);
  else
    band.backward_row<kChainBandwidth>(r, x);
  unborder(x, r);
}

// Partition j's back substitution of x (the separators' x known).
inline void backward_partition(sparse::BandedLdlt& band, ChainPartitions& cp, int j, int n_bodies, double* x) {
  if (is_tail(cp, j)) return backward_tail(cp, n_bodies, x);
  const Unborder unborder(cp, j, x);
  const int b0 = cp.first[j], b1 = cp.first[j + 1];
  for (int g = b1 - 1; g >= b0; --g) back_substitute_body(band, g, n_bodies, g == b1 - 1 && j + 1 < cp.parts, x, unborder);
}

// The separators' multipliers from their reduced right-hand sides (block.rhs) into x.
void solve_separators(ChainPartitions& cp, double* x);

// The step of the common chain (chain_sweep.cpp's sweep_hitched; `kicked`: after holonomic
// mode's passes) on ws.partitions()'s threads; the factorisation it leaves is partitioned
// (Workspace::solve and the next step's passes solve with it). Bitwise the same for the same
// partitions, whatever threads run them.
Status sweep_hitched_parted(const Model& model, Workspace& ws, const State& st, const RattleOptions& o, double h,
                            double t_next, bool kicked, double& check);

// x = C^-1 b with the factorisation a partitioned step left (x may be b), on its threads.
void solve_parted(const Model& model, Workspace& ws, const double* b, double* x);

// Holonomic mode's passes (chain_passes.cpp's, chain_sweep.hpp) with the partitioned
// factorisation of C(q_k) a partitioned step left, on its threads (chain_partitions_passes.cpp).
// The separators' gaps, whose bodies two partitions move, are taken on the calling thread.
double chain_gap_forward_parted(const Model& model, Workspace& ws, const State& st, double h, double scale, double* y,
                                double& size);
void chain_forward_substitute_parted(Workspace& ws, double* y);
double chain_correct_backward_parted(const Model& model, Workspace& ws, double* x, double h, double scale);

// chain_measure (chain_sweep.hpp) after a partitioned step, on its threads and with its
// factorisation (chain_partitions_measure.cpp): |d|_C^2 = r^T C^-1 r from the partitions' forward
// substitutions and the separators' reduced system.
Status chain_measure_parted(const Model& model, Workspace& ws, const double* p, const double* lambda, double h,
                            const State* from, double& amplitude);

}  // namespace nonholo::detail

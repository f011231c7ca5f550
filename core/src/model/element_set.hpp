#pragma once
// A model's local constraint elements (nonholo/elements.hpp) and what build() derives from
// them: the one-form values, bias and gaps in the model's row order, the springs' potential
// and the thrusts' forces (the general callbacks every integrator understands), and, when
// the rows run body by body, the per-body layout of the fused chain step (chain_sweep.cpp).
#include <nonholo/elements.hpp>
#include <nonholo/model.hpp>
#include <nonholo/types.hpp>

#include <memory>
#include <string>
#include <vector>

namespace nonholo::detail {

// Where a row of mu comes from. 8 bytes (24 MB for a million-body chain's 3 million rows; 12
// with `part` after `element`).
struct ElementRow {
  enum Kind : unsigned char { Knife, HitchX, HitchY, BodyAxis, SpaceAxis, Ball, Disk, Rod };
  ElementRow(Kind k, int e, unsigned char p = 0) : kind(k), part(p), element(e) {}
  Kind kind;
  // The row's place in its element: a ball's and a disk's rows 0 (x), 1 (y), 2 (height).
  unsigned char part;
  int element;  // index into the element's list (knife_edges, hitches, body_axes, ...)
  // Whether the row is the gradient of a gap (hitches, a ball's and a disk's height, rods).
  bool holonomic() const {
    return kind == HitchX || kind == HitchY || kind == Rod || ((kind == Ball || kind == Disk) && part == 2);
  }
  bool rigid() const { return kind >= BodyAxis; }  // on rigid bodies (rigid_elements.cpp); Rod: on centres
};
static_assert(sizeof(ElementRow) == 8);

// One body of a chain as the fused step streams it: its inverse mass, the knife edge on it
// (flag 1), the hitch from it (rear) to the next body (front) (flag 2, d on this body, f on
// the next), and the springs joining it to the next body: with D = theta_b - theta_{b+1},
// sum_i k_i/2 (D - r_i)^2 = k/2 D^2 - kr D + krr/2 (k, kr, krr: sums of k_i, k_i r_i, k_i r_i^2).
struct ChainBody {
  double wx, wy, wt;  // diagonal of M^-1
  double a, d, f, k, kr, krr;
  int flags;
};
inline constexpr int kChainKnife = 1, kChainHitch = 2;

// The chain's bodies as the fused passes read them. When every body but the last carries
// the same data bit for bit, as in generated chains, the passes read chain[0] and the last
// entry, which stay in L1, and stream only the state, not 80 B of element data a body per
// pass (some 17% of a holonomic step's traffic at 10^6 bodies).
struct ChainBodies {
  const ChainBody* data;
  int count;
  int stride;  // 1, or 0 when uniform
  int last;    // the last body's entry: count - 1, or 1 when uniform (data holds two entries)
  const ChainBody& operator[](int b) const { return data[b + 1 < count ? b * stride : last]; }
  int size() const { return count; }
};

struct ElementSet {
  std::vector<KnifeEdge> knife_edges;
  std::vector<Hitch> hitches;
  std::vector<TorsionalSpring> springs;
  std::vector<Thrust> thrusts;  // sorted by body in build()
  // On rigid bodies (and rods on any centres): rigid_elements.cpp evaluates them.
  std::vector<BodyAxisConstraint> body_axes;
  std::vector<SpaceAxisConstraint> space_axes;
  std::vector<RollingBall> balls;
  std::vector<RollingDisk> disks;
  std::vector<Rod> rods;
  std::vector<BodyTorque> torques;
  std::vector<BodyForce> body_forces;
  bool has_gravity = false;
  double gravity = 0.0;  // g of ModelBuilder::add_gravity
  // Where each row comes from and its first value (the pattern's row_ptr). Both are dropped at
  // build() when the chain layout implies them (rows_implied, below: 36 MB for a million-body
  // chain); read them through num_rows(), row() and value_start().
  std::vector<ElementRow> rows;
  std::vector<int> value_offset;
  // The rows of the common chain (hitched_chain: row 3b + j is body b's knife edge, j = 0, and its
  // hitch's x and y rows, j = 1, 2; 3 and 4 values) or of knife edges alone (knife_chain: row b,
  // 3 values), each element numbered by its body, as build() checked them to be.
  enum class Implied : unsigned char { None, Hitched, Knives };
  Implied rows_implied = Implied::None;
  std::size_t implied_rows = 0;
  std::size_t num_rows() const { return rows_implied == Implied::None ? rows.size() : implied_rows; }
  ElementRow row(std::size_t r) const {
    if (rows_implied == Implied::None) return rows[r];
    if (rows_implied == Implied::Knives) return {ElementRow::Knife, static_cast<int>(r)};
    static constexpr ElementRow::Kind kinds[3] = {ElementRow::Knife, ElementRow::HitchX, ElementRow::HitchY};
    return {kinds[r % 3], static_cast<int>(r / 3)};
  }
  // What row r is, for a message: "the hitch with rear body 2 and front body 3, its x row";
  // "" for the rows of rigid-body elements (their callers name them).
  std::string describe(std::size_t r) const;
  int value_start(std::size_t r) const {
    if (rows_implied == Implied::None) return value_offset[r];
    if (rows_implied == Implied::Knives) return static_cast<int>(3 * r);
    static constexpr int within[3] = {0, 3, 7};
    return static_cast<int>(11 * (r / 3)) + within[r % 3];
  }
  // First velocity entry of each body; empty when body b's is 3b (planar bodies only, in order:
  // 4 MB for a million bodies). Read it through v_offset().
  std::vector<int> body_offset;
  int v_offset(int body) const { return body_offset.empty() ? 3 * body : body_offset[body]; }
  // First configuration entry of each body; empty when every body's equals its velocity entry (no
  // rigid bodies: a million-body chain keeps no array).
  std::vector<int> body_q_offset;
  int q_offset(int body) const { return body_q_offset.empty() ? v_offset(body) : body_q_offset[body]; }
  // The model's rigid bodies and, per body, its index among them (-1: not rigid; empty when
  // there are none).
  // (The model's own list, shared: 17.6 MB for 10^5 balls when it was copied.)
  std::shared_ptr<const std::vector<RigidBlock>> rigid;
  std::vector<int> rigid_of;
  const RigidBlock& rigid_body(int body) const { return (*rigid)[static_cast<std::size_t>(rigid_of[body])]; }
  // The centre of a body (a rod's end): its first configuration and velocity entries and
  // dimension (a planar body's x, y; a rigid body's translation).
  int centre_q(int body) const { return rigid_of.empty() || rigid_of[body] < 0 ? q_offset(body) : rigid_body(body).q + 4; }
  int centre_v(int body) const { return rigid_of.empty() || rigid_of[body] < 0 ? v_offset(body) : rigid_body(body).v + 3; }
  int centre_dim(int body) const { return rigid_of.empty() || rigid_of[body] < 0 ? 2 : rigid_body(body).translation; }
  bool has_rigid_forces() const { return has_gravity || !torques.empty() || !body_forces.empty(); }

  // The chain layout, when every body is planar with a diagonal M^-1 and the rows run body
  // by body as [knife edge of b][hitch b -> b+1 (x, y)] with springs only between
  // neighbours: then chain holds an entry per body (two for a uniform chain, below). Empty
  // otherwise.
  std::vector<ChainBody> chain;
  // Every body but the last has chain[0]'s data bit for bit: the passes read chain_bodies().
  bool chain_uniform = false;
  // A uniform chain keeps two entries in `chain`, the common body's and the last's (80 MB less
  // for a million bodies); chain_count is the number of bodies either way.
  int chain_count = 0;
  ChainBodies chain_bodies() const {
    return {chain.data(), chain_count, chain_uniform ? 0 : 1, static_cast<int>(chain.size()) - 1};
  }
  // The half-bandwidth of C in the chain's row order (4 with knife edges and hitches, 0 with
  // knife edges only), from the layout alone: the banded factor of a chain is set up without
  // C's pattern (Model::gram is not built for it).
  int chain_bandwidth = 0;
  // The common chain of three bodies or more: every body has a knife edge and a hitch to the
  // next, the last only its knife edge (rows 3b, 3b+1, 3b+2 of body b; kd = 4): the sweep and
  // the holonomic corrections have closed forms for it.
  bool hitched_chain = false;
  // Every body has one knife edge and nothing joins their rows (C is diagonal; springs and
  // thrusts allowed): the step is one sweep (the single sleigh, the spring chain).
  bool knife_chain = false;
  // A chain of balls rolling on the plane (rigid bodies 0 .. N-1 in order, translation 2) with
  // rods between neighbours, rows ball by ball: rolling x and y of ball b (rows 3b, 3b+1, values
  // 12b and 12b + 4: [angular | 1]) and the rod b -> b+1 (row 3b+2, values 12b + 8: [d | -d]);
  // ball b is balls[b], its rod rods[b], its q at 6b and its velocities at 5b.
  // C is banded with chain_bandwidth min(3, m - 1) and is factorised from mu row by row
  // (ball_chain_band.cpp) without C's pattern or Model::gram; the step is the general one.
  bool ball_chain = false;

  // The general callbacks (row order, pattern order of values).
  void values(ConstVecRef q, VecRef mu) const;
  void ball_chain_values(const double* q, double* mu) const;  // values() of a ball_chain (rigid_elements.cpp)
  void ball_chain_values(const double* q, double* mu, int first, int last) const;  // balls [first, last) only
  // Model::mu_times and mu_transpose_times of a ball_chain, ball by ball from the layout (no
  // column indices; the pattern's order of sums, so the same bits): ball_chain_products.cpp.
  void ball_chain_times(const double* mu, const double* x, double* y) const;
  void ball_chain_transpose_times(const double* mu, const double* lambda, double* g) const;
  void bias(ConstVecRef q, ConstVecRef qdot, VecRef bias) const;
  void gap(ConstVecRef q, VecRef g) const;
  double potential(ConstVecRef q) const;
  void gradient(ConstVecRef q, VecRef grad) const;
  void force(double t, ConstVecRef q, VecRef out) const;
};

// Ball b's velocities' share of mu^T lambda, from its values x (the rod before's at x[-2], x[-1])
// and the multipliers l of its rows (l[-1]: the rod before), in the pattern's order of sums
// (ElementSet::ball_chain_transpose_times, ball_chain_kick).
inline void ball_chain_transpose_ball(const double* x, const double* l, bool before, bool after, double* g) {
  for (int i = 0; i < 3; ++i) g[i] = x[i] * l[0] + x[4 + i] * l[1];
  double gx = x[3] * l[0], gy = x[7] * l[1];
  if (before) {
    gx = x[-2] * l[-1] + gx;
    gy = x[-1] * l[-1] + gy;
  }
  if (after) {
    gx += x[8] * l[2];
    gy += x[9] * l[2];
  }
  g[3] = gx;
  g[4] = gy;
}

// The rows, bias, gaps and forces of the elements on rigid bodies and of rods (rigid_elements.cpp).
// row_values writes the row's values in the order of its columns (ModelBuilder's add_*).
void rigid_row_values(const ElementSet& set, const ElementRow& row, const double* q, double* values);
double rigid_row_bias(const ElementSet& set, const ElementRow& row, const double* q, const double* v);
double rigid_row_gap(const ElementSet& set, const ElementRow& row, const double* q);  // holonomic rows
void rigid_forces(const ElementSet& set, double t, const double* q, double* out);  // adds to out

}  // namespace nonholo::detail

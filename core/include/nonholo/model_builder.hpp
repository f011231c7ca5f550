#pragma once
/// @file
/// Validating construction of a Model. Every mistake is reported by a std::invalid_argument
/// whose message names the body, row or column and the offending value.
#include <nonholo/elements.hpp>
#include <nonholo/model.hpp>
#include <nonholo/rigid_body.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace nonholo {

/// Builds a Model: add bodies, then constraint rows or elements, then the callbacks, then
/// build().
class ModelBuilder {
 public:
  /// A body with one coordinate per name and a constant SPD mass block (names.size() square).
  /// Returns the body index. Throws on a non-square, mismatched, non-finite, non-symmetric or
  /// non-positive-definite block.
  int add_body(const std::vector<std::string>& coordinate_names, const Eigen::MatrixXd& mass_block);
  /// A planar rigid body in centre-of-mass coordinates (x, y, theta): M = diag(m, m, I).
  /// Throws unless mass and inertia are finite and positive.
  int add_planar_body(const std::array<std::string, 3>& coordinate_names, double mass, double inertia);
  /// A 3-D rigid body (nonholo/rigid_body.hpp): 4 + d configuration entries (quaternion, centre)
  /// and 3 + d velocity entries (Omega in the body frame, the centre's velocity), M =
  /// blockdiag(inertia, m Id). Throws unless the translation is 0, 2 or 3, the mass positive
  /// and finite, and the inertia finite, symmetric and positive definite (condition number at
  /// most 1e12, as add_body); the names follow RigidBody::name.
  int add_rigid_body(const RigidBody& body);
  /// Where a body added so far has its velocities: the first entry (its offset in p, in a
  /// force, in a row of mu, in a symmetry's generator) and how many (3 for a planar body,
  /// 3 + translation for a rigid one). Throws for a body that does not exist.
  struct VelocityRange {
    int first = 0;  ///< the body's first velocity entry
    int count = 0;  ///< its number of velocity entries
  };
  VelocityRange velocities_of(int body) const;  ///< see VelocityRange

  /// Optional: room for a model of this size, so that a million bodies are added without
  /// regrowing (and copying) the builder's arrays; the name table is sized once. Elements get
  /// room for the rows, a knife edge per body and a hitch per two rows.
  void reserve(int bodies, int coordinates, int rows, int values);

  /// A constraint row mu_a(q) qdot = 0 touching these coordinates (its sparsity pattern,
  /// fixed for ever). Returns the row index. Checked in build(): non-empty, no duplicates,
  /// every column in range. The optional label (say "constraints[3] (knife_edge on body 2)")
  /// is named by every message about this row: set-up errors and failed steps alike.
  int add_one_form(const std::vector<int>& columns, std::string label = "");
  /// A row that is the gradient of a holonomic constraint g_j(q) = 0 (a hitch component):
  /// added like add_one_form (its values come from one_form_values) and also recorded as
  /// holonomic; gap() gives g_j in the order of these calls.
  int add_holonomic_row(const std::vector<int>& columns, std::string label = "");
  /// Local constraint elements (nonholo/elements.hpp) on planar bodies (added with
  /// add_planar_body, or any body whose first three coordinates are x, y, theta and whose mass
  /// block is 3x3). Each adds its rows now, in call order, and evaluates them itself: a model
  /// whose rows all come from elements needs no one_form_values, bias or gap function, and
  /// its springs and thrusts make its potential and external force. Rows from add_one_form
  /// and element rows cannot be mixed in one model, nor springs with potential() or thrusts
  /// with external_force(). Throws at once for a body out of range, a non-planar body, a
  /// hitch of a body to itself, or a non-finite parameter; returns the first row's index.
  /// Add them body by body (knife edge of b, then the hitch b -> b+1) and the step streams
  /// the chain in one forward and one backward sweep (docs/design.md §7).
  ///@{
  int add_knife_edge(const KnifeEdge& knife, std::string label = "");
  int add_hitch(const Hitch& hitch, std::string label = "");
  void add_torsional_spring(const TorsionalSpring& spring);
  void add_thrust(Thrust thrust);
  ///@}
  /// Elements on rigid bodies (elements.hpp). Each throws at once for a body out of range or
  /// not rigid, a translation the element cannot use, a zero or non-finite axis, a radius or
  /// length that is not positive and finite; the constraints return their first row's index.
  ///@{
  int add_body_axis_constraint(const BodyAxisConstraint& constraint, std::string label = "");
  int add_space_axis_constraint(const SpaceAxisConstraint& constraint, std::string label = "");
  int add_rolling_ball(const RollingBall& ball, std::string label = "");
  int add_rolling_disk(const RollingDisk& disk, std::string label = "");
  int add_rod(const Rod& rod, std::string label = "");
  ///@}
  /// Uniform gravity g along -e3 on every rigid body that moves freely in 3-D (translation 3):
  /// a constant external force -m g e3 on its centre (so the discrete work-energy identity of
  /// the step holds to round-off; the energy m g z is the work's negative). Once per model.
  void add_gravity(double g);
  /// A torque on a rigid body (elements.hpp); throws for a body out of range, not rigid, or an
  /// empty function.
  void add_body_torque(BodyTorque torque);
  /// A force on a rigid body's centre (elements.hpp); throws also for a body whose centre is
  /// fixed (translation 0).
  void add_body_force(BodyForce force);

  /// The gaps g(q), required when there are holonomic rows.
  ModelBuilder& gap(ConstraintGap gap);
  /// Fills the values of all rows at q (required when there are rows).
  ModelBuilder& one_form_values(OneFormValues values);
  /// The bias (d/dt mu) qdot. Optional: without it, dynamics.hpp falls back to a central
  /// difference of the values along qdot (about 1e-10 relative accuracy).
  ModelBuilder& one_form_bias(OneFormBias bias);
  /// The potential V(q) and its gradient (both or neither).
  ModelBuilder& potential(Potential value, PotentialGradient gradient);
  /// The external forces F(t, q) (types.hpp).
  ModelBuilder& external_force(ExternalForce force);
  /// A momentum map J(q, p) to report, under a unique non-empty name.
  ModelBuilder& momentum_map(const std::string& name, MomentumMap map);
  /// A horizontal symmetry by its generator xi(q) (n_v entries, in D(q) for every q; checked at
  /// the start): the momentum map J = <xi(q), p>, named `name`, which the restarts and the
  /// composed steps' energy projection keep exactly by scaling only the part of p~ that no such
  /// map sees. `value`, when given, is J itself computed directly (it must equal <xi(q), p>,
  /// checked at the start): a generator local to one body then costs O(1) to evaluate instead of
  /// n_v (a chain of N balls declares N spins). Without it J is evaluated through xi (no heap up
  /// to 256 velocities).
  /// `body` >= 0 declares the symmetry local to that body: xi(q) is zero outside its velocities,
  /// and the generator writes those entries only (the others of the vector it is given are zero
  /// and must stay so). Restarts then store and orthogonalise its direction in O(1): a chain of
  /// N balls keeps its N spins and two rollings in O(N) memory, not N n_v.
  ModelBuilder& symmetry(const std::string& name, SymmetryGenerator generator, MomentumMap value = {},
                         int body = -1);
  /// M(q) and dM/dq_i over all coordinates (see Model::has_configuration_metric). The bodies'
  /// mass blocks should be M(q0): the set-up code and the diagnostics of q0 use them.
  ModelBuilder& configuration_metric(MetricValue value, MetricDerivative derivative);

  /// The model. On an rvalue (std::move(builder).build()) the builder's contents are moved
  /// into it rather than copied: a million-body chain is built in half the time and memory.
  ///@{
  Model build() const&;
  Model build() &&;
  ///@}

 private:
  // The model being built: bodies, names, mass blocks and callbacks go straight in; build()
  // validates the rows and fills the derived parts (inverse metric, pattern, index map of C).
  Model draft_;
  // The rows' columns, compressed (one allocation for a million rows, not one per row).
  std::vector<int> row_ptr_{0}, row_cols_;
  int num_rows() const { return static_cast<int>(row_ptr_.size()) - 1; }
  int add_row(const int* columns, int count, std::string label);
  // Coordinate names already used. A name "<prefix><n>" (n decimal, no leading zero, at most
  // 8 digits: x0, y17, theta123456) is found by its number in its prefix's pages of owners
  // (coordinate, -1 when free): generated names then touch memory in order, where a hash
  // table of a million bodies' names would miss the cache at every one (0.3 s at set-up).
  struct NumberedNames {
    std::vector<std::vector<int>> pages;  // kNamePage owners each, empty until used
  };
  static constexpr int kNamePage = 4096;
  std::unordered_map<std::string, int> numbered_of_;  // prefix -> index into numbered_
  std::vector<NumberedNames> numbered_;
  // The other names: an open-addressing table of (hash, coordinate index + 1), 0 for an
  // empty slot; no node or string per entry.
  std::vector<std::uint64_t> name_slots_;
  std::size_t hashed_names_ = 0;
  std::unordered_set<std::string> map_names_;  // the momentum maps' (a chain of N balls declares N + 2)
  int find_name(const std::string& name) const;  // its coordinate, or -1
  void insert_name(int coordinate, const std::string& name);  // name: the coordinate's
  int body_of_coordinate(int coordinate) const;
  void check_names(int index, const std::string* names, int k) const;
  // Appends a validated body: its names, its mass block, its offsets.
  void add_checked_body(const std::string* names, int k, const Eigen::Ref<const Eigen::MatrixXd>& block,
                        BodyKind kind);
  std::shared_ptr<detail::ElementSet> elements_;      // null until an element is added
  int reserved_bodies_ = 0, reserved_rows_ = 0;        // reserve()'s, for the elements' arrays
  detail::ElementSet& elements();
  int planar_body(int body, const char* element) const;  // its first coordinate, or throws
  const Body& rigid_body(int body, const char* element) const;  // the body, or throws
  int centre_dimension(int body, const char* element) const;  // 2 or 3 (a rod's ends), or throws
  // A length on a body, against its radius of gyration and the range of C (builder_scales.hpp).
  // `who` names the element for a message, built only when a check fails.
  using Describe = std::function<std::string()>;
  void check_planar_arm(const Describe& who, const char* what, double length, int offset) const;
  void check_rigid_arm(const Describe& who, int body, double radius) const;
  Model finish(Model model, std::shared_ptr<detail::ElementSet> elements) const;
  void build_elements(Model& model, std::shared_ptr<detail::ElementSet> set) const;
  static void note_dense_block(Model& model);  // Model::performance_note for a hub body
};

}  // namespace nonholo

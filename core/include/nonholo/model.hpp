#pragma once
/// @file
/// The immutable description of a nonholonomic system: bodies with constant SPD mass
/// blocks (a block-diagonal metric M), constraint one-forms mu(q) with a fixed sparsity
/// pattern, potential, external forces and momentum maps. Build one with ModelBuilder;
/// share it by const& across threads (its callbacks must be thread-safe).
///
/// Sizes: the configuration q has num_configuration() = n_q entries, everything in momentum
/// space (velocities, momenta p, forces, the columns of mu, M, a gradient of V) has
/// num_velocities() = n_v. They differ only with 3-D rigid bodies (nonholo/rigid_body.hpp:
/// a quaternion of 4 entries against an angular velocity of 3); for planar and general
/// bodies a coordinate and its velocity share their index.
#include <nonholo/sparse/block_diagonal.hpp>
#include <nonholo/sparse/gram_assembler.hpp>
#include <nonholo/sparse/patterns.hpp>
#include <nonholo/types.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

/// The library: models (ModelBuilder, Model), the reflection integrator (step()) with its
/// options, starts, restarts and diagnostics, the baselines (dla_step(), implicit_step()) and
/// their workspaces. The factorisations of C are in nonholo::sparse, the reference ODE
/// integrators in nonholo::reference, the scenes and the command-line tool in
/// nonholo::scenarios.
namespace nonholo {
namespace detail {
struct ElementSet;  // core/src/model/element_set.hpp

/// Coordinate names, compactly: a body whose names are its predecessor's with the number one
/// higher ("x8", "y8", "theta8" after "x7", "y7", "theta7") extends a run and costs nothing; other
/// names are packed into one buffer of characters. (A std::string each would take 32 bytes and
/// often a block of its own: 96 MB for a million-body chain's 3·10⁶ names.)
class NameStore {
 public:
  std::size_t size() const { return size_; }
  std::string operator[](std::size_t i) const;
  /// Appends one body's k names; std::length_error past 4 GiB of characters in all.
  void push_body(const std::string* names, int k);
  /// Appends one name kept as it is (never read as "<prefix><n>"): a row's label.
  void push_text(std::string_view text);
  /// Name i, which push_text() appended, without a copy (valid while the store lives).
  std::string_view text(std::size_t i) const;
  /// n of a name "<prefix><n>" written as std::to_string writes n (at most 8 digits, no leading
  /// zero), with the prefix's length; -1 for any other name. (ModelBuilder looks such names up
  /// by number too.)
  static int number_of(std::string_view name, std::size_t& prefix);

 private:
  // Names [first, first + count) are either literal names (k == 0: the literals from index
  // `literal` on) or a run of bodies of k names each, name j of body b being literal
  // `literal` + j (its prefix) followed by the decimal number + b.
  struct Segment {
    std::size_t first = 0, count = 0;
    std::uint32_t literal = 0, k = 0;
    std::int64_t number = 0;
  };
  std::string_view literal(std::size_t i) const {
    const std::size_t begin = i == 0 ? 0 : ends_[i - 1];
    return {chars_.data() + begin, ends_[i] - begin};
  }
  void push_literal(std::string_view name);
  std::vector<char> chars_;
  std::vector<std::uint32_t> ends_;  // one past each literal's last character
  std::vector<Segment> segments_;
  std::size_t size_ = 0;
};
}  // namespace detail

/// @enum BodyKind
/// What a body's coordinates are.
/// @var BodyKind::General
///   any coordinates with a constant SPD mass block (ModelBuilder::add_body);
/// @var BodyKind::Planar
///   (x, y, theta) of the centre of mass, M = diag(m, m, I) (add_planar_body);
/// @var BodyKind::Rigid
///   a 3-D rigid body: quaternion and centre in R^d (add_rigid_body).
enum class BodyKind : unsigned char { General, Planar, Rigid };

/// Where a body's entries are in q and in the velocity-space vectors (Model::body).
struct Body {
  int offset = 0;  ///< first velocity coordinate of the body (its first column of mu, entry of p)
  int size = 0;    ///< number of velocity coordinates
  int q_offset = 0;  ///< first configuration entry (offset unless a rigid body comes before)
  int q_size = 0;    ///< number of configuration entries (size + 1 for a rigid body)
  BodyKind kind = BodyKind::General;  ///< what its coordinates are
  int translation = 0;  ///< rigid bodies: d, the dimension of the centre's motion (0, 2, 3)
};

/// A rigid body as the step sees it: where its entries are, its inertia and mass.
struct RigidBlock {
  int body = 0;  ///< its index among the model's bodies
  int q = 0;  ///< first configuration entry: the quaternion (w, x, y, z), then the centre
  int v = 0;  ///< first velocity entry: Omega (body frame), then the centre's velocity
  int translation = 0;  ///< d, the dimension of the centre's motion (0, 2, 3)
  double mass = 1.0;  ///< m
  /// Central inertia in the body frame, and its inverse.
  ///@{
  Eigen::Matrix3d inertia, inverse_inertia;
  ///@}
  bool isotropic = false;  ///< inertia = J Id exactly: the Legendre transforms have closed forms
  /// 0, or e when the inertia's largest entry is 2^e with |e| > 64: the Legendre transforms then
  /// solve at unit scale (divided by 2^e, exactly), where their Newton determinant (the cube of
  /// the moments) neither under- nor overflows.
  int scale_exponent = 0;
};

/// J(q, p) with a name. With a generator (a horizontal symmetry declared through
/// ModelBuilder::symmetry), J = <xi(q), p> and the restarts read xi directly instead of probing J.
struct NamedMomentumMap {
  std::string name;  ///< as declared (ModelBuilder::momentum_map, ModelBuilder::symmetry)
  MomentumMap map;   ///< J(q, p)
  SymmetryGenerator generator;  ///< empty unless declared as a symmetry
  /// A symmetry local to one body (ModelBuilder::symmetry's `body`): xi is zero outside that
  /// body's velocities, which are all its generator writes. -1: xi may be nonzero anywhere.
  int body = -1;
};

/// A nonholonomic system, immutable once built (ModelBuilder::build). See model.hpp for the
/// sizes n_q and n_v.
class Model {
 public:
  /// n_v: the velocity count (the size of p, of forces and of a row of mu).
  int num_velocities() const { return mass_.size(); }
  /// n_q: the size of the configuration q (n_v plus one per rigid body).
  int num_configuration() const { return num_configuration_; }
  /// The velocity count n_v, under its older name (every body was planar then, n_q = n_v).
  int num_coordinates() const { return num_velocities(); }
  int num_bodies() const { return static_cast<int>(bodies_.size()); }  ///< bodies, in the order added
  int num_one_forms() const { return pattern_.rows; }  ///< m: the rows of mu (one-forms and holonomic rows)
  int num_one_form_values() const { return pattern_.nnz(); }  ///< nnz(mu): the values one_form_values() fills
  const Body& body(int b) const { return bodies_[b]; }  ///< body b's place in q and in the velocities
  /// Names of the n_q configuration entries (x, y, theta; qw0, qx0, ..., x0, y0) ...
  const std::vector<std::string>& coordinate_names() const;
  /// ... and of the n_v velocity entries (the same names for planar and general bodies; wx0,
  /// wy0, wz0, vx0, vy0 for a rigid body): messages about a column of mu name these.
  const std::vector<std::string>& velocity_names() const;
  /// The model keeps its coordinate names compactly (detail::NameStore: a generated chain's take
  /// no memory); the lists above are made as strings on their first call (once, thread-safe;
  /// shared by the model's copies), which a run that writes no names never makes. These read one
  /// name without making the list.
  ///@{
  std::string coordinate_name(int i) const { return names_[static_cast<std::size_t>(i)]; }
  std::string velocity_name(int i) const {
    return velocity_names_.size() == 0 ? names_[static_cast<std::size_t>(i)] : velocity_names_[static_cast<std::size_t>(i)];
  }
  ///@}

  /// 3-D rigid bodies (nonholo/rigid_body.hpp), in body order.
  ///@{
  bool has_rigid_bodies() const { return !rigid_bodies().empty(); }
  /// Whether every body is rigid, each one block of M^-1, all with the same translation d:
  /// then d (0, 2 or 3), else -1. The drift then takes each body in one pass (rigid/drift.cpp).
  int rigid_only_translation() const { return rigid_only_translation_; }
  const std::vector<RigidBlock>& rigid_bodies() const { return rigid_list_ ? *rigid_list_ : rigid_; }
  ///@}
  /// out = q moved along the velocity-space displacement delta (n_v entries): flat
  /// coordinates add delta, a rigid body's orientation becomes R exp(hat(delta_Omega)) (a
  /// body-frame rotation, renormalised). For q - h v on flat models, and wherever a model
  /// with rigid bodies must move q along a velocity. out may alias q.
  void retract(ConstVecRef q, ConstVecRef delta, VecRef out) const;
  /// The label given to one-form row r (ModelBuilder::add_one_form), "" when none: messages
  /// about a row of mu or of C name it, so that a scene file's error points at its element.
  std::string row_label(int r) const;
  /// The same without a copy, valid while the model lives (a step's failure message allocates nothing).
  std::string_view row_label_view(int r) const;
  /// "one-form row r" followed by " (label)" when the row has one; for set-up messages.
  std::string describe_row(int r) const;

  const sparse::BlockDiagonal& mass() const { return mass_; }  ///< M, the bodies' mass blocks
  const sparse::BlockDiagonal& inverse_mass() const { return inverse_mass_; }  ///< M^-1
  /// The rows of mu and their columns (fixed; the values come from one_form_values()).
  const sparse::RowPattern& one_form_pattern() const { return pattern_; }
  /// C = mu M^-1 mu^T: its fixed pattern and the index map that fills it. A chain of
  /// elements (is_chain), and a chain of rolling balls on rods, factorises C from its elements'
  /// rows and never needs them, so for it
  /// they are built at the first call (thread-safe; about 0.5 s and 250 MB for a million
  /// bodies), e.g. by a Workspace that forces CHOLMOD.
  const sparse::GramAssembler& gram() const;

  /// The values of mu(q) in pattern order (nnz entries; see OneFormValues).
  void one_form_values(ConstVecRef q, VecRef values) const { values_(q, values); }
  /// Whether the model gives its bias (d/dt mu) qdot in closed form (ModelBuilder::one_form_bias).
  bool has_analytic_bias() const { return static_cast<bool>(bias_); }
  /// Only when has_analytic_bias(); see nonholo/dynamics.hpp for the general entry point.
  void analytic_bias(ConstVecRef q, ConstVecRef qdot, VecRef bias) const { bias_(q, qdot, bias); }

  bool has_potential() const { return static_cast<bool>(potential_); }  ///< whether V is given
  double potential(ConstVecRef q) const { return potential_ ? potential_(q) : 0.0; }  ///< V(q); 0 without one
  bool has_external_force() const { return static_cast<bool>(force_); }  ///< whether F(t, q) is given
  /// F(t, q) alone (only when has_external_force()).
  void external_force(double t, ConstVecRef q, VecRef force) const { force_(t, q, force); }
  /// Whether f = -grad V + F can be nonzero; when false the integrators skip it entirely.
  bool has_applied_force() const { return has_potential() || has_external_force(); }
  /// f = -grad V(q) + F(t, q). scratch: n entries, clobbered.
  void applied_force(double t, ConstVecRef q, VecRef f, VecRef scratch) const;

  /// The momentum maps and symmetries, in declaration order (diagnostics.hpp evaluates them).
  const std::vector<NamedMomentumMap>& momentum_maps() const { return momentum_maps_; }

  /// A configuration-dependent metric replaces mass() (which then holds M(q0) only): the
  /// explicit integrators refuse such a model, the implicit general form (implicit.hpp) uses it.
  bool has_configuration_metric() const { return static_cast<bool>(metric_); }
  /// M(q), dense n x n (only when has_configuration_metric()).
  void metric(ConstVecRef q, MatRef m) const { metric_(q, m); }
  /// dM/dq_i at q (only when has_configuration_metric()).
  void metric_derivative(ConstVecRef q, int i, MatRef dm) const { metric_derivative_(q, i, dm); }

  /// Holonomic constraints g(q) = 0 (hitches): the rows of mu that are their gradients, in
  /// declaration order, and the gaps g(q) (one per such row). Integrators may treat them as
  /// plain one-forms or enforce g = 0 at position level (see RattleOptions::hitch). Call
  /// gap() only when num_holonomic() > 0.
  ///@{
  int num_holonomic() const { return static_cast<int>(holonomic_rows_.size()); }
  const std::vector<int>& holonomic_rows() const { return holonomic_rows_; }
  void gap(ConstVecRef q, VecRef g) const { gap_(q, g); }
  ///@}

  /// Built from local constraint elements (nonholo/elements.hpp)? Then its one-form values,
  /// bias, gaps, potential and forces are the elements' own, and element_set() describes them
  /// (for the integrators; its type is internal).
  ///@{
  bool has_elements() const { return static_cast<bool>(elements_); }
  const detail::ElementSet* element_set() const { return elements_.get(); }
  ///@}
  /// Whether the explicit step can stream this model body by body (element_set.hpp's chain
  /// layout): the banded backend is then chosen by Backend::Auto.
  bool is_chain() const;
  /// What in the model's structure makes its steps slower than they could be, for the user to
  /// see ("" when nothing): bodies and rows that make a chain in an order the fused chain step
  /// does not read (it then takes the general path, 3 to 4 times slower per body-step), or a
  /// body touched by so many rows (a hub hitched to hundreds of bodies) that C has a dense block
  /// whose factorisation, every step, costs the cube of their number. The run prints it as a
  /// warning; a model built in code reads it here.
  const std::string& performance_note() const { return performance_note_; }

  /// Sparse products with the one-form values (nnz entries, pattern order).
  ///@{
  void mu_times(const double* mu, const double* x, double* y) const;            ///< y = mu x
  void mu_transpose_times(const double* mu, const double* lambda, double* g) const;  ///< g = mu^T lambda
  ///@}

 private:
  friend class ModelBuilder;
  Model() = default;

  std::vector<Body> bodies_;
  std::string performance_note_;  // ModelBuilder::finish
  int num_configuration_ = 0;
  detail::NameStore names_;
  struct LazyNames;  // model.cpp: a once_flag and names_ as strings; shared by copies of the model
  std::shared_ptr<LazyNames> name_list_;
  detail::NameStore velocity_names_;  // empty unless some body is rigid (then n_v names)
  std::shared_ptr<LazyNames> velocity_list_;  // velocity_names_ as strings, made on first call
  std::vector<RigidBlock> rigid_;  // while the model is built; then in rigid_list_
  // The rigid bodies of a built model, shared with its copies and its elements (ElementSet).
  std::shared_ptr<const std::vector<RigidBlock>> rigid_list_;
  int rigid_only_translation_ = -1;
  sparse::BlockDiagonal mass_, inverse_mass_;
  sparse::RowPattern pattern_;
  struct LazyGram;  // model.cpp: a once_flag and the assembler; shared by copies of the model
  std::shared_ptr<LazyGram> gram_;
  void new_gram();  // a fresh LazyGram (ModelBuilder::finish), built now unless is_chain()
  void new_name_list();  // a fresh LazyNames (ModelBuilder::finish)
  OneFormValues values_;
  OneFormBias bias_;
  Potential potential_;
  PotentialGradient gradient_;
  ExternalForce force_;
  std::vector<NamedMomentumMap> momentum_maps_;
  std::vector<int> holonomic_rows_;
  // The rows' labels, "" for a row without one, kept as text (no string per row: a 10^5-ball
  // chain's 3 10^5 labels took 27 MB as strings); empty when no row has a label.
  detail::NameStore row_labels_;
  MetricValue metric_;
  MetricDerivative metric_derivative_;
  ConstraintGap gap_;
  std::shared_ptr<const detail::ElementSet> elements_;
};

}  // namespace nonholo

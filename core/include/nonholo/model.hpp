#pragma once
// The immutable description of a nonholonomic system: bodies with constant SPD mass
// blocks (a block-diagonal metric M), constraint one-forms mu(q) with a fixed sparsity
// pattern, potential, external forces and momentum maps. Build one with ModelBuilder;
// share it by const& across threads (its callbacks must be thread-safe).
#include <nonholo/sparse/block_diagonal.hpp>
#include <nonholo/sparse/gram_assembler.hpp>
#include <nonholo/sparse/patterns.hpp>
#include <nonholo/types.hpp>

#include <memory>
#include <string>
#include <vector>

namespace nonholo {
namespace detail {
struct ElementSet;  // core/src/element_set.hpp
}

struct Body {
  int offset = 0;  // first coordinate of the body
  int size = 0;    // number of coordinates
};

struct NamedMomentumMap {
  std::string name;
  MomentumMap map;
};

class Model {
 public:
  int num_coordinates() const { return mass_.size(); }
  int num_bodies() const { return static_cast<int>(bodies_.size()); }
  int num_one_forms() const { return pattern_.rows; }
  int num_one_form_values() const { return pattern_.nnz(); }
  const Body& body(int b) const { return bodies_[b]; }
  const std::vector<std::string>& coordinate_names() const { return names_; }
  // The label given to one-form row r (ModelBuilder::add_one_form), "" when none: messages
  // about a row of mu or of C name it, so that a scene file's error points at its element.
  const std::string& row_label(int r) const;
  // "one-form row r" followed by " (label)" when the row has one; for set-up messages.
  std::string describe_row(int r) const;

  const sparse::BlockDiagonal& mass() const { return mass_; }
  const sparse::BlockDiagonal& inverse_mass() const { return inverse_mass_; }
  const sparse::RowPattern& one_form_pattern() const { return pattern_; }
  // C = mu M^-1 mu^T: its fixed pattern and the index map that fills it. A chain of
  // elements (is_chain) factorises C from its elements' rows and never needs them, so for it
  // they are built at the first call (thread-safe; about 0.5 s and 250 MB for a million
  // bodies), e.g. by a Workspace that forces CHOLMOD.
  const sparse::GramAssembler& gram() const;

  void one_form_values(ConstVecRef q, VecRef values) const { values_(q, values); }
  bool has_analytic_bias() const { return static_cast<bool>(bias_); }
  // Only when has_analytic_bias(); see nonholo/dynamics.hpp for the general entry point.
  void analytic_bias(ConstVecRef q, ConstVecRef qdot, VecRef bias) const { bias_(q, qdot, bias); }

  bool has_potential() const { return static_cast<bool>(potential_); }
  double potential(ConstVecRef q) const { return potential_ ? potential_(q) : 0.0; }
  bool has_external_force() const { return static_cast<bool>(force_); }
  // F(t, q) alone (only when has_external_force()).
  void external_force(double t, ConstVecRef q, VecRef force) const { force_(t, q, force); }
  // Whether f = -grad V + F can be nonzero; when false the integrators skip it entirely.
  bool has_applied_force() const { return has_potential() || has_external_force(); }
  // f = -grad V(q) + F(t, q). scratch: n entries, clobbered.
  void applied_force(double t, ConstVecRef q, VecRef f, VecRef scratch) const;

  const std::vector<NamedMomentumMap>& momentum_maps() const { return momentum_maps_; }

  // A configuration-dependent metric replaces mass() (which then holds M(q0) only): the
  // explicit integrators refuse such a model, the implicit general form (implicit.hpp) uses it.
  bool has_configuration_metric() const { return static_cast<bool>(metric_); }
  void metric(ConstVecRef q, MatRef m) const { metric_(q, m); }
  void metric_derivative(ConstVecRef q, int i, MatRef dm) const { metric_derivative_(q, i, dm); }

  // Holonomic constraints g(q) = 0 (hitches): the rows of mu that are their gradients, in
  // declaration order, and the gaps g(q) (one per such row). Integrators may treat them as
  // plain one-forms or enforce g = 0 at position level (see RattleOptions::hitch). Call
  // gap() only when num_holonomic() > 0.
  int num_holonomic() const { return static_cast<int>(holonomic_rows_.size()); }
  const std::vector<int>& holonomic_rows() const { return holonomic_rows_; }
  void gap(ConstVecRef q, VecRef g) const { gap_(q, g); }

  // Built from local constraint elements (nonholo/elements.hpp)? Then its one-form values,
  // bias, gaps, potential and forces are the elements' own, and element_set() describes them
  // (for the integrators; its type is internal).
  bool has_elements() const { return static_cast<bool>(elements_); }
  const detail::ElementSet* element_set() const { return elements_.get(); }
  // Whether the explicit step can stream this model body by body (element_set.hpp's chain
  // layout): the banded backend is then chosen by Backend::Auto.
  bool is_chain() const;

  // Sparse products with the one-form values (nnz entries, pattern order).
  void mu_times(const double* mu, const double* x, double* y) const;            // y = mu x
  void mu_transpose_times(const double* mu, const double* lambda, double* g) const;  // g = mu^T lambda

 private:
  friend class ModelBuilder;
  Model() = default;

  std::vector<Body> bodies_;
  std::vector<std::string> names_;
  sparse::BlockDiagonal mass_, inverse_mass_;
  sparse::RowPattern pattern_;
  struct LazyGram;  // model.cpp: a once_flag and the assembler; shared by copies of the model
  std::shared_ptr<LazyGram> gram_;
  void new_gram();  // a fresh LazyGram (ModelBuilder::finish), built now unless is_chain()
  OneFormValues values_;
  OneFormBias bias_;
  Potential potential_;
  PotentialGradient gradient_;
  ExternalForce force_;
  std::vector<NamedMomentumMap> momentum_maps_;
  std::vector<int> holonomic_rows_;
  std::vector<std::string> row_labels_;  // empty when no row has a label (large chains)
  MetricValue metric_;
  MetricDerivative metric_derivative_;
  ConstraintGap gap_;
  std::shared_ptr<const detail::ElementSet> elements_;
};

}  // namespace nonholo

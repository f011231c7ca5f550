#pragma once
// Validating construction of a Model. Every mistake is reported by a std::invalid_argument
// whose message names the body, row or column and the offending value.
#include <nonholo/model.hpp>

#include <array>
#include <string>
#include <unordered_map>
#include <vector>

namespace nonholo {

class ModelBuilder {
 public:
  // A body with one coordinate per name and a constant SPD mass block (names.size() square).
  // Returns the body index. Throws on a non-square, mismatched, non-finite, non-symmetric or
  // non-positive-definite block.
  int add_body(const std::vector<std::string>& coordinate_names, const Eigen::MatrixXd& mass_block);
  // A planar rigid body in centre-of-mass coordinates (x, y, theta): M = diag(m, m, I).
  // Throws unless mass and inertia are finite and positive.
  int add_planar_body(const std::array<std::string, 3>& coordinate_names, double mass, double inertia);

  // A constraint row mu_a(q) qdot = 0 touching these coordinates (its sparsity pattern,
  // fixed for ever). Returns the row index. Checked in build(): non-empty, no duplicates,
  // every column in range. The optional label (say "constraints[3] (knife_edge on body 2)")
  // is named by every message about this row: set-up errors and failed steps alike.
  int add_one_form(const std::vector<int>& columns, std::string label = "");
  // A row that is the gradient of a holonomic constraint g_j(q) = 0 (a hitch component):
  // added like add_one_form (its values come from one_form_values) and also recorded as
  // holonomic; gap() gives g_j in the order of these calls.
  int add_holonomic_row(const std::vector<int>& columns, std::string label = "");
  // The gaps g(q), required when there are holonomic rows.
  ModelBuilder& gap(ConstraintGap gap);
  // Fills the values of all rows at q (required when there are rows).
  ModelBuilder& one_form_values(OneFormValues values);
  // The bias (d/dt mu) qdot. Optional: without it, dynamics.hpp falls back to a central
  // difference of the values along qdot (about 1e-10 relative accuracy).
  ModelBuilder& one_form_bias(OneFormBias bias);
  ModelBuilder& potential(Potential value, PotentialGradient gradient);
  ModelBuilder& external_force(ExternalForce force);
  ModelBuilder& momentum_map(const std::string& name, MomentumMap map);
  // M(q) and dM/dq_i over all coordinates (see Model::has_configuration_metric). The bodies'
  // mass blocks should be M(q0): the set-up code and the diagnostics of q0 use them.
  ModelBuilder& configuration_metric(MetricValue value, MetricDerivative derivative);

  Model build() const;

 private:
  // The model being built: bodies, names, mass blocks and callbacks go straight in; build()
  // validates the rows and fills the derived parts (inverse metric, pattern, index map of C).
  Model draft_;
  std::vector<std::vector<int>> rows_;
  std::unordered_map<std::string, int> body_of_name_;  // coordinate name -> body
};

}  // namespace nonholo

#include <nonholo/model_builder.hpp>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace nonholo {
namespace {

std::string describe_body(int index, const std::vector<std::string>& names) {
  std::ostringstream os;
  os << "body " << index << " (";
  for (std::size_t i = 0; i < names.size(); ++i) os << (i ? ", " : "") << names[i];
  os << ")";
  return os.str();
}

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

}  // namespace

int ModelBuilder::add_body(const std::vector<std::string>& names, const Eigen::MatrixXd& block) {
  const int index = static_cast<int>(draft_.bodies_.size());
  const int k = static_cast<int>(names.size());
  auto who = [&] { return describe_body(index, names); };  // built only for a message
  if (k == 0) fail("body " + std::to_string(index) + " has no coordinates");
  if (block.rows() != k || block.cols() != k) {
    std::ostringstream os;
    os << who() << ": mass block is " << block.rows() << "x" << block.cols() << ", expected " << k
       << "x" << k << " (one row and column per coordinate)";
    fail(os.str());
  }
  for (int i = 0; i < k; ++i) {
    if (names[i].empty()) fail(who() + ": coordinate " + std::to_string(i) + " has an empty name");
    const auto owner = body_of_name_.find(names[i]);
    if (owner != body_of_name_.end())
      fail("coordinate name '" + names[i] + "' is used by body " + std::to_string(owner->second) +
           " and by " + who());
    for (int j = 0; j < i; ++j)
      if (names[j] == names[i]) fail(who() + ": coordinate name '" + names[i] + "' appears twice");
  }
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      if (!std::isfinite(block(i, j))) {
        std::ostringstream os;
        os << who() << ": mass block entry (" << i << ", " << j << ") is " << block(i, j);
        fail(os.str());
      }
  for (int i = 0; i < k; ++i)
    if (!(block(i, i) > 0.0)) {
      std::ostringstream os;
      os << who() << ": mass block entry (" << i << ", " << i << ") for " << names[i] << " is "
         << block(i, i) << "; a mass or moment of inertia must be positive";
      fail(os.str());
    }
  const double scale = block.cwiseAbs().maxCoeff();
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < i; ++j)
      if (std::abs(block(i, j) - block(j, i)) > 1e-12 * scale) {
        std::ostringstream os;
        os.precision(17);
        os << who() << ": mass block is not symmetric: M(" << i << ", " << j << ") = " << block(i, j)
           << " but M(" << j << ", " << i << ") = " << block(j, i);
        fail(os.str());
      }
  const Eigen::MatrixXd symmetric = 0.5 * (block + block.transpose());
  // A diagonal block's eigenvalues are its entries; skip the eigensolver (a million bodies).
  const bool diagonal = (block - Eigen::MatrixXd(block.diagonal().asDiagonal())).cwiseAbs().maxCoeff() == 0.0;
  Eigen::VectorXd eigenvalues = block.diagonal();
  if (!diagonal)
    eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(symmetric, Eigen::EigenvaluesOnly).eigenvalues();
  const double smallest = eigenvalues.minCoeff(), largest = eigenvalues.maxCoeff();
  // Relative tests: the units of the entries mean nothing, their spread does. Solves with M
  // lose about log10(largest / smallest) of double precision's 16 digits.
  constexpr double kMaxCondition = 1e12;
  if (smallest < 0.0 && !(-smallest <= largest / kMaxCondition)) {
    std::ostringstream os;
    os << who() << ": mass block is not positive definite (smallest eigenvalue " << smallest << ")";
    fail(os.str());
  }
  if (!(smallest * kMaxCondition >= largest)) {
    std::ostringstream os;
    os << who() << ": mass block is too ill-conditioned for double precision: its eigenvalues run from "
       << smallest << " to " << largest;
    if (smallest > 0.0)
      os << ", condition number " << largest / smallest << " (above " << kMaxCondition
         << "): solves with it would lose about " << std::lround(std::log10(largest / smallest))
         << " of double precision's 16 significant digits";
    else
      os << ", singular within round-off (a condition number of at most " << kMaxCondition << " is needed)";
    fail(os.str());
  }
  for (const auto& name : names) body_of_name_.emplace(name, index);
  draft_.bodies_.push_back({static_cast<int>(draft_.names_.size()), k});
  draft_.names_.insert(draft_.names_.end(), names.begin(), names.end());
  draft_.mass_.add_block(symmetric);
  return index;
}

int ModelBuilder::add_planar_body(const std::array<std::string, 3>& names, double mass, double inertia) {
  const std::vector<std::string> list(names.begin(), names.end());
  auto who = [&] { return describe_body(static_cast<int>(draft_.bodies_.size()), list); };
  auto check = [&](const char* what, double value) {
    if (!(value > 0.0) || !std::isfinite(value)) {
      std::ostringstream os;
      os << who() << ": " << what << " = " << value << " must be positive and finite";
      fail(os.str());
    }
  };
  check("mass m", mass);
  check("moment of inertia I", inertia);
  return add_body(list, Eigen::Vector3d(mass, mass, inertia).asDiagonal().toDenseMatrix());
}

int ModelBuilder::add_one_form(const std::vector<int>& columns, std::string label) {
  rows_.push_back(columns);
  const int row = static_cast<int>(rows_.size()) - 1;
  if (!label.empty()) {
    draft_.row_labels_.resize(rows_.size());  // stays empty for unlabelled models
    draft_.row_labels_[row] = std::move(label);
  }
  return row;
}

int ModelBuilder::add_holonomic_row(const std::vector<int>& columns, std::string label) {
  const int row = add_one_form(columns, std::move(label));
  draft_.holonomic_rows_.push_back(row);
  return row;
}

ModelBuilder& ModelBuilder::gap(ConstraintGap gap) {
  if (!gap) fail("gap: the function is empty");
  draft_.gap_ = std::move(gap);
  return *this;
}

ModelBuilder& ModelBuilder::one_form_values(OneFormValues values) {
  if (!values) fail("one_form_values: the value function is empty");
  draft_.values_ = std::move(values);
  return *this;
}

ModelBuilder& ModelBuilder::one_form_bias(OneFormBias bias) {
  draft_.bias_ = std::move(bias);
  return *this;
}

ModelBuilder& ModelBuilder::potential(Potential value, PotentialGradient gradient) {
  if (static_cast<bool>(value) != static_cast<bool>(gradient))
    fail("potential: give both the value and its gradient, or neither");
  draft_.potential_ = std::move(value);
  draft_.gradient_ = std::move(gradient);
  return *this;
}

ModelBuilder& ModelBuilder::external_force(ExternalForce force) {
  draft_.force_ = std::move(force);
  return *this;
}

ModelBuilder& ModelBuilder::momentum_map(const std::string& name, MomentumMap map) {
  if (name.empty()) fail("momentum_map: the name is empty");
  if (!map) fail("momentum_map '" + name + "': the function is empty");
  for (const auto& existing : draft_.momentum_maps_)
    if (existing.name == name) fail("momentum_map '" + name + "' is defined twice");
  draft_.momentum_maps_.push_back({name, std::move(map)});
  return *this;
}

ModelBuilder& ModelBuilder::configuration_metric(MetricValue value, MetricDerivative derivative) {
  if (!value || !derivative) fail("configuration_metric: give both the metric and its derivative");
  draft_.metric_ = std::move(value);
  draft_.metric_derivative_ = std::move(derivative);
  return *this;
}

Model ModelBuilder::build() const {
  if (draft_.bodies_.empty()) fail("the model has no bodies");
  const int n = static_cast<int>(draft_.names_.size());
  const auto& names = draft_.names_;

  Model model = draft_;
  if (!model.row_labels_.empty()) model.row_labels_.resize(rows_.size());
  model.inverse_mass_ = model.mass_.inverse();

  model.pattern_.rows = static_cast<int>(rows_.size());
  model.pattern_.cols = n;
  std::vector<int> sorted;
  for (std::size_t r = 0; r < rows_.size(); ++r) {
    auto row = [&] { return draft_.describe_row(static_cast<int>(r)); };  // built only for a message
    if (rows_[r].empty()) fail(row() + " has no columns (an empty row constrains nothing)");
    for (int c : rows_[r]) {
      if (c < 0 || c >= n) {
        std::ostringstream os;
        os << row() << ": column " << c << " is out of range (the model has " << n
           << " coordinates, columns 0 to " << n - 1 << ")";
        fail(os.str());
      }
      model.pattern_.col_idx.push_back(c);
    }
    sorted.assign(rows_[r].begin(), rows_[r].end());
    std::sort(sorted.begin(), sorted.end());
    const auto twice = std::adjacent_find(sorted.begin(), sorted.end());
    if (twice != sorted.end())
      fail(row() + ": column " + std::to_string(*twice) + " (" + names[*twice] + ") appears twice");
    model.pattern_.row_ptr.push_back(model.pattern_.nnz());
  }
  if (!rows_.empty() && !model.values_)
    fail("the model has " + std::to_string(rows_.size()) +
         " one-form rows but no value function (call one_form_values)");
  if (!model.holonomic_rows_.empty() && !model.gap_)
    fail("the model has " + std::to_string(model.holonomic_rows_.size()) +
         " holonomic rows but no gap function (call gap)");
  if (model.holonomic_rows_.empty() && model.gap_)
    fail("a gap function was given but no holonomic rows (add them with add_holonomic_row)");
  model.gram_ = sparse::GramAssembler(model.pattern_, model.inverse_mass_);
  return model;
}

}  // namespace nonholo

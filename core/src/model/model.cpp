// Model's out-of-line members (model.hpp): the lazily built Gram assembler of C, row labels, the retraction
// (quaternions turned on rigid bodies), the applied force, and the products mu x and mu^T lambda.
#include <nonholo/model.hpp>

#include <mutex>

#include "model/element_set.hpp"
#include "model/quaternion.hpp"

namespace nonholo {

struct Model::LazyGram {
  std::once_flag once;
  sparse::GramAssembler gram;
};

const sparse::GramAssembler& Model::gram() const {
  static const sparse::GramAssembler none;  // a Model() that ModelBuilder never finished
  if (!gram_) return none;
  std::call_once(gram_->once, [this] { gram_->gram = sparse::GramAssembler(pattern_, inverse_mass_); });
  return gram_->gram;
}

void Model::new_gram() {
  gram_ = std::make_shared<LazyGram>();  // its own: a builder's copies share no draft's
  if (!is_chain()) gram();
}

const std::string& Model::row_label(int r) const {
  static const std::string none;
  return r >= 0 && r < static_cast<int>(row_labels_.size()) ? row_labels_[r] : none;
}

std::string Model::describe_row(int r) const {
  const std::string& label = row_label(r);
  return "one-form row " + std::to_string(r) + (label.empty() ? "" : " (" + label + ")");
}

bool Model::is_chain() const { return elements_ && !elements_->chain.empty() && num_one_forms() > 0; }

void Model::retract(ConstVecRef q, ConstVecRef delta, VecRef out) const {
  if (rigid_.empty()) {
    out = q + delta;
    return;
  }
  for (const Body& b : bodies_) {
    if (b.kind != BodyKind::Rigid) {
      for (int i = 0; i < b.size; ++i) out[b.q_offset + i] = q[b.q_offset + i] + delta[b.offset + i];
      continue;
    }
    const detail::Vec4 r(q[b.q_offset], q[b.q_offset + 1], q[b.q_offset + 2], q[b.q_offset + 3]);
    const detail::Vec4 turned = detail::compose_normalised(r, detail::quaternion_exp(delta.segment<3>(b.offset)));
    for (int i = 0; i < 4; ++i) out[b.q_offset + i] = turned[i];
    for (int i = 0; i < b.translation; ++i) out[b.q_offset + 4 + i] = q[b.q_offset + 4 + i] + delta[b.offset + 3 + i];
  }
}

void Model::applied_force(double t, ConstVecRef q, VecRef f, VecRef scratch) const {
  if (force_)
    force_(t, q, f);
  else
    f.setZero();
  if (gradient_) {
    gradient_(q, scratch);
    f -= scratch;
  }
}

void Model::mu_times(const double* mu, const double* x, double* y) const {
  const int* rp = pattern_.row_ptr.data();
  const int* ci = pattern_.col_idx.data();
  for (int r = 0; r < pattern_.rows; ++r) {
    double s = 0.0;
    for (int k = rp[r]; k < rp[r + 1]; ++k) s += mu[k] * x[ci[k]];
    y[r] = s;
  }
}

void Model::mu_transpose_times(const double* mu, const double* lambda, double* g) const {
  const int* rp = pattern_.row_ptr.data();
  const int* ci = pattern_.col_idx.data();
  for (int i = 0; i < pattern_.cols; ++i) g[i] = 0.0;
  for (int r = 0; r < pattern_.rows; ++r)
    for (int k = rp[r]; k < rp[r + 1]; ++k) g[ci[k]] += mu[k] * lambda[r];
}

}  // namespace nonholo

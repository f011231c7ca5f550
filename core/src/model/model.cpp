// Model's out-of-line members (model.hpp): the lazily built Gram assembler of C, row labels, the retraction
// (quaternions turned on rigid bodies), the applied force, and the products mu x and mu^T lambda.
#include <nonholo/model.hpp>

#include <algorithm>
#include <cstdint>
#include <mutex>
#include <stdexcept>

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
  if (!is_chain() && !(elements_ && elements_->ball_chain)) gram();  // a layout's band needs no pattern
}

struct Model::LazyNames {
  std::once_flag once;
  std::vector<std::string> names;
};

const std::vector<std::string>& Model::coordinate_names() const {
  static const std::vector<std::string> none;  // a Model() that ModelBuilder never finished
  if (!name_list_) return none;
  std::call_once(name_list_->once, [this] {
    auto& list = name_list_->names;
    list.reserve(names_.size());
    for (std::size_t i = 0; i < names_.size(); ++i) list.emplace_back(names_[i]);
  });
  return name_list_->names;
}

const std::vector<std::string>& Model::velocity_names() const {
  if (velocity_names_.size() == 0 || !velocity_list_) return coordinate_names();
  std::call_once(velocity_list_->once, [this] {
    auto& list = velocity_list_->names;
    list.reserve(velocity_names_.size());
    for (std::size_t i = 0; i < velocity_names_.size(); ++i) list.emplace_back(velocity_names_[i]);
  });
  return velocity_list_->names;
}

void Model::new_name_list() {
  name_list_ = std::make_shared<LazyNames>();
  velocity_list_ = std::make_shared<LazyNames>();
}

namespace detail {
int NameStore::number_of(std::string_view name, std::size_t& prefix) {
  std::size_t start = name.size();
  while (start > 0 && name[start - 1] >= '0' && name[start - 1] <= '9') --start;
  const std::size_t digits = name.size() - start;
  if (digits == 0 || digits > 8 || (digits > 1 && name[start] == '0')) return -1;
  int n = 0;
  for (std::size_t i = start; i < name.size(); ++i) n = 10 * n + (name[i] - '0');
  prefix = start;
  return n;
}

std::string NameStore::operator[](std::size_t i) const {
  const auto after = std::upper_bound(segments_.begin(), segments_.end(), i,
                                      [](std::size_t at, const Segment& s) { return at < s.first; });
  const Segment& s = *(after - 1);
  const std::size_t j = i - s.first;
  if (s.k == 0) return std::string(literal(s.literal + j));
  std::string name(literal(s.literal + j % s.k));
  name += std::to_string(s.number + static_cast<std::int64_t>(j / s.k));
  return name;
}

void NameStore::push_literal(std::string_view name) {
  if (name.size() > UINT32_MAX - chars_.size())
    throw std::length_error("coordinate names: more than 4 GiB of characters in all");
  chars_.insert(chars_.end(), name.begin(), name.end());
  ends_.push_back(static_cast<std::uint32_t>(chars_.size()));
}

void NameStore::push_text(std::string_view text) {
  if (segments_.empty() || segments_.back().k != 0)
    segments_.push_back({size_, 0, static_cast<std::uint32_t>(ends_.size()), 0, 0});
  segments_.back().count += 1;
  push_literal(text);
  ++size_;
}

std::string_view NameStore::text(std::size_t i) const {
  const auto after = std::upper_bound(segments_.begin(), segments_.end(), i,
                                      [](std::size_t at, const Segment& s) { return at < s.first; });
  const Segment& s = *(after - 1);
  return s.k == 0 ? literal(s.literal + (i - s.first)) : std::string_view();
}

void NameStore::push_body(const std::string* names, int k) {
  if (k <= 0) return;
  // The body's number: every name "<prefix><n>" with the same n, else -1.
  std::int64_t number = -1;
  std::size_t prefix[64];
  if (k <= 64)
    for (int i = 0; i < k; ++i) {
      const std::int64_t n = number_of(names[i], prefix[i]);
      if (n < 0 || (i > 0 && n != number)) {
        number = -1;
        break;
      }
      number = n;
    }
  if (number >= 0 && !segments_.empty()) {  // the next body of the last run?
    Segment& last = segments_.back();
    bool same = last.k == static_cast<std::uint32_t>(k) && last.number + static_cast<std::int64_t>(last.count / last.k) == number;
    for (int i = 0; same && i < k; ++i)
      same = literal(last.literal + static_cast<std::size_t>(i)) == std::string_view(names[i]).substr(0, prefix[i]);
    if (same) {
      last.count += static_cast<std::size_t>(k);
      size_ += static_cast<std::size_t>(k);
      return;
    }
  }
  if (number >= 0) {  // a new run: its prefixes as literals
    segments_.push_back({size_, static_cast<std::size_t>(k), static_cast<std::uint32_t>(ends_.size()),
                         static_cast<std::uint32_t>(k), number});
    for (int i = 0; i < k; ++i) push_literal(std::string_view(names[i]).substr(0, prefix[i]));
  } else {
    if (segments_.empty() || segments_.back().k != 0)
      segments_.push_back({size_, 0, static_cast<std::uint32_t>(ends_.size()), 0, 0});
    segments_.back().count += static_cast<std::size_t>(k);
    for (int i = 0; i < k; ++i) push_literal(names[i]);
  }
  size_ += static_cast<std::size_t>(k);
}

}  // namespace detail

std::string Model::row_label(int r) const { return std::string(row_label_view(r)); }

std::string_view Model::row_label_view(int r) const {
  return r >= 0 && static_cast<std::size_t>(r) < row_labels_.size() ? row_labels_.text(static_cast<std::size_t>(r))
                                                                       : std::string_view();
}

std::string Model::describe_row(int r) const {
  std::string label = row_label(r);
  if (label.empty() && elements_ && r >= 0 && static_cast<std::size_t>(r) < elements_->num_rows())
    label = elements_->describe(static_cast<std::size_t>(r));  // an element's row: which element
  return "one-form row " + std::to_string(r) + (label.empty() ? "" : " (" + label + ")");
}

bool Model::is_chain() const { return elements_ && !elements_->chain.empty() && num_one_forms() > 0; }

void Model::retract(ConstVecRef q, ConstVecRef delta, VecRef out) const {
  if (!has_rigid_bodies()) {
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
  if (elements_ && elements_->ball_chain) return elements_->ball_chain_times(mu, x, y);
  const int* rp = pattern_.row_ptr.data();
  const int* ci = pattern_.col_idx.data();
  for (int r = 0; r < pattern_.rows; ++r) {
    double s = 0.0;
    for (int k = rp[r]; k < rp[r + 1]; ++k) s += mu[k] * x[ci[k]];
    y[r] = s;
  }
}

void Model::mu_transpose_times(const double* mu, const double* lambda, double* g) const {
  if (elements_ && elements_->ball_chain) return elements_->ball_chain_transpose_times(mu, lambda, g);
  const int* rp = pattern_.row_ptr.data();
  const int* ci = pattern_.col_idx.data();
  for (int i = 0; i < pattern_.cols; ++i) g[i] = 0.0;
  for (int r = 0; r < pattern_.rows; ++r)
    for (int k = rp[r]; k < rp[r + 1]; ++k) g[ci[k]] += mu[k] * lambda[r];
}

}  // namespace nonholo

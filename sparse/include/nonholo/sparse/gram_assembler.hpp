#pragma once
// C = A W A^T for a fixed row pattern A (the one-forms mu) and a constant block-diagonal W
// (M^-1). The pattern of C and an index map of products are computed once; assemble() then
// writes C's values with no allocation and no sparse product. A product whose weight is a
// structural zero of W is dropped, but a value of A that happens to be zero keeps its slot.
#include <nonholo/sparse/block_diagonal.hpp>
#include <nonholo/sparse/patterns.hpp>

#include <vector>

namespace nonholo::sparse {

class GramAssembler {
 public:
  GramAssembler() = default;
  GramAssembler(const RowPattern& a, const BlockDiagonal& w);

  const SymmetricPattern& pattern() const { return pattern_; }
  int num_products() const { return static_cast<int>(weight_.size()); }

  // c_values[s] for every slot s of pattern(), from the values of A in pattern order.
  void assemble(const double* a_values, double* c_values) const;

 private:
  SymmetricPattern pattern_;
  // Slot s sums weight_[t] * a[left_[t]] * a[right_[t]] for t in [slot_begin_[s], slot_begin_[s+1]).
  std::vector<int> slot_begin_{0};
  std::vector<int> left_, right_;
  std::vector<double> weight_;
};

}  // namespace nonholo::sparse

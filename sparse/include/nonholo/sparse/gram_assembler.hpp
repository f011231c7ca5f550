#pragma once
/// @file
/// C = A W A^T for a fixed row pattern A (the one-forms mu) and a constant block-diagonal W
/// (M^-1). The pattern of C and an index map of products are computed once; assemble() then
/// writes C's values with no allocation and no sparse product. A product whose weight is a
/// structural zero of W is dropped, but a value of A that happens to be zero keeps its slot.
/// Built in O(nnz(A) + products) time with arrays of their final size (a million-body chain
/// takes a fraction of a second; the only temporaries are a transpose of A's pattern and a
/// few per-row markers).
#include <nonholo/sparse/block_diagonal.hpp>
#include <nonholo/sparse/patterns.hpp>

#include <vector>

namespace nonholo::sparse {

/// Assembles C = A W A^T for a fixed pattern of A (see gram_assembler.hpp).
class GramAssembler {
 public:
  GramAssembler() = default;  ///< empty: for C of no rows
  /// Computes C's pattern and the index map of its products for this A and W.
  GramAssembler(const RowPattern& a, const BlockDiagonal& w);

  const SymmetricPattern& pattern() const { return pattern_; }  ///< C's lower triangle
  int num_products() const { return num_products_; }  ///< products summed by assemble()

  /// c_values[s] for every slot s of pattern(), from the values of A in pattern order;
  /// with `position`, slot s goes to c_values[position[s]] instead (a solver's own storage).
  void assemble(const double* a_values, double* c_values, const int* position = nullptr) const;

 private:
  // The two constructions: W diagonal (each product pairs two values of A in one column), or not.
  void build_diagonal(const RowPattern& a, const BlockDiagonal& w);
  void build_general(const RowPattern& a, const BlockDiagonal& w);

  SymmetricPattern pattern_;
  int num_products_ = 0;
  // Slot s sums the terms t in [slot_begin_[s], slot_begin_[s+1]) (kept unless compact_) ...
  std::vector<int> slot_begin_{0};
  // ... for a diagonal W (the usual case): a[left] a[right] w_value_[left], where
  // w_value_[k] is W's entry for the column of A's k-th value (pairs stored interleaved,
  // in slot order: one sweep through A's values);
  std::vector<int> pairs_;
  std::vector<double> w_value_;
  // The same terms in a compact form, used when every slot fits it (chains do): slot s
  // starts at A-value base_[s]; its count_[s] terms are byte offsets (left, right) from it.
  // A third of the index traffic of pairs_, which is what the assembly's time is spent on.
  bool compact_ = false;
  std::vector<int> base_;
  std::vector<unsigned char> count_, offsets_;
  // ... otherwise weight_[t] a[left_[t]] a[right_[t]].
  bool diagonal_ = true;
  std::vector<int> left_, right_;
  std::vector<double> weight_;
};

}  // namespace nonholo::sparse

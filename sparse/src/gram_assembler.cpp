// C = A W A^T for a fixed pattern of A (gram_assembler.hpp): C's pattern and the index map of its products
// built once (a faster construction for diagonal W), then assemble() every step.
#include <nonholo/sparse/gram_assembler.hpp>

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace nonholo::sparse {

GramAssembler::GramAssembler(const RowPattern& a, const BlockDiagonal& w) : diagonal_(w.is_diagonal()) {
  pattern_.size = a.rows;
  if (diagonal_)
    build_diagonal(a, w);
  else
    build_general(a, w);
}

// W diagonal (the usual case: planar bodies). A product a[kr] W(j, j) a[kc] is nonzero only
// when the values kr of row r and kc of row c sit in the same column j, so the rows r >= c
// that share a slot with row c are those of c's columns (a transpose of A's pattern), and
// each value of row r meets at most one of row c. Slots and terms come out in the order of
// the general construction (rows ascending within a column; the terms of a slot by kr), so
// the assembled sums are the same to the bit.
void GramAssembler::build_diagonal(const RowPattern& a, const BlockDiagonal& w) {
  const int m = a.rows, n = w.size(), nnz = a.nnz();
  const int* row_ptr = a.row_ptr.data();
  const int* col_idx = a.col_idx.data();
  const double* diag = w.diagonal();

  // Rows of each column j, ascending: rows_of[col_ptr[j] .. col_ptr[j+1]).
  std::vector<int> col_ptr(static_cast<std::size_t>(n) + 2, 0), rows_of(static_cast<std::size_t>(nnz));
  for (int k = 0; k < nnz; ++k) ++col_ptr[col_idx[k] + 2];
  for (int j = 2; j <= n + 1; ++j) col_ptr[j] += col_ptr[j - 1];
  for (int r = 0; r < m; ++r)
    for (int k = row_ptr[r]; k < row_ptr[r + 1]; ++k) rows_of[col_ptr[col_idx[k] + 1]++] = r;
  // first[j]: the first row of column j not below the current column c of C (it only advances).
  std::vector<int> first(col_ptr.begin(), col_ptr.begin() + n);
  auto advance = [&](int j, int c) {
    int t = first[j];
    while (t < col_ptr[j + 1] && rows_of[t] < c) ++t;
    first[j] = t;
    return t;
  };

  // Pass 1: the number of slots and of terms, to size every array once. A column j of row c
  // gives one term to each row r >= c that has j (with W(j, j) != 0, always so for an SPD W).
  std::vector<int> mark(static_cast<std::size_t>(m), -1);
  long long slots = 0, terms = 0;
  for (int c = 0; c < m; ++c) {
    mark[c] = c;
    ++slots;  // the diagonal always has a slot
    for (int kc = row_ptr[c]; kc < row_ptr[c + 1]; ++kc) {
      const int j = col_idx[kc];
      if (diag[j] == 0.0) continue;
      for (int t = advance(j, c); t < col_ptr[j + 1]; ++t) {
        const int r = rows_of[t];
        ++terms;
        if (mark[r] != c) {
          mark[r] = c;
          ++slots;
        }
      }
    }
  }
  if (slots > std::numeric_limits<int>::max() || terms > std::numeric_limits<int>::max())
    throw std::length_error("GramAssembler: C has more than 2^31 entries or products");
  num_products_ = static_cast<int>(terms);
  pattern_.col_ptr.reserve(static_cast<std::size_t>(m) + 1);
  pattern_.row_idx.reserve(static_cast<std::size_t>(slots));
  w_value_.reserve(static_cast<std::size_t>(nnz));
  for (int k = 0; k < nnz; ++k) w_value_.push_back(diag[col_idx[k]]);

  // Pass 2: the slots and their terms, in the compact form while every slot fits it (at most
  // 255 terms, all within 255 values of the slot's smallest), else as pairs.
  compact_ = true;
  base_.reserve(static_cast<std::size_t>(slots));
  count_.reserve(static_cast<std::size_t>(slots));
  offsets_.reserve(2 * static_cast<std::size_t>(terms));
  auto to_pairs = [&] {  // convert the slots so far, then continue as pairs
    compact_ = false;
    slot_begin_.reserve(static_cast<std::size_t>(slots) + 1);
    pairs_.reserve(2 * static_cast<std::size_t>(terms));
    const unsigned char* off = offsets_.data();
    for (std::size_t s = 0; s < base_.size(); ++s) {
      for (int t = 0; t < count_[s]; ++t, off += 2) {
        pairs_.push_back(base_[s] + off[0]);
        pairs_.push_back(base_[s] + off[1]);
      }
      slot_begin_.push_back(static_cast<int>(pairs_.size() / 2));
    }
    std::vector<int>().swap(base_);
    std::vector<unsigned char>().swap(count_);
    std::vector<unsigned char>().swap(offsets_);
  };
  std::fill(mark.begin(), mark.end(), -1);
  std::vector<int> position(static_cast<std::size_t>(n), -1);  // column -> its value in row c
  std::vector<int> candidates, slot_terms;
  for (int j = 0; j < n; ++j) first[j] = col_ptr[j];
  for (int c = 0; c < m; ++c) {
    candidates.assign(1, c);
    mark[c] = c;
    for (int kc = row_ptr[c]; kc < row_ptr[c + 1]; ++kc) {
      const int j = col_idx[kc];
      if (diag[j] == 0.0) continue;
      position[j] = kc;
      for (int t = advance(j, c); t < col_ptr[j + 1]; ++t)
        if (mark[rows_of[t]] != c) {
          mark[rows_of[t]] = c;
          candidates.push_back(rows_of[t]);
        }
    }
    std::sort(candidates.begin(), candidates.end());
    for (int r : candidates) {
      slot_terms.clear();  // (kr, kc) pairs, kr ascending
      int lo = nnz, hi = 0;
      for (int kr = row_ptr[r]; kr < row_ptr[r + 1]; ++kr) {
        const int kc = position[col_idx[kr]];
        if (kc < 0) continue;
        slot_terms.push_back(kr);
        slot_terms.push_back(kc);
        lo = std::min({lo, kr, kc});
        hi = std::max({hi, kr, kc});
      }
      pattern_.row_idx.push_back(r);
      const int count = static_cast<int>(slot_terms.size() / 2);
      if (compact_ && (count > 255 || hi - lo > 255)) to_pairs();
      if (compact_) {
        base_.push_back(count > 0 ? lo : 0);
        count_.push_back(static_cast<unsigned char>(count));
        for (int v : slot_terms) offsets_.push_back(static_cast<unsigned char>(v - lo));
      } else {
        pairs_.insert(pairs_.end(), slot_terms.begin(), slot_terms.end());
        slot_begin_.push_back(static_cast<int>(pairs_.size() / 2));
      }
    }
    pattern_.col_ptr.push_back(pattern_.nnz());
    for (int kc = row_ptr[c]; kc < row_ptr[c + 1]; ++kc) position[col_idx[kc]] = -1;
  }
  if (compact_) std::vector<int>{0}.swap(slot_begin_);
}

// General W: the rows touching a block of W are the candidates; each pair of values of rows r
// and c whose columns W couples is a term with its weight (doubled for the two equal
// off-diagonal products of a diagonal slot).
void GramAssembler::build_general(const RowPattern& a, const BlockDiagonal& w) {
  const int m = a.rows;
  // Rows touching each block of W (compressed, ascending): the candidates for a nonzero
  // C(r, c). Two passes, no per-block vectors.
  const int blocks = w.num_blocks();
  std::vector<int> block_ptr(blocks + 1, 0), last(blocks, -1), block_rows;
  for (int pass = 0; pass < 2; ++pass) {
    std::fill(last.begin(), last.end(), -1);
    std::vector<int> next(block_ptr.begin(), block_ptr.end() - 1);
    for (int r = 0; r < m; ++r)
      for (int k = a.row_ptr[r]; k < a.row_ptr[r + 1]; ++k) {
        const int b = w.block_of(a.col_idx[k]);
        if (last[b] == r) continue;
        last[b] = r;
        if (pass == 0) ++block_ptr[b + 1];
        else block_rows[next[b]++] = r;
      }
    if (pass == 0) {
      for (int b = 0; b < blocks; ++b) block_ptr[b + 1] += block_ptr[b];
      block_rows.resize(block_ptr[blocks]);
    }
  }

  std::vector<int> candidates, mark(static_cast<std::size_t>(m), -1);
  for (int c = 0; c < m; ++c) {  // column c of the lower triangle, rows r >= c
    candidates.clear();
    for (int k = a.row_ptr[c]; k < a.row_ptr[c + 1]; ++k)
      for (int b = w.block_of(a.col_idx[k]), t = block_ptr[b]; t < block_ptr[b + 1]; ++t)
        if (block_rows[t] >= c && mark[block_rows[t]] != c) {
          mark[block_rows[t]] = c;
          candidates.push_back(block_rows[t]);
        }
    std::sort(candidates.begin(), candidates.end());

    for (int r : candidates) {
      const std::size_t first = weight_.size();
      for (int kr = a.row_ptr[r]; kr < a.row_ptr[r + 1]; ++kr) {
        for (int kc = a.row_ptr[c]; kc < a.row_ptr[c + 1]; ++kc) {
          // On the diagonal the products (kr, kc) and (kc, kr) are equal: keep one, twice.
          if (r == c && kc < kr) continue;
          const double wt = w.entry(a.col_idx[kr], a.col_idx[kc]);
          if (wt == 0.0) continue;  // structural zero of the constant metric
          left_.push_back(kr);
          right_.push_back(kc);
          weight_.push_back((r == c && kc != kr) ? 2.0 * wt : wt);
        }
      }
      // The diagonal always has a slot (W is SPD, so it has products); an off-diagonal
      // pair whose every product has a structural zero weight is identically zero.
      if (weight_.size() == first && r != c) continue;
      pattern_.row_idx.push_back(r);
      slot_begin_.push_back(static_cast<int>(weight_.size()));
    }
    pattern_.col_ptr.push_back(pattern_.nnz());
  }
  num_products_ = slot_begin_.back();
}

namespace {

// The general slot loop, with the store through `position` or direct.
template <bool Scattered, class Term>
void assemble_slots(int slots, const int* begin, const int* position, double* out, Term term) {
  for (int s = 0; s < slots; ++s) {
    double sum = 0.0;
    for (int t = begin[s]; t < begin[s + 1]; ++t) sum += term(t);
    out[Scattered ? position[s] : s] = sum;
  }
}

template <bool Scattered>
void assemble_compact(int slots, const int* base, const unsigned char* count, const unsigned char* off,
                      const double* wv, const double* a, const int* position, double* out) {
  for (int s = 0; s < slots; ++s) {
    const double* as = a + base[s];
    const double* ws = wv + base[s];
    double sum = 0.0;
    for (int t = count[s]; t > 0; --t, off += 2) sum += ws[off[0]] * as[off[0]] * as[off[1]];
    out[Scattered ? position[s] : s] = sum;
  }
}

}  // namespace

void GramAssembler::assemble(const double* a, double* c_values, const int* position) const {
  const int slots = pattern_.nnz();
  const int* begin = slot_begin_.data();
  if (diagonal_ && compact_) {
    if (position)
      assemble_compact<true>(slots, base_.data(), count_.data(), offsets_.data(), w_value_.data(), a,
                             position, c_values);
    else
      assemble_compact<false>(slots, base_.data(), count_.data(), offsets_.data(), w_value_.data(), a,
                              position, c_values);
    return;
  }
  if (diagonal_) {
    const int* pair = pairs_.data();
    const double* wv = w_value_.data();
    auto term = [&](int t) {
      const int l = pair[2 * t], r = pair[2 * t + 1];
      return wv[l] * a[l] * a[r];
    };
    if (position)
      assemble_slots<true>(slots, begin, position, c_values, term);
    else
      assemble_slots<false>(slots, begin, position, c_values, term);
    return;
  }
  auto term = [&](int t) { return weight_[t] * a[left_[t]] * a[right_[t]]; };
  if (position)
    assemble_slots<true>(slots, begin, position, c_values, term);
  else
    assemble_slots<false>(slots, begin, position, c_values, term);
}

}  // namespace nonholo::sparse

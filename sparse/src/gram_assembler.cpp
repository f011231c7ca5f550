#include <nonholo/sparse/gram_assembler.hpp>

#include <algorithm>

namespace nonholo::sparse {

GramAssembler::GramAssembler(const RowPattern& a, const BlockDiagonal& w) : diagonal_(w.is_diagonal()) {
  const int m = a.rows;
  pattern_.size = m;

  // Rows touching each block of W (compressed, ascending): the candidates for a nonzero
  // C(r, c). Two passes, no per-block vectors (a million bodies).
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

  std::vector<int> candidates;
  for (int c = 0; c < m; ++c) {  // column c of the lower triangle, rows r >= c
    candidates.clear();
    for (int k = a.row_ptr[c]; k < a.row_ptr[c + 1]; ++k)
      for (int b = w.block_of(a.col_idx[k]), t = block_ptr[b]; t < block_ptr[b + 1]; ++t)
        if (block_rows[t] >= c) candidates.push_back(block_rows[t]);
    std::sort(candidates.begin(), candidates.end());
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());

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
  if (diagonal_) {
    // Only same-column products survive a diagonal W, each with weight W(j, j) (never the
    // doubled off-diagonal products of a diagonal slot): keep the pairs and a per-value
    // weight, half the memory of the general terms and streamed in order.
    w_value_.resize(a.col_idx.size());
    for (std::size_t k = 0; k < a.col_idx.size(); ++k) w_value_[k] = w.entry(a.col_idx[k], a.col_idx[k]);
    pairs_.resize(2 * left_.size());
    for (std::size_t t = 0; t < left_.size(); ++t) {
      pairs_[2 * t] = left_[t];
      pairs_[2 * t + 1] = right_[t];
    }
    // Compact form: every slot's terms within 255 values of its smallest one, at most 255 terms.
    const int slots = pattern_.nnz();
    compact_ = true;
    base_.resize(slots);
    count_.resize(slots);
    offsets_.reserve(2 * left_.size());
    for (int slot = 0; slot < slots && compact_; ++slot) {
      int lo = a.nnz(), hi = 0;
      for (int t = slot_begin_[slot]; t < slot_begin_[slot + 1]; ++t) {
        lo = std::min({lo, left_[t], right_[t]});
        hi = std::max({hi, left_[t], right_[t]});
      }
      const int terms = slot_begin_[slot + 1] - slot_begin_[slot];
      if (terms > 255 || hi - lo > 255) {
        compact_ = false;
        break;
      }
      base_[slot] = lo;
      count_[slot] = static_cast<unsigned char>(terms);
      for (int t = slot_begin_[slot]; t < slot_begin_[slot + 1]; ++t) {
        offsets_.push_back(static_cast<unsigned char>(left_[t] - lo));
        offsets_.push_back(static_cast<unsigned char>(right_[t] - lo));
      }
    }
    if (compact_) {
      std::vector<int>().swap(pairs_);
    } else {
      std::vector<int>().swap(base_);
      std::vector<unsigned char>().swap(count_);
      std::vector<unsigned char>().swap(offsets_);
    }
    std::vector<int>().swap(left_);
    std::vector<int>().swap(right_);
    std::vector<double>().swap(weight_);
  }
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

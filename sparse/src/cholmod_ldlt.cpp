// The CHOLMOD backends (cholmod_ldlt.hpp): simplicial LDL^T of P C P^T analysed once, refactorised in place
// every step and solved with cholmod_solve2; CHOLMOD's statuses become a FactorStatus and a message.
#include "cholmod_ldlt.hpp"

#include <cholmod.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace nonholo::sparse {
namespace {

// CHOLMOD reports errors through a callback without user data; keep the last message of
// this thread (each thread owns its own cholmod_common anyway).
thread_local char last_cholmod_error[160] = "";

void record_cholmod_error(int /*status*/, const char* /*file*/, int /*line*/, const char* msg) {
  std::snprintf(last_cholmod_error, sizeof last_cholmod_error, "%s", msg ? msg : "");
}

}  // namespace

struct CholmodLDLT::Impl {
  cholmod_common common;
  // P C P^T, upper triangle, in the factor's own order: CHOLMOD factorises an upper,
  // naturally ordered matrix in place, whereas a lower or permuted one would be transposed
  // (allocated) on every call.
  cholmod_sparse* c = nullptr;
  cholmod_factor* l = nullptr;    // symbolic analysis kept, numeric values refreshed
  cholmod_dense* b = nullptr;     // permuted right-hand side
  cholmod_dense* x = nullptr;     // cholmod_solve2's reusable solution and workspace
  cholmod_dense* y = nullptr;
  cholmod_dense* e = nullptr;
  std::vector<int> perm;          // k-th row of P C P^T is row perm[k] of C
  std::vector<int> slot_to_upper; // slot of C's pattern -> entry of c
  std::vector<int> diag_slot;     // slot of C's diagonal for the k-th row of the factor
  std::vector<int> diag_pos;      // and its position in c
  std::vector<double> pivot, diag;

  Impl() {
    cholmod_start(&common);
    common.print = 0;  // errors come back through the handler, not stdout
    common.error_handler = record_cholmod_error;
    common.supernodal = CHOLMOD_SIMPLICIAL;  // D must be readable for the pivot check
    common.final_ll = false;
    common.nmethods = 1;
  }
  ~Impl() {
    cholmod_free_dense(&b, &common);
    cholmod_free_dense(&x, &common);
    cholmod_free_dense(&y, &common);
    cholmod_free_dense(&e, &common);
    cholmod_free_factor(&l, &common);
    cholmod_free_sparse(&c, &common);
    cholmod_finish(&common);
  }

  [[noreturn]] void fail(const char* what) {
    throw std::runtime_error(std::string("CHOLMOD: ") + what + ": " + last_cholmod_error);
  }

  // The fill-reducing order of the pattern (AMD and a postorder), from a throw-away analysis.
  void order_with_amd(const SymmetricPattern& pattern) {
    const int m = pattern.size;
    cholmod_sparse* lower = cholmod_allocate_sparse(m, m, pattern.nnz(), true, true, -1, CHOLMOD_PATTERN, &common);
    if (!lower) fail("cannot allocate the pattern of C");
    std::copy(pattern.col_ptr.begin(), pattern.col_ptr.end(), static_cast<int*>(lower->p));
    std::copy(pattern.row_idx.begin(), pattern.row_idx.end(), static_cast<int*>(lower->i));
    common.method[0].ordering = CHOLMOD_AMD;
    common.postorder = true;
    cholmod_factor* symbolic = cholmod_analyze(lower, &common);
    if (!symbolic) {
      cholmod_free_sparse(&lower, &common);
      fail("AMD ordering of C failed");
    }
    const int* p = static_cast<const int*>(symbolic->Perm);
    perm.assign(p, p + m);
    cholmod_free_factor(&symbolic, &common);
    cholmod_free_sparse(&lower, &common);
  }

  // Upper triangle of P C P^T (compressed columns, rows sorted) and the slot map into it: a
  // counting sort by column, in O(nnz) (no sort of all entries; a million-body chain has 12
  // million). In the natural order the rows come out sorted; a permuted column is sorted on
  // its own (its few entries).
  void build_permuted_upper(const SymmetricPattern& pattern) {
    const int m = pattern.size, nnz = pattern.nnz();
    const bool natural = ordering_is_natural();
    std::vector<int> inverse;
    if (!natural) {
      inverse.resize(m);
      for (int k = 0; k < m; ++k) inverse[perm[k]] = k;
    }
    c = cholmod_allocate_sparse(m, m, nnz, true, true, 1, CHOLMOD_REAL, &common);
    if (!c) fail("cannot allocate C");
    int* cp = static_cast<int*>(c->p);
    int* ci = static_cast<int*>(c->i);
    // Entry (row u, column v) of the upper triangle for slot s of column j: u <= v.
    auto upper = [&](int j, int s, int& u, int& v) {
      const int row = natural ? pattern.row_idx[s] : inverse[pattern.row_idx[s]], col = natural ? j : inverse[j];
      u = std::min(row, col);
      v = std::max(row, col);
    };
    std::fill(cp, cp + m + 1, 0);
    int u, v;
    for (int j = 0; j < m; ++j)
      for (int s = pattern.col_ptr[j]; s < pattern.col_ptr[j + 1]; ++s) {
        upper(j, s, u, v);
        ++cp[v + 1];
      }
    for (int k = 0; k < m; ++k) cp[k + 1] += cp[k];
    slot_to_upper.resize(nnz);
    std::vector<int> next(cp, cp + m);
    for (int j = 0; j < m; ++j)
      for (int s = pattern.col_ptr[j]; s < pattern.col_ptr[j + 1]; ++s) {
        upper(j, s, u, v);
        const int k = next[v]++;
        ci[k] = u;
        slot_to_upper[s] = k;
      }
    std::vector<int>().swap(next);
    if (natural) return;
    std::vector<int> slot_of(static_cast<std::size_t>(nnz));  // entry of c -> slot
    for (int slot = 0; slot < nnz; ++slot) slot_of[slot_to_upper[slot]] = slot;
    std::vector<std::pair<int, int>> column;
    for (int k = 0; k < m; ++k) {
      const int begin = cp[k], end = cp[k + 1];
      if (std::is_sorted(ci + begin, ci + end)) continue;
      column.clear();
      for (int t = begin; t < end; ++t) column.emplace_back(ci[t], slot_of[t]);
      std::sort(column.begin(), column.end());
      for (int t = begin; t < end; ++t) {
        ci[t] = column[t - begin].first;
        slot_to_upper[column[t - begin].second] = t;
      }
    }
  }

  bool ordering_is_natural() const {
    for (std::size_t k = 0; k < perm.size(); ++k)
      if (perm[k] != static_cast<int>(k)) return false;
    return true;
  }
};

CholmodLDLT::CholmodLDLT(const SymmetricPattern& pattern, CholmodOrdering ordering)
    : Factorization(pattern.size), impl_(std::make_unique<Impl>()), ordering_(ordering) {
  Impl& s = *impl_;
  const int m = pattern.size;
  if (ordering == CholmodOrdering::Amd) {
    s.order_with_amd(pattern);
  } else {
    s.perm.resize(m);
    for (int k = 0; k < m; ++k) s.perm[k] = k;
  }
  s.build_permuted_upper(pattern);

  // The permuted matrix is factorised in its own (natural) order.
  s.common.method[0].ordering = CHOLMOD_NATURAL;
  s.common.postorder = false;
  s.l = cholmod_analyze(s.c, &s.common);
  if (!s.l || s.common.status < CHOLMOD_OK) s.fail("symbolic analysis of C failed");

  s.diag_slot.resize(m);
  s.diag_pos.resize(m);
  for (int k = 0; k < m; ++k) {  // factor order
    s.diag_slot[k] = pattern.diagonal_slot(s.perm[k]);
    s.diag_pos[k] = s.slot_to_upper[s.diag_slot[k]];
  }
  s.pivot.resize(m);
  s.diag.resize(m);
  s.b = cholmod_allocate_dense(m, 1, m, CHOLMOD_REAL, &s.common);
  if (!s.b) s.fail("cannot allocate the right-hand side");

  // One factorisation and solve of a diagonally dominant matrix with the same pattern, so
  // that CHOLMOD allocates the numeric factor and the solve workspace here, not in a step.
  // The values go straight into C's own storage (no temporary of nnz(C) values).
  double* cx = static_cast<double*>(s.c->x);
  std::fill(cx, cx + pattern.nnz(), -1.0);
  for (int k = 0; k < m; ++k) cx[s.diag_pos[k]] = 2.0 * m + 1.0;
  std::vector<double> rhs(m, 1.0), out(m);
  if (factorize_in_place(0.0) != FactorStatus::Ok || solve(rhs.data(), out.data()) != FactorStatus::Ok)
    throw std::runtime_error(std::string("CHOLMOD: warm-up factorisation failed: ") + message());
}

CholmodLDLT::~CholmodLDLT() = default;

FactorStatus CholmodLDLT::from_cholmod(int cholmod_status, const char* call) {
  set_failed_row(-1);  // CHOLMOD's own failures are not tied to a row we can name
  switch (cholmod_status) {
    case CHOLMOD_OK: return FactorStatus::Ok;
    case CHOLMOD_NOT_POSDEF:
      return fail(FactorStatus::NotPositiveDefinite, "%s: CHOLMOD_NOT_POSDEF at column %zu", call,
                  impl_->l ? impl_->l->minor : size_t{0});
    case CHOLMOD_DSMALL:
      return fail(FactorStatus::NearlySingular, "%s: CHOLMOD_DSMALL (a pivot below dbound)", call);
    case CHOLMOD_OUT_OF_MEMORY:
      return fail(FactorStatus::OutOfMemory, "%s: CHOLMOD_OUT_OF_MEMORY: %s", call, last_cholmod_error);
    case CHOLMOD_TOO_LARGE:
      return fail(FactorStatus::TooLarge, "%s: CHOLMOD_TOO_LARGE: %s", call, last_cholmod_error);
    case CHOLMOD_INVALID:
      return fail(FactorStatus::InvalidInput, "%s: CHOLMOD_INVALID: %s", call, last_cholmod_error);
    case CHOLMOD_NOT_INSTALLED:
      return fail(FactorStatus::NotInstalled, "%s: CHOLMOD_NOT_INSTALLED: %s", call, last_cholmod_error);
    case CHOLMOD_GPU_PROBLEM:
      return fail(FactorStatus::GpuProblem, "%s: CHOLMOD_GPU_PROBLEM: %s", call, last_cholmod_error);
    default:
      return fail(FactorStatus::Failed, "%s: CHOLMOD status %d: %s", call, cholmod_status,
                  last_cholmod_error);
  }
}

double* CholmodLDLT::values_in_place() { return static_cast<double*>(impl_->c->x); }
const int* CholmodLDLT::slot_positions() const { return impl_->slot_to_upper.data(); }

FactorStatus CholmodLDLT::factorize(const double* c_values, double min_pivot_ratio) {
  Impl& s = *impl_;
  double* cx = static_cast<double*>(s.c->x);
  const int* to = s.slot_to_upper.data();
  const std::size_t slots = s.slot_to_upper.size();
  for (std::size_t slot = 0; slot < slots; ++slot) cx[to[slot]] = c_values[slot];
  return factorize_in_place(min_pivot_ratio);
}

FactorStatus CholmodLDLT::factorize_in_place(double min_pivot_ratio) {
  Impl& s = *impl_;
  const int m = size();
  const int ok = cholmod_factorize(s.c, s.l, &s.common);
  // NOT_POSDEF for LDL^T means a zero pivot: the pivot scan below names its row. Any other
  // failure is CHOLMOD's own.
  if ((!ok || s.common.status != CHOLMOD_OK) && s.common.status != CHOLMOD_NOT_POSDEF)
    return from_cholmod(s.common.status, "cholmod_factorize");
  // Simplicial LDL^T stores D on the diagonal of L: column k starts with D(k, k). Columns
  // after a failure (l->minor < m) are not computed.
  const int* lp = static_cast<const int*>(s.l->p);
  const double* lx = static_cast<const double*>(s.l->x);
  const double* cx = static_cast<const double*>(s.c->x);
  const size_t minor = s.l->minor;
  const int* diag_pos = s.diag_pos.data();
  double* diag = s.diag.data();
  double* pivot = s.pivot.data();
  if (minor >= static_cast<size_t>(m)) {
    for (int k = 0; k < m; ++k) {
      diag[k] = cx[diag_pos[k]];
      pivot[k] = lx[lp[k]];
    }
  } else {
    for (int k = 0; k < m; ++k) {
      diag[k] = cx[diag_pos[k]];
      pivot[k] = static_cast<size_t>(k) <= minor ? lx[lp[k]] : diag[k];
    }
  }
  const FactorStatus status = check_pivots(pivot, diag, s.perm.data(), min_pivot_ratio);
  if (status == FactorStatus::Ok && s.common.status == CHOLMOD_NOT_POSDEF)
    return from_cholmod(s.common.status, "cholmod_factorize");
  return status;
}

FactorStatus CholmodLDLT::solve(const double* b, double* x) {
  Impl& s = *impl_;
  const int m = size();
  double* bp = static_cast<double*>(s.b->x);
  for (int k = 0; k < m; ++k) bp[k] = b[s.perm[k]];
  // The simplicial solve allocates Y as 4 x m (room for four right-hand sides) but leaves
  // it shaped 1 x m; cholmod_ensure_dense would then reallocate it on the next call.
  // Restore the shape it was allocated with (test_no_allocation checks this).
  if (s.y && s.y->ncol == static_cast<size_t>(m) && s.y->nzmax >= 4 * static_cast<size_t>(m)) {
    s.y->nrow = 4;
    s.y->d = 4;
  }
  if (!cholmod_solve2(CHOLMOD_A, s.l, s.b, nullptr, &s.x, nullptr, &s.y, &s.e, &s.common))
    return from_cholmod(s.common.status == CHOLMOD_OK ? CHOLMOD_INVALID : s.common.status, "cholmod_solve2");
  const double* xp = static_cast<const double*>(s.x->x);
  for (int k = 0; k < m; ++k) x[s.perm[k]] = xp[k];
  return FactorStatus::Ok;
}

}  // namespace nonholo::sparse

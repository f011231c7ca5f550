// Rows dependent by their pattern alone (structural_rank.hpp): a Hopcroft-Karp maximum matching of rows to
// columns, then the rows that alternating paths reach from the unmatched ones.
#include "model/structural_rank.hpp"

#include <algorithm>
#include <limits>

namespace nonholo::detail {
namespace {

constexpr int kUnmatched = -1;
constexpr int kFar = std::numeric_limits<int>::max();

struct Matching {
  int rows, cols;
  const std::vector<int>& ptr;
  const std::vector<int>& idx;
  std::vector<int> col_of, row_of;  // row -> column, column -> row (kUnmatched)
  std::vector<int> level, next;     // BFS layer of a row; next column slot to try in the DFS
  int limit = kFar;                 // the layer whose rows see a free column: shortest paths only

  Matching(int r, int c, const std::vector<int>& p, const std::vector<int>& i)
      : rows(r), cols(c), ptr(p), idx(i), col_of(r, kUnmatched), row_of(c, kUnmatched), level(r), next(r) {}

  // Each row takes its first free column: a chain's rows all match here, in one pass.
  void greedy() {
    for (int r = 0; r < rows; ++r)
      for (int s = ptr[r]; s < ptr[r + 1]; ++s)
        if (row_of[idx[s]] == kUnmatched) {
          row_of[idx[s]] = r;
          col_of[r] = idx[s];
          break;
        }
  }

  // Layers the rows by alternating distance from the free rows; whether a free column is reached.
  bool layer(std::vector<int>& queue) {
    queue.clear();
    for (int r = 0; r < rows; ++r) {
      level[r] = col_of[r] == kUnmatched ? 0 : kFar;
      if (level[r] == 0) queue.push_back(r);
    }
    limit = kFar;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const int r = queue[head];
      if (level[r] > limit) break;
      for (int s = ptr[r]; s < ptr[r + 1]; ++s) {
        const int w = row_of[idx[s]];
        if (w == kUnmatched) limit = level[r];
        else if (level[w] == kFar) {
          level[w] = level[r] + 1;
          queue.push_back(w);
        }
      }
    }
    return limit != kFar;
  }

  // One augmenting path from free row `start` along the layers, by an explicit stack (paths
  // can be as long as the model). Rows that lead nowhere are dropped from the layers.
  bool augment(int start, std::vector<int>& stack) {
    stack.assign(1, start);
    while (!stack.empty()) {
      const int r = stack.back();
      if (next[r] == ptr[r + 1]) {
        level[r] = kFar;
        stack.pop_back();
        continue;
      }
      const int c = idx[next[r]++];
      const int w = row_of[c];
      if (w != kUnmatched) {
        if (level[w] == level[r] + 1 && level[w] <= limit) stack.push_back(w);
        continue;
      }
      if (level[r] != limit) continue;
      // A free column: flip the path, each row on the stack taking the column it came through.
      for (int k = static_cast<int>(stack.size()) - 1, col = c; k >= 0; --k) {
        const int row = stack[static_cast<std::size_t>(k)], previous = col_of[row];
        col_of[row] = col;
        row_of[col] = row;
        col = previous;
      }
      return true;
    }
    return false;
  }
};

}  // namespace

StructuralDeficiency structural_deficiency(int rows, int cols, const std::vector<int>& row_ptr,
                                           const std::vector<int>& col_idx) {
  Matching m(rows, cols, row_ptr, col_idx);
  m.greedy();
  std::vector<int> queue, stack;
  if (std::find(m.col_of.begin(), m.col_of.end(), kUnmatched) == m.col_of.end()) return {};
  while (m.layer(queue)) {
    for (int r = 0; r < rows; ++r) m.next[r] = row_ptr[r];
    for (int r = 0; r < rows; ++r)
      if (m.col_of[r] == kUnmatched) m.augment(r, stack);
  }
  // The matching is maximum. The rows reachable from the free rows by alternating paths touch
  // only columns matched to rows among them: more rows than columns (Hall's condition fails).
  m.layer(queue);
  StructuralDeficiency d;
  if (queue.empty()) return d;
  std::vector<char> seen(static_cast<std::size_t>(cols), 0);
  for (int r : queue)
    for (int s = row_ptr[r]; s < row_ptr[r + 1]; ++s)
      if (!seen[static_cast<std::size_t>(col_idx[s])]) {
        seen[static_cast<std::size_t>(col_idx[s])] = 1;
        d.columns.push_back(col_idx[s]);
      }
  d.rows = std::move(queue);
  std::sort(d.rows.begin(), d.rows.end());
  std::sort(d.columns.begin(), d.columns.end());
  return d;
}

}  // namespace nonholo::detail

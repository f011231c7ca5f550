// Rows dependent by their pattern alone are found by a maximum matching of rows to columns and
// refused by the builder before C (dense for such rows) exists: the matching against the rank of
// random values on the same pattern, and 10^4 copies of one knife edge refused in little memory.
#include <nonholo/model_builder.hpp>

#include <Eigen/LU>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <random>

#include "model/structural_rank.hpp"
#include "support/expect_error.hpp"

namespace nonholo {
namespace {

struct Pattern {
  int rows = 0, cols = 0;
  std::vector<int> ptr{0}, idx;
  void add(std::vector<int> columns) {
    idx.insert(idx.end(), columns.begin(), columns.end());
    ptr.push_back(static_cast<int>(idx.size()));
    ++rows;
  }
};

// The rank of random values on the pattern: its structural rank with probability one.
int generic_rank(const Pattern& p, std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(p.rows, p.cols);
  for (int r = 0; r < p.rows; ++r)
    for (int s = p.ptr[r]; s < p.ptr[r + 1]; ++s) a(r, p.idx[s]) = normal(rng);
  return static_cast<int>(Eigen::FullPivLU<Eigen::MatrixXd>(a).rank());
}

TEST(StructuralRank, MatchesTheRankOfRandomValues) {
  std::mt19937 rng(23);
  int deficient = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    Pattern p;
    p.cols = 1 + static_cast<int>(rng() % 10);
    const int rows = 1 + static_cast<int>(rng() % 12);
    const double density = 0.1 + 0.4 * static_cast<double>(rng() % 100) / 100.0;
    for (int r = 0; r < rows; ++r) {
      std::vector<int> columns;
      for (int c = 0; c < p.cols; ++c)
        if (std::uniform_real_distribution<double>()(rng) < density) columns.push_back(c);
      if (columns.empty()) columns.push_back(static_cast<int>(rng() % p.cols));
      std::shuffle(columns.begin(), columns.end(), rng);  // the greedy pass meets them in any order
      p.add(columns);
    }
    const auto d = detail::structural_deficiency(p.rows, p.cols, p.ptr, p.idx);
    const int excess = static_cast<int>(d.rows.size()) - static_cast<int>(d.columns.size());
    ASSERT_EQ(p.rows - (d.empty() ? 0 : excess), generic_rank(p, rng)) << "trial " << trial;
    if (d.empty()) continue;
    ++deficient;
    EXPECT_GT(excess, 0);
    for (int r : d.rows)  // the named rows touch only the named columns
      for (int s = p.ptr[r]; s < p.ptr[r + 1]; ++s)
        EXPECT_TRUE(std::binary_search(d.columns.begin(), d.columns.end(), p.idx[s])) << "trial " << trial;
  }
  EXPECT_GT(deficient, 200);  // both outcomes exercised
  EXPECT_LT(deficient, 1800);
}

TEST(StructuralRank, LongAugmentingPathsNeedNoRecursion) {
  // Row i on columns i, i+1: the greedy pass gives row i column i, and the last row, on column 0
  // only, needs a path through all of them to reach column n.
  const int n = 200000;
  Pattern p;
  p.cols = n + 1;
  for (int i = 0; i < n; ++i) p.add({i, i + 1});
  p.add({0});
  EXPECT_TRUE(detail::structural_deficiency(p.rows, p.cols, p.ptr, p.idx).empty());
  p.add({n});  // one row too many on columns 0 .. n: all of them dependent together
  const auto d = detail::structural_deficiency(p.rows, p.cols, p.ptr, p.idx);
  EXPECT_EQ(d.rows.size(), static_cast<std::size_t>(n + 2));
  EXPECT_EQ(d.columns.size(), static_cast<std::size_t>(n + 1));
}

long peak_rss_kb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

TEST(StructuralRank, TenThousandCopiesOfAKnifeEdgeAreRefusedInLittleMemory) {
  const long before = peak_rss_kb();
  testing::expect_error(
      [] {
        ModelBuilder b;
        b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
        for (int i = 0; i < 10000; ++i) b.add_knife_edge({0, 0.2}, "constraints[" + std::to_string(i) + "]");
        std::move(b).build();
      },
      "dependent-one-forms: 10000 one-form rows touch only the 3 velocity coordinates x, y, theta, so at most 3 of "
      "them can be independent at any configuration and 9997 are redundant: one-form row 0 (constraints[0]), "
      "one-form row 1 (constraints[1]), one-form row 2 (constraints[2]), one-form row 3 (constraints[3]) and 9996 "
      "more; remove the repeated or redundant constraints");
  // C of these rows would hold 5 10^7 entries in its lower triangle alone (200 MB of indices);
  // the builder's own arrays and labels are about 1 MB.
  EXPECT_LT(peak_rss_kb() - before, 20000);
}

TEST(StructuralRank, CopiesOfAHitchAndSquareBlocksAreTold) {
  // Three copies of a hitch (6 rows) on two bodies with knife edges (8 rows on 6 columns).
  ModelBuilder b;
  b.add_planar_body({"x0", "y0", "theta0"}, 1.0, 1.0);
  b.add_planar_body({"x1", "y1", "theta1"}, 1.0, 1.0);
  b.add_knife_edge({0, 0.2});
  b.add_knife_edge({1, 0.2});
  for (int i = 0; i < 3; ++i) b.add_hitch({0, 1, 0.5, 0.5});
  testing::expect_error([&] { b.build(); },
                        "8 one-form rows touch only the 6 velocity coordinates x0, y0, theta0, x1, y1, theta1, so "
                        "at most 6 of them can be independent at any configuration and 2 are redundant");
  // Two copies of one knife edge are dependent by their values, not their pattern: the start
  // finds them (test_start), the builder accepts them.
  ModelBuilder two;
  two.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  two.add_knife_edge({0, 0.2});
  two.add_knife_edge({0, 0.2});
  EXPECT_EQ(two.build().num_one_forms(), 2);
}

}  // namespace
}  // namespace nonholo

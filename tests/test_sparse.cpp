// The linear algebra behind C = mu M^-1 mu^T: the index-map assembly against a dense
// product, the dense and CHOLMOD factorisations against each other, and the pivot checks.
#include <nonholo/sparse/big_buffer.hpp>
#include <nonholo/sparse/factorization.hpp>
#include <nonholo/sparse/gram_assembler.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/start.hpp>
#include <nonholo/workspace.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "support/dense_reference.hpp"
#include "support/random_model.hpp"

namespace nonholo {
namespace {

using sparse::Backend;
using sparse::FactorStatus;
using ::testing::HasSubstr;

// Dense lower triangle of the assembled C.
Eigen::MatrixXd dense_from_pattern(const sparse::SymmetricPattern& pat, const Vector& values) {
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(pat.size, pat.size);
  for (int j = 0; j < pat.size; ++j)
    for (int s = pat.col_ptr[j]; s < pat.col_ptr[j + 1]; ++s) {
      c(pat.row_idx[s], j) = values[s];
      c(j, pat.row_idx[s]) = values[s];
    }
  return c;
}

Vector assembled_c(const Model& model, const Vector& q) {
  Vector mu(model.num_one_form_values()), c(model.gram().pattern().nnz());
  model.one_form_values(q, mu);
  model.gram().assemble(mu.data(), c.data());
  return c;
}

TEST(GramAssembler, MatchesDenseProductOnRandomModels) {
  for (std::uint32_t seed = 1; seed <= 20; ++seed) {
    testing::RandomModelOptions o;
    o.bodies = 4 + static_cast<int>(seed % 7);
    o.rows = 1 + static_cast<int>(seed % 5);
    const Model model = testing::random_model(seed, o);
    const Vector q = testing::random_vector(seed + 100, model.num_coordinates());
    const Eigen::MatrixXd mu = testing::dense_one_forms(model, q);
    const Eigen::MatrixXd expected = mu * testing::dense_mass(model).inverse() * mu.transpose();
    const auto& pat = model.gram().pattern();
    const Eigen::MatrixXd got = dense_from_pattern(pat, assembled_c(model, q));
    EXPECT_LE((got - expected).cwiseAbs().maxCoeff(), 1e-13 * expected.cwiseAbs().maxCoeff())
        << "seed " << seed;
    for (int j = 0; j < pat.size; ++j) EXPECT_EQ(pat.row_idx[pat.diagonal_slot(j)], j);
  }
}

TEST(GramAssembler, ValuesThatVanishKeepTheirSlots) {
  // Particle-like row [-y, 1] on cols {0, 2} and a second row [x, 0] on cols {0, 1}: at
  // x = y = 0 several values are zero, yet C(1, 0) must keep its slot.
  sparse::RowPattern a;
  a.rows = 2;
  a.cols = 3;
  a.col_idx = {0, 2, 0, 1};
  a.row_ptr = {0, 2, 4};
  sparse::BlockDiagonal w;
  w.add_block(Eigen::Matrix3d::Identity());
  const sparse::GramAssembler gram(a, w);
  EXPECT_EQ(gram.pattern().nnz(), 3);  // (0,0), (1,0), (1,1)
  const double zero_values[] = {0.0, 1.0, 0.0, 0.0};
  Vector c(3);
  gram.assemble(zero_values, c.data());
  EXPECT_EQ(c[1], 0.0);
  const double values[] = {-2.0, 1.0, 3.0, 0.5};
  gram.assemble(values, c.data());
  EXPECT_DOUBLE_EQ(c[1], -6.0);  // (-2)(3)
}

TEST(GramAssembler, DropsPairsThatTheMetricNeverCouples) {
  // Rows on different coordinates of one diagonal block: C(1, 0) is identically zero.
  sparse::RowPattern a;
  a.rows = 2;
  a.cols = 2;
  a.col_idx = {0, 1};
  a.row_ptr = {0, 1, 2};
  sparse::BlockDiagonal w;
  w.add_block(Eigen::Vector2d(1.0, 2.0).asDiagonal().toDenseMatrix());
  EXPECT_EQ(sparse::GramAssembler(a, w).pattern().nnz(), 2);
}

// A random SPD matrix with a random sparsity pattern, as C would be.
struct RandomSpd {
  sparse::SymmetricPattern pattern;
  Vector values;
  Eigen::MatrixXd dense;
};

RandomSpd random_spd(std::uint32_t seed, int m) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = m + 3;
  Eigen::MatrixXd mu = Eigen::MatrixXd::Zero(m, n);
  for (int r = 0; r < m; ++r) {
    mu(r, r) = 2.0 + u(rng);
    for (int k = 0; k < 2; ++k) mu(r, std::uniform_int_distribution<int>(0, n - 1)(rng)) = u(rng);
  }
  RandomSpd out;
  out.dense = mu * mu.transpose();
  out.pattern.size = m;
  for (int j = 0; j < m; ++j) {
    for (int i = j; i < m; ++i)
      if (i == j || out.dense(i, j) != 0.0) {
        out.pattern.row_idx.push_back(i);
        out.values.conservativeResize(out.values.size() + 1);
        out.values[out.values.size() - 1] = out.dense(i, j);
      }
    out.pattern.col_ptr.push_back(out.pattern.nnz());
  }
  return out;
}

// Every backend that accepts the pattern (block-diagonal only when its blocks are small).
std::vector<std::unique_ptr<sparse::Factorization>> every_backend(const sparse::SymmetricPattern& pattern) {
  std::vector<std::unique_ptr<sparse::Factorization>> out;
  for (Backend b : {Backend::BlockDiagonal, Backend::Dense, Backend::Banded, Backend::CholmodNatural,
                    Backend::CholmodAmd}) {
    try {
      out.push_back(sparse::make_factorization(b, pattern));
      EXPECT_EQ(out.back()->backend(), b);
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(b, Backend::BlockDiagonal) << e.what();  // the only one that may refuse here
    }
  }
  return out;
}

void expect_all_solve(const sparse::SymmetricPattern& pattern, const Vector& values,
                      const Eigen::MatrixXd& dense, std::uint32_t seed, std::size_t min_backends) {
  auto factors = every_backend(pattern);
  ASSERT_GE(factors.size(), min_backends);
  const int m = pattern.size;
  const Vector b = testing::random_vector(seed, m);
  const Vector exact = dense.fullPivLu().solve(b);
  double ratio = -1.0;
  for (auto& f : factors) {
    const char* name = sparse::to_string(f->backend());
    ASSERT_EQ(f->factorize(values.data(), 1e-12), FactorStatus::Ok) << name << ": " << f->message();
    EXPECT_GT(f->min_pivot_ratio(), 0.0);
    EXPECT_LE(f->min_pivot_ratio(), 1.0 + 1e-15) << "a ratio in (0, 1]";
    if (ratio < 0.0) ratio = f->min_pivot_ratio();
    Vector x(m);
    f->solve(b.data(), x.data());
    EXPECT_LE((x - exact).norm(), 1e-12 * exact.norm()) << name << ", m = " << m << " seed " << seed;
    Vector inplace = b;  // b and x alias
    f->solve(inplace.data(), inplace.data());
    EXPECT_LE((inplace - x).norm(), 1e-15 * x.norm()) << name;
  }
}

TEST(Factorization, EveryBackendSolvesRandomSpdMatrices) {
  for (int m : {1, 2, 3, 4, 5, 8, 13, 30}) {
    for (std::uint32_t seed = 1; seed <= 5; ++seed) {
      const RandomSpd c = random_spd(seed * 97 + static_cast<std::uint32_t>(m), m);
      expect_all_solve(c.pattern, c.values, c.dense, seed, 3);
    }
  }
}

// Block-diagonal C with interleaved blocks: rows {0, 3, 5}, {1, 4}, {2}, {6, 7}, plus an
// all-scalar (diagonal) C, against a dense solve; every backend must agree.
TEST(Factorization, BlockDiagonalPathHandlesInterleavedAndScalarBlocks) {
  const std::vector<std::vector<int>> blocks{{0, 3, 5}, {1, 4}, {2}, {6, 7}};
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(8, 8);
  for (const auto& rows : blocks) {
    const int k = static_cast<int>(rows.size());
    Eigen::MatrixXd g(k, k + 2);
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k + 2; ++j) g(i, j) = u(rng);
    const Eigen::MatrixXd block = g * g.transpose();
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j) dense(rows[i], rows[j]) = block(i, j);
  }
  for (const Eigen::MatrixXd& c : {dense, Eigen::MatrixXd(Eigen::VectorXd::LinSpaced(8, 1.0, 8.0).asDiagonal())}) {
    sparse::SymmetricPattern pattern;
    pattern.size = 8;
    Vector values(0);
    for (int j = 0; j < 8; ++j) {
      for (int i = j; i < 8; ++i)
        if (i == j || c(i, j) != 0.0) {
          pattern.row_idx.push_back(i);
          values.conservativeResize(values.size() + 1);
          values[values.size() - 1] = c(i, j);
        }
      pattern.col_ptr.push_back(pattern.nnz());
    }
    ASSERT_EQ(sparse::resolve_backend(Backend::Auto, pattern), Backend::BlockDiagonal);
    expect_all_solve(pattern, values, c, 3, 4);
  }
}

TEST(Factorization, EveryBackendGivesTheSameTrajectory) {
  // Whole steps on random models with forces: the paths differ only in how C is
  // factorised, so they must agree to round-off.
  for (std::uint32_t seed = 1; seed <= 6; ++seed) {
    testing::RandomModelOptions o;
    o.bodies = 6 + static_cast<int>(seed);
    o.rows = 2 + static_cast<int>(seed);
    o.applied_force = true;
    const Model model = testing::random_model(seed * 31, o);
    const int n = model.num_coordinates();
    const Vector q0 = testing::random_vector(seed, n, 0.5), v0 = testing::random_vector(seed + 1, n);
    Workspace dense(model, {Backend::Dense});
    ASSERT_STREQ(dense.backend_name(), "dense");
    State a = start_from_velocity(model, dense, 0.0, q0, v0);
    for (int k = 0; k < 100; ++k) ASSERT_EQ(step(model, dense, a, {0.01}), Status::Ok) << dense.message();
    for (Backend backend : {Backend::CholmodNatural, Backend::CholmodAmd}) {
      Workspace ws(model, {backend});
      ASSERT_STREQ(ws.backend_name(), sparse::to_string(backend));
      State b = start_from_velocity(model, ws, 0.0, q0, v0);
      for (int k = 0; k < 100; ++k) ASSERT_EQ(step(model, ws, b, {0.01}), Status::Ok) << ws.message();
      EXPECT_LE((a.q - b.q).norm(), 1e-12 * a.q.norm()) << "seed " << seed << " " << ws.backend_name();
      EXPECT_LE((a.p - b.p).norm(), 1e-12 * a.p.norm()) << "seed " << seed << " " << ws.backend_name();
      EXPECT_LE((a.lambda - b.lambda).norm(), 1e-12 * a.lambda.norm()) << "seed " << seed;
    }
  }
}

TEST(Factorization, RefactorisationReusesTheAnalysis) {
  const RandomSpd c = random_spd(7, 12);
  auto chol = sparse::make_factorization(Backend::CholmodAmd, c.pattern);
  for (double scale : {1.0, 3.0, 0.25}) {
    const Vector values = scale * c.values;
    ASSERT_EQ(chol->factorize(values.data(), 1e-12), FactorStatus::Ok);
    const Vector b = Vector::Ones(12);
    Vector x(12);
    chol->solve(b.data(), x.data());
    EXPECT_LE((scale * c.dense * x - b).norm(), 1e-13);
  }
}

// Two one-forms at an angle: C = [[1, cos a], [cos a, 1]]; the second pivot is sin^2 a.
sparse::SymmetricPattern two_by_two() {
  sparse::SymmetricPattern p;
  p.size = 2;
  p.row_idx = {0, 1, 1};
  p.col_ptr = {0, 2, 3};
  return p;
}

TEST(Factorization, PivotRatioIsTheSquaredSineBetweenOneForms) {
  for (Backend backend : {Backend::BlockDiagonal, Backend::Dense, Backend::CholmodNatural, Backend::CholmodAmd}) {
    auto f = sparse::make_factorization(backend, two_by_two());
    const double angle = 1e-3;
    const double values[] = {1.0, std::cos(angle), 1.0};
    ASSERT_EQ(f->factorize(values, 1e-12), FactorStatus::Ok);
    EXPECT_NEAR(f->min_pivot_ratio(), std::pow(std::sin(angle), 2), 1e-12);
    // The same matrix refused when the tolerance is above sin^2.
    EXPECT_EQ(f->factorize(values, 1e-5), FactorStatus::NearlySingular);
    EXPECT_THAT(f->message(), HasSubstr("nearly dependent"));
  }
}

TEST(Factorization, DependentOneFormsAreReported) {
  for (Backend backend : {Backend::BlockDiagonal, Backend::Dense, Backend::CholmodNatural, Backend::CholmodAmd}) {
    auto f = sparse::make_factorization(backend, two_by_two());
    const double values[] = {1.0, 1.0, 1.0};  // identical rows
    const FactorStatus s = f->factorize(values, 1e-12);
    EXPECT_TRUE(s == FactorStatus::NotPositiveDefinite || s == FactorStatus::NearlySingular)
        << sparse::to_string(backend) << ": " << sparse::to_string(s);
    EXPECT_THAT(f->message(), HasSubstr("row 1 of C"));
    const double indefinite[] = {1.0, 2.0, 1.0};
    EXPECT_EQ(f->factorize(indefinite, 1e-12), FactorStatus::NotPositiveDefinite) << sparse::to_string(backend);
    const double nan_values[] = {1.0, NAN, 1.0};
    EXPECT_NE(f->factorize(nan_values, 1e-12), FactorStatus::Ok);
    const double vanishing[] = {0.0, 0.0, 1.0};
    EXPECT_EQ(f->factorize(vanishing, 1e-12), FactorStatus::NotPositiveDefinite);
    EXPECT_THAT(f->message(), HasSubstr("vanishes"));
  }
}

TEST(Factorization, BackendNamesAndAutomaticChoice) {
  EXPECT_EQ(sparse::backend_from_string("cholmod-amd"), Backend::CholmodAmd);
  EXPECT_EQ(sparse::backend_from_string("cholmod-natural"), Backend::CholmodNatural);
  EXPECT_EQ(sparse::backend_from_string("block-diagonal"), Backend::BlockDiagonal);
  EXPECT_EQ(sparse::backend_from_string("dense"), Backend::Dense);
  EXPECT_EQ(sparse::backend_from_string("auto"), Backend::Auto);
  try {
    sparse::backend_from_string("lapack");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(
        "unknown backend 'lapack' (valid: auto, block-diagonal, dense, banded, cholmod-natural, cholmod-amd)"));
  }
  EXPECT_EQ(sparse::resolve_backend(Backend::CholmodAmd, random_spd(1, 2).pattern), Backend::CholmodAmd);
}

}  // namespace
}  // namespace nonholo

// A band set up without a pattern (a chain's, filled row by row by its owner) refuses the
// pattern-based factorisations with a message, and a bandwidth beyond the banded path's limit.
namespace nonholo::sparse {
TEST(Factorization, ABandWithoutAPatternIsFilledByItsOwnerOnly) {
  BandedLdlt band(6, 2);
  EXPECT_EQ(band.bandwidth(), 2);
  const std::vector<double> c(6, 1.0);
  EXPECT_EQ(band.factorize(c.data(), 1e-12), FactorStatus::InvalidInput);
  EXPECT_NE(std::string(band.message()).find("without a pattern"), std::string::npos) << band.message();
  EXPECT_EQ(band.factorize_in_place(1e-12), FactorStatus::InvalidInput);
  // Filled by rows: C = tridiagonal(-1, 4, -1) within the band, solved against the product.
  band.begin_rows();
  for (int r = 0; r < 6; ++r) {
    double* a = band.row(r);
    a[0] = 0.0, a[1] = r > 0 ? -1.0 : 0.0, a[2] = 4.0;
    ASSERT_TRUE(band.eliminate_row(r, 1e-12));
  }
  ASSERT_EQ(band.finish_rows(1e-12), FactorStatus::Ok);
  const double x[6] = {1, -2, 3, 0.5, -1, 2};
  double b[6];
  for (int r = 0; r < 6; ++r) b[r] = 4 * x[r] - (r > 0 ? x[r - 1] : 0) - (r < 5 ? x[r + 1] : 0);
  double y[6];
  ASSERT_EQ(band.solve(b, y), FactorStatus::Ok);
  for (int r = 0; r < 6; ++r) EXPECT_NEAR(y[r], x[r], 1e-14);
  EXPECT_THROW(BandedLdlt(6, kBandedMaxBandwidth + 1), std::invalid_argument);
  EXPECT_THROW(BandedLdlt(-1, 2), std::invalid_argument);
}

// zero_bytes hands whole pages back to the kernel and writes only the ends: every byte reads zero
// afterwards, dirty or not, whatever the buffer's alignment and size, and nothing outside it is
// touched (the allocator's words around a buffer included).
TEST(BigBuffer, ZeroBytesZeroesExactlyTheBuffer) {
  for (const std::size_t bytes : {std::size_t{0}, std::size_t{1}, std::size_t{4095}, std::size_t{65536},
                                  std::size_t{3} << 20, (std::size_t{5} << 20) + 123}) {
    for (const std::size_t offset : {std::size_t{0}, std::size_t{8}, std::size_t{4093}}) {
      std::vector<unsigned char> memory(bytes + offset + 2 * 4096, 0xAB);
      unsigned char* data = memory.data() + 4096 + offset;
      zero_bytes(data, bytes);
      std::size_t wrong = 0;
      for (std::size_t i = 0; i < memory.size(); ++i) {
        const bool inside = &memory[i] >= data && &memory[i] < data + bytes;
        wrong += memory[i] != (inside ? 0 : 0xAB);
      }
      EXPECT_EQ(wrong, 0u) << bytes << " bytes at offset " << offset;
      // Written again after the pages went back: they read what was written.
      if (bytes > 0) {
        data[bytes / 2] = 7;
        EXPECT_EQ(data[bytes / 2], 7);
      }
    }
  }
  Eigen::VectorXd v = Eigen::VectorXd::Constant(1 << 20, 3.0);  // 8 MB, dirty
  zero_buffer(v, v.size());
  EXPECT_EQ(v.cwiseAbs().maxCoeff(), 0.0);
#if defined(__linux__)
  // Fresh memory with some pages written (resident) among untouched ones: both kinds of run.
  constexpr std::size_t kPage = 4096, kPages = 64;
  void* map = mmap(nullptr, kPages * kPage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(map, MAP_FAILED);
  auto* base = static_cast<unsigned char*>(map);
  for (const std::size_t page : {0, 1, 2, 3, 10, 20, 21, 22, 23, 40, 63}) std::memset(base + page * kPage, 0xAB, kPage);
  zero_bytes(base + 100, (kPages - 1) * kPage);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < kPages * kPage; ++i) {
    const bool inside = i >= 100 && i < 100 + (kPages - 1) * kPage;
    const bool written = i / kPage == 0 || i / kPage == 63;  // the pages the ends are on
    wrong += base[i] != (inside ? 0 : written ? 0xAB : 0);
  }
  EXPECT_EQ(wrong, 0u);
  munmap(map, kPages * kPage);
#endif
}

}  // namespace nonholo::sparse

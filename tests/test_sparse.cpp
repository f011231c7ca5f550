// The linear algebra behind C = mu M^-1 mu^T: the index-map assembly against a dense
// product, the dense and CHOLMOD factorisations against each other, and the pivot checks.
#include <nonholo/sparse/factorization.hpp>
#include <nonholo/sparse/gram_assembler.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/start.hpp>
#include <nonholo/workspace.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

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

TEST(Factorization, DenseAndCholmodAgreeOnRandomSpdMatrices) {
  for (int m : {1, 2, 3, 4, 5, 8, 13, 30}) {
    for (std::uint32_t seed = 1; seed <= 5; ++seed) {
      const RandomSpd c = random_spd(seed * 97 + static_cast<std::uint32_t>(m), m);
      auto dense = sparse::make_factorization(Backend::Dense, c.pattern);
      auto chol = sparse::make_factorization(Backend::Cholmod, c.pattern);
      ASSERT_EQ(dense->backend(), Backend::Dense);
      ASSERT_EQ(chol->backend(), Backend::Cholmod);
      ASSERT_EQ(dense->factorize(c.values.data(), 1e-12), FactorStatus::Ok) << dense->message();
      ASSERT_EQ(chol->factorize(c.values.data(), 1e-12), FactorStatus::Ok) << chol->message();
      EXPECT_NEAR(dense->min_pivot_ratio(), chol->min_pivot_ratio(), 1.0)
          << "both are ratios in (0, 1]";
      const Vector b = testing::random_vector(seed, m);
      Vector xd(m), xc(m);
      dense->solve(b.data(), xd.data());
      chol->solve(b.data(), xc.data());
      const Vector exact = c.dense.fullPivLu().solve(b);
      EXPECT_LE((xd - xc).norm(), 1e-12 * xd.norm()) << "m = " << m << " seed " << seed;
      EXPECT_LE((xd - exact).norm(), 1e-12 * exact.norm());
      // In-place solve (b and x alias).
      Vector inplace = b;
      chol->solve(inplace.data(), inplace.data());
      EXPECT_LE((inplace - xc).norm(), 1e-15 * xc.norm());
    }
  }
}

TEST(Factorization, DenseAndCholmodWorkspacesGiveTheSameTrajectory) {
  // Whole steps on random models with forces: the two paths differ only in how C is
  // factorised, so they must agree to round-off.
  for (std::uint32_t seed = 1; seed <= 6; ++seed) {
    testing::RandomModelOptions o;
    o.bodies = 6 + static_cast<int>(seed);
    o.rows = 2 + static_cast<int>(seed);
    o.applied_force = true;
    const Model model = testing::random_model(seed * 31, o);
    const int n = model.num_coordinates();
    Workspace dense(model, {Backend::Dense}), chol(model, {Backend::Cholmod});
    ASSERT_STREQ(dense.backend_name(), "dense");
    ASSERT_STREQ(chol.backend_name(), "cholmod");
    const Vector q0 = testing::random_vector(seed, n, 0.5), v0 = testing::random_vector(seed + 1, n);
    State a = start_from_velocity(model, dense, 0.0, q0, v0);
    State b = start_from_velocity(model, chol, 0.0, q0, v0);
    for (int k = 0; k < 100; ++k) {
      ASSERT_EQ(step(model, dense, a, {0.01}), Status::Ok) << dense.message();
      ASSERT_EQ(step(model, chol, b, {0.01}), Status::Ok) << chol.message();
    }
    EXPECT_LE((a.q - b.q).norm(), 1e-12 * a.q.norm()) << "seed " << seed;
    EXPECT_LE((a.p - b.p).norm(), 1e-12 * a.p.norm()) << "seed " << seed;
    EXPECT_LE((a.lambda - b.lambda).norm(), 1e-12 * a.lambda.norm()) << "seed " << seed;
  }
}

TEST(Factorization, RefactorisationReusesTheAnalysis) {
  const RandomSpd c = random_spd(7, 12);
  auto chol = sparse::make_factorization(Backend::Cholmod, c.pattern);
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
  for (Backend backend : {Backend::Dense, Backend::Cholmod}) {
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
  for (Backend backend : {Backend::Dense, Backend::Cholmod}) {
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
  EXPECT_EQ(sparse::backend_from_string("cholmod"), Backend::Cholmod);
  EXPECT_EQ(sparse::backend_from_string("dense"), Backend::Dense);
  EXPECT_EQ(sparse::backend_from_string("auto"), Backend::Auto);
  try {
    sparse::backend_from_string("lapack");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("unknown backend 'lapack' (valid: auto, dense, cholmod)"));
  }
  EXPECT_EQ(sparse::resolve_backend(Backend::Auto, random_spd(1, 8).pattern), Backend::Dense);
  EXPECT_EQ(sparse::resolve_backend(Backend::Auto, random_spd(1, 9).pattern), Backend::Cholmod);
  EXPECT_EQ(sparse::resolve_backend(Backend::Cholmod, random_spd(1, 2).pattern), Backend::Cholmod);
}

}  // namespace
}  // namespace nonholo

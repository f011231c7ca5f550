// The choice of factorisation by structure (docs/design.md section 3, "model only what a scene
// needs"): the structural facts it rests on, the choice each scene gets, clear refusals
// when a forced backend cannot serve, and agreement of all backends on the same step.
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/sparse/factorization.hpp>
#include <nonholo/sparse/structure.hpp>
#include <nonholo/start.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "support/scenes.hpp"
#include "support/expect_error.hpp"

namespace nonholo {
namespace {

using sparse::Backend;

// Lower-triangle pattern from a list of off-diagonal couplings (i > j) of an m x m matrix.
sparse::SymmetricPattern pattern_of(int m, const std::vector<std::pair<int, int>>& lower) {
  sparse::SymmetricPattern p;
  p.size = m;
  for (int j = 0; j < m; ++j) {
    p.row_idx.push_back(j);
    std::vector<int> rows;
    for (auto [i, jj] : lower)
      if (jj == j) rows.push_back(i);
    std::sort(rows.begin(), rows.end());
    p.row_idx.insert(p.row_idx.end(), rows.begin(), rows.end());
    p.col_ptr.push_back(p.nnz());
  }
  return p;
}

TEST(Structure, DiagonalBlocksAreTheConnectedComponents) {
  // 0-3, 3-5 and 1-4 coupled; 2 alone.
  const auto blocks = sparse::find_diagonal_blocks(pattern_of(6, {{3, 0}, {5, 3}, {4, 1}}));
  ASSERT_EQ(blocks.count(), 3);
  EXPECT_EQ(std::vector<int>(blocks.rows.begin(), blocks.rows.begin() + 3), (std::vector<int>{0, 3, 5}));
  EXPECT_EQ(blocks.size(1), 2);
  EXPECT_EQ(blocks.rows[3], 1);
  EXPECT_EQ(blocks.rows[4], 4);
  EXPECT_EQ(blocks.rows[5], 2);
  EXPECT_EQ(blocks.max_size(), 3);
}

TEST(Structure, NaturalEnvelopeMeasuresBandedness) {
  // Tridiagonal: envelope = nnz. Arrow (row 0 coupled to all): rows reach back to column 0.
  std::vector<std::pair<int, int>> tri, arrow, arrow8;
  for (int i = 1; i < 10; ++i) {
    tri.push_back({i, i - 1});
    arrow.push_back({i, 0});
    if (i < 8) arrow8.push_back({i, 0});
  }
  EXPECT_EQ(sparse::natural_envelope(pattern_of(10, tri)), 19);
  EXPECT_EQ(sparse::natural_envelope(pattern_of(10, arrow)), 10 + 45);
  EXPECT_EQ(sparse::resolve_backend(Backend::Auto, pattern_of(10, tri)), Backend::Banded);
  EXPECT_EQ(sparse::resolve_backend(Backend::Auto, pattern_of(10, arrow)), Backend::CholmodAmd);
  EXPECT_EQ(sparse::resolve_backend(Backend::Auto, pattern_of(8, arrow8)), Backend::Dense);
  EXPECT_EQ(sparse::resolve_backend(Backend::Auto, pattern_of(20, {})), Backend::BlockDiagonal);
  EXPECT_EQ(sparse::resolve_backend(Backend::CholmodAmd, pattern_of(20, {})), Backend::CholmodAmd);
}

TEST(Structure, MalformedPatternsAreRefused) {
  using testing::expect_error;
  // Row 9 of an 8 x 8 pattern: read past the end before the check existed.
  const auto out_of_range = pattern_of(8, {{9, 0}});
  expect_error([&] { sparse::natural_envelope(out_of_range); },
               "column 0: row 9 is out of range (size 8, rows 0 to 7)");
  expect_error([&] { sparse::find_diagonal_blocks(out_of_range); }, "row 9");
  expect_error([&] { sparse::resolve_backend(Backend::CholmodAmd, out_of_range); }, "row 9");
  expect_error([&] { sparse::natural_envelope(pattern_of(8, {{5, 0}, {5, 0}})); },
               "column 0: rows must increase, row 5 follows 5");
  auto no_diagonal = pattern_of(3, {});
  no_diagonal.row_idx[1] = 2;
  expect_error([&] { sparse::make_factorization(Backend::Auto, no_diagonal); },
               "symmetric pattern: column 1 is empty or does not start with its diagonal (row 1)");
  auto short_col_ptr = pattern_of(3, {});
  short_col_ptr.col_ptr.pop_back();
  expect_error([&] { sparse::natural_envelope(short_col_ptr); },
               "col_ptr must hold size + 1 = 4 offsets from 0 to nnz = 3");
}

using testing::scene;

TEST(BackendChoice, EachSceneGetsTheBackendItsStructureCallsFor) {
  struct Case {
    std::string scene;
    std::vector<std::string> sets;
    const char* expected;
  };
  const std::vector<Case> cases{
      {"particle", {}, "dense"},      // one row from a callback
      {"sleigh", {}, "banded"},       // a knife edge element: the fused step
      {"snakeboard", {}, "dense"},    // two rows on one body: one 2 x 2 block
      // Chains of elements are streamed whatever C's structure (docs/design.md section 7).
      {"sleigh_chain", {"bodies=3"}, "banded"},
      {"sleigh_chain", {"bodies=10"}, "banded"},
      {"sleigh_chain", {"bodies=1000"}, "banded"},
      {"sleigh_chain", {"bodies=1000", "hitched=0", "k=1"}, "banded"},  // C diagonal
      {"wheeled_train", {"bodies=200"}, "banded"},
  };
  for (const auto& c : cases) {
    const auto setup = scene(c.scene, c.sets);
    Workspace ws(setup.model);
    EXPECT_STREQ(ws.backend_name(), c.expected) << c.scene << " " << (c.sets.empty() ? "" : c.sets[0]);
  }
}

TEST(BackendChoice, AForcedBackendThatCannotServeIsRefusedClearly) {
  const auto chain = scene("sleigh_chain", {"bodies=10"});
  testing::expect_error([&] { Workspace ws(chain.model, {Backend::BlockDiagonal}); },
                        "backend block-diagonal: C has a coupled block of 28 one-forms");
  const auto big = scene("sleigh_chain", {"bodies=1000"});
  testing::expect_error([&] { Workspace ws(big.model, {Backend::Dense}); },
                        "backend dense: C has 2998 rows; the dense path stops at 2000");
}

// One step from the same state through every backend that can serve: the same numbers.
void expect_backends_agree(const std::string& name, const std::vector<std::string>& sets,
                           const std::vector<Backend>& backends) {
  const auto setup = scene(name, sets);
  const Model& model = setup.model;
  for (HitchMode hitch : {HitchMode::OneForm, HitchMode::Holonomic}) {
    RattleOptions o;
    o.hitch = hitch;
    Workspace ref_ws(model, {backends[0]});
    State start = start_from_velocity(model, ref_ws, 0.0, setup.q0, setup.v0);
    for (int k = 0; k < 20; ++k) ASSERT_EQ(step(model, ref_ws, start, o), Status::Ok);  // generic angles
    State ref = start;
    ASSERT_EQ(step(model, ref_ws, ref, o), Status::Ok);
    for (std::size_t b = 1; b < backends.size(); ++b) {
      Workspace ws(model, {backends[b]});
      State s = start;
      ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
      const double scale_p = ref.p.lpNorm<Eigen::Infinity>(), scale_l = ref.lambda.lpNorm<Eigen::Infinity>();
      EXPECT_LE((s.q - ref.q).lpNorm<Eigen::Infinity>(), 1e-10) << name << " " << ws.backend_name();
      EXPECT_LE((s.p - ref.p).lpNorm<Eigen::Infinity>(), 1e-10 * scale_p) << name << " " << ws.backend_name();
      EXPECT_LE((s.lambda - ref.lambda).lpNorm<Eigen::Infinity>(), 1e-10 * scale_l)
          << name << " " << ws.backend_name() << " hitch " << to_string(hitch);
    }
  }
}

TEST(BackendChoice, AllBackendsAgreeOnTheSameStep) {
  expect_backends_agree("sleigh_chain", {"bodies=10"},
                        {Backend::Dense, Backend::Banded, Backend::CholmodNatural, Backend::CholmodAmd});
  expect_backends_agree("wheeled_train", {"bodies=40"},
                        {Backend::Dense, Backend::Banded, Backend::CholmodNatural, Backend::CholmodAmd});
  expect_backends_agree("sleigh_chain", {"bodies=30", "hitched=0", "k=1"},
                        {Backend::Dense, Backend::BlockDiagonal, Backend::Banded, Backend::CholmodNatural, Backend::CholmodAmd});
  expect_backends_agree("snakeboard", {},
                        {Backend::Dense, Backend::BlockDiagonal, Backend::Banded, Backend::CholmodNatural, Backend::CholmodAmd});
}

}  // namespace
}  // namespace nonholo

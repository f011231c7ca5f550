// The library's contract with an embedding code (docs/guide/library.md): workspaces
// cannot be built from a temporary model; a step never throws, not even when a model callback
// does; a step checks its options; set-up errors are std::invalid_argument; a callback that
// fills too few values is caught at the start; times are t0 + k h, not sums.
#include <nonholo/dla.hpp>
#include <nonholo/implicit.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/restart.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "support/expect_error.hpp"

namespace nonholo {
namespace {

using ::testing::HasSubstr;

// `Workspace ws(b.build());` would keep a pointer to a destroyed model: it must not compile.
static_assert(std::is_constructible_v<Workspace, const Model&>);
static_assert(!std::is_constructible_v<Workspace, Model&&>);
static_assert(!std::is_constructible_v<Workspace, Model>);
static_assert(!std::is_constructible_v<Workspace, const Model&&>);
static_assert(!std::is_constructible_v<ImplicitWorkspace, Model&&>);

// A Chaplygin sleigh with a spring pulling its heading back: one-form values, a potential and
// its gradient, each of which can be told to throw after a number of calls or to under-fill.
struct Faults {
  long calls = 0, throw_after = -1;  // -1: never
  bool fill_too_few = false;
};

Model sleigh(Faults& f) {
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 0.5);
  b.add_one_form({0, 1, 2}, "the blade");
  b.one_form_values([&f](ConstVecRef q, VecRef mu) {
    if (f.throw_after >= 0 && ++f.calls > f.throw_after) throw std::runtime_error("user callback broke at q = (...)");
    mu[0] = -std::sin(q[2]);
    mu[1] = std::cos(q[2]);
    if (!f.fill_too_few) mu[2] = -0.3;
  });
  b.potential([](ConstVecRef q) { return 0.5 * q[2] * q[2]; },
              [](ConstVecRef q, VecRef g) { g << 0.0, 0.0, q[2]; });
  return b.build();
}

bool same(const State& a, const State& b) {
  return a.t == b.t && a.q == b.q && a.p == b.p && a.lambda == b.lambda && a.force == b.force &&
         a.steps == b.steps;
}

TEST(LibraryContract, CallbackExceptionsBecomeAStatusAndLeaveTheState) {
  Faults f;
  const Model model = sleigh(f);
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d(1, 0, 0.5));
  for (int order : {2, 4, 6}) {
    RattleOptions o{0.01};
    o.order = order;
    ASSERT_EQ(step(model, ws, s, o), Status::Ok);
    // Throw at the step's evaluation of mu (order 2), or in the middle of a composed step
    // (after 3 of its 10 or 18 substeps), when substeps have already moved the state.
    const State before = s;
    f.calls = 0;
    f.throw_after = order == 2 ? 0 : 3;
    Status status = Status::Ok;
    EXPECT_NO_THROW(status = step(model, ws, s, o));
    EXPECT_EQ(status, Status::CallbackFailed) << "order " << order;
    EXPECT_THAT(ws.message(), HasSubstr("user callback broke at q = (...)"));
    EXPECT_TRUE(same(s, before)) << "order " << order;
    f.throw_after = -1;
    EXPECT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();  // and it goes on
  }
  // The same for the DLA baseline and the public restart.
  f.throw_after = 0;
  f.calls = 0;
  DlaState d{s.t, {}, s.q, s.p};
  const DlaState dla_before = d;
  EXPECT_EQ(dla_step(model, ws, d, DlaOptions{}), Status::CallbackFailed);
  EXPECT_EQ(d.q, dla_before.q);
  f.calls = 0;
  EXPECT_EQ(restart(model, ws, s, RattleOptions{0.01}), Status::CallbackFailed);
}

TEST(LibraryContract, StepChecksItsOptions) {
  Faults f;
  const Model model = sleigh(f);
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d(1, 0, 0.5));
  const State before = s;
  RattleOptions o{0.01};
  o.max_gap_iterations = -1;  // would remove the bound on the position iteration
  EXPECT_EQ(step(model, ws, s, o), Status::InvalidOptions);
  EXPECT_THAT(ws.message(), HasSubstr("max_gap_iterations = -1 must be at least 1"));
  o = RattleOptions{0.01};
  o.restart.monitor_every = -2;
  EXPECT_EQ(step(model, ws, s, o), Status::InvalidOptions);
  EXPECT_THAT(ws.message(), HasSubstr("monitor_every = -2"));
  o = RattleOptions{0.01};
  o.min_pivot_ratio = 2.0;
  EXPECT_EQ(step(model, ws, s, o), Status::InvalidOptions);
  o = RattleOptions{0.01};
  o.order = 4;
  o.composition = Composition::KahanLi9;
  EXPECT_EQ(step(model, ws, s, o), Status::InvalidOptions);
  EXPECT_THAT(ws.message(), HasSubstr("does not match the composition"));
  EXPECT_TRUE(same(s, before));
  DlaState d{s.t, {}, s.q, s.p};
  DlaOptions dla;
  dla.max_newton_iterations = 0;
  EXPECT_EQ(dla_step(model, ws, d, dla), Status::InvalidOptions);
}

// step() skips its checks for the options it last found valid (Workspace::options_checked):
// after valid steps, a change of any one field to an invalid value is still refused.
TEST(LibraryContract, StepChecksEveryChangedOptionAfterValidSteps) {
  Faults f;
  const Model model = sleigh(f);
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d(1, 0, 0.5));
  const std::vector<std::pair<const char*, void (*)(RattleOptions&)>> bad{
      {"min_pivot_ratio", [](RattleOptions& o) { o.min_pivot_ratio = 2.0; }},
      {"gap_tolerance", [](RattleOptions& o) { o.gap_tolerance = -1.0; }},
      {"gap_tolerance_limit", [](RattleOptions& o) { o.gap_tolerance_limit = 0.0; }},
      {"max_gap_iterations", [](RattleOptions& o) { o.max_gap_iterations = 0; }},
      {"restart every", [](RattleOptions& o) { o.restart.mode = RestartMode::Periodic; }},
      {"restart every", [](RattleOptions& o) { o.restart.every = -1; }},
      {"restart tolerance", [](RattleOptions& o) { o.restart.tolerance = -1.0; }},
      {"monitor_every", [](RattleOptions& o) { o.restart.monitor_every = 0; }},
      {"order", [](RattleOptions& o) { o.order = 3; }},
      {"order", [](RattleOptions& o) { o.composition = Composition::KahanLi9; }},
  };
  for (const auto& [what, spoil] : bad) {
    RattleOptions o{0.01};
    ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
    ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
    const State before = s;
    spoil(o);
    EXPECT_EQ(step(model, ws, s, o), Status::InvalidOptions) << what;
    EXPECT_THAT(ws.message(), HasSubstr(what));
    EXPECT_TRUE(same(s, before)) << what;
  }
}

TEST(LibraryContract, UnderFilledCallbackIsNamedAtTheStart) {
  Faults f;
  f.fill_too_few = true;
  const Model model = sleigh(f);
  Workspace ws(model);
  testing::expect_error(
      [&] { start_from_velocity(model, ws, 0.0, Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d(1, 0, 0.5)); },
      "one_form_values left value 2 (one-form row 0 (the blade), column theta) unset or NaN at q0");
  testing::expect_error(
      [&] { start_from_two_points(model, ws, 0.0, Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d(0, 0, 0.4), 0.1); },
      "one_form_values left value 2");

  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 0.5);
  b.potential([](ConstVecRef q) { return q.squaredNorm(); }, [](ConstVecRef q, VecRef g) { g.head(2) = q.head(2); });
  const Model half_gradient = b.build();
  Workspace wh(half_gradient);
  testing::expect_error([&] { start_from_velocity(half_gradient, wh, 0.0, Vector::Zero(3), Vector::Zero(3)); },
                        "the potential gradient left entry 2 (theta) unset or NaN at q0");
}

TEST(LibraryContract, TimesAreOnTheGridNotSummed) {
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);  // a free body: the cheapest step
  const Model model = b.build();
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, Vector::Zero(3), Vector::Ones(3));
  double summed = 0.0;
  for (int k = 0; k < 100000; ++k) {
    ASSERT_EQ(step(model, ws, s, RattleOptions{0.1}), Status::Ok);
    summed += 0.1;
  }
  EXPECT_EQ(s.t, 10000.0);
  EXPECT_NE(summed, 10000.0);  // what accumulation gives (10000.000000018848)
  // A step of another size starts a new grid at the current time.
  ASSERT_EQ(step(model, ws, s, RattleOptions{0.25}), Status::Ok);
  ASSERT_EQ(step(model, ws, s, RattleOptions{0.25}), Status::Ok);
  EXPECT_EQ(s.t, 10000.5);
  // Composed steps too.
  RattleOptions o{0.1};
  o.order = 4;
  for (int k = 0; k < 1000; ++k) ASSERT_EQ(step(model, ws, s, o), Status::Ok);
  EXPECT_EQ(s.t, 10000.5 + 1000 * 0.1);
}

}  // namespace
}  // namespace nonholo

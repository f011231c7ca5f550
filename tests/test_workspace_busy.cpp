// One call at a time on a workspace (busy_flag.hpp): a model callback that steps, starts or
// diagnoses on the workspace running it, and a second thread, are refused (Status::WorkspaceBusy,
// or "workspace-busy:" from set-up calls) without touching the workspace, and the running step's
// result is that of a run without them. Before the flag both calls ran on the same buffers: the
// outer step returned Ok 1.7 off (Python, tests/python/test_core.py) and two threads ~190 off.
#include <nonholo/diagnostics.hpp>
#include <nonholo/dla.hpp>
#include <nonholo/dynamics.hpp>
#include <nonholo/implicit.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/reference/integrators.hpp>
#include <nonholo/restart.hpp>
#include <nonholo/stability.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include "support/expect_error.hpp"

namespace nonholo {
namespace {

using ::testing::HasSubstr;
using testing::expect_error;

// A sleigh with a spring on its heading and a driving force whose callback runs `inside` (when
// set) at every evaluation: the hook for re-entry and for holding a step open.
struct Hook {
  std::function<void()> inside;
};

Model hooked_sleigh(Hook& hook) {
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 0.5);
  b.add_one_form({0, 1, 2}, "the blade");
  b.one_form_values([](ConstVecRef q, VecRef mu) { mu << -std::sin(q[2]), std::cos(q[2]), -0.3; });
  b.potential([](ConstVecRef q) { return 0.5 * q[2] * q[2]; },
              [](ConstVecRef q, VecRef g) { g << 0.0, 0.0, q[2]; });
  b.external_force([&hook](double t, ConstVecRef q, VecRef f) {
    if (hook.inside) hook.inside();
    f << 0.2 * std::cos(q[2]), 0.2 * std::sin(q[2]), 0.1 * std::sin(t);
  });
  return b.build();
}

const Eigen::Vector3d kQ0(0.0, 0.0, 0.4), kV0(1.0, 0.0, 0.5);

// Every entry point on ws (with a state s of its model): the statuses they return and the texts
// of what they threw. None may succeed while another call holds the workspace.
struct Refusals {
  std::vector<Status> statuses;
  std::vector<std::string> errors;
};

Refusals call_everything(const Model& model, Workspace& ws, State& s) {
  Refusals r;
  const RattleOptions o{0.01};
  RattleOptions composed = o;
  composed.order = 4;
  double amplitude = 0.0;
  Vector scratch(3), lambda(1);
  DlaState d = dla_start(s, 0.01);
  r.statuses = {step(model, ws, s, o),
                step(model, ws, s, composed),
                restart(model, ws, s, o),
                parasitic_amplitude(model, ws, s, 0.01, amplitude),
                dla_step(model, ws, d, DlaOptions{}),
                one_form_bias(model, ws, s.q, s.p, lambda),
                constraint_bias(model, ws, s.q, s.p, lambda),
                project_momentum(model, ws, s.q, s.p, scratch, 0.0),
                constraint_multiplier(model, ws, s.t, s.q, s.p, lambda, 0.0)};
  const std::vector<std::function<void()>> throwing = {
      [&] { start_from_velocity(model, ws, 0.0, kQ0, kV0); },
      [&] { start_from_two_points(model, ws, 0.0, kQ0, kQ0, 0.01); },
      [&] { diagnose(model, ws, s, 0.01); },
      [&] { diagnose_step(model, ws, s, 0.01); },
      [&] { external_power(model, ws, s); },
      [&] { stiffest_frequency(model, ws, s.t, s.q); }};
  for (const auto& f : throwing) {
    try {
      f();
      r.errors.emplace_back("returned");
    } catch (const std::invalid_argument& e) {
      r.errors.emplace_back(e.what());
    }
  }
  return r;
}

void expect_all_refused(const Refusals& r) {
  for (std::size_t i = 0; i < r.statuses.size(); ++i)
    EXPECT_EQ(r.statuses[i], Status::WorkspaceBusy) << "call " << i << ": " << to_string(r.statuses[i]);
  for (const auto& e : r.errors) EXPECT_THAT(e, ::testing::StartsWith("workspace-busy: ")) << e;
}

bool same(const State& a, const State& b) {
  return a.t == b.t && a.q == b.q && a.p == b.p && a.lambda == b.lambda && a.force == b.force && a.steps == b.steps;
}

TEST(WorkspaceBusy, HeldFlagRefusesEveryEntryPointWithoutWritingTheWorkspace) {
  Hook hook;
  const Model model = hooked_sleigh(hook);
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, kQ0, kV0);
  ASSERT_EQ(step(model, ws, s, RattleOptions{-1.0}), Status::InvalidStepSize);
  const std::string message = ws.message();
  const State before = s;
  {
    const BusyEntry held(ws.busy_flag());
    ASSERT_TRUE(held.held());
    expect_all_refused(call_everything(model, ws, s));
  }
  EXPECT_EQ(ws.message(), message);  // the refused calls wrote nothing
  EXPECT_TRUE(same(s, before));
  // Every exit path gave the flag back: a failed step, a throwing start, a step whose callback threw.
  EXPECT_EQ(step(model, ws, s, RattleOptions{-1.0}), Status::InvalidStepSize);
  expect_error([&] { start_from_velocity(model, ws, 0.0, Eigen::Vector2d(0, 0), kV0); }, "q0");
  hook.inside = [] { throw std::runtime_error("callback broke"); };
  EXPECT_EQ(step(model, ws, s, RattleOptions{0.01}), Status::CallbackFailed);
  hook.inside = nullptr;
  EXPECT_EQ(step(model, ws, s, RattleOptions{0.01}), Status::Ok) << ws.message();
}

TEST(WorkspaceBusy, CallbackReenteringItsWorkspaceIsRefusedAndTheStepUnaffected) {
  for (int order : {2, 4}) {
    Hook hook;
    const Model model = hooked_sleigh(hook);
    Workspace ws(model), plain_ws(model);
    State s = start_from_velocity(model, ws, 0.0, kQ0, kV0), plain = s;
    State other = start_from_velocity(model, plain_ws, 0.0, Eigen::Vector3d(3, 2, 1), Eigen::Vector3d(-5, 4, 9));
    RattleOptions o{0.01};
    o.order = order;
    long reentries = 0;
    hook.inside = [&] {
      expect_all_refused(call_everything(model, ws, other));
      ++reentries;
    };
    for (int k = 0; k < 50; ++k) ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
    hook.inside = nullptr;
    for (int k = 0; k < 50; ++k) ASSERT_EQ(step(model, plain_ws, plain, o), Status::Ok);
    EXPECT_GE(reentries, 50);  // once a plain step, once a substep
    EXPECT_TRUE(same(s, plain)) << "order " << order << ": |q - q_plain| = " << (s.q - plain.q).norm();
  }
}

TEST(WorkspaceBusy, ABusyErrorEscapingTheCallbackFailsTheStepAndLeavesTheState) {
  Hook hook;
  const Model model = hooked_sleigh(hook);
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, kQ0, kV0);
  const State before = s;
  hook.inside = [&] { start_from_velocity(model, ws, 0.0, kQ0, kV0); };
  EXPECT_EQ(step(model, ws, s, RattleOptions{0.01}), Status::CallbackFailed);
  EXPECT_THAT(ws.message(), HasSubstr("workspace-busy: start_from_velocity"));
  EXPECT_TRUE(same(s, before));
}

TEST(WorkspaceBusy, ASecondThreadIsRefusedWhileAStepRuns) {
  // The step holds still inside its callback while the main thread tries the workspace.
  Hook hook;
  const Model model = hooked_sleigh(hook);
  Workspace ws(model), plain_ws(model);
  State s = start_from_velocity(model, ws, 0.0, kQ0, kV0), plain = s;
  State other = start_from_velocity(model, plain_ws, 0.0, kQ0, kV0);
  std::promise<void> inside, go;
  std::shared_future<void> released = go.get_future().share();
  bool first = true;
  hook.inside = [&] {
    if (!first) return;
    first = false;
    inside.set_value();
    released.wait();
  };
  auto worker = std::async(std::launch::async, [&] { return step(model, ws, s, RattleOptions{0.01}); });
  inside.get_future().wait();
  expect_all_refused(call_everything(model, ws, other));
  go.set_value();
  EXPECT_EQ(worker.get(), Status::Ok) << ws.message();
  hook.inside = nullptr;
  ASSERT_EQ(step(model, plain_ws, plain, RattleOptions{0.01}), Status::Ok);
  EXPECT_TRUE(same(s, plain));
  EXPECT_EQ(step(model, ws, other, RattleOptions{0.01}), Status::Ok) << ws.message();  // free again
}

TEST(WorkspaceBusy, ImplicitAndReferenceIntegratorsRefuseReentry) {
  Hook hook;
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  b.configuration_metric([](ConstVecRef, MatRef m) { m = Eigen::Vector3d(1.0, 1.0, 1.0).asDiagonal(); },
                         [](ConstVecRef, int, MatRef dm) { dm.setZero(); });
  b.add_one_form({0, 1, 2});
  b.one_form_values([&hook](ConstVecRef q, VecRef mu) {
    if (hook.inside) hook.inside();
    mu << std::sin(q[2]), -std::cos(q[2]), 0.2;
  });
  const Model model = b.build();
  ImplicitOptions o;
  ImplicitWorkspace ws(model);
  ImplicitState s = implicit_start(model, ws, 0.0, kQ0, kV0, o);
  ImplicitState other = s;
  std::vector<Status> inner;
  std::string start_error;
  hook.inside = [&] {
    inner.push_back(implicit_step(model, ws, other, o));
    try {
      implicit_start(model, ws, 0.0, kQ0, kV0, o);
    } catch (const std::invalid_argument& e) {
      start_error = e.what();
    }
  };
  EXPECT_EQ(implicit_step(model, ws, s, o), Status::Ok) << ws.message();
  ASSERT_FALSE(inner.empty());
  for (Status st : inner) EXPECT_EQ(st, Status::WorkspaceBusy);
  EXPECT_THAT(start_error, ::testing::StartsWith("workspace-busy: implicit_start"));
  hook.inside = nullptr;

  // The reference integrator (a constant metric of its own: the explicit model).
  Hook ref_hook;
  const Model sleigh = hooked_sleigh(ref_hook);
  reference::Integrator rk4(sleigh, reference::Method::Rk4, {}, 0.0, kQ0, Eigen::Vector3d(0, 0, 0));
  std::vector<Status> nested;
  ref_hook.inside = [&] { nested.push_back(rk4.advance_to(1.0)); };
  EXPECT_EQ(rk4.advance_to(0.1), Status::Ok) << rk4.message();
  ASSERT_FALSE(nested.empty());
  for (Status st : nested) EXPECT_EQ(st, Status::WorkspaceBusy);
}

}  // namespace
}  // namespace nonholo

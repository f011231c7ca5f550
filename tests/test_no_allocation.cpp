// No allocation inside a step, for every backend: the process's malloc is counted while
// steps (and the per-step diagnostics the command line uses) run.
#include <nonholo/accuracy.hpp>
#include <nonholo/adaptive.hpp>
#include <nonholo/diagnostics.hpp>
#include <nonholo/dla.hpp>
#include <nonholo/implicit.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "support/counting_malloc.hpp"
#include "support/random_model.hpp"
#include "support/scenes.hpp"

namespace nonholo {
namespace {

using sparse::Backend;

long allocations_in_steps(const Model& model, Backend backend, const Vector& q0, const Vector& v0,
                          const RattleOptions& options = {}) {
  Workspace ws(model, {backend});
  State s = start_from_velocity(model, ws, 0.0, q0, v0);
  Vector maps(model.momentum_maps().size());
  EXPECT_EQ(step(model, ws, s, options), Status::Ok) << ws.message();  // warm-up outside the count
  testing::start_counting_allocations();
  double sink = 0.0;
  for (int k = 0; k < 200; ++k) {
    if (step(model, ws, s, options) != Status::Ok) break;
    sink += diagnose(model, ws, s, options.h).energy_post;
    evaluate_momentum_maps(model, s, maps);
  }
  const long count = testing::stop_counting_allocations();
  EXPECT_TRUE(std::isfinite(sink));
  EXPECT_NEAR(s.t, 2.01, 1e-9) << "all steps ran";
  return count;
}

// The accuracy check's shadow steps (sampled step doubling) allocate nothing either, at order 2
// and 4 (a chain in holonomic mode: the shadow's gap iteration and factorisation run too).
TEST(NoAllocation, AccuracyWatch) {
  const auto& info = scenarios::find_scene("sleigh_chain");
  const auto setup = info.build(info.defaults());
  for (int order : {2, 4}) {
    RattleOptions o;
    o.order = order;
    Workspace ws(setup.model);
    State s = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
    AccuracyWatch watch(ws, o, 8);  // on the run's workspace, as nonholo run
    for (int k = 0; k < 4; ++k) {  // warm-up outside the count: the first samples
      watch.before_step(s);
      ASSERT_EQ(step(setup.model, ws, s, o), Status::Ok) << ws.message();
      watch.after_step(s);
    }
    testing::start_counting_allocations();
    for (int k = 0; k < 100; ++k) {
      watch.before_step(s);
      if (step(setup.model, ws, s, o) != Status::Ok) break;
      watch.after_step(s);
    }
    EXPECT_EQ(testing::stop_counting_allocations(), 0) << "order " << order;
    EXPECT_GT(watch.estimate().samples(), 10);
    EXPECT_TRUE(std::isfinite(watch.estimate().estimate()));
  }
}

// Adaptive composed steps: the pair, its shadow step, the rejections (the state restored by copy) and the
// retries allocate nothing (order 6, a chain in both hitch modes, a tolerance that rejects).
// A whole run of `nonholo run` with the accuracy check's companion (its steps, the comparison
// every two steps, the sampled check beside it) allocates the same for 200 steps as for 100:
// nothing per step (set-up, the summary and its messages allocate once).
TEST(NoAllocation, TheRunWithItsCompanion) {
  for (const char* tol : {"", "1e-6"}) {
    auto count = [tol](double t_end) {
      scenarios::RunConfig c;
      c.scene = "sleigh_chain";
      c.t_end = t_end;
      c.accuracy_check = "companion";
      if (*tol) {
        c.adaptive = true;
        c.tol = std::stod(tol);
        c.order = 4;
      }
      testing::start_counting_allocations();
      const scenarios::RunSummary r = scenarios::run_scene(c);
      const long n = testing::stop_counting_allocations();
      EXPECT_EQ(r.status, Status::Ok) << r.message;
      EXPECT_EQ(r.accuracy_check, "companion");
      return n;
    };
    count(0.5);  // what is made once per process
    EXPECT_EQ(count(2.0), count(1.0)) << (*tol ? "adaptive" : "fixed steps");
  }
}

TEST(NoAllocation, AdaptiveStepper) {
  const auto& info = scenarios::find_scene("sleigh_chain");
  const auto setup = info.build(info.defaults());
  for (HitchMode hitch : {HitchMode::OneForm, HitchMode::Holonomic}) {
    RattleOptions o;
    o.order = 6;
    o.hitch = hitch;
    AdaptiveOptions a;
    a.tol = 1e-9;
    a.h_initial = 0.2;
    AdaptiveStepper stepper(setup.model, o, a);
    Workspace ws(setup.model, {Backend::Auto, true});
    State s = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
    ASSERT_EQ(stepper.step(setup.model, ws, s, 100.0), Status::Ok) << ws.message();  // warm-up
    testing::start_counting_allocations();
    for (int k = 0; k < 40; ++k)
      if (stepper.step(setup.model, ws, s, 100.0) != Status::Ok) break;
    EXPECT_EQ(testing::stop_counting_allocations(), 0) << to_string(hitch);
    EXPECT_GT(stepper.rejected(), 0) << "the count must include rejections";
    EXPECT_EQ(stepper.accepted(), 82);  // two steps a pair
  }
}

TEST(NoAllocation, CounterSeesAllocations) {
  // Through volatile pointers: the compiler may not elide these (it may elide new/delete).
  void* (*volatile allocate)(std::size_t) = std::malloc;
  void (*volatile release)(void*) = std::free;
  testing::start_counting_allocations();
  release(allocate(100));
  Vector grown(3);
  grown.resize(1000);  // Eigen's allocator
  EXPECT_GE(testing::stop_counting_allocations(), 2) << "the counter must be able to fail the tests below";
}

// Every scene on every backend that can serve it (block-diagonal only where C is), both
// hitch modes, and every restart policy (a restart at every step included).
TEST(NoAllocation, ScenesOnEveryBackend) {
  struct Case {
    std::string scene;
    std::vector<std::string> sets;
  };
  const std::vector<Case> cases{
      {"particle", {}},
      {"sleigh", {}},
      {"snakeboard", {"u_psi_amp=0.1", "u_phi_amp=0.1"}},  // forces too
      {"sleigh_chain", {"bodies=12"}},
      {"sleigh_chain", {"bodies=12", "hitched=0", "k=1"}},  // C diagonal
      {"wheeled_train", {"bodies=12"}},
      // 3-D rigid bodies: the Legendre transforms' Newton iterations, closed forms, rods, gravity.
      {"suslov", {}},
      {"veselova", {}},
      {"chaplygin_ball", {}},  // momentum maps from generators (their thread_local buffer)
      {"ball_chain", {"bodies=4"}},
      {"ball_chain", {"bodies=2", "I1=0.4", "I2=0.4", "I3=0.4"}},  // isotropic: closed form
      {"rolling_disk", {}},
  };  // sleigh_contact: see ImplicitGeneralForm
  ASSERT_EQ(scenarios::scene_catalogue().size(), 11u) << "a new scene needs a case here";
  for (const auto& c : cases) {
    const auto& info = scenarios::find_scene(c.scene);
    scenarios::Parameters p = info.defaults();
    for (const auto& a : c.sets) p.assign(a);
    const auto setup = info.build(p);
    int served = 0;
    for (Backend backend : {Backend::BlockDiagonal, Backend::Dense, Backend::Banded, Backend::CholmodNatural,
                             Backend::CholmodAmd})
      for (HitchMode hitch : {HitchMode::OneForm, HitchMode::Holonomic}) {
        if (hitch == HitchMode::OneForm && setup.model.num_holonomic() == 0) continue;
        if (backend == Backend::BlockDiagonal &&
            sparse::resolve_backend(Backend::Auto, setup.model.gram().pattern()) != Backend::BlockDiagonal)
          continue;  // C is coupled: the block-diagonal path refuses it (tested in test_backends)
        ++served;
        for (const char* restart : {"auto", "7", "0", "every step", "order 4", "order 6", "order 6, 3"}) {
          RattleOptions options;
          options.hitch = hitch;
          if (std::string(restart).rfind("order", 0) == 0) {  // composed steps (composition.hpp)
            options.order = restart[6] - '0';
            set_restart(options.restart, std::string(restart).size() > 7 ? "3" : "auto");
          } else if (std::string(restart) == "every step") {
            options.restart.tolerance = 1e-300;  // auto, measuring and restarting at every step
            options.restart.monitor_every = 1;
          } else {
            set_restart(options.restart, restart);
          }
          EXPECT_EQ(allocations_in_steps(setup.model, backend, setup.q0, setup.v0, options), 0)
              << c.scene << " " << (c.sets.empty() ? "" : c.sets.back()) << " on " << sparse::to_string(backend)
              << ", hitch " << to_string(hitch) << ", restart " << restart;
        }
      }
    EXPECT_GE(served, 3) << c.scene;
  }
}

// sleigh_contact (configuration metric): the implicit general form.
TEST(NoAllocation, ImplicitGeneralForm) {
  const auto& info = scenarios::find_scene("sleigh_contact");
  const auto setup = info.build(info.defaults());
  for (const char* restart : {"auto", "0", "every step"}) {
    ImplicitWorkspace ws(setup.model);
    ImplicitOptions o;
    if (std::string(restart) == "every step") {
      o.restart.tolerance = 1e-300;  // measured and restarted at every step
      o.restart.monitor_every = 1;
    } else {
      set_restart(o.restart, restart);
    }
    ImplicitState s = implicit_start(setup.model, ws, 0.0, setup.q0, setup.v0, o);
    ASSERT_EQ(implicit_step(setup.model, ws, s, o), Status::Ok);
    testing::start_counting_allocations();
    for (int k = 0; k < 200; ++k)
      if (implicit_step(setup.model, ws, s, o) != Status::Ok) break;
    EXPECT_EQ(testing::stop_counting_allocations(), 0) << restart;
    EXPECT_NEAR(s.t, 2.01, 1e-9) << "all steps ran";
    if (std::string(restart) == "every step") {
      EXPECT_EQ(s.restarts, 201);
    }
  }
}

// The DLA baseline (both constraint discretisations).
TEST(NoAllocation, DlaBaseline) {
  const auto& info = scenarios::find_scene("sleigh_chain");
  const auto setup = info.build(info.defaults());
  for (DlaConstraint c : {DlaConstraint::Midpoint, DlaConstraint::Left}) {
    Workspace ws(setup.model);
    DlaOptions o;
    o.constraint = c;
    DlaState s = dla_start(start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0), o.h);
    ASSERT_EQ(dla_step(setup.model, ws, s, o), Status::Ok);
    testing::start_counting_allocations();
    for (int k = 0; k < 200; ++k)
      if (dla_step(setup.model, ws, s, o) != Status::Ok) break;
    EXPECT_EQ(testing::stop_counting_allocations(), 0) << to_string(c);
    EXPECT_NEAR(s.t, 2.01, 1e-9) << "all steps ran";
  }
}

TEST(NoAllocation, LargerModelWithForcesOnEveryBackend) {
  testing::RandomModelOptions o;
  o.bodies = 20;
  o.rows = 18;
  o.applied_force = true;
  const Model model = testing::random_model(17, o);
  const int n = model.num_coordinates();
  for (Backend backend : {Backend::Dense, Backend::CholmodNatural, Backend::CholmodAmd})
    EXPECT_EQ(allocations_in_steps(model, backend, testing::random_vector(1, n, 0.3),
                                   testing::random_vector(2, n)),
              0)
        << sparse::to_string(backend);
}

// A chain split over threads (WorkspaceOptions::threads): its workers allocate nothing either,
// once the thread pool has started (the first steps), with the mode measured and restarted, in
// both hitch modes (holonomic: the corrections' passes on the threads too).
TEST(NoAllocation, ChainOnThreads) {
  const auto setup = testing::scene("sleigh_chain", {"bodies=60", "k=2"});
  for (HitchMode mode : {HitchMode::OneForm, HitchMode::Holonomic}) {
    WorkspaceOptions threads;
    threads.threads = 3;
    Workspace ws(setup.model, threads);
    ASSERT_EQ(ws.threads(), 3);
    State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
    RattleOptions o;
    o.hitch = mode;
    o.restart.mode = RestartMode::Periodic;
    o.restart.every = 5;
    for (int k = 0; k < 3; ++k) ASSERT_EQ(step(setup.model, ws, s, o), Status::Ok) << ws.message();
    testing::start_counting_allocations();
    for (int k = 0; k < 200; ++k)
      if (step(setup.model, ws, s, o) != Status::Ok) break;
    EXPECT_EQ(testing::stop_counting_allocations(), 0) << to_string(mode);
    EXPECT_EQ(s.steps, 203) << ws.message();
  }
}

}  // namespace
}  // namespace nonholo

// No allocation inside a step, for every backend: the process's malloc is counted while
// steps (and the per-step diagnostics the command line uses) run.
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include "support/counting_malloc.hpp"
#include "support/random_model.hpp"

namespace nonholo {
namespace {

using sparse::Backend;

long allocations_in_steps(const Model& model, Backend backend, const Vector& q0, const Vector& v0) {
  Workspace ws(model, {backend});
  State s = start_from_velocity(model, ws, 0.0, q0, v0);
  Vector maps(model.momentum_maps().size());
  const RattleOptions options{0.01};
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

TEST(NoAllocation, ScenesOnEveryBackend) {
  for (const auto& info : scenarios::scene_catalogue()) {
    std::vector<std::string> sets;
    if (info.name == "snakeboard") sets = {"u_psi_amp=0.1", "u_phi_amp=0.1"};  // forces too
    scenarios::Parameters p = info.defaults();
    for (const auto& a : sets) p.assign(a);
    const auto setup = info.build(p);
    for (Backend backend : {Backend::Dense, Backend::Cholmod})
      EXPECT_EQ(allocations_in_steps(setup.model, backend, setup.q0, setup.v0), 0)
          << info.name << " on " << sparse::to_string(backend);
  }
}

TEST(NoAllocation, LargerModelWithForcesOnEveryBackend) {
  testing::RandomModelOptions o;
  o.bodies = 20;
  o.rows = 18;
  o.applied_force = true;
  const Model model = testing::random_model(17, o);
  const int n = model.num_coordinates();
  for (Backend backend : {Backend::Dense, Backend::Cholmod})
    EXPECT_EQ(allocations_in_steps(model, backend, testing::random_vector(1, n, 0.3),
                                   testing::random_vector(2, n)),
              0)
        << sparse::to_string(backend);
}

}  // namespace
}  // namespace nonholo

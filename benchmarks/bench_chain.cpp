// Scaling of the chain step (docs/design.md section 7, issues 3 and 12): ns per body-step of
// sleigh_chain at N = 10^3 .. 10^6 in both hitch modes on the fused banded sweep (the default
// for a chain of elements) and on the general path forced through CHOLMOD, and, on the same C
// (assembled at the same state), CHOLMOD factor+solve alone, the banded LDL^T's factor+solve
// alone and LAPACK dpbtrf+dpbtrs. Also the spring-coupled chain without hitches (C diagonal)
// on the fused sweep, through the block-diagonal path and forced through CHOLMOD. tools/scaling.py runs this binary and turns the JSON into the
// docs/results/scaling.md's table, ratios and plot; every benchmark reports its N as the counter `bodies`.
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/sparse/factorization.hpp>
#include <nonholo/start.hpp>

#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

extern "C" {
void dpbtrf_(const char* uplo, const int* n, const int* kd, double* ab, const int* ldab, int* info,
             std::size_t uplo_len);
void dpbtrs_(const char* uplo, const int* n, const int* kd, const int* nrhs, const double* ab,
             const int* ldab, double* b, const int* ldb, int* info, std::size_t uplo_len);
}

namespace {

using namespace nonholo;
using sparse::Backend;

// A chain after some steps (generic angles), kept across the benchmark's repeated calls:
// building a million-body model takes seconds. The fused chains take 40 steps first, past the
// start's transient: at 10^6 bodies the automatic restarts learn the round-off floor of the
// period-2 mode's measurement there (docs/guide/methods.md "Restarts"), a cost a long run pays once. The
// chains forced through CHOLMOD (the "before", a second a step at 10^6) take 5.
struct Chain {
  scenarios::SceneSetup setup;
  Workspace ws;
  State state;
  RattleOptions options;
  Vector rhs;       // a right-hand side for the factor+solve benchmarks
  Vector c_values;  // C at the state, in its pattern's order

  Chain(long bodies, bool hitched, Backend backend, HitchMode mode, int threads = 1)
      : setup(build(bodies, hitched)), ws(setup.model, workspace_options(backend, threads)),
        state(start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0)) {
    options.hitch = mode;
    const int warm_up = backend == Backend::Auto ? 40 : 5;
    for (int k = 0; k < warm_up; ++k) step(setup.model, ws, state, options);
    ws.evaluate_one_forms(state.q);
    c_values.resize(setup.model.gram().pattern().nnz());
    setup.model.gram().assemble(ws.mu_values.data(), c_values.data());
    rhs = Vector::LinSpaced(setup.model.num_one_forms(), -1.0, 1.0);
  }
  static WorkspaceOptions workspace_options(Backend backend, int threads) {
    WorkspaceOptions o;
    o.backend = backend;
    o.threads = threads;
    return o;
  }
  static scenarios::SceneSetup build(long bodies, bool hitched) {
    const auto& info = scenarios::find_scene("sleigh_chain");
    auto p = info.defaults();
    p.set("bodies", static_cast<double>(bodies));
    p.set("hitched", hitched ? 1.0 : 0.0);
    if (!hitched) p.set("k", 1.0);
    return info.build(p);
  }
};

Chain& chain(long bodies, bool hitched, Backend backend, HitchMode mode, int threads = 1) {
  static std::map<std::string, std::unique_ptr<Chain>> cache;
  const std::string key = std::to_string(bodies) + (hitched ? "h" : "s") + sparse::to_string(backend) +
                          to_string(mode) + "t" + std::to_string(threads);
  if (cache.count(key) == 0) {
    cache.clear();  // one chain alive at a time (a million bodies is ~1 GB with its factor)
    cache[key] = std::make_unique<Chain>(bodies, hitched, backend, mode, threads);
  }
  return *cache[key];
}

void report(benchmark::State& s, long bodies, const char* label) {
  s.counters["bodies"] = static_cast<double>(bodies);
  s.SetLabel(label);
}

void step_loop(benchmark::State& s, bool hitched, Backend backend, HitchMode mode) {
  const long n = s.range(0);
  Chain& c = chain(n, hitched, backend, mode);
  for (auto _ : s) {
    if (step(c.setup.model, c.ws, c.state, c.options) != Status::Ok) s.SkipWithError(c.ws.message());
    benchmark::DoNotOptimize(c.state.q.data());
  }
  report(s, n, c.ws.backend_name());
}

// The cost of controlling the period-2 mode (docs/guide/long-runs.md), one-form chain: the paper's
// plain method without measuring the mode (the bare step), the plain method measuring it
// (what --restart 0 does), the default (automatic restarts, measurement spaced by the
// predicted growth, at most 8 steps apart) and the default measuring at every step.
void restart_loop(benchmark::State& s, const char* restart, int monitor_every) {
  const long n = s.range(0);
  Chain& c = chain(n, true, Backend::Auto, HitchMode::OneForm);
  RattleOptions o = c.options;
  set_restart(o.restart, restart);
  o.restart.monitor_every = monitor_every;
  const long restarts = c.state.restarts;
  long measured = 0;
  for (auto _ : s) {
    if (step(c.setup.model, c.ws, c.state, o) != Status::Ok) s.SkipWithError(c.ws.message());
    measured += !std::isnan(c.ws.parasitic);
    benchmark::DoNotOptimize(c.state.q.data());
  }
  s.counters["restarts"] = static_cast<double>(c.state.restarts - restarts);
  s.counters["measured"] = benchmark::Counter(static_cast<double>(measured), benchmark::Counter::kAvgIterations);
  report(s, n, c.ws.backend_name());
}
void ChainStep_OneForm_Plain(benchmark::State& s) { restart_loop(s, "0", 0); }

// One chain on several threads (WorkspaceOptions::threads): the one-form step with the
// default options (the mode measured and restarts as they come) and the bare step, and the
// holonomic step (default options: its gap corrections on the threads too), for (bodies,
// threads). Compare threads = 1 and P in the same run (ratios, not times).
void threads_loop(benchmark::State& s, bool bare, HitchMode mode = HitchMode::OneForm) {
  const long n = s.range(0);
  const int threads = static_cast<int>(s.range(1));
  Chain& c = chain(n, true, Backend::Auto, mode, threads);
  RattleOptions o = c.options;
  if (bare) {
    set_restart(o.restart, "0");
    o.restart.monitor_every = 0;
  }
  for (auto _ : s) {
    if (step(c.setup.model, c.ws, c.state, o) != Status::Ok) s.SkipWithError(c.ws.message());
    benchmark::DoNotOptimize(c.state.q.data());
  }
  s.counters["threads"] = c.ws.threads();
  s.counters["ns_per_body"] = benchmark::Counter(static_cast<double>(n) * 1e-9,
                                                 benchmark::Counter::kIsIterationInvariantRate |
                                                     benchmark::Counter::kInvert);
  report(s, n, c.ws.backend_name());
}
void ChainStep_OneForm_Threads(benchmark::State& s) { threads_loop(s, false); }
void ChainStep_OneForm_Plain_Threads(benchmark::State& s) { threads_loop(s, true); }
void ChainStep_Holonomic_Threads(benchmark::State& s) { threads_loop(s, false, HitchMode::Holonomic); }
void ChainStep_OneForm_PlainMeasured(benchmark::State& s) { restart_loop(s, "0", 8); }
void ChainStep_OneForm_Auto(benchmark::State& s) { restart_loop(s, "auto", 8); }
void ChainStep_OneForm_AutoEveryStep(benchmark::State& s) { restart_loop(s, "auto", 1); }

void ChainStep_OneForm(benchmark::State& s) { step_loop(s, true, Backend::Auto, HitchMode::OneForm); }
void ChainStep_Holonomic(benchmark::State& s) { step_loop(s, true, Backend::Auto, HitchMode::Holonomic); }
// The same steps on the general path (separate passes around CHOLMOD): the "before".
void ChainStep_OneForm_Cholmod(benchmark::State& s) {
  step_loop(s, true, Backend::CholmodNatural, HitchMode::OneForm);
}
void ChainStep_Holonomic_Cholmod(benchmark::State& s) {
  step_loop(s, true, Backend::CholmodNatural, HitchMode::Holonomic);
}
void SpringChainStep(benchmark::State& s) { step_loop(s, false, Backend::Auto, HitchMode::OneForm); }
void SpringChainStep_BlockDiagonal(benchmark::State& s) {
  step_loop(s, false, Backend::BlockDiagonal, HitchMode::OneForm);
}
void SpringChainStep_Cholmod(benchmark::State& s) {
  step_loop(s, false, Backend::CholmodNatural, HitchMode::OneForm);
}

// CHOLMOD numeric factorisation + solve of the chain's C, values already assembled.
void ChainFactorSolve_Cholmod(benchmark::State& s) {
  const long n = s.range(0);
  Chain& c = chain(n, true, Backend::Auto, HitchMode::OneForm);
  auto f = sparse::make_factorization(Backend::CholmodNatural, c.setup.model.gram().pattern());
  Vector x(c.rhs.size());
  for (auto _ : s) {
    if (f->factorize(c.c_values.data(), 0.0) != sparse::FactorStatus::Ok) s.SkipWithError(f->message());
    f->solve(c.rhs.data(), x.data());
    benchmark::DoNotOptimize(x.data());
  }
  report(s, n, "cholmod-natural");
}

// The banded LDL^T alone (band filled from C's values, factorised, solved), the general path's
// use of the banded backend.
void ChainFactorSolve_Banded(benchmark::State& s) {
  const long n = s.range(0);
  Chain& c = chain(n, true, Backend::Auto, HitchMode::OneForm);
  auto f = sparse::make_factorization(Backend::Banded, c.setup.model.gram().pattern());
  Vector x(c.rhs.size());
  for (auto _ : s) {
    if (f->factorize(c.c_values.data(), 0.0) != sparse::FactorStatus::Ok) s.SkipWithError(f->message());
    f->solve(c.rhs.data(), x.data());
    benchmark::DoNotOptimize(x.data());
  }
  report(s, n, "banded");
}

// The banded floor: LAPACK dpbtrf + dpbtrs on the same C in band storage (lower, kd from the
// pattern). Each iteration writes the band from C's values, as any factorisation must.
void ChainFactorSolve_LapackBanded(benchmark::State& s) {
  const long n = s.range(0);
  Chain& c = chain(n, true, Backend::Auto, HitchMode::OneForm);
  const auto& pat = c.setup.model.gram().pattern();
  const int m = pat.size;
  int kd = 0;
  for (int j = 0; j < m; ++j)
    for (int t = pat.col_ptr[j]; t < pat.col_ptr[j + 1]; ++t) kd = std::max(kd, pat.row_idx[t] - j);
  const int ldab = kd + 1, one = 1;
  std::vector<int> band_pos(pat.nnz());
  for (int j = 0; j < m; ++j)
    for (int t = pat.col_ptr[j]; t < pat.col_ptr[j + 1]; ++t)
      band_pos[t] = (pat.row_idx[t] - j) + ldab * j;  // AB(1 + i - j, j), column-major
  std::vector<double> ab(static_cast<std::size_t>(ldab) * m), x(m);
  const double* cv = c.c_values.data();
  for (auto _ : s) {
    std::fill(ab.begin(), ab.end(), 0.0);
    for (int t = 0; t < pat.nnz(); ++t) ab[band_pos[t]] = cv[t];
    int info = 0;
    dpbtrf_("L", &m, &kd, ab.data(), &ldab, &info, 1);
    if (info != 0) s.SkipWithError("dpbtrf failed");
    std::copy(c.rhs.data(), c.rhs.data() + m, x.begin());
    dpbtrs_("L", &m, &kd, &one, ab.data(), &ldab, x.data(), &m, &info, 1);
    benchmark::DoNotOptimize(x.data());
  }
  report(s, n, ("lapack kd=" + std::to_string(kd)).c_str());
}

void sizes(benchmark::internal::Benchmark* b) {
  for (long n : {1000L, 10000L, 100000L}) b->Arg(n);
  b->Unit(benchmark::kMicrosecond)->UseRealTime();
}
// At 10^6 a fused step takes 0.1 s: 3 s of steps (some 25) spread the period-2 mode's
// measurement, every 8 steps, evenly over the repetitions.
void million(benchmark::internal::Benchmark* b) {
  b->Arg(1000000)->MinTime(3.0)->Unit(benchmark::kMicrosecond)->UseRealTime();
}

// On these shared machines the minimum over repetitions is the least disturbed estimate of
// a ratio of costs; run with --benchmark_repetitions=15 --benchmark_enable_random_interleaving.
void restart_sizes(benchmark::internal::Benchmark* b) {
  b->Arg(1000)->Arg(100000)->Unit(benchmark::kMicrosecond)->UseRealTime();
  b->ComputeStatistics("min", [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); });
}

// (bodies, threads): 1, 2, 4, ... up to the processors present, and their number.
void thread_sizes(benchmark::internal::Benchmark* b) {
  const int cores = omp_get_num_procs();
  for (long n : {100L, 300L, 1000L, 10000L, 100000L, 1000000L}) {  // from below the break-even
    for (int p = 1; p < cores; p *= 2) b->Args({n, p});
    b->Args({n, cores});
  }
  b->Unit(benchmark::kMicrosecond)->UseRealTime()->MinTime(0.5);
  b->ComputeStatistics("min", [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); });
}

BENCHMARK(ChainStep_OneForm_Threads)->Apply(thread_sizes);
BENCHMARK(ChainStep_OneForm_Plain_Threads)->Apply(thread_sizes);
BENCHMARK(ChainStep_Holonomic_Threads)->Apply(thread_sizes);
BENCHMARK(ChainStep_OneForm)->Apply(sizes);
BENCHMARK(ChainStep_OneForm)->Apply(million);
BENCHMARK(ChainStep_OneForm_Plain)->Apply(restart_sizes);
BENCHMARK(ChainStep_OneForm_PlainMeasured)->Apply(restart_sizes);
BENCHMARK(ChainStep_OneForm_Auto)->Apply(restart_sizes);
BENCHMARK(ChainStep_OneForm_AutoEveryStep)->Apply(restart_sizes);
BENCHMARK(ChainStep_Holonomic)->Apply(sizes);
BENCHMARK(ChainStep_Holonomic)->Apply(million);
BENCHMARK(ChainStep_OneForm_Cholmod)->Apply(sizes);
BENCHMARK(ChainStep_OneForm_Cholmod)->Apply(million);
BENCHMARK(ChainStep_Holonomic_Cholmod)->Apply(sizes);
BENCHMARK(ChainStep_Holonomic_Cholmod)->Apply(million);
BENCHMARK(ChainFactorSolve_Cholmod)->Apply(sizes);
BENCHMARK(ChainFactorSolve_Cholmod)->Apply(million);
BENCHMARK(ChainFactorSolve_Banded)->Apply(sizes);
BENCHMARK(ChainFactorSolve_Banded)->Apply(million);
BENCHMARK(ChainFactorSolve_LapackBanded)->Apply(sizes);
BENCHMARK(ChainFactorSolve_LapackBanded)->Apply(million);
BENCHMARK(SpringChainStep)->Apply(sizes);
BENCHMARK(SpringChainStep)->Apply(million);
BENCHMARK(SpringChainStep_BlockDiagonal)->Apply(sizes);
BENCHMARK(SpringChainStep_BlockDiagonal)->Apply(million);
BENCHMARK(SpringChainStep_Cholmod)->Apply(sizes);
BENCHMARK(SpringChainStep_Cholmod)->Apply(million);

}  // namespace

BENCHMARK_MAIN();

// MPI ensembles (ensemble_for, nonholo/mpi_ensemble.hpp) on two ranks of one thread each:
//   mpirun -n 2 build/benchmarks/bench_ensemble      (as root: --allow-run-as-root)
// Rank 0 prints.
//
// Scaling, as bench_batch does for threads: in alternation within one run, the ensemble on a
// communicator of rank 0 alone and on both ranks, and a compute-only loop of the same
// granularity on one rank and on two (rank 1 sleeps while rank 0 works alone), and reports
//   speedup          ensemble time on 1 rank / on 2 ranks (the gather included)
//   machine_speedup  the same for the compute-only loop (what this shared machine gives now)
//   fraction         speedup / machine_speedup
// Load balance: trajectories of sleigh_chain with 1 to 50 bodies, set up and integrated as
// `nonholo batch` does (their costs measured one by one: about 1 to 100x), on 2 ranks with the
// static and the dynamic schedule, in random order and as a sweep whose cost grows with the
// index; `ideal` is half the serial sum of the costs, `halves` what the static split gives each
// rank by those costs.
#include <nonholo/batch.hpp>
#include <nonholo/mpi_ensemble.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace nonholo;
using Clock = std::chrono::steady_clock;

int rank_of(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

// A barrier whose waiting rank sleeps instead of spinning (OpenMPI's blocking calls spin): a
// rank waiting while the other works alone must not take a core from it.
void quiet_barrier() {
  MPI_Request request;
  MPI_Ibarrier(MPI_COMM_WORLD, &request);
  for (int done = 0;;) {
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
}

// Seconds from both ranks starting f together to both having finished it.
double timed(const std::function<void()>& f) {
  quiet_barrier();
  const auto start = Clock::now();
  f();
  quiet_barrier();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

scenarios::SceneSetup chain(int bodies) {
  const auto& info = scenarios::find_scene("sleigh_chain");
  auto p = info.defaults();
  p.set("bodies", bodies);
  return info.build(p);
}

// One trajectory: set up (model, workspace, start) and `steps` steps, as `nonholo batch` does
// per trajectory; the final configuration as bytes.
std::string trajectory(int bodies, double turn, long steps) {
  const scenarios::SceneSetup s = chain(bodies);
  Workspace ws(s.model);
  Vector v0 = s.v0;
  v0[2] = turn;
  State st = start_from_velocity(s.model, ws, 0.0, s.q0, v0);
  for (long k = 0; k < steps; ++k) step(s.model, ws, st, RattleOptions{0.01});
  return std::string(reinterpret_cast<const char*>(st.q.data()), sizeof(double) * static_cast<std::size_t>(st.q.size()));
}

// The compute-only loop: `count` jobs of `work` sin's, split in contiguous halves over the
// ranks of comm (a rank outside comm does nothing).
void compute_only(MPI_Comm comm, long count, int work) {
  if (comm == MPI_COMM_NULL) return;
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  volatile double sink = 0.0;
  for (long i = count * rank / size; i < count * (rank + 1) / size; ++i) {
    double x = static_cast<double>(i);
    for (int k = 0; k < work; ++k) x = std::sin(x) + 1e-3 * k;
    sink = sink + x;
  }
}

EnsembleOptions one_thread(EnsembleSchedule schedule) {
  EnsembleOptions o;
  o.threads = 1;
  o.schedule = schedule;
  return o;
}

void scaling(const char* name, int bodies, long count, long steps, int work) {
  MPI_Comm alone;  // rank 0 by itself
  MPI_Comm_split(MPI_COMM_WORLD, rank_of(MPI_COMM_WORLD) == 0 ? 0 : MPI_UNDEFINED, 0, &alone);
  const EnsembleJob job = [&](long i, int) { return trajectory(bodies, 0.5 + 1e-4 * static_cast<double>(i), steps); };
  double t1 = 1e30, t2 = 1e30, c1 = 1e30, c2 = 1e30;
  for (int round = 0; round < 3; ++round) {
    t1 = std::min(t1, timed([&] {
                    if (alone != MPI_COMM_NULL) ensemble_for(alone, count, job, one_thread(EnsembleSchedule::Dynamic));
                  }));
    t2 = std::min(t2, timed([&] { ensemble_for(MPI_COMM_WORLD, count, job, one_thread(EnsembleSchedule::Dynamic)); }));
    c1 = std::min(c1, timed([&] { compute_only(alone, count, work); }));
    c2 = std::min(c2, timed([&] { compute_only(MPI_COMM_WORLD, count, work); }));
  }
  if (alone != MPI_COMM_NULL) MPI_Comm_free(&alone);
  if (rank_of(MPI_COMM_WORLD) == 0)
    std::printf("%s: 1 rank %.1f ms, 2 ranks %.1f ms: speedup=%.3f machine_speedup=%.3f fraction=%.3f "
                "(compute-only %.1f / %.1f ms)\n",
                name, 1e3 * t1, 1e3 * t2, t1 / t2, c1 / c2, (t1 / t2) / (c1 / c2), 1e3 * c1, 1e3 * c2);
}

void load_balance(long count, long steps) {
  // Bodies per trajectory: uniform in 1..50 (splitmix64), in random order or sorted (a sweep).
  std::vector<int> random_order(static_cast<std::size_t>(count));
  std::uint64_t x = 12345;
  for (int& b : random_order) {
    std::uint64_t z = (x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    b = 1 + static_cast<int>((z ^ (z >> 31)) % 50);
  }
  std::vector<int> sweep = random_order;
  std::sort(sweep.begin(), sweep.end());

  // Each trajectory's cost alone (rank 0; rank 1 sleeps), for the spread and the ideal.
  std::vector<double> cost(static_cast<std::size_t>(count), 0.0);
  timed([&] {
    if (rank_of(MPI_COMM_WORLD) != 0) return;
    for (long i = 0; i < count; ++i) {
      const auto start = Clock::now();
      trajectory(random_order[static_cast<std::size_t>(i)], 0.5, steps);
      cost[static_cast<std::size_t>(i)] = std::chrono::duration<double>(Clock::now() - start).count();
    }
  });
  double total = 0.0;
  for (double c : cost) total += c;
  const auto [lo, hi] = std::minmax_element(cost.begin(), cost.end());
  // The static split's contiguous halves, by those costs (the sweep's sorted by bodies).
  auto halves = [&](const std::vector<int>& order) {
    double first = 0.0;
    std::vector<double> by_bodies(51, 0.0);
    for (long i = 0; i < count; ++i) by_bodies[static_cast<std::size_t>(random_order[static_cast<std::size_t>(i)])] = cost[static_cast<std::size_t>(i)];
    for (long i = 0; i < count / 2; ++i) first += by_bodies[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])];
    return std::pair<double, double>(first, total - first);
  };

  for (const auto* order : {&random_order, &sweep}) {
    const EnsembleJob job = [&](long i, int) { return trajectory((*order)[static_cast<std::size_t>(i)], 0.5, steps); };
    double s = 1e30, d = 1e30;
    for (int round = 0; round < 3; ++round) {
      s = std::min(s, timed([&] { ensemble_for(MPI_COMM_WORLD, count, job, one_thread(EnsembleSchedule::Static)); }));
      d = std::min(d, timed([&] { ensemble_for(MPI_COMM_WORLD, count, job, one_thread(EnsembleSchedule::Dynamic)); }));
    }
    const auto [first, second] = halves(*order);
    if (rank_of(MPI_COMM_WORLD) == 0)
      std::printf("load balance, %s: %ld trajectories of %ld steps, costs %.3g to %.3g ms (%.0fx), ideal %.1f ms, "
                  "static halves %.1f + %.1f ms: static %.1f ms (%.2f of ideal), dynamic %.1f ms (%.2f of ideal), "
                  "static/dynamic=%.3f\n",
                  order == &sweep ? "sweep (cost grows with the index)" : "random order", count, steps, 1e3 * *lo,
                  1e3 * *hi, *hi / *lo, 1e3 * total / 2, 1e3 * first, 1e3 * second, 1e3 * s, total / 2 / s, 1e3 * d,
                  total / 2 / d, s / d);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
  int size = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size != 2) {
    if (rank_of(MPI_COMM_WORLD) == 0) std::fprintf(stderr, "bench_ensemble: run it on 2 ranks (mpirun -n 2)\n");
    MPI_Finalize();
    return 1;
  }
  // As bench_batch's BatchScaling_Sleighs and _Chains10, with each trajectory's set-up.
  scaling("sleighs (10^4 x 100 steps)", 1, 10000, 100, 300);
  scaling("chains of 10 (10^3 x 100 steps)", 10, 1000, 100, 3000);
  load_balance(400, 200);
  MPI_Finalize();
  return 0;
}

// The process's worker pool for chains split over threads (thread_team.hpp).
#include "base/thread_team.hpp"

#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace nonholo::detail {
namespace {

inline void cpu_relax() {
#if defined(__SSE2__)
  _mm_pause();
#endif
}

// How long an idle worker spins before it sleeps: about a step of a chain the threads pay for
// (a few hundred bodies: tens of us) and the run's work between steps, with room.
constexpr auto kIdleSpin = std::chrono::microseconds(300);
// Spins at a barrier or join before each yield: a member the machine descheduled gets the core.
constexpr int kSpinsBeforeYield = 4096;

// The job word: the job's number times kTeamBits plus its team (a worker reads both at once).
constexpr long kTeamBits = long{ThreadPool::kMaxTeam} + 1;

}  // namespace

struct PoolState {
  alignas(64) std::atomic<long> job{0};
  alignas(64) std::atomic<long> finished{0};  // members done, over all jobs
  alignas(64) std::atomic<int> arrived{0};    // at the current barrier
  alignas(64) std::atomic<long> generation{0};  // barriers passed, over all jobs
  alignas(64) void (*fn)(void*, TeamMember&) = nullptr;  // the job's: written before `job`
  void* body = nullptr;
  long job_generation = 0;
  long finished_target = 0;  // the caller's
  std::atomic<int> workers{0};
  std::atomic<int> sleepers{0};
  std::atomic<bool> stop{false};
  std::mutex run_mutex, grow_mutex, sleep_mutex;
  std::condition_variable wake;
  std::vector<std::thread> threads;

  // The next job word after `seen`, or -1 when the pool stops.
  long wait_for_job(long seen) {
    using Clock = std::chrono::steady_clock;
    const auto until = Clock::now() + kIdleSpin;
    for (int i = 1;; ++i) {
      const long j = job.load(std::memory_order_acquire);
      if (j != seen) return j;
      if (stop.load(std::memory_order_relaxed)) return -1;
      cpu_relax();
      if ((i & 255) == 0 && Clock::now() > until) break;
    }
    std::unique_lock<std::mutex> lock(sleep_mutex);
    sleepers.fetch_add(1);  // seq_cst, against run_job's store of the job and load of sleepers
    long j;
    while ((j = job.load()) == seen && !stop.load()) wake.wait(lock);
    sleepers.fetch_sub(1);
    return stop.load() ? -1 : j;
  }

  // `seen`: the job word when the worker was made (the thread may start after later jobs).
  void worker(int index, long seen) {
    for (;;) {
      const long j = wait_for_job(seen);
      if (j < 0) return;
      seen = j;
      const int team = static_cast<int>(j % kTeamBits);
      if (index >= team) continue;  // not in this job
      TeamMember member(index, team, this);
      member.generation_ = job_generation;
      fn(body, member);
      finished.fetch_add(1, std::memory_order_release);
    }
  }

  void shut_down() {
    {
      std::lock_guard<std::mutex> lock(sleep_mutex);
      stop.store(true);
    }
    wake.notify_all();
    for (auto& t : threads) t.join();
    threads.clear();
  }
};

namespace {

std::atomic<PoolState*> g_pool{nullptr};

// A forked child has none of the parent's workers: it starts a pool of its own when it needs
// one (the parent's state is left behind, not freed: its locks may be held).
void forget_pool_in_child() { g_pool.store(nullptr); }

// The workers are stopped and joined at exit.
struct Reaper {
  ~Reaper() {
    if (PoolState* pool = g_pool.load()) pool->shut_down();
  }
};
Reaper g_reaper;

}  // namespace

void ThreadPool::reserve(int threads) {
  static std::once_flag registered;
  std::call_once(registered, [] { pthread_atfork(nullptr, nullptr, forget_pool_in_child); });
  static std::mutex create_mutex;
  std::lock_guard<std::mutex> create(create_mutex);
  if (!g_pool.load()) g_pool.store(new PoolState);
  PoolState& pool = *g_pool.load();
  std::lock_guard<std::mutex> lock(pool.grow_mutex);
  const int wanted = std::min(threads, ThreadPool::kMaxTeam) - 1;
  while (static_cast<int>(pool.threads.size()) < wanted) {
    const int index = static_cast<int>(pool.threads.size()) + 1;
    const long seen = pool.job.load(std::memory_order_acquire);
    pool.threads.emplace_back([&pool, index, seen] { pool.worker(index, seen); });
    pool.workers.store(index, std::memory_order_release);
  }
}

int ThreadPool::sleeping() {
  const PoolState* pool = g_pool.load();
  return pool ? pool->sleepers.load() : 0;
}

void ThreadPool::run_job(int team, void (*fn)(void*, TeamMember&), void* body) {
  PoolState* pool = g_pool.load(std::memory_order_acquire);
  if (team > 1 && pool && pool->workers.load(std::memory_order_acquire) >= team - 1 && pool->run_mutex.try_lock()) {
    std::lock_guard<std::mutex> lock(pool->run_mutex, std::adopt_lock);
    pool->fn = fn;
    pool->body = body;
    pool->job_generation = pool->generation.load(std::memory_order_relaxed);
    const long word = (pool->job.load(std::memory_order_relaxed) / kTeamBits + 1) * kTeamBits + team;
    pool->job.store(word);  // seq_cst: see wait_for_job
    if (pool->sleepers.load() > 0) {
      { std::lock_guard<std::mutex> sleep(pool->sleep_mutex); }
      pool->wake.notify_all();
    }
    TeamMember member(0, team, pool);
    member.generation_ = pool->job_generation;
    fn(body, member);
    pool->finished_target += team - 1;
    for (int i = 1; pool->finished.load(std::memory_order_acquire) != pool->finished_target; ++i) {
      cpu_relax();
      if (i % kSpinsBeforeYield == 0) std::this_thread::yield();
    }
    return;
  }
  // One thread, or the pool busy with another thread's job: every partition here, in turn.
  TeamMember member(0, 1, nullptr);
  fn(body, member);
}

void TeamMember::barrier() {
  if (size_ == 1) return;
  PoolState& pool = *pool_;
  const long next = generation_ + 1;
  generation_ = next;
  if (pool.arrived.fetch_add(1, std::memory_order_acq_rel) == size_ - 1) {
    pool.arrived.store(0, std::memory_order_relaxed);
    pool.generation.store(next, std::memory_order_release);
    return;
  }
  for (int i = 1; pool.generation.load(std::memory_order_acquire) != next; ++i) {
    cpu_relax();
    if (i % kSpinsBeforeYield == 0) std::this_thread::yield();
  }
}

}  // namespace nonholo::detail

// The worker pool that runs a chain's partitions (core/src/base/thread_team.hpp): every member
// runs, a barrier orders what members wrote before it, a job asked for while another thread's
// runs on the pool runs on its caller alone, sleeping workers wake, and a forked child gets
// workers of its own. The chain step's agreement and bitwise tests (test_chain_threads.cpp)
// run on it; this file tests the pool alone, also under TSan (tools/sanitize.sh).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "base/thread_team.hpp"

namespace nonholo::detail {
namespace {

// Polls `done` for up to a minute (no test waits on a fixed time).
template <class Done>
bool eventually(Done done) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

// Each member writes its slot, then reads every other member's after a barrier, over `rounds`
// barriers in one job; a barrier that let a member through early reads a stale slot.
bool barriers_order_writes(int team, int rounds) {
  std::vector<long> slot(static_cast<std::size_t>(team), 0);
  std::atomic<int> wrong{0}, members{0};
  auto job = [&](TeamMember& m) {
    members.fetch_add(1);
    if (m.size() != team) wrong.fetch_add(1);
    for (int r = 1; r <= rounds; ++r) {
      slot[static_cast<std::size_t>(m.index())] = r * 1000 + m.index();
      m.barrier();
      for (int k = 0; k < team; ++k)
        if (slot[static_cast<std::size_t>(k)] != r * 1000 + k) wrong.fetch_add(1);
      m.barrier();  // nobody writes round r+1 before all have read round r
    }
  };
  ThreadPool::run(team, job);
  return wrong.load() == 0 && members.load() == team;
}

TEST(ThreadTeam, EveryMemberRunsAndBarriersOrderWhatTheyWrote) {
  ThreadPool::reserve(4);
  for (int team = 1; team <= 4; ++team)
    for (int job = 0; job < 50; ++job) ASSERT_TRUE(barriers_order_writes(team, 5)) << "team " << team << ", job " << job;
}

TEST(ThreadTeam, AJobWhileAnotherThreadsRunsRunsOnItsCallerAlone) {
  ThreadPool::reserve(2);
  std::atomic<bool> inside{false}, release{false};
  std::atomic<int> second_size{0};
  auto holding = [&](TeamMember& m) {
    if (m.index() == 0) {
      inside.store(true);
      eventually([&] { return release.load(); });  // (bounded: a pool that blocks the other fails, not hangs)
    }
  };
  std::thread first([&] { ThreadPool::run(2, holding); });
  ASSERT_TRUE(eventually([&] { return inside.load(); }));
  auto other = [&](TeamMember& m) { second_size.fetch_add(m.size()); };
  ThreadPool::run(2, other);  // the pool is busy: this thread alone, team of one
  release.store(true);
  first.join();
  EXPECT_EQ(second_size.load(), 1);
  EXPECT_TRUE(barriers_order_writes(2, 3));  // and the pool works afterwards
}

TEST(ThreadTeam, SleepingWorkersWake) {
  ThreadPool::reserve(3);
  ASSERT_TRUE(barriers_order_writes(3, 2));
  // Idle workers spin a few hundred microseconds, then sleep.
  ASSERT_TRUE(eventually([] { return ThreadPool::sleeping() >= 2; })) << ThreadPool::sleeping();
  for (int job = 0; job < 20; ++job) {
    ASSERT_TRUE(barriers_order_writes(3, 2));
    ASSERT_TRUE(eventually([] { return ThreadPool::sleeping() >= 2; }));
  }
}

#if defined(__SANITIZE_THREAD__)
#define NONHOLO_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define NONHOLO_TSAN 1
#endif
#endif

TEST(ThreadTeam, AForkedChildStartsWorkersOfItsOwn) {
#ifdef NONHOLO_TSAN
  GTEST_SKIP() << "TSan does not start threads after a multi-threaded fork";
#endif
  ThreadPool::reserve(2);
  ASSERT_TRUE(barriers_order_writes(2, 2));
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {  // the parent's workers are not here: without its own the job would hang
    alarm(120);     // (a hang ends the child by a signal: the test fails, it does not hang)
    ThreadPool::reserve(2);
    _exit(barriers_order_writes(2, 3) ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_TRUE(barriers_order_writes(2, 2));
}

}  // namespace
}  // namespace nonholo::detail

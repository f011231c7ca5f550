#pragma once
// The threads that run one chain's partitions (docs/design.md, "One chain on several threads"):
// a team kept alive across steps. An OpenMP parallel region costs 3-4.5 us on the 2-core AMD
// machine (workers woken, a join); handing a job to workers that spin between jobs costs about
// 1 us with a barrier in it (measured in the same session), and a holonomic step runs about
// eight such jobs. Workers spin for a while after a job (the next step's job comes soon),
// then sleep until one comes.
//
// One pool for the process: the workspaces of a run (its step's and the accuracy check's
// shadow) take turns, and idle workers of one team never spin on the cores another needs. A
// job asked for while another thread's job runs on the pool runs on the calling thread alone
// (its partitions in turn: bit for bit the same results, Workspace::set_team).
#include <atomic>
#include <type_traits>

namespace nonholo::detail {

class TeamMember;
struct PoolState;

// The process's worker pool (thread_team.cpp).
class ThreadPool {
 public:
  static constexpr int kMaxTeam = 1 << 15;  // threads in one job

  // At set-up: at least `threads` - 1 workers from now on (throws std::system_error when a
  // thread cannot be started). Call before run() asks for that many.
  static void reserve(int threads);

  // Workers asleep now (waiting for a job after their spin; for tests).
  static int sleeping();

  // body(member) on `team` threads, the calling thread as member 0; returns when all are
  // done. `body` must not throw (a worker's exception ends the process). No allocation.
  template <class Body>
  static void run(int team, Body& body) {
    run_job(team, &call<Body>, static_cast<void*>(&body));
  }

 private:
  template <class Body>
  static void call(void* body, TeamMember& member) {
    (*static_cast<Body*>(body))(member);
  }
  static void run_job(int team, void (*fn)(void*, TeamMember&), void* body);
};

// A thread's place in a job: its index (0 the caller), the team's size, and a barrier.
class TeamMember {
 public:
  int index() const { return index_; }
  int size() const { return size_; }
  // Every member waits here until all have arrived; what each wrote before is visible to all
  // after. A no-op for a team of one.
  void barrier();

 private:
  friend class ThreadPool;
  friend struct PoolState;
  TeamMember(int index, int size, PoolState* pool) : index_(index), size_(size), pool_(pool) {}
  int index_, size_;
  PoolState* pool_;
  long generation_ = 0;  // barriers this member passed in this job
};

}  // namespace nonholo::detail

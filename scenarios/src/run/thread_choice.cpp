// RunConfig::threads resolved for the run's model (thread_choice.hpp): automatic, all usable
// cores for a chain long enough to pay for the threads' synchronisation; asked for, checked
// against the model and the cores.
#include "run/thread_choice.hpp"

#include <nonholo/scenarios/run_types.hpp>
#include <nonholo/workspace.hpp>

#include <omp.h>
#if defined(__linux__)
#include <sched.h>
#endif

#include <algorithm>
#include <stdexcept>

namespace nonholo::scenarios {

int usable_cores() {
  int cores = omp_get_num_procs();
#if defined(__linux__)
  cpu_set_t mask;
  if (sched_getaffinity(0, sizeof mask, &mask) == 0) cores = CPU_COUNT(&mask);
#endif
  return std::max(1, std::min(cores, omp_get_max_threads()));
}

ThreadChoice choose_threads(int asked, const Model& model, bool reflection, HitchMode hitch) {
  ThreadChoice c;
  if (asked == 1) return c;  // a batch's trajectory: no system call for the cores
  const int limit = reflection ? max_step_threads(model) : 1;
  if (asked == 0) {
    const int per_thread = hitch == HitchMode::OneForm ? kBodiesPerThread : kHolonomicBodiesPerThread;
    if (limit > 1) c.threads = std::max(1, std::min({usable_cores(), limit, model.num_bodies() / per_thread}));
    return c;
  }
  if (limit == 1) {
    c.warning = "--threads " + std::to_string(asked) + ": ran on one thread: threads split the reflection "
                "method's step of a chain of knife edges and hitches (not this run's)";
    return c;
  }
  if (asked > limit)
    throw std::invalid_argument("--threads " + std::to_string(asked) + " for " + std::to_string(model.num_bodies()) +
                                " bodies: each thread needs at least 2 bodies, so at most " + std::to_string(limit));
  c.threads = asked;
  const int cores = usable_cores();
  if (asked > cores)
    c.warning = "--threads " + std::to_string(asked) + " is more than the " + std::to_string(cores) +
                " cores this process may use: at every step the threads wait for each other, slower than " +
                std::to_string(cores) + " threads";
  return c;
}

}  // namespace nonholo::scenarios

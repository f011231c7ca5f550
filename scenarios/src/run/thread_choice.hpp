#pragma once
// How many threads one step of a run's chain uses (RunConfig::threads, `--threads`), and what
// to say when the choice is not what was asked for.
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>

#include <string>

namespace nonholo::scenarios {

struct ThreadChoice {
  int threads = 1;
  std::string warning;  // empty, or why the threads asked for do not all help
};

// The cores this process may run on: its affinity mask, capped by OpenMP's thread limit
// (OMP_NUM_THREADS).
int usable_cores();

// `asked` (0: automatic) for this model and method (`reflection`: the method whose step is
// split; `hitch`: its hitch mode, which sets the automatic choice's threshold). Throws std::invalid_argument when the chain cannot be split so (fewer than 2
// bodies a thread).
ThreadChoice choose_threads(int asked, const Model& model, bool reflection, HitchMode hitch);

}  // namespace nonholo::scenarios

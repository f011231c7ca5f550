#pragma once
// A run's options in a checkpoint (archive.hpp): everything `nonholo run` was given, so that
// --resume rebuilds the same run (a scene file's text too: a changed file is refused).
#include <nonholo/archive.hpp>
#include <nonholo/scenarios/run_types.hpp>

namespace nonholo::scenarios {

void save(OutArchive& a, const RunConfig& config);
// The options as saved; the caller keeps its own sink, stop flag and checkpoint settings.
// Throws std::runtime_error if the run read a scene file that has changed (or gone) since.
void load(InArchive& a, RunConfig& config);

}  // namespace nonholo::scenarios

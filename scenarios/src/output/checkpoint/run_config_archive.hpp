#pragma once
// A run's options in a checkpoint (archive.hpp): everything `nonholo run` was given, so that
// --resume rebuilds the same run (a scene file's text too: a changed file is refused).
#include <nonholo/archive.hpp>
#include <nonholo/scenarios/run_types.hpp>

#include <string>

namespace nonholo::scenarios {

void save(OutArchive& a, const RunConfig& config);
// The options as saved; the caller keeps its own sink, stop flag and checkpoint settings.
// Throws std::runtime_error if the run read a scene file that has changed (or gone) since.
void load(InArchive& a, RunConfig& config);

// What the run integrated, saved after its options: a scene (built again from them on resume) or
// a model built in code (run_model: the caller gives the model again) with its start (the
// methods start from it before the checkpoint's state replaces theirs, as in the run saved), and
// the model's fingerprint (model_fingerprint.hpp).
struct RunSource {
  bool from_code = false;
  RunStart start;  // a model built in code's (a scene's is built again: empty)
  std::string fingerprint;
};
// `start` is saved for a model built in code only.
void save(OutArchive& a, bool from_code, const RunStart& start, const std::string& fingerprint);
void load(InArchive& a, RunSource& source);

}  // namespace nonholo::scenarios

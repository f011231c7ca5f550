#pragma once
/// @file
/// `nonholo run`: integrate one scene, optionally write its trajectory as CSV, and summarise.
/// The run's options and summary are in <nonholo/scenarios/run_types.hpp>.
#include <nonholo/scenarios/run_types.hpp>
#include <nonholo/scenarios/scene.hpp>

/// The built-in scenes, scene files and the `nonholo` command line (run, batch, wp) on top of the
/// library: what the tool and the Python package call.
namespace nonholo::scenarios {

/// Runs the scene `config` names and returns its summary.
/// Throws std::invalid_argument (unknown scene or parameter, bad value, CSV not writable)
/// before integrating; a failed step ends the run early with summary.status set.
RunSummary run_scene(const RunConfig& config);

}  // namespace nonholo::scenarios

#pragma once
/// @file
/// `nonholo run`: integrate one scene, or a model built in code, optionally write its trajectory
/// (CSV, HDF5), and summarise. The run's options and summary are in <nonholo/scenarios/run_types.hpp>.
#include <nonholo/model.hpp>
#include <nonholo/scenarios/run_types.hpp>
#include <nonholo/scenarios/scene.hpp>

/// The built-in scenes, scene files and the `nonholo` command line (run, batch, wp) on top of the
/// library: what the tool and the Python package call.
namespace nonholo::scenarios {

/// Runs the scene `config` names and returns its summary.
/// Throws std::invalid_argument (unknown scene or parameter, bad value, CSV not writable)
/// before integrating; a failed step ends the run early with summary.status set.
RunSummary run_scene(const RunConfig& config);

/// Runs a model built in code (ModelBuilder) from `start` as run_scene() runs a scene: the same
/// run loop, with every check (energy, constraints, stability, precision, accuracy), outputs
/// (config.csv_path: CSV or HDF5; config.sink), checkpoints and summary. config.scene names the
/// model in the summary and the files; config.dt and config.t_end (an end time) are required,
/// config.assignments must be empty. A run resumed from a checkpoint (config.resume_path) takes
/// its options and state from the checkpoint, `start` unused; the model must be the one the
/// checkpoint was written with (its sizes, names and masses are compared). `model` is read, not
/// copied, and must outlive the call.
/// Throws std::invalid_argument before integrating; a failed step ends the run with status set.
RunSummary run_model(const Model& model, const RunStart& start, const RunConfig& config);

}  // namespace nonholo::scenarios

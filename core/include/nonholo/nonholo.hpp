#pragma once
/// @file
/// Everything needed to build a model and integrate it (elements.hpp, rattle_options.hpp,
/// restart_options.hpp and types.hpp come with the headers below). Left out, to be included on
/// their own: accuracy.hpp and adaptive.hpp (the run driver's error control, which most embedders
/// leave to nonholo::scenarios), ensemble.hpp (only what MPI ensembles share), archive.hpp and
/// time_grid.hpp (the checkpoints' byte archive and the step times, included by the headers that
/// need them), busy_flag.hpp (the workspace's own guard) and version.hpp (generated at configure
/// time).
#include <nonholo/batch.hpp>
#include <nonholo/composition.hpp>
#include <nonholo/diagnostics.hpp>
#include <nonholo/dynamics.hpp>
#include <nonholo/model.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/restart.hpp>
#include <nonholo/rigid_body.hpp>
#include <nonholo/stability.hpp>
#include <nonholo/dla.hpp>
#include <nonholo/implicit.hpp>
#include <nonholo/start.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

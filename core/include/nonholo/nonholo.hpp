#pragma once
// Everything needed to build a model and integrate it.
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

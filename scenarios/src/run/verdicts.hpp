#pragma once
// What a run's end says about it (verdicts.cpp): the accuracy check's verdict and the warnings
// of a run that ended ok, each with the change that would help.
#include <nonholo/accuracy.hpp>
#include <nonholo/rattle_options.hpp>
#include <nonholo/scenarios/run_types.hpp>

#include <string>

namespace nonholo::scenarios {

// A parasitic amplitude above this is worth a warning: the mode then holds its square, a
// visible share of the kinetic energy, and the trajectory is no longer the method's
// second-order approximation.
inline constexpr double kParasiticWarning = 1e-3;
// Gap-correction kicks (2 gap / dt) above this fraction of the motion's speed excite the mode
// beyond kParasiticWarning (the 1000-body train: kicks of 1.6e-3 of its speed gave 0.011).
inline constexpr double kGapKick = 1e-4;

// The accuracy check's verdict on a run that ended ok: status=inaccurate, with the advice in
// summary.message, when the estimated error (summary.error_estimate: the companion's, or the
// sampled `watch`'s) exceeds config.accuracy of the motion's extent, or, for adaptive steps,
// 10 times their tol. `watch`: the sampled check, if the method has one (its failures, transients
// and largest coordinate); `largest_coordinate` without one.
void judge_accuracy(RunSummary& summary, const RunConfig& config, int order, const DoublingEstimate* watch,
                    double largest_coordinate, bool has_orders);
// The warning of a run whose period-2 mode reached parasitic_max, with what would remove it.
std::string parasitic_warning(const RunSummary& r, const RattleOptions& o);
// What to change when the energy blew up: restarts for a grown period-2 mode, else a smaller step.
std::string energy_advice(const RunSummary& r, const RattleOptions& o);
// Appends a warning (if any) of this kind to summary.warnings, and its text to summary.warning,
// space-separated.
void add_warning(RunSummary& summary, WarningKind kind, const std::string& warning);

}  // namespace nonholo::scenarios

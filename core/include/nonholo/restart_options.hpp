#pragma once
/// @file
/// What the integrators do about the period-2 mode (docs/design.md §8, README "Restarts"):
/// the multiplier lambda~ carries, besides its smooth part, a component that flips sign every
/// step and grows wherever the continuous motion is attracting; left alone it takes the energy
/// of p~ and ruins the trajectory while the post-momentum energy stays exact. A restart
/// replaces lambda~ by the continuous multiplier lambda_s(q, p~) and rescales p~ so that the
/// post-momentum energy (with f = 0; with forces, the discrete work-energy balance) is
/// unchanged, together with every momentum map of the model (restart.hpp).
#include <algorithm>
#include <string>

namespace nonholo {

/// @enum RestartMode
/// When the multipliers are restarted.
/// (A Robert-Asselin-type filter, lambda~ moved a fraction towards lambda_s every step with the
/// same rescale, was measured against Auto and dropped: README, "The period-2 mode".)
/// @var RestartMode::Never
///   the paper's plain method (the amplitude is still measured and reported);
/// @var RestartMode::Periodic
///   restart every RestartOptions::every steps;
/// @var RestartMode::Auto
///   restart when the measured parasitic amplitude exceeds the tolerance.
enum class RestartMode { Never, Periodic, Auto };
const char* to_string(RestartMode mode);  ///< "never", "periodic", "auto"

/// What a step does about the period-2 mode (RattleOptions::restart, ImplicitOptions::restart).
struct RestartOptions {
  RestartMode mode = RestartMode::Auto;  ///< when to restart
  int every = 0;  ///< Periodic: steps between restarts (>= 1)
  /// Auto: restart when the parasitic amplitude (h/2) |lambda~ - lambda_s|_C / |p~|_{M^-1}
  /// exceeds this; 0 means min(h^3, 1e-3) (h in the model's time unit: the mode's seed after a
  /// restart is O((h/tau)^3) for a motion on the time scale tau, so set it for models far from
  /// tau ~ 1; the cap keeps the mode's share of the energy, the amplitude squared, below 1e-6).
  double tolerance = 0.0;
  /// Measure the amplitude at least every this many steps (0: never; Auto needs >= 1), in every
  /// mode: with Auto, at the next step while it is above the tolerance or after a restart, and
  /// otherwise after as many steps as its growth between the last two measurements allows (the
  /// mode can double per step where the motion attracts strongly). A measurement costs one bias
  /// evaluation, one solve with the factorisation the step already has and one mu^T product:
  /// about a step's worth on a small model, 40% of one on a long chain; a chain of knife edges
  /// (the single sleigh) takes it from its sweep's data in one pass (under a step).
  int monitor_every = 8;

  /// The tolerance Auto uses at step size h. The default has a floor at the amplitude's
  /// round-off, kRoundOff: lambda~ solves (h/2) mu M^-1 mu^T lambda~ = -mu M^-1 (p + ...) to
  /// eps |p| in momentum, so (h/2)|lambda~ - lambda_s|_C / |p| carries a few eps times the
  /// condition of C whatever h is (measured at h = 1e-9: 0.26 eps on the sleigh, 4 eps on the
  /// 10-sleigh chain, 3 eps on the snakeboard). Below it h^3 asked for a restart at every step
  /// (10^4 restarts in 10^4 steps at h = 1e-9, tolerance 1e-27).
  ///@{
  static constexpr double kRoundOff = 64.0 * 2.220446049250313e-16;
  double tolerance_for(double h) const {
    return tolerance > 0.0 ? tolerance : (h < 0.1 ? std::max(h * h * h, kRoundOff) : 1e-3);
  }
  ///@}
};

/// Throws std::invalid_argument naming the field and the offending value.
void validate(const RestartOptions& options);
/// Sets mode (and every) from "auto", "0" or "never", or a whole number K >= 1 (every K steps).
/// Throws std::invalid_argument naming the accepted forms.
void set_restart(RestartOptions& options, const std::string& spec);
/// The inverse: "auto", "0" or "K".
std::string restart_spec(const RestartOptions& options);

/// A trajectory's measurement schedule (kept with its state): the step count of the next
/// measurement, and the last amplitude measured with its step count (-1 after a restart, -1 - a
/// after a restart that probes a floor, below; 0 before any measurement). 32 bytes: the step
/// copies it in and out (at 40 the compiler's `rep movs` cost a batched single sleigh 30% of its
/// step).
struct ModeWatch {
  long next_step = 1;  ///< the step count of the next measurement
  long last_step = 0;  ///< the step count of the last measurement or restart
  double last_amplitude = 0.0;  ///< its amplitude: -1 after a restart, -1 - a after a probe's, 0 before any
  /// Auto restarts: an amplitude still above the tolerance the step after each of two restarts
  /// in a row is what restarts cannot remove (in holonomic mode the round-off of the hitch gaps,
  /// 16 eps |q| each, summed over a long chain: 6e-6 at 10^6 bodies, h = 0.01). Auto with the
  /// default tolerance then restarts only above twice the largest such floor, rather than at
  /// nearly every step; a tolerance the user set is kept as it is. One restart is not proof: a
  /// step can excite the mode afresh (a chain passing a configuration where its one-forms become
  /// dependent), and a second restart removes that.
  double floor = 0.0;
};

}  // namespace nonholo

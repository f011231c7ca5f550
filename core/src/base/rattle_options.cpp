// The reflection step's options (rattle_options.hpp): the hitch modes' and rotation Lagrangians'
// names, and the checks of RattleOptions that step() refuses with a status and validate() throws.
#include <nonholo/rattle_options.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

#include "base/option_checks.hpp"

namespace nonholo {

const char* to_string(HitchMode mode) {
  return mode == HitchMode::OneForm ? "oneform" : "holonomic";
}

HitchMode hitch_mode_from_string(const std::string& name) {
  if (name == "oneform") return HitchMode::OneForm;
  if (name == "holonomic") return HitchMode::Holonomic;
  throw std::invalid_argument("unknown hitch mode '" + name + "' (valid: oneform, holonomic)");
}

const char* to_string(RotationLagrangian rotation) {
  switch (rotation) {
    case RotationLagrangian::MoserVeselov: return "moser-veselov";
    case RotationLagrangian::MoserVeselovF: return "moser-veselov-f";
    case RotationLagrangian::Exponential: return "exponential";
  }
  return "unknown";
}

RotationLagrangian rotation_from_string(const std::string& name) {
  for (RotationLagrangian r :
       {RotationLagrangian::MoserVeselov, RotationLagrangian::MoserVeselovF, RotationLagrangian::Exponential})
    if (name == to_string(r)) return r;
  throw std::invalid_argument("unknown rotation Lagrangian '" + name +
                              "' (valid: moser-veselov, moser-veselov-f, exponential)");
}

namespace detail {

// Built once, on the first mismatch (OptionProblem holds a const char*).
const char* composition_mismatch() {
  static const std::string text = "does not match the composition (" + composition_choices() + ")";
  return text.c_str();
}

OptionProblem rattle_problem(const RattleOptions& o) {
  if (OptionProblem p = step_size_problem(o.h)) return p;
  if (OptionProblem p = pivot_ratio_problem(o.min_pivot_ratio)) return p;
  if (!(o.gap_tolerance > 0.0) || !std::isfinite(o.gap_tolerance))
    return {"gap_tolerance", o.gap_tolerance, "must be positive and finite"};
  if (!(o.gap_tolerance_limit >= o.gap_tolerance) || !std::isfinite(o.gap_tolerance_limit))
    return {"gap_tolerance_limit", o.gap_tolerance_limit, "must be finite and at least gap_tolerance"};
  if (o.max_gap_iterations < 1)
    return {"max_gap_iterations", static_cast<double>(o.max_gap_iterations), "must be at least 1"};
  if (OptionProblem p = restart_problem(o.restart)) return p;
  if (o.order != 2 && o.order != 4 && o.order != 6 && o.order != 8)
    return {"order", static_cast<double>(o.order), "must be 2, 4, 6 or 8"};
  if (CompositionScheme scheme; !find_composition(o.order, o.composition, scheme))
    return {"order", static_cast<double>(o.order), composition_mismatch()};
  return {};
}

}  // namespace detail

void validate(const RattleOptions& options) {
  detail::reject_if(detail::rattle_problem(options));
  composition_scheme(options.order, options.composition);  // its own message for a bad pair
}

}  // namespace nonholo

#pragma once
// The builder's range checks of physical scales: masses and moments of inertia, and the
// lengths of elements against the bodies they act on. Each throws std::invalid_argument with
// a message naming the value, the bound and why (ModelBuilder's contract). `who` names the
// body or element for the message: a callable returning a std::string, called only when a check
// fails (a million bodies pass them: their names are never built).
#include <string>

namespace nonholo::detail {

// A mass, moment of inertia or mass-block eigenvalue: it, its inverse and their round-off
// (eps times them) must be normal doubles, so [2^-970, 2^970] = [1.0e-292, 1.0e292]. Outside,
// 1/m overflows (a mass of 1e-320) or the step's products underflow into subnormals (1e308).
inline constexpr double kMinScale = 0x1p-970, kMaxScale = 0x1p970;
[[noreturn]] void mass_scale_failure(const std::string& who, const char* what, double value);
template <class Who>
void check_mass_scale(const Who& who, const char* what, double value) {
  if (!(value >= kMinScale && value <= kMaxScale)) mass_scale_failure(who(), what, value);
}

// A length `what` = `length` (a knife edge's offset, a hitch point's, a rolling radius) on a
// body with translational inverse mass `w_trans` and largest rotational inverse inertia
// `w_rot`: the one-form has entries of order 1 on the centre's velocity and `length` on the
// turning rate. Refused when the first fall below the round-off of the second (|length| above
// 2^52 radii of gyration sqrt(I/m): the element would only stop the body turning) or when the
// row's diagonal entry of C, w_trans + length^2 w_rot (an inverse effective mass), exceeds
// kMaxScale, the bound of inverse masses.
bool lever_arm_in_range(double length, double w_trans, double w_rot);
[[noreturn]] void lever_arm_failure(const std::string& who, const char* what, double length, double w_trans,
                                    double w_rot);
template <class Who>
void check_lever_arm(const Who& who, const char* what, double length, double w_trans, double w_rot) {
  if (!lever_arm_in_range(length, w_trans, w_rot)) lever_arm_failure(who(), what, length, w_trans, w_rot);
}

// A rod's length: its gap (|x_1 - x_2|^2 - l^2) / (2 l) squares it, so l^2 must stay in range.
void check_rod_length(const std::string& who, double length);

}  // namespace nonholo::detail

// The builder's range checks of masses, lever arms and rod lengths, with their messages (builder_scales.hpp).
#include "model/builder_scales.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace nonholo::detail {
namespace {
constexpr double kRoundOff = 0x1p52;  // 1/eps: an entry this much smaller is lost in a sum
}  // namespace

void mass_scale_failure(const std::string& who, const char* what, double value) {
  const bool small = value < kMinScale;
  std::ostringstream os;
  os << who << ": " << what << " = " << value << " is " << (small ? "below " : "above ")
     << (small ? kMinScale : kMaxScale)
     << ": a mass or moment of inertia, its inverse and their round-off must be normal doubles (from " << kMinScale
     << " to " << kMaxScale << "), or " << (small ? "its inverse overflows" : "the step's products with its inverse underflow")
     << "; choose units that bring the masses nearer 1";
  throw std::invalid_argument(os.str());
}

bool lever_arm_in_range(double length, double w_trans, double w_rot) {
  const double a = std::abs(length);
  const double gyration = std::sqrt(w_trans) / std::sqrt(w_rot);  // sqrt(I / m); no overflow
  return a <= kRoundOff * gyration && w_trans + a * a * w_rot <= kMaxScale;
}

void lever_arm_failure(const std::string& who, const char* what, double length, double w_trans, double w_rot) {
  const double a = std::abs(length);
  const double gyration = std::sqrt(w_trans) / std::sqrt(w_rot);
  const double diagonal = w_trans + a * a * w_rot;
  std::ostringstream os;
  os << who << ": " << what << " = " << length;
  if (a > kRoundOff * gyration)
    os << " is " << a / gyration << " times the body's radius of gyration sqrt(I/m) = " << gyration
       << ": the constraint's entries on the centre's velocity would fall below the round-off of its entry on "
          "the turning rate (a ratio above 2^52 = "
       << kRoundOff << "), so it would act on the turning rate alone; use at most " << kRoundOff * gyration
       << " (2^52 radii of gyration)";
  else
    os << " makes the constraint's inverse effective mass, its entry of C = mu M^-1 mu^T, " << diagonal << ", above "
       << kMaxScale << " (the bound of inverse masses, for the same reason); use a shorter length or larger masses";
  throw std::invalid_argument(os.str());
}

void check_rod_length(const std::string& who, double length) {
  const double square = length * length;
  if (square >= kMinScale && square <= kMaxScale) return;
  std::ostringstream os;
  os << who << ": length = " << length << " squared is " << square << ", outside [" << kMinScale << ", " << kMaxScale
     << "]: the rod's gap (|x1 - x2|^2 - l^2) / (2 l) would " << (square < kMinScale ? "underflow" : "overflow")
     << "; choose length units that bring it nearer 1";
  throw std::invalid_argument(os.str());
}

}  // namespace nonholo::detail

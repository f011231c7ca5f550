// The public quaternion helpers of nonholo/rigid_body.hpp.
#include <nonholo/rigid_body.hpp>

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "model/quaternion.hpp"

namespace nonholo {

Eigen::Vector4d axis_angle_quaternion(const Eigen::Vector3d& axis, double angle) {
  const double norm = axis.stableNorm();  // no overflow or underflow for extreme lengths
  if (!(norm > 0.0) || !std::isfinite(norm) || !std::isfinite(angle)) {
    std::ostringstream os;
    os << "axis_angle_quaternion: axis (" << axis.transpose() << ") and angle " << angle
       << " must be finite, the axis nonzero";
    throw std::invalid_argument(os.str());
  }
  const double s = std::sin(0.5 * angle) / norm;
  return {std::cos(0.5 * angle), s * axis.x(), s * axis.y(), s * axis.z()};
}

Eigen::Matrix3d quaternion_matrix(const Eigen::Vector4d& q) { return detail::rotation_of(q); }

}  // namespace nonholo

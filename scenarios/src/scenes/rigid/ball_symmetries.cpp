// The rolling balls' horizontal symmetries as generators (ball_symmetries.hpp): a ball's vertical spin and
// its momentum map, and all balls rolling together about a horizontal axis.
#include "scenes/rigid/ball_symmetries.hpp"

#include <nonholo/rigid_body.hpp>

#include <Eigen/Geometry>

namespace nonholo::scenarios {

SymmetryGenerator vertical_spin(BallSlots ball) {
  return [ball](ConstVecRef q, VecRef xi) {
    const Eigen::Matrix3d r = quaternion_matrix(q.segment<4>(ball.q));
    xi.segment<3>(ball.v) = r.row(2).transpose();
    xi.segment(ball.v + 3, ball.translation).setZero();
  };
}

MomentumMap vertical_spin_value(BallSlots ball) {
  return [ball](ConstVecRef q, ConstVecRef p) {
    return quaternion_matrix(q.segment<4>(ball.q)).row(2).dot(p.segment<3>(ball.v));
  };
}

SymmetryGenerator rolling(std::vector<BallSlots> balls, double radius, int j) {
  return [balls, radius, j](ConstVecRef q, VecRef xi) {
    xi.setZero();
    const Eigen::Vector3d axis = Eigen::Vector3d::Unit(j);
    const Eigen::Vector3d xdot = radius * axis.cross(Eigen::Vector3d::UnitZ());
    for (const BallSlots& b : balls) {
      const Eigen::Matrix3d r = quaternion_matrix(q.segment<4>(b.q));
      xi.segment<3>(b.v) = r.transpose() * axis;
      xi.segment<2>(b.v + 3) = xdot.head<2>();
    }
  };
}

}  // namespace nonholo::scenarios

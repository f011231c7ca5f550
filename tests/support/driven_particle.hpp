#pragma once
// A small model for failure tests: a body with coordinates (x, y, z) and unit mass, one
// one-form dz - y dx (mu = [-y, 0, 1]), and the given external force (which a test can make
// fail at some time). Header-only.
#include <nonholo/model_builder.hpp>

#include <utility>

namespace nonholo::testing {

inline Model driven_particle(ExternalForce force) {
  ModelBuilder b;
  b.add_body({"x", "y", "z"}, Eigen::Matrix3d::Identity());
  b.add_one_form({0, 2});
  b.one_form_values([](ConstVecRef q, VecRef mu) {
    mu[0] = -q[1];
    mu[1] = 1.0;
  });
  b.one_form_bias([](ConstVecRef, ConstVecRef v, VecRef bias) { bias[0] = -v[1] * v[0]; });
  b.external_force(std::move(force));
  return b.build();
}

}  // namespace nonholo::testing

#pragma once
// Random models for cross-checks: bodies of 1 to 3 coordinates with random SPD (sometimes
// diagonal) mass blocks, one-form rows touching one or two bodies with smooth values, and
// optionally a potential and a time-dependent force.
#include <nonholo/model.hpp>

#include <cstdint>

namespace nonholo::testing {

struct RandomModelOptions {
  int bodies = 6;
  int rows = 5;             // must not exceed the number of coordinates
  bool applied_force = false;  // quadratic potential plus a force F(t, q)
  bool analytic_bias = true;
};

Model random_model(std::uint32_t seed, const RandomModelOptions& options);
// A configuration and a velocity guess of the right size.
Vector random_vector(std::uint32_t seed, int n, double scale = 1.0);

}  // namespace nonholo::testing

#pragma once
// A model's fingerprint for checkpoints: a resumed run must integrate the model the checkpoint
// was written with, which for a model built in code only the caller can give again.
#include <nonholo/model.hpp>

#include <string>

namespace nonholo::scenarios {

// 16 hex digits (a 64-bit FNV-1a) of the model's sizes, coordinate and velocity names, what it has (forces,
// potential, metric, holonomic rows) and its inverse masses: equal models give equal prints on
// every build; a model with another body, constraint or mass, a different one. (Not its
// callbacks: two models alike in all these but a force law are not told apart.)
std::string model_fingerprint(const Model& model);

}  // namespace nonholo::scenarios

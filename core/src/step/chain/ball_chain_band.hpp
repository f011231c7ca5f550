#pragma once
// C of a ball chain (ElementSet::ball_chain) factorised from mu's values row by row, without
// C's pattern or the Gram assembler (ball_chain_band.cpp).
#include <nonholo/workspace.hpp>

namespace nonholo::detail {

// C(q) = mu M^-1 mu^T from mu(q) in ws.mu_values into ws.banded(), eliminated as its rows are
// made (Workspace::factorize for a ball chain).
sparse::FactorStatus factorize_ball_chain(const Model& model, Workspace& ws, double min_pivot_ratio);

}  // namespace nonholo::detail

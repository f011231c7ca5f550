#pragma once
// A batch's summary line from its trajectories' (aggregate.cpp): what is summed, what is the
// worst over them, and which trajectory failed first.
#include <nonholo/scenarios/batch_types.hpp>

#include <string>
#include <vector>

#include "run/run_internal.hpp"

namespace nonholo::scenarios {

// result.aggregate, failed, inaccurate and first_failure from the rows; a row whose `errors`
// entry is not empty (its set-up threw) gets status=invalid-input with that message first.
void aggregate(const PreparedRun& prepared, const BatchConfig& config, std::vector<BatchResult::Trajectory>& rows,
               std::vector<std::string>& errors, BatchResult& result);

}  // namespace nonholo::scenarios

#pragma once
// Counts every malloc/calloc/realloc/aligned allocation of the process (operator new,
// Eigen and CHOLMOD all end up there) while counting is switched on.
namespace nonholo::testing {

void start_counting_allocations();
// Stops counting and returns the number of allocations since start.
long stop_counting_allocations();

}  // namespace nonholo::testing

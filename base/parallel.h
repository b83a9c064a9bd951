// A parallel loop over independent work items (fits, simulations, participants), shared by the
// full-model fit, the benchmark and the diagnosis. C++ standard library only.
#pragma once

#include <cstddef>
#include <functional>

namespace fesim {

/// Runs fn(0) … fn(n − 1) on min(threads, n) threads (at least one; dynamic assignment, so
/// uneven items balance). Every index runs even when some throw; afterwards the exception of the
/// lowest failing index is rethrown, so the reported failure does not depend on the thread count.
void ParallelFor(std::size_t n, int threads, const std::function<void(std::size_t)>& fn);

}  // namespace fesim

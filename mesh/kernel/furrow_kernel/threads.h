// How many threads a call may use, as TBB sees it.
#pragma once

#include <algorithm>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

namespace furrow::kernel {

// Whether this call runs on one thread: every limit in force, the arena's and a global_control's
// (`furrow -j 1` sets the latter; the arena's own concurrency does not reflect it). A caller with a serial and
// a parallel way to the same result takes the serial one here, where the parallel one would only add its
// bookkeeping.
inline bool one_thread() {
    return std::min(tbb::this_task_arena::max_concurrency(),
                    int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism))) <= 1;
}

} // namespace furrow::kernel

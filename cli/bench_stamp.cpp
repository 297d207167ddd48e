// `furrow bench stamp` (being written).
#include "bench_common.h"

namespace furrow::cli {
void register_bench_stamp(CLI::App& bench, GlobalFlags& g) { (void)bench; (void)g; }
} // namespace furrow::cli

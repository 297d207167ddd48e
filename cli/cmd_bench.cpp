// `furrow bench <tool>`: benchmarks that report time next to an error measure and against a baseline
// measured in the same run (so the ratios survive a slower or faster machine). One file per tool:
// cli/bench_<tool>.cpp.
#include "bench_common.h"

namespace furrow::cli {

void register_bench(CLI::App& app, GlobalFlags& g) {
    CLI::App* bench = app.add_subcommand("bench", "Benchmarks: time against an error measure and an in-run baseline");
    bench->require_subcommand(1);
    register_bench_io(*bench, g);
    register_bench_tessellate(*bench, g);
    register_bench_render(*bench, g);
    register_bench_shells(*bench, g);
    register_bench_stamp(*bench, g);
}

} // namespace furrow::cli

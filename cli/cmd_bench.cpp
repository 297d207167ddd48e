// `furrow bench [<tool>]`: benchmarks that report time next to an error measure and against a baseline
// measured in the same run (so the ratios survive a slower or faster machine). One file per tool:
// cli/bench/bench_<tool>.cpp (the furrow_bench library). Without a tool, every benchmark runs in turn on its default
// inputs (the bundled models and ../shared/corpus when present), with one JSON document and the SVG plots of all of
// them on request.
#include "bench_common.h"
#include "commands.h"

#include <algorithm>

namespace furrow::cli {

void run_bench_all(const BenchAllArgs& a, const GlobalFlags& g) {
    using Fn = nlohmann::json (*)(const BenchRun&, const GlobalFlags&);
    const std::vector<std::pair<std::string, Fn>> tools = {{"io", bench_io_default},
                                                          {"render", bench_render_default},
                                                          {"shells", bench_shells_default},
                                                          {"tessellate", bench_tessellate_default},
                                                          {"stamp", bench_stamp_default},
                                                          {"memory", bench_memory_default}};
    for (const auto& name : a.only) {
        bool known = false;
        for (const auto& [n, f] : tools) known |= n == name;
        if (!known) throw CLI::ValidationError("--only", "unknown benchmark \"" + name + "\" (io, render, shells, tessellate, stamp, memory)");
    }
    BenchRun run = a.run;
    run.tables = !a.out.json;
    nlohmann::json all{{"bench", "all"}, {"quick", run.quick}, {"benches", nlohmann::json::array()}};
    bool first = true;
    for (const auto& [name, fn] : tools) {
        if (!a.only.empty() && std::find(a.only.begin(), a.only.end(), name) == a.only.end()) continue;
        if (run.tables) std::printf("%s==== furrow bench %s%s\n", first ? "" : "\n", name.c_str(), run.quick ? " (quick)" : "");
        first = false;
        std::fflush(stdout);
        all["benches"].push_back(fn(run, g));
    }
    finish_bench(all, a.out, g);
}

void register_bench(CLI::App& app, GlobalFlags& g) {
    auto a = std::make_shared<BenchAllArgs>();
    CLI::App* bench = app.add_subcommand("bench", "Benchmarks: time against an error measure and an in-run baseline "
                                                  "(no tool: all of them)");
    bench->require_subcommand(0, 1);
    bench->add_flag("--quick", a->run.quick, "Fewer inputs and settings (bundled models only; under a minute)");
    bench->add_option("--repeat", a->run.repeat, "Runs per measurement; the median is reported (default: each benchmark's own)")
        ->check(finite_range(1, 1000));
    bench->add_option("--only", a->only, "Run only these benchmarks (io render shells tessellate stamp memory)")->delimiter(',');
    add_bench_output_flags(*bench, a->out);
    bench->footer("Examples:\n  furrow bench --quick\n  furrow bench --json --plots bench-plots > bench.json\n"
                  "  furrow bench tessellate --help");
    register_bench_io(*bench, g);
    register_bench_tessellate(*bench, g);
    register_bench_render(*bench, g);
    register_bench_shells(*bench, g);
    register_bench_stamp(*bench, g);
    register_bench_memory(*bench, g);
    bench->callback([a, bench, &g] {
        if (bench->get_subcommands().empty()) run_bench_all(*a, g);
    });
}

} // namespace furrow::cli

// Shared pieces of `furrow bench`: timing (median of runs), peak memory, a plain text table.
#pragma once

#include "cli_common.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace furrow::cli {

struct BenchArgs {
    std::vector<std::string> inputs; // files or folders; empty = bundled models + the shared corpus if present
    int repeat = 5;
    bool json = false;
};

// Median wall time in seconds of `repeat` calls of f (one untimed warm-up call first).
double median_seconds(int repeat, const std::function<void()>& f);

// Keeps the compiler from removing a computation whose result is otherwise unused.
inline void do_not_optimize(const void* p) { asm volatile("" : : "g"(p) : "memory"); }

// Peak resident memory since construction, in MiB above the resident size at construction (Linux: resets
// the process's high-water mark through /proc/self/clear_refs).
class PeakMemory {
public:
    PeakMemory();
    double peak_mib() const;

private:
    double base_kib_ = 0;
};

// Files with one of `extensions` from the given inputs (folders searched one level deep, sorted).
std::vector<std::filesystem::path> collect_bench_inputs(const BenchArgs& args, const std::vector<std::string>& extensions);

std::string fmt(double v, int decimals);
std::string fmt_sci(double v);

class Table {
public:
    explicit Table(std::vector<std::string> header) : rows_{std::move(header)} {}
    void add(std::vector<std::string> row) { rows_.push_back(std::move(row)); }
    void print() const;

private:
    std::vector<std::vector<std::string>> rows_;
};

// One registration per benchmark (cli/bench_<tool>.cpp), called by register_bench.
void register_bench_io(CLI::App& bench, GlobalFlags& g);
void register_bench_tessellate(CLI::App& bench, GlobalFlags& g);
void register_bench_render(CLI::App& bench, GlobalFlags& g);
void register_bench_shells(CLI::App& bench, GlobalFlags& g);
void register_bench_stamp(CLI::App& bench, GlobalFlags& g);

} // namespace furrow::cli

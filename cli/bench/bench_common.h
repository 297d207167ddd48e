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

// The worker threads a parallel loop may use now: the smallest of every thread limit in force (`furrow -j 1
// bench ...` caps a row that asks for 2, and the row must say so).
int active_threads();

// Median wall time in seconds of `repeat` calls of f (one untimed warm-up call first).
double median_seconds(int repeat, const std::function<void()>& f);
// The median of `values` (0 for none).
double median_of(std::vector<double> values);
// Runs run(0), the untimed warm-up, then run(1) .. run(repeat), each on a trimmed heap (glibc malloc_trim: the
// memory the previous run freed goes back to the system, so every run pays the page faults a fresh process
// pays, and a peak measured inside the run is not hidden by reused memory). run(r) times what it measures
// itself (not its untimed set-up, such as a fresh copy of the input) and returns those seconds; the median of
// runs 1 .. repeat is returned.
double median_fresh_seconds(int repeat, const std::function<double(int run)>& run);

// Runs a peer program (looked up on PATH), its output to /dev/null; returns its exit code, or -1 when it
// could not be started. Peers (three.js, Blender, gltfpack) are optional: a bench prints "not installed".
int run_peer(const std::vector<std::string>& argv);
// A peer run with the kernel's account of it: exit code (-1 = could not start or did not exit), wall time and
// peak resident memory (wait4's ru_maxrss, KiB). Linux starts a spawned child's peak at the spawning process's
// high-water mark: reset that mark first (a PeakMemory constructed just before) to read the child's own peak.
struct PeerRun {
    int exit_code = -1;
    double seconds = 0, max_rss_kib = 0;
};
PeerRun run_peer_measured(const std::vector<std::string>& argv);
// Whether `program` is an executable file in a folder of PATH (a peer that is not is "not installed").
bool on_path(const std::string& program);
// Blender as a peer: writes the Python `script` to a temporary file and runs
// `blender -b --factory-startup -t 1 --python <script> -- <result file> <args...>`. The script times inside
// Blender only what is compared (file import and start-up excluded) and writes one line of numbers per
// measurement to <result file> (sys.argv after "--", first); those lines are returned. Empty when `blender` is
// not on PATH or the run failed.
std::vector<std::vector<double>> blender_peer_values(const std::string& script, const std::vector<std::string>& args);
// The first number of blender_peer_values (a script that measures one time, in seconds); NaN when none.
double blender_peer_seconds(const std::string& script_text, const std::vector<std::string>& args);

// Diagonal of the world bounding box of the meshes the scene's nodes place (skinned meshes in their bind
// pose); 0 for an empty scene.
double bbox_diagonal(const Scene& s);

// Keeps the compiler from removing a computation whose result is otherwise unused.
inline void do_not_optimize(const void* p) { asm volatile("" : : "g"(p) : "memory"); }

// Peak resident memory since construction, in MiB above the resident size at construction (Linux: resets
// the process's high-water mark through /proc/self/clear_refs).
class PeakMemory {
public:
    PeakMemory();
    double base_mib() const; // the resident size at construction
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

// Speed-versus-error points of a benchmark, for the plots: one file per group (a model, a shape), one line per
// series (a criterion, a method), one point per setting.
struct PlotPoint {
    std::string group, series, label;
    double seconds = 0, triangles = 0, error = 0;
};
// {"error": error_name, "points": [...]}: stored as result["plot"] by every benchmark.
nlohmann::json plot_json(const std::string& error_name, const std::vector<PlotPoint>& points);
// Writes <bench>_<group>_error_vs_time.svg and _error_vs_triangles.svg (or _time_vs_triangles.svg when every
// error is 0) into dir; returns the files written.
std::vector<std::string> write_plots(const nlohmann::json& result, const std::filesystem::path& dir);

// Output flags every benchmark shares.
struct BenchOutput {
    bool json = false;
    std::string plots; // folder for SVG plots; empty = none
};
void add_bench_output_flags(CLI::App& cmd, BenchOutput& o);
// Prints the JSON if asked and writes the plots (of each entry of result["benches"] for `furrow bench`).
void finish_bench(const nlohmann::json& result, const BenchOutput& o, const GlobalFlags& g);

// Every benchmark as a function: returns {"bench": <tool>, ..., "plot": plot_json(...)} and prints its tables
// when `tables` is set. `quick` = fewer inputs and settings (what `furrow bench --quick` runs).
struct BenchRun {
    bool quick = false;
    int repeat = 0; // 0 = the benchmark's own default
    bool tables = true;
};
nlohmann::json bench_io_default(const BenchRun& r, const GlobalFlags& g);
nlohmann::json bench_render_default(const BenchRun& r, const GlobalFlags& g);
nlohmann::json bench_shells_default(const BenchRun& r, const GlobalFlags& g);
nlohmann::json bench_tessellate_default(const BenchRun& r, const GlobalFlags& g);
nlohmann::json bench_stamp_default(const BenchRun& r, const GlobalFlags& g);
nlohmann::json bench_memory_default(const BenchRun& r, const GlobalFlags& g);
// bench_shells_lod.cpp: `bench shells`' LOD-by-simplification table on one model (N layers, `levels` LOD
// levels, fur `length` in model units): rows for the error bounds off, 0.005, 0.01, 0.02; printed when asked.
nlohmann::json bench_lod_simplify(const std::string& name, const Scene& base, const ImageF* mask, double length, int layers,
                                  int levels, int repeat, bool tables);

// One registration per benchmark (cli/bench/bench_<tool>.cpp), called by register_bench.
void register_bench_io(CLI::App& bench, GlobalFlags& g);
void register_bench_tessellate(CLI::App& bench, GlobalFlags& g);
void register_bench_render(CLI::App& bench, GlobalFlags& g);
void register_bench_shells(CLI::App& bench, GlobalFlags& g);
void register_bench_stamp(CLI::App& bench, GlobalFlags& g);
void register_bench_memory(CLI::App& bench, GlobalFlags& g);

} // namespace furrow::cli

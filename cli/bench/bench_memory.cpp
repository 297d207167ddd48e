// `furrow bench memory`: the peak resident memory of every writing command on the bench inputs, against the
// project's memory rule: no command may peak above 2 × (input + output bytes) + 64 MiB. Each command runs as a
// subprocess of this executable, as a user runs it, and its peak is the kernel's own account of it
// (wait4's ru_maxrss: the high-water mark of the child's resident set, binary and libraries included; Linux
// starts it at the spawning process's resident size, which the "floor" column reports). An
// in-process figure (PeakMemory) cannot see a whole command: the load, the work and the writer each reuse pages
// the previous stage freed, and the process's own start-up pages are already counted.
//
// Input bytes are the file and the external resources it names (a .gltf's .bin and images); output bytes are
// what the command wrote. The commands: convert (GLB), shells (32 layers, 2 % of the diagonal), tessellate
// (uniform rate 4), render (the default PNG) and, on the bundled ground, stamp with the bundled colliders.
#include "bench_common.h"
#include "data_dirs.h"

#include <furrow/mesh.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>

#include <malloc.h>

#include <unistd.h>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

struct MemoryRow {
    std::string model, command;
    double input_bytes = 0, output_bytes = 0;
    double peak_mib = -1, seconds = 0; // -1: the command failed
    double floor_mib = 0;              // the bench's own resident size at the spawn: no peak reads below it
    int exit_code = 0;
    double limit_mib() const { return 2.0 * (input_bytes + output_bytes) / (1024.0 * 1024.0) + 64.0; }
    bool within() const { return peak_mib >= 0 && peak_mib <= limit_mib(); }
};

double file_bytes(const fs::path& p) {
    std::error_code ec;
    const auto n = fs::file_size(p, ec);
    return ec ? 0.0 : double(n);
}

// A .gltf's size with the files its buffers and images name (data: URIs are inside the file already).
double input_bytes(const fs::path& file) {
    double total = file_bytes(file);
    if (lower_extension(file.string()) != ".gltf") return total;
    std::ifstream in(file);
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_discarded()) return total;
    for (const char* key : {"buffers", "images"})
        if (j.contains(key) && j[key].is_array())
            for (const auto& e : j[key])
                if (e.contains("uri") && e["uri"].is_string() && e["uri"].get<std::string>().rfind("data:", 0) != 0)
                    total += file_bytes(file.parent_path() / e["uri"].get<std::string>());
    return total;
}

// Output bytes: the file, and a .gltf's .bin beside it.
double output_bytes(const fs::path& out) {
    double total = file_bytes(out);
    if (out.extension() == ".gltf") total += file_bytes(fs::path(out).replace_extension(".bin"));
    return total;
}

MemoryRow measure(const std::string& model, const std::string& command, const std::vector<std::string>& argv,
                  double in_bytes, const fs::path& out) {
    MemoryRow r;
    r.model = model;
    r.command = command;
    r.input_bytes = in_bytes;
    std::error_code ec;
    fs::remove(out, ec);
    // Return the freed heap, then reset this process's high-water mark (PeakMemory): the child's peak starts
    // there (Linux: exec_mmap), so it cannot read below this process's resident size now, the row's floor.
    malloc_trim(0);
    const PeakMemory floor;
    const PeerRun run = run_peer_measured(argv);
    r.exit_code = run.exit_code;
    r.seconds = run.seconds;
    r.floor_mib = floor.base_mib();
    if (run.exit_code == 0) {
        r.peak_mib = run.max_rss_kib / 1024.0;
        r.output_bytes = output_bytes(out);
    }
    fs::remove(out, ec);
    return r;
}

std::vector<MemoryRow> rows_for(const fs::path& file, const fs::path& self, const fs::path& tmp) {
    double diagonal = 0;
    {
        Scene scene; // freed before the commands run: this process's size is their floor
        if (!load_scene(scene, file.string()).ok()) return {};
        diagonal = bbox_diagonal(scene);
    }
    const double in = input_bytes(file);
    const std::string name = file.filename().string(), exe = self.string(), path = file.string();
    const fs::path glb = tmp / "out.glb", png = tmp / "out.png";
    char length[32];
    std::snprintf(length, sizeof length, "%.6g", 0.02 * (diagonal > 0 ? diagonal : 1.0));
    std::vector<MemoryRow> rows;
    rows.push_back(measure(name, "convert", {exe, "-q", "convert", path, "-o", glb.string()}, in, glb));
    rows.push_back(measure(name, "shells --layers 32", {exe, "-q", "shells", path, "-o", glb.string(), "--layers", "32", "--length", length},
                           in, glb));
    rows.push_back(measure(name, "tessellate --uniform 4", {exe, "-q", "tessellate", path, "-o", glb.string(), "--uniform", "4"}, in, glb));
    rows.push_back(measure(name, "render", {exe, "-q", "render", path, "-o", png.string()}, in, png));
    // The bundled ground and the colliders placed on it (models/): stamp where both are found together.
    const fs::path colliders = file.parent_path() / "colliders.json";
    if (file.filename() == "ground.glb" && fs::exists(colliders))
        rows.push_back(measure(name, "stamp (bundled colliders)",
                               {exe, "-q", "stamp", path, "--colliders", colliders.string(), "-o", glb.string()},
                               in + input_bytes(colliders), glb));
    return rows;
}

void print_memory_table(const std::vector<MemoryRow>& rows) {
    std::printf("furrow bench memory: peak resident memory of each command as a subprocess (wait4 ru_maxrss), against "
                "the rule peak <= 2 x (input + output bytes) + 64 MiB\n");
    Table t({"model", "command", "input MiB", "output MiB", "peak MiB", "limit MiB", "peak/limit", "within", "floor MiB", "wall s"});
    for (const auto& r : rows) {
        const bool ran = r.peak_mib >= 0;
        t.add({r.model, r.command, fmt(r.input_bytes / 1048576.0, 2), ran ? fmt(r.output_bytes / 1048576.0, 2) : "-",
               ran ? fmt(r.peak_mib, 1) : "exit " + std::to_string(r.exit_code), ran ? fmt(r.limit_mib(), 1) : "-",
               ran ? fmt(r.peak_mib / r.limit_mib(), 2) : "-", ran ? (r.within() ? "yes" : "NO") : "-", fmt(r.floor_mib, 1), fmt(r.seconds, 2)});
    }
    t.print();
}

nlohmann::json run_bench_memory(const BenchArgs& args, const GlobalFlags& g, bool tables) {
    const std::vector<fs::path> files = collect_bench_inputs(args, {".gltf", ".glb", ".obj", ".ply", ".off", ".stl"});
    if (files.empty()) throw InputError("bench memory", "no input models found (give files or folders)");
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (ec) throw InputError("bench memory", "cannot find this executable (/proc/self/exe)");
    const fs::path tmp = fs::temp_directory_path() / ("furrow-bench-memory-" + std::to_string(::getpid()));
    fs::create_directories(tmp);
    std::vector<MemoryRow> rows;
    for (const auto& f : files) {
        info(g, "bench memory: " + f.string());
        for (MemoryRow& r : rows_for(f, self, tmp)) rows.push_back(std::move(r));
    }
    fs::remove_all(tmp, ec);
    if (tables) print_memory_table(rows);
    nlohmann::json j = nlohmann::json::array();
    for (const auto& r : rows)
        j.push_back({{"model", r.model}, {"command", r.command}, {"input_bytes", r.input_bytes}, {"output_bytes", r.output_bytes},
                     {"exit_code", r.exit_code}, {"peak_mib", r.peak_mib >= 0 ? nlohmann::json(r.peak_mib) : nlohmann::json()},
                     {"limit_mib", r.limit_mib()}, {"within", r.within()}, {"floor_mib", r.floor_mib}, {"seconds", r.seconds}});
    return {{"bench", "memory"}, {"rule", "peak <= 2 x (input + output bytes) + 64 MiB"}, {"rows", j}, {"plot", plot_json("", {})}};
}

} // namespace

nlohmann::json bench_memory_default(const BenchRun& r, const GlobalFlags& g) {
    BenchArgs a;
    if (r.quick) a.inputs = {bundled_models_dir().string()};
    return run_bench_memory(a, g, r.tables);
}

void register_bench_memory(CLI::App& bench, GlobalFlags& g) {
    auto args = std::make_shared<BenchArgs>();
    auto out = std::make_shared<BenchOutput>();
    CLI::App* cmd = bench.add_subcommand("memory", "Peak memory of every writing command against 2 x (input + output) + 64 MiB");
    cmd->add_option("inputs", args->inputs, "Model files or folders (default: models/ and ../shared/corpus)");
    add_bench_output_flags(*cmd, *out);
    cmd->footer("Examples:\n  furrow bench memory\n  furrow bench memory models --json");
    cmd->callback([args, out, &g] { finish_bench(run_bench_memory(*args, g, !out->json), *out, g); });
}

} // namespace furrow::cli

// `furrow bench io`: load + save time per model as a ratio to memcpy of the same bytes, with the round-trip
// error.
#include "bench_common.h"
#include "data_dirs.h"
#include "cli_common.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unistd.h>
#include <filesystem>
#include <fstream>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

struct IoRow {
    std::string name;
    size_t bytes = 0, triangles = 0;
    double load_s = 0, save_s = 0, memcpy_s = 0;
    double peak_mib = 0;
    double roundtrip_max_error = 0; // max |position difference| after save + reload (object space)
};

double max_position_error(const Scene& a, const Scene& b) {
    if (a.meshes.size() != b.meshes.size()) return INFINITY;
    double worst = 0;
    for (size_t m = 0; m < a.meshes.size(); ++m) {
        if (a.meshes[m].primitives.size() != b.meshes[m].primitives.size()) return INFINITY;
        for (size_t p = 0; p < a.meshes[m].primitives.size(); ++p) {
            const auto& x = a.meshes[m].primitives[p].positions;
            const auto& y = b.meshes[m].primitives[p].positions;
            if (x.size() != y.size()) return INFINITY;
            for (size_t i = 0; i < x.size(); ++i) worst = std::max(worst, double(std::abs(x[i] - y[i])));
        }
    }
    return worst;
}

IoRow bench_one(const fs::path& file, const fs::path& tmp, int repeat) {
    IoRow row;
    row.name = file.filename().string();
    std::ifstream in(file, std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
    // A .gltf's buffers and images may live in files beside it: the loader reads those bytes too, so the
    // baseline copies them as well.
    if (lower_extension(file.string()) == ".gltf") {
        nlohmann::json doc = nlohmann::json::parse(bytes.begin(), bytes.end(), nullptr, false);
        if (doc.is_object())
            for (const char* key : {"buffers", "images"})
                if (doc.contains(key) && doc[key].is_array())
                    for (const auto& b : doc[key]) {
                        const std::string uri = b.is_object() ? b.value("uri", std::string()) : std::string();
                        if (uri.empty() || uri.rfind("data:", 0) == 0) continue;
                        std::error_code ec;
                        const auto size = fs::file_size(file.parent_path() / uri, ec);
                        if (!ec) bytes.resize(bytes.size() + size_t(size), 0);
                    }
    }
    row.bytes = bytes.size();
    // Baseline: copying the file's bytes once, in memory (median of many, it is short).
    std::vector<char> dst(bytes.size());
    row.memcpy_s = median_seconds(std::max(repeat, 25), [&] {
        std::memcpy(dst.data(), bytes.data(), bytes.size());
        do_not_optimize(dst.data());
    });
    Scene scene;
    PeakMemory peak;
    row.load_s = median_seconds(repeat, [&] {
        Scene s;
        require_ok(load_scene(s, file.string()), file.string());
        scene = std::move(s);
    });
    for (const auto& m : scene.meshes)
        for (const auto& p : m.primitives) row.triangles += p.triangle_count();
    const fs::path out = tmp / (row.name + ".glb");
    row.save_s = median_seconds(repeat, [&] { require_ok(save_scene(scene, out.string()), out.string()); });
    row.peak_mib = peak.peak_mib();
    Scene back;
    require_ok(load_scene(back, out.string()), out.string());
    row.roundtrip_max_error = max_position_error(scene, back);
    fs::remove(out);
    return row;
}

} // namespace

nlohmann::json run_bench_io(const BenchArgs& args, const GlobalFlags& g, bool tables) {
    std::vector<fs::path> files = collect_bench_inputs(args, {".glb", ".gltf", ".obj", ".ply", ".off", ".stl"});
    if (files.empty()) throw InputError("bench io", "no input models found (give files or folders)");
    fs::path tmp = fs::temp_directory_path() / ("furrow-bench-" + std::to_string(::getpid()));
    fs::create_directories(tmp);
    std::vector<IoRow> rows;
    for (const auto& f : files) {
        info(g, "bench io: " + f.string());
        rows.push_back(bench_one(f, tmp, args.repeat));
    }
    fs::remove_all(tmp);

    Table t({"model", "input KiB", "triangles", "load ms", "save ms", "memcpy us", "load/memcpy", "save/memcpy",
             "load MB/s", "peak MiB", "roundtrip max|dp|"});
    nlohmann::json j = nlohmann::json::array();
    std::vector<PlotPoint> points;
    for (const auto& r : rows) {
        t.add({r.name, fmt(r.bytes / 1024.0, 1), std::to_string(r.triangles), fmt(r.load_s * 1e3, 2), fmt(r.save_s * 1e3, 2),
               fmt(r.memcpy_s * 1e6, 2), fmt(r.load_s / r.memcpy_s, 0), fmt(r.save_s / r.memcpy_s, 0),
               fmt(r.bytes / r.load_s / 1e6, 1), fmt(r.peak_mib, 1), fmt_sci(r.roundtrip_max_error)});
        j.push_back({{"model", r.name},
                     {"bytes", r.bytes},
                     {"triangles", r.triangles},
                     {"load_s", r.load_s},
                     {"save_s", r.save_s},
                     {"memcpy_s", r.memcpy_s},
                     {"load_over_memcpy", r.load_s / r.memcpy_s},
                     {"save_over_memcpy", r.save_s / r.memcpy_s},
                     {"peak_mib", r.peak_mib},
                     {"roundtrip_max_error", r.roundtrip_max_error}});
        points.push_back({"", "load", r.name, r.load_s, double(r.triangles), r.roundtrip_max_error});
        points.push_back({"", "save (GLB)", r.name, r.save_s, double(r.triangles), r.roundtrip_max_error});
    }
    if (tables) {
        std::printf("furrow bench io: load and save (GLB) per model, median of %d runs; baseline = memcpy of the "
                    "input's bytes (a .gltf with its .bin and image files) in this run; error = max |position change| after save + reload\n",
                    args.repeat);
        t.print();
    }
    return {{"bench", "io"}, {"repeat", args.repeat}, {"rows", j}, {"plot", plot_json("round-trip max |dp|", points)}};
}

nlohmann::json bench_io_default(const BenchRun& r, const GlobalFlags& g) {
    BenchArgs a;
    if (r.quick) a.inputs = {bundled_models_dir().string()};
    if (r.repeat > 0) a.repeat = r.repeat;
    return run_bench_io(a, g, r.tables);
}

void register_bench_io(CLI::App& bench, GlobalFlags& g) {
    auto args = std::make_shared<BenchArgs>();
    auto out = std::make_shared<BenchOutput>();
    CLI::App* io = bench.add_subcommand("io", "Load + save time per model, as a ratio to memcpy of its bytes");
    io->add_option("inputs", args->inputs, "Model files or folders (default: models/ and ../shared/corpus)");
    io->add_option("--repeat", args->repeat, "Runs per measurement; the median is reported (default 5)")
        ->check(finite_range(1, 1000));
    add_bench_output_flags(*io, *out);
    io->footer("Examples:\n  furrow bench io\n  furrow bench io ../shared/corpus --repeat 9 --json --plots plots");
    io->callback([args, out, &g] { finish_bench(run_bench_io(*args, g, !out->json), *out, g); });
}

} // namespace furrow::cli

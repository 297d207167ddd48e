// `furrow bench io`: load + save time per model as a ratio to memcpy of the same bytes, the load throughput
// (MB/s) per format, peak memory, the round-trip error, and `furrow convert` against gltfpack (an optional
// peer, run as a subprocess like furrow itself) on what gltfpack reads. Unless --quick, a generated ~100 MB
// OBJ grid (models/obj_grid.h) is one more row: text meshes of that size are what the loader is for.
#include "bench_common.h"
#include "data_dirs.h"
#include "cli_common.h"
#include "obj_grid.h"

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
    std::string name, format;
    size_t bytes = 0, triangles = 0;
    double load_s = 0, save_s = 0, memcpy_s = 0;
    double convert_s = -1, gltfpack_s = -1; // subprocess wall times; -1 = not run
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

// The format as the loader sees it: ASCII and binary PLY and STL are different parsers.
std::string format_of(const fs::path& file, const std::vector<char>& bytes) {
    const std::string ext = lower_extension(file.string()).substr(1);
    const std::string head(bytes.data(), std::min<size_t>(bytes.size(), 512));
    if (ext == "ply") return head.find("format ascii") != std::string::npos ? "ply ascii" : "ply binary";
    if (ext == "stl") {
        uint32_t n = 0;
        if (bytes.size() >= 84) std::memcpy(&n, bytes.data() + 80, 4);
        const bool binary = bytes.size() >= 84 && (head.rfind("solid", 0) != 0 || size_t(84) + size_t(n) * 50 == bytes.size());
        return binary ? "stl binary" : "stl ascii";
    }
    return ext;
}

// `furrow convert` (this executable) and gltfpack -noq, each a subprocess writing a GLB, on formats gltfpack
// reads. Seconds of wall time, median of `repeat`; -1 when not run.
void bench_convert(IoRow& row, const fs::path& file, const fs::path& tmp, int repeat, bool gltfpack) {
    const std::string ext = lower_extension(file.string());
    if (ext != ".obj" && ext != ".gltf" && ext != ".glb") return;
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    const std::string out = (tmp / "convert.glb").string();
    auto timed = [&](const std::vector<std::string>& argv) {
        int code = 0;
        const double s = median_seconds(repeat, [&] { code |= run_peer(argv); });
        return code == 0 ? s : -1.0;
    };
    if (!ec) row.convert_s = timed({self.string(), "convert", file.string(), "-o", out});
    if (gltfpack) row.gltfpack_s = timed({"gltfpack", "-i", file.string(), "-o", out, "-noq"});
    fs::remove(out, ec);
}

IoRow bench_one(const fs::path& file, const fs::path& tmp, int repeat, bool gltfpack) {
    IoRow row;
    row.name = file.filename().string();
    std::vector<char> bytes;
    {
        std::ifstream in(file, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    row.format = format_of(file, bytes);
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
    bench_convert(row, file, tmp, repeat, gltfpack);
    return row;
}


std::string ms_or_dash(double s) { return s < 0 ? "-" : fmt(s * 1e3, 1); }

nlohmann::json row_json(const IoRow& r) {
    const bool peer = r.convert_s > 0 && r.gltfpack_s > 0;
    return {{"model", r.name},
            {"format", r.format},
            {"bytes", r.bytes},
            {"triangles", r.triangles},
            {"load_s", r.load_s},
            {"load_mb_s", r.bytes / r.load_s / 1e6},
            {"save_s", r.save_s},
            {"memcpy_s", r.memcpy_s},
            {"load_over_memcpy", r.load_s / r.memcpy_s},
            {"save_over_memcpy", r.save_s / r.memcpy_s},
            {"peak_mib", r.peak_mib},
            {"roundtrip_max_error", r.roundtrip_max_error},
            {"convert_s", r.convert_s > 0 ? nlohmann::json(r.convert_s) : nlohmann::json()},
            {"gltfpack_s", r.gltfpack_s > 0 ? nlohmann::json(r.gltfpack_s) : nlohmann::json()},
            {"convert_over_gltfpack", peer ? nlohmann::json(r.convert_s / r.gltfpack_s) : nlohmann::json()}};
}

} // namespace

nlohmann::json run_bench_io(const BenchArgs& args, const GlobalFlags& g, bool tables, double generated_mb) {
    std::vector<fs::path> files = collect_bench_inputs(args, {".glb", ".gltf", ".obj", ".ply", ".off", ".stl"});
    if (files.empty() && generated_mb <= 0) throw InputError("bench io", "no input models found (give files or folders)");
    fs::path tmp = fs::temp_directory_path() / ("furrow-bench-" + std::to_string(::getpid()));
    fs::create_directories(tmp);
    const bool gltfpack = on_path("gltfpack");
    std::vector<IoRow> rows;
    for (const auto& f : files) {
        info(g, "bench io: " + f.string());
        rows.push_back(bench_one(f, tmp, args.repeat, gltfpack));
    }
    if (generated_mb > 0) {
        const int n = models::obj_grid_side_for_bytes(generated_mb * 1e6);
        const fs::path grid = tmp / ("grid_" + std::to_string(n) + ".obj");
        info(g, "bench io: generating " + grid.string());
        if (!models::write_obj_grid(grid.string(), n)) throw InputError(grid.string(), "cannot be written");
        rows.push_back(bench_one(grid, tmp, std::min(args.repeat, 2), gltfpack));
        rows.back().name = "generated " + rows.back().name;
    }
    fs::remove_all(tmp);

    Table t({"model", "format", "input KiB", "triangles", "load ms", "save ms", "memcpy us", "load/memcpy", "save/memcpy",
             "load MB/s", "peak MiB", "roundtrip max|dp|", "convert ms", "gltfpack ms", "convert/gltfpack"});
    nlohmann::json j = nlohmann::json::array();
    std::vector<PlotPoint> points;
    for (const auto& r : rows) {
        const bool peer = r.convert_s > 0 && r.gltfpack_s > 0;
        t.add({r.name, r.format, fmt(r.bytes / 1024.0, 1), std::to_string(r.triangles), fmt(r.load_s * 1e3, 2), fmt(r.save_s * 1e3, 2),
               fmt(r.memcpy_s * 1e6, 2), fmt(r.load_s / r.memcpy_s, 0), fmt(r.save_s / r.memcpy_s, 0),
               fmt(r.bytes / r.load_s / 1e6, 1), fmt(r.peak_mib, 1), fmt_sci(r.roundtrip_max_error), ms_or_dash(r.convert_s),
               ms_or_dash(r.gltfpack_s), peer ? fmt(r.convert_s / r.gltfpack_s, 2) : "-"});
        j.push_back(row_json(r));
        points.push_back({"", "load", r.name, r.load_s, double(r.triangles), r.roundtrip_max_error});
        points.push_back({"", "save (GLB)", r.name, r.save_s, double(r.triangles), r.roundtrip_max_error});
    }
    const std::string peer = gltfpack ? "gltfpack" : "peer not installed";
    if (tables) {
        const std::string generated_runs = generated_mb > 0 ? " (" + std::to_string(std::min(args.repeat, 2)) + " for the generated OBJ)" : "";
        std::printf("furrow bench io: load and save (GLB) per model, median of %d runs%s; baseline = memcpy of the input's bytes "
                    "(a .gltf with its .bin and image files) in this run; error = max |position change| after save + reload; "
                    "peak MiB = peak resident memory of load + save; convert and gltfpack -noq: wall time of each as a "
                    "subprocess on .obj/.gltf/.glb inputs (gltfpack: %s)\n",
                    args.repeat, generated_runs.c_str(), gltfpack ? "installed" : "peer not installed");
        t.print();
    }
    return {{"bench", "io"}, {"repeat", args.repeat}, {"peer", peer}, {"rows", j}, {"plot", plot_json("round-trip max |dp|", points)}};
}

nlohmann::json bench_io_default(const BenchRun& r, const GlobalFlags& g) {
    BenchArgs a;
    if (r.quick) a.inputs = {bundled_models_dir().string()};
    if (r.repeat > 0) a.repeat = r.repeat;
    return run_bench_io(a, g, r.tables, r.quick ? 0 : 100);
}

void register_bench_io(CLI::App& bench, GlobalFlags& g) {
    auto args = std::make_shared<BenchArgs>();
    auto out = std::make_shared<BenchOutput>();
    auto quick = std::make_shared<bool>(false);
    auto generated_mb = std::make_shared<double>(100);
    CLI::App* io = bench.add_subcommand("io", "Load + save time and MB/s per model, peak memory, convert against gltfpack");
    io->add_option("inputs", args->inputs, "Model files or folders (default: models/ and ../shared/corpus)");
    io->add_option("--repeat", args->repeat, "Runs per measurement; the median is reported (default 5)")
        ->check(finite_range(1, 1000));
    io->add_option("--generated-mb", *generated_mb, "Size of the generated OBJ grid row in MB (default 100; 0 = none)")
        ->check(finite_range(0, 200));
    io->add_flag("--quick", *quick, "No generated OBJ row");
    add_bench_output_flags(*io, *out);
    io->footer("Examples:\n  furrow bench io\n  furrow bench io --quick\n  furrow bench io ../shared/corpus --repeat 9 --json --plots plots");
    io->callback([args, out, quick, generated_mb, &g] {
        finish_bench(run_bench_io(*args, g, !out->json, *quick ? 0 : *generated_mb), *out, g);
    });
}

} // namespace furrow::cli

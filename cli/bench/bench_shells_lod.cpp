// `furrow bench shells`, LOD by simplification (FurOptions::lod_simplify_error, shells/src/simplify_lod.cpp):
// on one model, --lod K with the far levels' bases simplified at several error bounds, against the same LOD
// without simplification in the same run. Per setting: the triangles the shells add over all levels, the
// written file's bytes, the time of add_fur_shells (median) and its ratio to the unsimplified run, and per
// far level its base triangles and the measured two-sided surface distance to the full base (FurReport::
// lod_simplify_error, relative to the model's extent) next to the bound it had to meet.
#include "bench_common.h"

#include <furrow/shells.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <unistd.h>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

struct LodRow {
    double error = 0; // the bound asked for (0: off)
    double seconds = 0;
    size_t shell_triangles = 0, file_bytes = 0;
    FurReport report;
};

// Timed as `bench shells` times its rows: a fresh copy of the scene each run (not timed), the heap handed back
// first so that every run pays the first touch of its output as a new process does; run 0 is the warm-up.
LodRow lod_row(const Scene& base, const FurOptions& options, double error, int repeat, const fs::path& tmp) {
    LodRow row;
    row.error = error;
    FurOptions o = options;
    o.lod_simplify_error = error;
    Scene result;
    row.seconds = median_fresh_seconds(repeat, [&](int r) {
        Scene s = base;
        FurReport rep;
        const auto t0 = std::chrono::steady_clock::now();
        require_ok(add_fur_shells(s, o, &rep), "bench shells --lod-simplify");
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (r == repeat) result = std::move(s), row.report = std::move(rep);
        return seconds;
    });
    row.shell_triangles = row.report.shell_triangles;
    require_ok(save_scene(result, tmp.string()), tmp.string());
    row.file_bytes = size_t(fs::file_size(tmp));
    fs::remove(tmp);
    return row;
}

} // namespace

nlohmann::json bench_lod_simplify(const std::string& name, const Scene& base, const ImageF* mask, double length, int layers,
                                  int levels, int repeat, bool tables) {
    FurOptions o;
    o.shells.layers = layers;
    o.shells.length = length;
    o.shells.lod_levels = levels;
    if (mask) o.mask = *mask;
    const fs::path tmp = fs::temp_directory_path() / ("furrow_bench_lod_" + std::to_string(::getpid()) + ".glb");
    std::vector<LodRow> rows;
    for (double e : {0.0, 0.005, 0.01, 0.02}) rows.push_back(lod_row(base, o, e, repeat, tmp));
    std::vector<std::string> header{"model", "N", "levels", "error bound", "shell tris", "file MiB", "ms", "x off"};
    for (int k = 1; k < levels; ++k) {
        header.push_back("L" + std::to_string(k) + " base tris");
        header.push_back("L" + std::to_string(k) + " dist / bound");
    }
    Table t(header);
    nlohmann::json j = nlohmann::json::array();
    for (const LodRow& r : rows) {
        std::vector<std::string> cells{name, std::to_string(layers), std::to_string(levels), r.error > 0 ? fmt(r.error, 3) : "off",
                                       std::to_string(r.shell_triangles), fmt(double(r.file_bytes) / 1048576.0, 2),
                                       fmt(r.seconds * 1e3, 1), fmt(r.seconds / rows[0].seconds, 2)};
        nlohmann::json lv = nlohmann::json::array();
        for (int k = 1; k < levels; ++k) {
            const size_t tris = size_t(k) < r.report.lod_base_triangles.size() ? r.report.lod_base_triangles[size_t(k)] : 0;
            const double dist = size_t(k) < r.report.lod_simplify_error.size() ? r.report.lod_simplify_error[size_t(k)] : 0.0;
            const double bound = r.error * double(1 << (k - 1));
            cells.push_back(std::to_string(tris));
            cells.push_back(r.error > 0 ? fmt(dist, 4) + " / " + fmt(bound, 3) : "-");
            lv.push_back({{"level", k}, {"base_triangles", tris}, {"relative_distance", dist}, {"bound", bound}});
        }
        t.add(cells);
        j.push_back({{"model", name}, {"layers", layers}, {"levels", levels}, {"error_bound", r.error},
                     {"shell_triangles", r.shell_triangles}, {"file_bytes", r.file_bytes}, {"seconds", r.seconds},
                     {"over_off", r.seconds / rows[0].seconds}, {"far_levels", lv}});
    }
    if (tables) {
        std::printf("\nLOD by simplification (--lod %d --lod-simplify E, viewer layout, median of %d runs): far level k grows on "
                    "the base simplified within E x 2^(k-1) of the extent; shell tris = all levels; file = the written GLB; "
                    "x off = time against the same LOD without simplification; dist = measured two-sided surface distance "
                    "to the full base, relative to the extent\n",
                    levels, repeat);
        t.print();
    }
    return j;
}

} // namespace furrow::cli

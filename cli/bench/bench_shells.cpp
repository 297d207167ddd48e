// `furrow bench shells`: time of add_fur_shells per model and shell count, against a memcpy of the bytes it
// produces (same run), with the achieved offset measured against the requested one.
//
// The total is split as FurReport reports it: setup (once per base mesh: frames, clamps, the exact
// intersection test, vertex sets, albedo) and emission (the shell primitives: grows with N). Emission is
// what compares with a memcpy of the output; setup is a cost per base triangle that does not depend on N,
// so the total's ratio to memcpy falls roughly as 1/N and is largest for few shells on small meshes.
#include "bench_common.h"
#include "data_dirs.h"
#include "cli_common.h"
#include "lattice.h"

#include <furrow/shells.h>
#include <furrow_kernel/vec3.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <sstream>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

struct ShellsArgs {
    BenchArgs base;
    std::vector<int> layers{8, 32, 64};
    double relative_length = 0.02;   // fur length as a fraction of the model's bounding-box diagonal
    size_t max_samples = 200000;     // distance queries per row (vertices sampled evenly)
    int lattice = 0;                 // cells per axis of the generated non-manifold lattice row (0: none)
    bool lod_table = true;           // the LOD-by-simplification table on the first model
};

struct Row {
    std::string model;
    int layers = 0;
    size_t base_triangles = 0, out_triangles = 0, out_bytes = 0;
    double seconds = 0, memcpy_seconds = 0, peak_mib = 0;
    double setup_seconds = 0, emit_seconds = 0; // medians of FurReport's split
    double fresh_seconds = 0;                   // memcpy of the output bytes into memory just allocated
    double first_seconds = 0;                   // the untimed first call (strand textures not yet cached)
    double max_rel = 0, mean_rel = 0;
    double furred = 0; // the share of the base's area where the fur grows to >= 0.8 of the length asked
    double kept = 0;   // the share of the fur asked that grows (min(1, length / asked), area-weighted)
    size_t measured = 0, clamped = 0, welded = 0;
};

size_t primitive_bytes(const Primitive& p) {
    size_t b = (p.positions.size() + p.normals.size() + p.tangents.size() + p.uv0.size() + p.uv1.size() + p.colors.size() +
                p.weights.size()) * sizeof(float) +
               p.joints.size() * sizeof(uint16_t) + p.indices.size() * sizeof(uint32_t);
    for (const auto& t : p.targets) b += (t.position_deltas.size() + t.normal_deltas.size() + t.tangent_deltas.size()) * sizeof(float);
    for (const auto& c : p.custom) b += c.values.size() * sizeof(float);
    return b;
}

// Bytes that add_fur_shells appended: primitives beyond the original counts, new meshes, new images.
size_t added_bytes(const Scene& before, const Scene& after) {
    size_t b = 0;
    for (size_t m = 0; m < after.meshes.size(); ++m) {
        size_t first = m < before.meshes.size() ? before.meshes[m].primitives.size() : 0;
        for (size_t p = first; p < after.meshes[m].primitives.size(); ++p) b += primitive_bytes(after.meshes[m].primitives[p]);
    }
    for (size_t i = before.images.size(); i < after.images.size(); ++i) b += after.images[i].encoded.size();
    return b;
}

// Over the furred base's area (triangles where any fur is asked): the share where the fur grows to at least
// 0.8 of the length asked (furred; the threshold is refine_starved_faces' "starved"), and the share of the
// fur asked that grows (kept: min(1, length / asked), the measure refine_starved_faces' rounds converge on).
// What the clamps leave, and what refining starved faces wins back. Lengths interpolated over each triangle,
// sampled on a barycentric grid.
void furred_area(Row& row, const Scene& scene, const FurReport& rep) {
    double covered = 0, total = 0, kept = 0;
    constexpr int kGrid = 8;
    for (const auto& f : rep.frames) {
        const auto& P = scene.meshes[f.mesh].primitives[f.primitive].positions;
        for (size_t t = 0; t + 2 < f.triangles.size(); t += 3) {
            const uint32_t* c = &f.triangles[t];
            if (!(f.frame.requested[c[0]] > 0 || f.frame.requested[c[1]] > 0 || f.frame.requested[c[2]] > 0)) continue;
            const kernel::Vec3 a = kernel::point_at(P.data(), c[0]), b = kernel::point_at(P.data(), c[1]), d = kernel::point_at(P.data(), c[2]);
            const double area = 0.5 * kernel::norm(kernel::cross(b - a, d - a));
            if (!(area > 0) || !std::isfinite(area)) continue;
            const double w = area / double((kGrid + 1) * (kGrid + 2) / 2);
            for (int i = 0; i <= kGrid; ++i)
                for (int j = 0; i + j <= kGrid; ++j) {
                    const double b1 = double(i) / kGrid, b2 = double(j) / kGrid, b0 = 1 - b1 - b2;
                    const double len = b0 * f.frame.length[c[0]] + b1 * f.frame.length[c[1]] + b2 * f.frame.length[c[2]];
                    const double req = b0 * f.frame.requested[c[0]] + b1 * f.frame.requested[c[1]] + b2 * f.frame.requested[c[2]];
                    total += w;
                    covered += len >= 0.8 * req ? w : 0.0;
                    kept += req > 0 ? w * std::min(1.0, len / req) : 0.0;
                }
        }
    }
    row.furred = total > 0 ? covered / total : 0.0;
    row.kept = total > 0 ? kept / total : 0.0;
}

// Distance of sampled shell faces (their centroids) to the base surface vs the requested offset s·L·mask,
// over triangles no clamp touched (a clamped vertex is short on purpose). Faces, not vertices: the offset is
// even in the face planes' sense, so a convex corner's vertex stands farther out (√3·L on a cube) while
// every face around it is at L.
void measure(Row& row, const Scene& scene, const FurReport& rep, int layers, size_t max_samples) {
    auto usable = [](const ShellFrame& fr, const uint32_t* t) {
        for (int c = 0; c < 3; ++c)
            if (fr.flags[t[c]] != 0 || !(fr.requested[t[c]] > 0)) return false;
        return true;
    };
    size_t candidates = 0;
    for (const auto& f : rep.frames)
        for (size_t t = 0; t + 2 < f.triangles.size(); t += 3) candidates += usable(f.frame, &f.triangles[t]);
    const size_t total = candidates * size_t(layers);
    const size_t stride = std::max<size_t>(1, (total + max_samples - 1) / std::max<size_t>(max_samples, 1));
    double sum = 0, worst = 0;
    size_t count = 0, k = 0;
    for (const auto& f : rep.frames) {
        const Primitive& p = scene.meshes[f.mesh].primitives[f.primitive];
        std::vector<float> pts;
        std::vector<double> want;
        for (int i = 1; i <= layers; ++i) {
            const double s = shell_height_fraction(i, layers, 1.0);
            for (size_t t = 0; t + 2 < f.triangles.size(); t += 3) {
                const uint32_t* tri = &f.triangles[t];
                if (!usable(f.frame, tri) || k++ % stride) continue;
                double centroid[3] = {0, 0, 0}, requested = 0;
                for (int c = 0; c < 3; ++c) {
                    const size_t v = tri[c];
                    for (int a = 0; a < 3; ++a)
                        centroid[a] += (double(p.positions[3 * v + size_t(a)]) +
                                        f.frame.length[v] * s * double(f.frame.direction[3 * v + size_t(a)])) / 3;
                    requested += f.frame.requested[v] / 3;
                }
                for (double x : centroid) pts.push_back(float(x));
                want.push_back(s * requested);
            }
        }
        std::vector<double> d(want.size());
        distances_to_mesh(d.data(), pts.data(), want.size(), p.positions.data(), p.vertex_count(), f.triangles.data(), f.triangles.size());
        for (size_t i = 0; i < want.size(); ++i) {
            double e = std::abs(d[i] - want[i]) / want[i];
            sum += e;
            worst = std::max(worst, e);
            ++count;
        }
        row.clamped += f.frame.clamped_vertices;
        row.welded += f.frame.welded_vertices;
    }
    row.measured = count;
    row.max_rel = worst;
    row.mean_rel = count ? sum / double(count) : 0;
    furred_area(row, scene, rep);
}

// One row: `base` as loaded from `name` (a model file, or a generated scene), its fur mask if it has one.
Row bench_one(const std::string& name, const Scene& base, const ImageF* mask, int layers, const ShellsArgs& a) {
    Row row;
    row.model = name;
    row.layers = layers;
    const std::string file = name;
    FurOptions o;
    o.shells.layers = layers;
    o.shells.length = a.relative_length * bbox_diagonal(base);
    if (mask) o.mask = *mask;
    // Timed: add_fur_shells on a fresh copy of the loaded scene (the copy is not timed). Run 0 warms up (and
    // fills the strand-texture cache); the last run's scene and report are kept.
    std::vector<double> setup, emit;
    Scene result;
    FurReport rep;
    double peak = 0;
    row.seconds = median_fresh_seconds(a.base.repeat, [&](int r) {
        Scene s = base;
        FurReport rr;
        PeakMemory pm;
        auto t0 = std::chrono::steady_clock::now();
        Status st = add_fur_shells(s, o, &rr);
        auto t1 = std::chrono::steady_clock::now();
        peak = std::max(peak, pm.peak_mib());
        require_ok(st, file);
        const double seconds = std::chrono::duration<double>(t1 - t0).count();
        if (r == 0) row.first_seconds = seconds;
        else setup.push_back(rr.setup_seconds), emit.push_back(rr.emit_seconds);
        if (r == a.base.repeat) result = std::move(s), rep = std::move(rr);
        return seconds;
    });
    row.setup_seconds = median_of(setup);
    row.emit_seconds = median_of(emit);
    row.peak_mib = peak;
    row.base_triangles = rep.base_triangles;
    row.out_triangles = rep.shell_triangles;
    row.out_bytes = added_bytes(base, result);
    std::vector<char> src(row.out_bytes, 1), dst(row.out_bytes);
    row.memcpy_seconds = median_seconds(std::max(a.base.repeat, 9), [&] {
        std::memcpy(dst.data(), src.data(), src.size());
        do_not_optimize(dst.data());
    });
    // The same copy into memory just allocated, as the shells are written: the kernel maps and zeroes every
    // page on first touch, which the warm baseline above never pays and no producer of new output avoids.
    row.fresh_seconds = median_fresh_seconds(std::max(a.base.repeat, 5), [&](int) {
        auto t0 = std::chrono::steady_clock::now();
        std::unique_ptr<char[]> buffer(new char[std::max<size_t>(src.size(), 1)]);
        std::memcpy(buffer.get(), src.data(), src.size());
        do_not_optimize(buffer.get());
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    });
    // Accuracy from one more run that keeps the frames (not timed).
    Scene s = base;
    FurOptions keep = o;
    keep.keep_frames = true;
    FurReport fr;
    require_ok(add_fur_shells(s, keep, &fr), file);
    measure(row, s, fr, layers, a.max_samples); // s: its bases may have been refined (FurReport::refined_faces)
    return row;
}

// A bench model and its mask "<stem>_fur_mask.png" beside it, if there is one; false (said why) if unreadable.
bool load_model(const fs::path& f, Scene& base, ImageF& mask, bool& has_mask, const GlobalFlags& g) {
    has_mask = false;
    try {
        base = load_or_throw(f.string());
        const fs::path mask_file = f.parent_path() / (f.stem().string() + "_fur_mask.png");
        if (fs::exists(mask_file)) require_ok(load_png(mask, mask_file.string()), mask_file.string()), has_mask = true;
    } catch (const InputError& e) {
        info(g, "  skipped: " + e.file + ": " + e.what());
        return false;
    }
    return true;
}

nlohmann::json run_bench_shells(const ShellsArgs& a, const GlobalFlags& g, bool tables) {
    BenchArgs ba = a.base;
    if (ba.inputs.empty()) {
        fs::path creature = bundled_models_dir() / "creature.glb";
        if (fs::exists(creature)) ba.inputs.push_back(creature.string());
        if (fs::is_directory(corpus_dir().string())) ba.inputs.push_back(corpus_dir().string());
    }
    std::vector<fs::path> files = collect_bench_inputs(ba, {".glb", ".gltf", ".obj", ".ply", ".off", ".stl"});
    if (files.empty() && a.lattice <= 0) throw InputError("bench shells", "no input models found (give files or folders)");
    std::vector<Row> rows;
    for (const auto& f : files) {
        Scene base;
        ImageF mask;
        bool has_mask = false;
        if (!load_model(f, base, mask, has_mask, g)) continue;
        for (int n : a.layers) {
            info(g, "bench shells: " + f.string() + " N=" + std::to_string(n));
            try {
                rows.push_back(bench_one(f.filename().string(), base, has_mask ? &mask : nullptr, n, a));
            } catch (const InputError& e) {
                info(g, "  skipped: " + e.file + ": " + e.what());
            }
        }
    }
    if (a.lattice > 0) {
        // The generated non-manifold lattice (models/lattice.h): the intersection-heavy set-up case.
        const Scene base = make_scene(models::lattice_primitive(a.lattice), "lattice");
        const std::string name = "lattice" + std::to_string(a.lattice) + " (" + std::to_string(models::lattice_quad_count(a.lattice)) + " quads)";
        for (int n : a.layers) {
            info(g, "bench shells: " + name + " N=" + std::to_string(n));
            rows.push_back(bench_one(name, base, nullptr, n, a));
        }
    }
    Table t({"model", "N", "base tris", "out tris", "ms", "Mtri/s", "out MiB", "memcpy ms", "x memcpy", "setup ms", "setup us/tri", "emit ms",
             "emit x memcpy", "fresh ms", "emit x fresh", "1st call ms", "peak MiB", "max rel err", "mean rel err", "measured",
             "clamped", "furred area", "fur kept"});
    nlohmann::json j = nlohmann::json::array();
    std::vector<PlotPoint> points;
    for (const auto& r : rows) {
        const double ratio = r.seconds / r.memcpy_seconds;
        points.push_back({r.model, "shells", "N=" + std::to_string(r.layers), r.seconds, double(r.out_triangles), r.max_rel});
        t.add({r.model, std::to_string(r.layers), std::to_string(r.base_triangles), std::to_string(r.out_triangles),
               fmt(r.seconds * 1e3, 2), fmt(r.out_triangles / r.seconds / 1e6, 1), fmt(r.out_bytes / 1048576.0, 1),
               fmt(r.memcpy_seconds * 1e3, 3), fmt(ratio, 1), fmt(r.setup_seconds * 1e3, 2),
               fmt(r.base_triangles ? r.setup_seconds * 1e6 / double(r.base_triangles) : 0.0, 2), fmt(r.emit_seconds * 1e3, 2),
               fmt(r.emit_seconds / r.memcpy_seconds, 2), fmt(r.fresh_seconds * 1e3, 3), fmt(r.emit_seconds / r.fresh_seconds, 2),
               fmt(r.first_seconds * 1e3, 2), fmt(r.peak_mib, 1), fmt_sci(r.max_rel), fmt_sci(r.mean_rel),
               std::to_string(r.measured), std::to_string(r.clamped) + "/" + std::to_string(r.welded), fmt(r.furred, 3), fmt(r.kept, 3)});
        j.push_back({{"model", r.model}, {"layers", r.layers}, {"base_triangles", r.base_triangles},
                     {"out_triangles", r.out_triangles}, {"seconds", r.seconds}, {"out_bytes", r.out_bytes},
                     {"memcpy_seconds", r.memcpy_seconds}, {"over_memcpy", ratio}, {"setup_seconds", r.setup_seconds},
                     {"setup_us_per_base_triangle", r.base_triangles ? r.setup_seconds * 1e6 / double(r.base_triangles) : 0.0},
                     {"emit_seconds", r.emit_seconds}, {"emit_over_memcpy", r.emit_seconds / r.memcpy_seconds},
                     {"fresh_memcpy_seconds", r.fresh_seconds}, {"emit_over_fresh_memcpy", r.emit_seconds / r.fresh_seconds},
                     {"first_call_seconds", r.first_seconds}, {"peak_mib", r.peak_mib},
                     {"max_relative_error", r.max_rel}, {"mean_relative_error", r.mean_rel}, {"measured", r.measured},
                     {"clamped_vertices", r.clamped}, {"welded_vertices", r.welded}, {"furred_area", r.furred}, {"fur_kept", r.kept}});
    }
    if (tables) {
        std::printf("furrow bench shells: add_fur_shells (viewer layout) per model and N, median of %d runs on %d thread(s), "
                    "length = %.3g x bbox diagonal (creature: with its mask); baseline = memcpy (one thread, warm buffers) of "
                    "the output bytes in this run; ms = setup (per base mesh: frames, clamps, exact intersection test, "
                    "albedo; setup us/tri = setup / base triangles, after refinement) + emit (the N shells: compare this one with memcpy); fresh = the same memcpy into memory just "
                    "allocated (first-touch page faults, as any new output pays); 1st call = the warm-up run, which also "
                    "draws and encodes the strand textures (cached for later calls with the same options); error = | "
                    "distance of a shell face's centroid to the base surface (CGAL) - requested offset | / requested, over unclamped "
                    "vertices; furred area = the share of the furred base's area where the fur reaches 0.8 of the length asked; fur kept "
                    "= the share of the fur asked over that area that grows (min(1, length / asked), area-weighted)\n",
                    a.base.repeat, active_threads(), a.relative_length);
        t.print();
    }
    // LOD by simplification on the first model (bench_shells_lod.cpp), at the largest N, 3 levels. The model is
    // loaded again rather than kept from the loop above: holding it would add its size to every later row's peak.
    nlohmann::json lod = nlohmann::json::array();
    Scene first;
    ImageF first_mask;
    bool first_has_mask = false;
    if (a.lod_table && !files.empty() && load_model(files[0], first, first_mask, first_has_mask, g)) {
        info(g, "bench shells: " + files[0].string() + " LOD by simplification");
        lod = bench_lod_simplify(files[0].filename().string(), first, first_has_mask ? &first_mask : nullptr,
                                 a.relative_length * bbox_diagonal(first), *std::max_element(a.layers.begin(), a.layers.end()), 3,
                                 a.base.repeat, tables);
    }
    return {{"bench", "shells"}, {"repeat", a.base.repeat}, {"relative_length", a.relative_length},
            {"threads", active_threads()}, {"rows", j},
            {"lod_simplify", lod},
            {"plot", plot_json("max relative offset error", points)}};
}

} // namespace

nlohmann::json bench_shells_default(const BenchRun& r, const GlobalFlags& g) {
    ShellsArgs a;
    a.base.repeat = r.repeat > 0 ? r.repeat : 3;
    if (r.quick) {
        a.base.inputs = {(bundled_models_dir() / "creature.glb").string()};
        a.layers = {8, 32};
    }
    return run_bench_shells(a, g, r.tables);
}

void register_bench_shells(CLI::App& bench, GlobalFlags& g) {
    auto a = std::make_shared<ShellsArgs>();
    auto out = std::make_shared<BenchOutput>();
    a->base.repeat = 3;
    CLI::App* cmd = bench.add_subcommand("shells", "Fur shells per model and N: time vs memcpy of the output, achieved offset");
    cmd->add_option("inputs", a->base.inputs, "Model files or folders (default: models/creature.glb and ../shared/corpus)");
    cmd->add_option("--layers", a->layers, "Shell counts to run (default 8 32 64)")->check(finite_range(1, 256))->delimiter(',');
    cmd->add_option("--relative-length", a->relative_length, "Fur length as a fraction of the bbox diagonal (default 0.02)")
        ->check(finite_range(1e-6, 1.0));
    cmd->add_option("--lattice", a->lattice, "Also a generated non-manifold lattice of this many cells per axis (25: 48750 quads, "
                                             "the issue's case; default 0: none)")->check(finite_range(0, 64));
    cmd->add_option("--repeat", a->base.repeat, "Timed runs per row; the median is reported (default 3)")->check(finite_range(1, 1000));
    cmd->add_flag("!--no-lod-table", a->lod_table,
                  "Leave out the LOD-by-simplification table (--lod 3 --lod-simplify off/0.005/0.01/0.02 on the first model)");
    add_bench_output_flags(*cmd, *out);
    cmd->footer("Examples:\n  furrow bench shells\n  furrow bench shells models/creature.glb --layers 16,128 --repeat 5 --json\n"
                "  furrow bench shells --lattice 25 --layers 8");
    cmd->callback([a, out, &g] { finish_bench(run_bench_shells(*a, g, !out->json), *out, g); });
}

} // namespace furrow::cli

// `furrow bench render`: frame time and triangles/s of the verification rasterizer on a shell asset of about
// two million triangles at 1920×1080, as a ratio to merely transforming the same vertices (measured in the
// same run), per thread count; plus the determinism check (identical pixels for every thread count); and speed
// against image error: supersampling 1..3 against a 4x4-supersampled reference of the same frame (mean absolute
// difference of the 8-bit sRGB channels, in 1/255 steps); and fur in real viewers: the demo's fur asset at the
// demo's view, half and twice its distance, with the coverage furrow render predicts for a mip-mapping viewer
// and, where three.js is installed (bash .ci/install-deps --tests), what three.js draws of the same view.
#include "bench_common.h"
#include "data_dirs.h"

#include <furrow/render.h>
#include <furrow/shells.h>

#include <tbb/global_control.h>

#include <cmath>
#include <fstream>
#include <thread>
#include <unistd.h>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

struct RenderBenchArgs {
    std::string input;   // default: models/creature.glb with shells
    int layers = 128;    // shells grown on the input (0 = render the input as it is)
    int width = 1920, height = 1080;
    int repeat = 3;
    bool quick = false; // the SSAA sweep and the fur views at a quarter of the pixels
    std::string three;  // the repository (tests/viewer/render_three.mjs, .cache/viewer); default: the current folder
};

// One render at 8 bits per channel, as a PNG or a viewer's canvas holds it.
ImageF render8(const Scene& scene, const RenderOptions& o, const std::string& input, double* seconds = nullptr,
               int repeat = 1) {
    RenderResult r;
    const double s = median_seconds(repeat, [&] { require_ok(render_scene(r, scene, o), input); });
    if (seconds) *seconds = s;
    ImageF im{r.color.width, r.color.height, 4, std::vector<float>(r.rgba8.size())};
    for (size_t i = 0; i < r.rgba8.size(); ++i) im.pixels[i] = float(r.rgba8[i]) / 255.0f;
    return im;
}

// The fur views: the demo's creature with its fur (models/scene.json's camera), at 0.5, 1 and 2 times the
// distance. Coverage = cutoff_coverage (render.h) against a 2×-supersampled render without mipmaps.
nlohmann::json fur_distance_rows(const RenderBenchArgs& a, const GlobalFlags& g, bool tables) {
    const fs::path models(bundled_models_dir().string());
    const std::string input = (models / "creature.glb").string();
    Scene scene = load_or_throw(input);
    FurOptions fo;
    fo.shells.layers = 32;
    fo.shells.length = 0.04;
    require_ok(load_png(fo.mask, (models / "creature_fur_mask.png").string()), "creature_fur_mask.png");
    require_ok(add_fur_shells(scene, fo), input);
    const std::array<double, 3> eye{1.6, 1.1, 2.2}, target{0, 0.45, 0};
    const double factors[3] = {0.5, 1.0, 2.0};
    auto view = [&](double f, int scale, RenderMode mode, bool mipmaps) {
        RenderOptions o;
        o.width = (a.quick ? 480 : 960) * scale;
        o.height = (a.quick ? 360 : 720) * scale;
        o.camera.eye = std::array<double, 3>{target[0] + f * (eye[0] - target[0]), target[1] + f * (eye[1] - target[1]),
                                             target[2] + f * (eye[2] - target[2])};
        o.camera.target = target;
        o.camera.fov_degrees = 40;
        o.camera.near_plane = 0.05 * std::min(1.0, f);
        o.mode = mode;
        o.ambient = 1; // unlit: the material colour, comparable with three.js's MeshBasicMaterial
        o.mipmaps = mipmaps;
        o.subpixel_bits = 4; // as SwiftShader, which three.js runs on here
        return o;
    };

    // three.js in headless Chromium, when the repository's viewer harness and its npm packages are there.
    const fs::path root = a.three.empty() ? fs::current_path() : fs::path(a.three);
    const fs::path script = root / "tests/viewer/render_three.mjs", modules = root / ".cache/viewer";
    std::string three_status = "not installed (run from the repository after bash .ci/install-deps --tests, or --three DIR)";
    std::vector<ImageF> three; // per distance: material, coverage, reference
    if (fs::exists(script) && fs::exists(modules / "node_modules/three/package.json")) {
        const fs::path tmp = fs::temp_directory_path() / ("furrow-bench-render-" + std::to_string(getpid()));
        fs::create_directories(tmp);
        require_ok(save_scene(scene, (tmp / "fur.glb").string()), (tmp / "fur.glb").string());
        nlohmann::json jobs = nlohmann::json::array();
        for (int k = 0; k < 3; ++k)
            for (int j = 0; j < 3; ++j) {
                const RenderOptions o = view(factors[k], j == 2 ? 2 : 1, RenderMode::shaded, true);
                jobs.push_back({{"model", (tmp / "fur.glb").string()}, {"out", (tmp / (std::to_string(3 * k + j) + ".png")).string()},
                                {"width", o.width}, {"height", o.height}, {"eye", *o.camera.eye}, {"target", target},
                                {"fov", 40}, {"near", o.camera.near_plane}, {"far", 1000},
                                {"mode", j == 0 ? "material" : "coverage"}, {"mipmaps", j == 2 ? "off" : "sampler"}});
            }
        std::ofstream(tmp / "jobs.json") << jobs.dump();
        const int code = run_peer({"node", script.string(), "--modules", modules.string(), (tmp / "jobs.json").string()});
        if (code == 0) {
            three_status = "three.js r170 in headless Chromium (SwiftShader)";
            for (int i = 0; i < 9; ++i) {
                ImageF im;
                require_ok(load_png(im, (tmp / (std::to_string(i) + ".png")).string()), "three.js render");
                three.push_back(std::move(im));
            }
        } else {
            three_status = "failed (render_three.mjs exit " + std::to_string(code) + ")";
        }
        std::error_code ec;
        fs::remove_all(tmp, ec);
    }

    Table t({"distance", "pixels", "frame ms", "coverage", "height cov", "three.js cov", "three.js height",
             "IoU vs three.js", "colour |d| (1/255)"});
    nlohmann::json rows = nlohmann::json::array();
    for (int k = 0; k < 3; ++k) {
        double seconds = 0;
        const RenderOptions o = view(factors[k], 1, RenderMode::shaded, true);
        const ImageF shaded = render8(scene, o, input, &seconds, a.repeat);
        const CutoffCoverage ours = cutoff_coverage(render8(scene, view(factors[k], 1, RenderMode::cutoff, true), input));
        const CutoffCoverage ref = cutoff_coverage(render8(scene, view(factors[k], 2, RenderMode::cutoff, false), input));
        nlohmann::json row{{"distance", factors[k]}, {"frame_s", seconds}, {"coverage", ours.covered / ref.covered},
                           {"height_coverage", ours.height / ref.height}};
        std::vector<std::string> cells{"x" + fmt(factors[k], 1), std::to_string(o.width) + "x" + std::to_string(o.height),
                                       fmt(seconds * 1e3, 1), fmt(ours.covered / ref.covered, 3), fmt(ours.height / ref.height, 3)};
        if (three.empty()) {
            cells.insert(cells.end(), {"-", "-", "-", "-"});
        } else {
            const ImageF& mat = three[size_t(3 * k)];
            const CutoffCoverage tc = cutoff_coverage(three[size_t(3 * k + 1)]), tr = cutoff_coverage(three[size_t(3 * k + 2)]);
            const double iou = mask_iou(silhouette_mask(mat), silhouette_mask(shaded));
            const double colour = 255 * mean_covered_difference(mat, shaded);
            cells.insert(cells.end(), {fmt(tc.covered / tr.covered, 3), fmt(tc.height / tr.height, 3), fmt(iou, 4), fmt(colour, 2)});
            row.update({{"three_coverage", tc.covered / tr.covered}, {"three_height_coverage", tc.height / tr.height},
                        {"iou_three", iou}, {"colour_diff_255", colour}});
        }
        t.add(cells);
        rows.push_back(row);
    }
    if (tables) {
        std::printf("\nFur in real viewers: the demo's fur (32 shells) at the demo's view ×0.5, ×1, ×2; coverage = "
                    "shell pixels (height cov: weighted by shell height) against a 2x-supersampled render without "
                    "mipmaps; frame = furrow render, one sample per pixel; three.js: %s\n", three_status.c_str());
        t.print();
    }
    return {{"three", three_status}, {"rows", rows}};
}

// The baseline: every vertex of every drawn primitive through a 4×4 matrix into clip space (float4), one
// thread, the least any rasterizer must do.
double transform_seconds(const Scene& scene, int repeat) {
    const auto world = scene.world_matrices();
    std::vector<std::pair<const Primitive*, std::array<double, 16>>> items;
    size_t n = 0;
    for (size_t i = 0; i < scene.nodes.size(); ++i) {
        if (scene.nodes[i].mesh < 0) continue;
        for (const auto& p : scene.meshes[size_t(scene.nodes[i].mesh)].primitives) {
            items.push_back({&p, world[i]});
            n = std::max(n, p.vertex_count());
        }
    }
    std::vector<float> clip(n * 4);
    return median_seconds(repeat, [&] {
        for (const auto& [p, m] : items) {
            float f[16];
            for (int k = 0; k < 16; ++k) f[k] = float(m[size_t(k)]);
            const float* v = p->positions.data();
            for (size_t i = 0, c = p->vertex_count(); i < c; ++i) {
                const float x = v[i * 3], y = v[i * 3 + 1], z = v[i * 3 + 2];
                for (int r = 0; r < 4; ++r) clip[i * 4 + size_t(r)] = f[r] * x + f[4 + r] * y + f[8 + r] * z + f[12 + r];
            }
            do_not_optimize(clip.data());
        }
    });
}

nlohmann::json run(const RenderBenchArgs& a, const GlobalFlags& g, bool tables) {
    const std::string input = a.input.empty() ? (bundled_models_dir() / "creature.glb").string() : a.input;
    Scene scene = load_or_throw(input);
    if (a.layers > 0) {
        FurOptions fo;
        fo.shells.layers = a.layers;
        fo.shells.length = 0.04;
        FurReport rep;
        require_ok(add_fur_shells(scene, fo, &rep), input);
    }
    size_t tris = 0, verts = 0;
    for (const auto& m : scene.meshes)
        for (const auto& p : m.primitives) tris += p.triangle_count(), verts += p.vertex_count();
    info(g, "bench render: " + std::to_string(tris) + " triangles, " + std::to_string(verts) + " vertices");

    const double t_transform = transform_seconds(scene, std::max(a.repeat, 5));
    RenderOptions ro;
    ro.width = a.width;
    ro.height = a.height;
    const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
    std::vector<int> threads{1};
    if (cores > 1) threads.push_back(cores);
    Table t({"threads", "triangles", "pixels", "frame ms", "vertex ms", "setup ms", "raster ms", "Mtri/s",
             "frame/transform", "identical pixels"});
    nlohmann::json rows = nlohmann::json::array();
    std::vector<uint8_t> reference;
    for (int asked : threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(asked));
        const int n = active_threads(); // what the row runs with (a global -j 1 caps it)
        RenderResult r;
        const double s = median_seconds(a.repeat, [&] { require_ok(render_scene(r, scene, ro), input); });
        if (reference.empty()) reference = r.rgba8;
        const bool same = r.rgba8 == reference;
        t.add({std::to_string(n), std::to_string(r.triangles), std::to_string(a.width) + "x" + std::to_string(a.height),
               fmt(s * 1e3, 1), fmt(r.timing.vertices, 1), fmt(r.timing.setup, 1), fmt(r.timing.raster, 1),
               fmt(double(r.triangles) / s / 1e6, 2), fmt(s / t_transform, 1), same ? "yes" : "NO"});
        rows.push_back({{"threads", n}, {"triangles", r.triangles}, {"frame_s", s}, {"vertices_ms", r.timing.vertices},
                        {"setup_ms", r.timing.setup}, {"raster_ms", r.timing.raster},
                        {"triangles_per_s", double(r.triangles) / s}, {"frame_over_transform", s / t_transform},
                        {"identical", same}});
    }

    // Speed against error: supersampling levels against a 4x4 reference, at a smaller frame (the reference
    // has 16 samples per pixel).
    RenderOptions so = ro;
    so.width = a.quick ? 480 : 960;
    so.height = a.quick ? 270 : 540;
    so.ssaa = 4;
    RenderResult ref;
    const auto ref_start = std::chrono::steady_clock::now();
    require_ok(render_scene(ref, scene, so), input); // one frame: it is the slowest and only a yardstick
    const double t_ref = std::chrono::duration<double>(std::chrono::steady_clock::now() - ref_start).count();
    Table ts({"ssaa", "frame", "frame ms", "ms/reference", "mean |d| (1/255)", "max-channel pixels > 8/255 %"});
    nlohmann::json ssaa_rows = nlohmann::json::array();
    std::vector<PlotPoint> points;
    for (int level : {1, 2, 3}) {
        so.ssaa = level;
        RenderResult r;
        const double s = median_seconds(a.repeat, [&] { require_ok(render_scene(r, scene, so), input); });
        const double mad = mean_absolute_difference(r.color, ref.color) * 255.0;
        size_t off = 0, n = size_t(r.color.width) * size_t(r.color.height);
        for (size_t i = 0; i < n; ++i) {
            float d = 0;
            for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(r.color.pixels[i * 4 + size_t(c)] - ref.color.pixels[i * 4 + size_t(c)]));
            off += d * 255.0f > 8.0f;
        }
        ts.add({std::to_string(level), std::to_string(so.width) + "x" + std::to_string(so.height), fmt(s * 1e3, 1), fmt(s / t_ref, 3),
                fmt(mad, 3), fmt(100.0 * double(off) / double(n), 2)});
        ssaa_rows.push_back({{"ssaa", level}, {"seconds", s}, {"over_reference", s / t_ref}, {"mean_abs_diff_255", mad},
                             {"pixels_off_pct", 100.0 * double(off) / double(n)}});
        points.push_back({"", "ssaa 1..3 vs 4x4 reference", "ssaa " + std::to_string(level), s, double(r.triangles), mad});
    }
    if (tables) {
        std::printf("furrow bench render: %s with %d shells, %zu triangles at %dx%d, median of %d frames; baseline = "
                    "transforming all %zu vertices to clip space on one thread: %.2f ms\n",
                    fs::path(input).filename().string().c_str(), a.layers, tris, a.width, a.height, a.repeat, verts,
                    t_transform * 1e3);
        t.print();
        std::printf("\nSpeed against error: supersampling levels against a 4x4-supersampled reference frame (%.1f ms); error = "
                    "mean |difference| of the sRGB channels\n", t_ref * 1e3);
        ts.print();
    }
    nlohmann::json fur = fur_distance_rows(a, g, tables);
    return {{"bench", "render"}, {"input", input}, {"layers", a.layers}, {"transform_s", t_transform}, {"rows", rows},
            {"ssaa", ssaa_rows}, {"reference_s", t_ref}, {"fur_views", fur}, {"plot", plot_json("mean |d| (1/255)", points)}};
}

} // namespace

nlohmann::json bench_render_default(const BenchRun& r, const GlobalFlags& g) {
    RenderBenchArgs a;
    if (r.quick) a.layers = 32, a.width = 960, a.height = 540, a.quick = true;
    if (r.repeat > 0) a.repeat = r.repeat;
    return run(a, g, r.tables);
}

void register_bench_render(CLI::App& bench, GlobalFlags& g) {
    auto a = std::make_shared<RenderBenchArgs>();
    auto out = std::make_shared<BenchOutput>();
    CLI::App* c = bench.add_subcommand("render", "Rasterizer frame time and triangles/s vs transforming the vertices");
    c->add_option("input", a->input, "Scene to render (default: models/creature.glb)");
    c->add_option("--layers", a->layers, "Fur shells grown on the input first (default 128, about 2M triangles "
                                         "on the creature; 0 = none)")
        ->check(finite_range(0, 256));
    c->add_option("--repeat", a->repeat, "Frames per measurement; the median is reported (default 3)")
        ->check(finite_range(1, 100));
    c->add_option("--three", a->three, "The furrow repository, for the three.js comparison of the fur views "
                                       "(tests/viewer, .cache/viewer; default: the current folder)");
    add_bench_output_flags(*c, *out);
    c->footer("Examples:\n  furrow bench render\n  furrow bench render scene.glb --layers 0");
    c->callback([a, out, &g] { finish_bench(run(*a, g, !out->json), *out, g); });
}

} // namespace furrow::cli

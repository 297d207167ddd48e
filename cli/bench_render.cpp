// `furrow bench render`: frame time and triangles/s of the verification rasterizer on a shell asset of about
// two million triangles at 1920×1080, as a ratio to merely transforming the same vertices (measured in the
// same run), per thread count; plus the determinism check (identical pixels for every thread count).
#include "bench_common.h"

#include <furrow/render.h>
#include <furrow/shells.h>

#include <tbb/global_control.h>

#include <cmath>
#include <thread>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

struct RenderBenchArgs {
    std::string input;   // default: models/creature.glb with shells
    int layers = 128;    // shells grown on the input (0 = render the input as it is)
    int width = 1920, height = 1080;
    int repeat = 3;
    bool json = false;
};

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

void run(const RenderBenchArgs& a, const GlobalFlags& g) {
    const std::string input = a.input.empty() ? (fs::path(FURROW_MODELS_DIR) / "creature.glb").string() : a.input;
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
    for (int n : threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(n));
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
    if (a.json) {
        std::printf("%s\n", nlohmann::json{{"bench", "render"}, {"input", input}, {"layers", a.layers},
                                           {"transform_s", t_transform}, {"rows", rows}}
                                .dump(2)
                                .c_str());
        return;
    }
    std::printf("furrow bench render: %s with %d shells, %zu triangles at %dx%d, median of %d frames; baseline = "
                "transforming all %zu vertices to clip space on one thread: %.2f ms\n",
                fs::path(input).filename().string().c_str(), a.layers, tris, a.width, a.height, a.repeat, verts,
                t_transform * 1e3);
    t.print();
}

} // namespace

void register_bench_render(CLI::App& bench, GlobalFlags& g) {
    auto a = std::make_shared<RenderBenchArgs>();
    CLI::App* c = bench.add_subcommand("render", "Rasterizer frame time and triangles/s vs transforming the vertices");
    c->add_option("input", a->input, "Scene to render (default: models/creature.glb)");
    c->add_option("--layers", a->layers, "Fur shells grown on the input first (default 128, about 2M triangles "
                                         "on the creature; 0 = none)")
        ->check(CLI::Range(0, 256));
    c->add_option("--repeat", a->repeat, "Frames per measurement; the median is reported (default 3)")
        ->check(CLI::Range(1, 100));
    c->add_flag("--json", a->json, "Print one JSON object instead of the table");
    c->footer("Examples:\n  furrow bench render\n  furrow bench render scene.glb --layers 0");
    c->callback([a, &g] { run(*a, g); });
}

} // namespace furrow::cli

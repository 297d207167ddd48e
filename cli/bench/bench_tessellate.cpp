// `furrow bench tessellate`: triangles, time and error of each rate criterion, and the triangle count each
// needs to reach the same maximum projected error — uniform rates and the seed's distance formula being the
// in-run baselines.
//
// Error = chordal distance to the limit surface sampled at every output triangle's centroid and edge
// midpoints (Tessellator::measure), as % of the bounding-box diagonal (Metro convention), and in pixels
// (distance x focal length / distance to the eye) for a 1920 x 1080 view with a 50 degree vertical field.
//
// Peer: Blender's Subdivision Surface modifier (Catmull-Clark, levels 2 and 3) against uniform rates 4 and 8
// on the same OBJ (by default the generated 32k-quad cube sphere of models/obj_quad_sphere.h), both cold:
// furrow's prepare + tessellate against Blender's first evaluation of a newly added modifier (its topology
// refiner is built there too), timed inside Blender so that start-up and the import are excluded.
#include "bench_common.h"
#include "data_dirs.h"
#include "obj_quad_sphere.h"

#include <furrow/shapes.h>
#include <furrow/tessellate.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include <unistd.h>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

struct BenchModel {
    std::string name;
    Primitive primitive;
    SubdivisionScheme scheme = SubdivisionScheme::catmark;
    TessellationCamera camera;
    double near = 0, far = 1; // nearest and farthest control point from the eye (the seed's near/far)
    double diagonal = 1;
};

// Deterministic value noise (integer hash, smoothstep), 4 octaves: rolling hills for the terrain patch.
double value_noise(double x, double z) {
    auto hash = [](int i, int j) {
        uint32_t h = uint32_t(i) * 374761393u + uint32_t(j) * 668265263u;
        h = (h ^ (h >> 13)) * 1274126177u;
        return double(h ^ (h >> 16)) / 4294967295.0;
    };
    double sum = 0, amplitude = 1, frequency = 1;
    for (int octave = 0; octave < 4; ++octave) {
        const double fx = x * frequency, fz = z * frequency;
        const int i = int(std::floor(fx)), j = int(std::floor(fz));
        double u = fx - i, v = fz - j;
        u = u * u * (3 - 2 * u);
        v = v * v * (3 - 2 * v);
        const double a = hash(i, j), b = hash(i + 1, j), c = hash(i, j + 1), d = hash(i + 1, j + 1);
        sum += amplitude * ((a * (1 - u) + b * u) * (1 - v) + (c * (1 - u) + d * u) * v);
        amplitude *= 0.5;
        frequency *= 2.0;
    }
    return sum;
}

void finish_model(BenchModel& m, std::array<double, 3> eye) {
    const auto& p = m.primitive.positions;
    std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    m.near = INFINITY;
    m.far = 0;
    for (size_t v = 0; v < p.size() / 3; ++v) {
        double d2 = 0;
        for (int k = 0; k < 3; ++k) {
            lo[size_t(k)] = std::min(lo[size_t(k)], double(p[v * 3 + size_t(k)]));
            hi[size_t(k)] = std::max(hi[size_t(k)], double(p[v * 3 + size_t(k)]));
            d2 += (p[v * 3 + size_t(k)] - eye[size_t(k)]) * (p[v * 3 + size_t(k)] - eye[size_t(k)]);
        }
        m.near = std::min(m.near, std::sqrt(d2));
        m.far = std::max(m.far, std::sqrt(d2));
    }
    m.diagonal = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
    m.camera = TessellationCamera{eye, 50.0, 1080};
}

// A 20 x 20 m terrain patch of 32 x 32 quads (Catmull-Clark), eye 1.5 m above one corner.
BenchModel terrain_patch() {
    BenchModel m;
    m.name = "terrain 32x32 (catmark)";
    m.primitive = shapes::quad_grid(20, 20, 32, 32);
    auto& p = m.primitive.positions;
    for (size_t v = 0; v < p.size() / 3; ++v) p[v * 3 + 1] = float(2.0 * value_noise(p[v * 3] / 5.0 + 7.3, p[v * 3 + 2] / 5.0 + 2.1));
    m.scheme = SubdivisionScheme::catmark;
    finish_model(m, {-9.5, 2.5, -9.5});
    return m;
}

// A closed model seen from one bounding-box diagonal in front (+z) and a little above.
bool file_model(BenchModel& m, const fs::path& file) {
    Scene s;
    if (!load_scene(s, file.string()).ok()) return false;
    const Primitive* best = nullptr;
    for (const auto& mesh : s.meshes)
        for (const auto& p : mesh.primitives)
            if (p.mode == PrimitiveMode::triangles && (!best || p.face_count() > best->face_count())) best = &p;
    if (!best) return false;
    m.primitive = *best;
    m.primitive.targets.clear();
    bool quads = false;
    for (uint32_t n : m.primitive.face_sizes) quads |= n != 3;
    m.scheme = quads ? SubdivisionScheme::catmark : SubdivisionScheme::loop;
    m.name = file.filename().string() + (quads ? " (catmark)" : " (loop)");
    CheckReport r = check_primitive(m.primitive);
    std::array<double, 3> c{(r.bbox_min[0] + r.bbox_max[0]) / 2, (r.bbox_min[1] + r.bbox_max[1]) / 2,
                            (r.bbox_min[2] + r.bbox_max[2]) / 2};
    finish_model(m, {c[0], c[1] + 0.3 * r.diagonal, c[2] + r.diagonal});
    return true;
}

TessellateInput input_of(const Primitive& p) {
    TessellateInput in;
    in.positions = p.positions.data();
    in.vertex_count = p.vertex_count();
    in.indices = p.indices.data();
    in.index_count = p.indices.size();
    if (!p.face_sizes.empty()) {
        in.face_sizes = p.face_sizes.data();
        in.face_count = p.face_sizes.size();
    }
    return in;
}

struct Criterion {
    const char* name;
    // Rate options for one setting x of the criterion (bigger x = finer).
    std::function<RateOptions(double x)> options;
    std::function<std::string(double x)> label;
    std::vector<double> settings; // the table's settings
    std::vector<double> sweep;    // coarse to fine, for the matched comparison
};

std::vector<Criterion> criteria(const BenchModel& m) {
    auto base = [&] {
        RateOptions r;
        r.camera = m.camera;
        r.max_rate = 64;
        return r;
    };
    std::vector<Criterion> out;
    auto range = [](double from, double to, double factor) {
        std::vector<double> v;
        for (double x = from; factor > 1 ? x <= to * 1.0001 : x >= to * 0.9999; x *= factor) v.push_back(x);
        return v;
    };
    std::vector<double> ints;
    for (int i = 1; i <= 64; ++i) ints.push_back(i);
    out.push_back({"uniform",
                   [=](double x) {
                       RateOptions r = base();
                       r.uniform = int(x);
                       return r;
                   },
                   [](double x) { return "R=" + std::to_string(int(x)); }, {1, 2, 4, 8, 16}, ints});
    out.push_back({"distance (seed)",
                   [=](double x) {
                       RateOptions r = base();
                       r.distance = true;
                       r.near = m.near;
                       r.far = m.far;
                       r.max_rate = int(x);
                       return r;
                   },
                   [](double x) { return "tess=" + std::to_string(int(x)); }, {4, 8, 16, 32, 64}, ints});
    out.push_back({"pixel-error",
                   [=](double x) {
                       RateOptions r = base();
                       r.pixel_error = x;
                       return r;
                   },
                   [](double x) { return fmt(x, 2) + " px"; }, {16, 8, 4, 2, 1}, range(128, 0.1, 1 / 1.15)});
    out.push_back({"screen-error",
                   [=](double x) {
                       RateOptions r = base();
                       r.screen_error = x;
                       return r;
                   },
                   [](double x) { return fmt(x, 3) + " px"; }, {2, 1, 0.5, 0.25}, range(8, 0.01, 1 / 1.15)});
    const double d = m.diagonal;
    out.push_back({"max-error",
                   [=](double x) {
                       RateOptions r = base();
                       r.max_error = x * d;
                       return r;
                   },
                   [](double x) { return fmt_sci(x * 100) + "% diag"; }, {1e-2, 3e-3, 1e-3, 3e-4}, range(3e-2, 1e-6, 1 / 1.15)});
    return out;
}

struct Row {
    std::string model, criterion, setting;
    size_t triangles = 0;
    double seconds = 0, max_pct = 0, mean_pct = 0, max_px = 0;
    int max_rate = 0;
};

Row run_one(const Tessellator& t, const BenchModel& m, const Criterion& c, double x, int repeat) {
    Row row{m.name, c.name, c.label(x)};
    const RateOptions r = c.options(x);
    TessellateOutput out;
    Status s = t.tessellate(out, r, true);
    require_ok(s, m.name);
    ErrorReport e;
    require_ok(t.measure(e, out, r), m.name);
    row.triangles = out.stats.triangles;
    row.max_rate = out.stats.max_rate;
    row.max_pct = 100 * e.max_error / m.diagonal;
    row.mean_pct = 100 * e.mean_error / m.diagonal;
    row.max_px = e.max_pixels;
    if (repeat > 0)
        row.seconds = median_seconds(repeat, [&] {
            TessellateOutput o;
            require_ok(t.tessellate(o, r, false), m.name);
            do_not_optimize(o.indices.data());
        });
    return row;
}

// Imports the OBJ (argv after "--": result file, OBJ, repeat, levels...) and times, per level, the median of
// `repeat` first evaluations of a new Subdivision Surface modifier (one warm-up), with its triangle count.
const char* const blender_subsurf_script = R"PY(
import bpy, sys, time
argv = sys.argv[sys.argv.index("--") + 1:]
result, path, repeat, levels = argv[0], argv[1], int(argv[2]), [int(x) for x in argv[3:]]
bpy.ops.wm.read_factory_settings(use_empty=True)
if hasattr(bpy.ops.wm, "obj_import"):
    bpy.ops.wm.obj_import(filepath=path)
else:
    bpy.ops.import_scene.obj(filepath=path)
obj = bpy.context.selected_objects[0]
bpy.context.view_layer.objects.active = obj
bpy.context.evaluated_depsgraph_get()  # the imported mesh, evaluated once outside the timing
lines = []
for level in levels:
    times, tris = [], 0
    for r in range(repeat + 1):
        mod = obj.modifiers.new("subsurf", "SUBSURF")
        mod.subdivision_type = "CATMULL_CLARK"
        mod.levels = level
        mod.render_levels = level
        t0 = time.perf_counter()
        evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        mesh = evaluated.to_mesh()
        t1 = time.perf_counter()
        tris = len(mesh.loops) - 2 * len(mesh.polygons)
        evaluated.to_mesh_clear()
        obj.modifiers.remove(mod)
        if r > 0:
            times.append(t1 - t0)
    times.sort()
    lines.append("%d %.9f %d" % (level, times[len(times) // 2], tris))
with open(result, "w") as f:
    f.write("\n".join(lines) + "\n")
)PY";

// furrow uniform rate 4 and 8 against Blender levels 2 and 3 on each OBJ.
// `generated`: the files[0] is the generated cube sphere (named so in the table, not by its temporary file).
nlohmann::json run_blender_comparison(const std::vector<fs::path>& files, bool generated, int repeat, const GlobalFlags& g,
                                      bool tables) {
    const std::string threads = g.threads > 0 ? std::to_string(g.threads) : "all";
    Table t({"model", "furrow rate", "Blender level", "triangles", "Blender triangles", "furrow ms (-j " + threads + ")",
             "Blender ms (-t 1)", "Blender / furrow", "max err %diag", "max err px"});
    nlohmann::json rows = nlohmann::json::array();
    const bool blender = on_path("blender");
    for (const auto& file : files) {
        BenchModel m;
        if (!file_model(m, file)) throw InputError(file.string(), "cannot load a polygon primitive");
        if (generated) m.name = "cube sphere, 31974 quads (catmark)";
        info(g, "bench tessellate: Blender comparison on " + m.name);
        std::vector<std::vector<double>> peer;
        if (blender) peer = blender_peer_values(blender_subsurf_script, {file.string(), std::to_string(repeat), "2", "3"});
        SurfaceOptions so;
        so.scheme = m.scheme;
        for (int level : {2, 3}) {
            const int rate = 1 << level;
            RateOptions r;
            r.uniform = rate;
            r.camera = m.camera;
            r.max_rate = 64;
            Tessellator tess;
            const double seconds = median_seconds(repeat, [&] {
                Tessellator cold;
                require_ok(cold.prepare(input_of(m.primitive), so), m.name);
                TessellateOutput o;
                require_ok(cold.tessellate(o, r, false), m.name);
                do_not_optimize(o.indices.data());
            });
            require_ok(tess.prepare(input_of(m.primitive), so), m.name);
            TessellateOutput out;
            require_ok(tess.tessellate(out, r, true), m.name);
            ErrorReport e;
            require_ok(tess.measure(e, out, r), m.name);
            double peer_s = 0, peer_tris = 0;
            for (const auto& line : peer)
                if (line.size() == 3 && int(line[0]) == level) peer_s = line[1], peer_tris = line[2];
            const bool have = peer_s > 0;
            const std::string missing = blender ? "failed" : "peer not installed";
            t.add({m.name, std::to_string(rate), std::to_string(level), std::to_string(out.stats.triangles),
                   have ? fmt(peer_tris, 0) : "-", fmt(seconds * 1e3, 1), have ? fmt(peer_s * 1e3, 1) : missing,
                   have ? fmt(peer_s / seconds, 2) : "-", fmt_sci(100 * e.max_error / m.diagonal), fmt_sci(e.max_pixels)});
            rows.push_back({{"model", m.name}, {"rate", rate}, {"blender_level", level}, {"triangles", out.stats.triangles},
                            {"blender_triangles", peer_tris}, {"seconds", seconds}, {"threads", g.threads},
                            {"blender_seconds", have ? nlohmann::json(peer_s) : nlohmann::json(nullptr)},
                            {"max_error_pct_diag", 100 * e.max_error / m.diagonal}, {"max_error_px", e.max_pixels}});
        }
    }
    if (tables) {
        std::printf("\nBlender Subdivision Surface (Catmull-Clark, level L) against furrow uniform rate 2^L on the same OBJ, "
                    "median of %d cold runs each: furrow prepare + tessellate, Blender's first evaluation of a new "
                    "modifier (timed inside Blender, import excluded)\n", repeat);
        t.print();
    }
    return rows;
}

// The generated 32k-quad cube sphere (models/obj_quad_sphere.h) in a temporary folder.
fs::path quad_sphere_obj() {
    const fs::path file = fs::temp_directory_path() / ("furrow_bench_quad_sphere_" + std::to_string(::getpid()) + ".obj");
    if (!models::write_obj_quad_sphere(file.string(), 73)) throw InputError(file.string(), "cannot write the generated OBJ");
    return file;
}

} // namespace

nlohmann::json run_blender_only(const BenchArgs& args, const GlobalFlags& g, bool tables) {
    std::vector<fs::path> files;
    for (const auto& f : args.inputs)
        if (lower_extension(f) == ".obj") files.push_back(f);
    const bool generated = files.empty();
    if (generated) files.push_back(quad_sphere_obj());
    nlohmann::json rows = run_blender_comparison(files, generated, args.repeat, g, tables);
    std::error_code ec;
    if (generated) fs::remove(files[0], ec);
    return {{"bench", "tessellate"}, {"repeat", args.repeat}, {"blender", rows}, {"plot", plot_json("max error (px)", {})}};
}

nlohmann::json run_bench_tessellate(const BenchArgs& args, const std::vector<double>& targets, const GlobalFlags& g,
                                    bool tables, bool quick = false) {
    std::vector<BenchModel> models;
    if (quick) {
        models.push_back(terrain_patch());
    } else if (args.inputs.empty()) {
        models.push_back(terrain_patch());
        const fs::path corpus = corpus_dir().string();
        std::vector<fs::path> files;
        for (const char* f : {"spot/spot_control_mesh.obj", "bunny_closed/bunny.off"})
            if (fs::exists(corpus / f)) files.push_back(corpus / f);
        if (files.empty()) files.push_back(bundled_models_dir() / "creature.glb");
        for (const auto& f : files) {
            BenchModel m;
            if (!file_model(m, f)) throw InputError(f.string(), "no triangle primitive to tessellate");
            models.push_back(std::move(m));
        }
    } else {
        for (const auto& f : collect_bench_inputs(args, {".glb", ".gltf", ".obj", ".ply", ".off", ".stl"})) {
            BenchModel m;
            if (!file_model(m, f)) throw InputError(f.string(), "cannot load a triangle primitive");
            models.push_back(std::move(m));
        }
    }
    std::vector<Row> rows, matched;
    std::vector<std::pair<std::string, double>> prepare_ms;
    for (const auto& m : models) {
        info(g, "bench tessellate: " + m.name);
        Tessellator t;
        SurfaceOptions so;
        so.scheme = m.scheme;
        const double prep = median_seconds(std::max(1, args.repeat / 2), [&] { require_ok(t.prepare(input_of(m.primitive), so), m.name); });
        prepare_ms.push_back({m.name, prep * 1e3});
        for (const auto& c : criteria(m))
            for (size_t k = 0; k < c.settings.size() && (!quick || k < 3); ++k) // quick: the coarse settings
                rows.push_back(run_one(t, m, c, c.settings[k], args.repeat));
        // Matched: the cheapest setting of each criterion whose max projected error is within the target.
        for (double target : targets) {
            for (const auto& c : criteria(m)) {
                Row best{m.name, c.name, "not reached (max rate 64)"};
                double previous = INFINITY;
                for (double x : c.sweep) {
                    Row r = run_one(t, m, c, x, 0);
                    if (r.max_px <= target) {
                        best = run_one(t, m, c, x, args.repeat);
                        break;
                    }
                    // At the rate cap and no longer improving: this criterion cannot reach the target.
                    if (r.max_rate >= 64 && r.max_px >= previous * 0.99) break;
                    previous = r.max_px;
                }
                best.setting = fmt(target, 2) + " px: " + best.setting;
                matched.push_back(best);
            }
        }
    }

    auto tri_per_s = [](const Row& r) { return r.seconds > 0 ? double(r.triangles) / r.seconds / 1e6 : 0.0; };
    nlohmann::json j_rows = nlohmann::json::array(), j_matched = nlohmann::json::array();
    Table t({"model", "criterion", "setting", "max rate", "triangles", "ms", "Mtri/s", "max err %diag", "mean err %diag",
             "max err px"});
    std::vector<PlotPoint> points;
    for (const auto& r : rows) {
        points.push_back({r.model, r.criterion, r.setting, r.seconds, double(r.triangles), r.max_px});
        t.add({r.model, r.criterion, r.setting, std::to_string(r.max_rate), std::to_string(r.triangles), fmt(r.seconds * 1e3, 1),
               fmt(tri_per_s(r), 2), fmt_sci(r.max_pct), fmt_sci(r.mean_pct), fmt_sci(r.max_px)});
        j_rows.push_back({{"model", r.model}, {"criterion", r.criterion}, {"setting", r.setting}, {"max_rate", r.max_rate},
                          {"triangles", r.triangles}, {"seconds", r.seconds}, {"max_error_pct_diag", r.max_pct},
                          {"mean_error_pct_diag", r.mean_pct}, {"max_error_px", r.max_px}});
    }
    Table tm({"model", "target: cheapest setting", "criterion", "triangles", "vs uniform", "vs seed", "ms", "max err px",
              "max err %diag"});
    for (size_t i = 0; i < matched.size(); ++i) {
        const Row& r = matched[i];
        const size_t group = i / 5 * 5; // 5 criteria per (model, target): uniform first, the seed second
        const double uni = double(matched[group].triangles), seed = double(matched[group + 1].triangles);
        const bool ok = r.triangles > 0;
        tm.add({r.model, r.setting, r.criterion, ok ? std::to_string(r.triangles) : "-",
                ok && uni > 0 ? fmt(double(r.triangles) / uni, 3) : "-", ok && seed > 0 ? fmt(double(r.triangles) / seed, 3) : "-",
                ok ? fmt(r.seconds * 1e3, 1) : "-", ok ? fmt_sci(r.max_px) : "-", ok ? fmt_sci(r.max_pct) : "-"});
        j_matched.push_back({{"model", r.model}, {"target_and_setting", r.setting}, {"criterion", r.criterion},
                             {"triangles", r.triangles}, {"over_uniform", uni > 0 ? double(r.triangles) / uni : 0.0},
                             {"over_seed", seed > 0 ? double(r.triangles) / seed : 0.0}, {"seconds", r.seconds},
                             {"max_error_px", r.max_px}, {"max_error_pct_diag", r.max_pct}});
    }
    nlohmann::json prep = nlohmann::json::object();
    for (const auto& [name, ms] : prepare_ms) prep[name] = ms;
    nlohmann::json result{{"bench", "tessellate"}, {"repeat", args.repeat},   {"prepare_ms", prep},
                          {"rows", j_rows},        {"matched", j_matched}, {"plot", plot_json("max error (px)", points)}};
    if (!tables) return result;
    std::printf("furrow bench tessellate: median of %d runs (tessellation only; prepare = weld, repair, refiner, Bfr "
                "factory: ", args.repeat);
    for (size_t i = 0; i < prepare_ms.size(); ++i)
        std::printf("%s%s %.1f ms", i ? ", " : "", prepare_ms[i].first.c_str(), prepare_ms[i].second);
    std::printf(")\nerror = distance to the limit surface at triangle centroids and edge midpoints; px for a 1920x1080 "
                "view, 50 deg vertical fov, eye near the terrain's corner / one diagonal in front of the closed models\n");
    t.print();
    std::printf("\nEqual max projected error: the cheapest setting of each criterion (parameter swept coarse to fine) "
                "whose max error in pixels is within the target; baselines uniform and the seed (Unity distance) "
                "formula, max rate 64\n");
    tm.print();
    if (!quick && args.inputs.empty()) result["blender"] = run_blender_only(args, g, tables)["blender"];
    return result;
}

nlohmann::json bench_tessellate_default(const BenchRun& r, const GlobalFlags& g) {
    BenchArgs a;
    a.repeat = r.repeat > 0 ? r.repeat : 3;
    return run_bench_tessellate(a, r.quick ? std::vector<double>{1.0} : std::vector<double>{1.0, 0.5}, g, r.tables, r.quick);
}

void register_bench_tessellate(CLI::App& bench, GlobalFlags& g) {
    auto args = std::make_shared<BenchArgs>();
    args->repeat = 3;
    auto out = std::make_shared<BenchOutput>();
    auto targets = std::make_shared<std::vector<double>>(std::vector<double>{1.0, 0.5});
    auto blender_only = std::make_shared<bool>(false);
    CLI::App* cmd = bench.add_subcommand("tessellate", "Triangles, time and error of the tessellation criteria, and "
                                                       "triangles needed for equal max pixel error");
    cmd->add_option("inputs", args->inputs,
                    "Model files or folders (default: a noise terrain patch, and spot's cage and the closed bunny "
                    "from ../shared/corpus, else the bundled creature)");
    cmd->add_option("--repeat", args->repeat, "Runs per timing; the median is reported (default 3)")->check(finite_range(1, 1000));
    cmd->add_option("--targets", *targets, "Max projected errors (pixels) for the matched comparison (default 1 0.5)")
        ->check(positive());
    cmd->add_flag("--blender-only", *blender_only,
                  "Only the comparison with Blender's Subdivision Surface (levels 2, 3 against uniform rates 4, 8) on "
                  "the OBJ inputs, or on a generated 32k-quad cube sphere (also run, after the tables, by the default run)");
    add_bench_output_flags(*cmd, *out);
    cmd->footer("Examples:\n  furrow bench tessellate --plots plots\n  furrow bench tessellate --targets 2 1 0.5 --repeat 5\n"
                "  furrow bench tessellate ../shared/corpus/duck/Duck.glb --json\n  furrow -j 1 bench tessellate --blender-only");
    cmd->callback([args, targets, out, blender_only, &g] {
        finish_bench(*blender_only ? run_blender_only(*args, g, !out->json) : run_bench_tessellate(*args, *targets, g, !out->json),
                     *out, g);
    });
}

} // namespace furrow::cli

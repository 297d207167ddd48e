// `furrow tessellate IN -o OUT`: adaptive, crack-free tessellation of the scene's meshes (furrow/tessellate.h).
#include "commands.h"

#include <furrow/tessellate.h>

#include <chrono>
#include <cstdio>
#include <sstream>

namespace furrow::cli {
namespace {

std::string number(double x) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", x);
    return b;
}

FocusPoint parse_focus(const std::string& s) {
    FocusPoint f;
    std::istringstream in(s);
    char c1 = 0, c2 = 0, c3 = 0;
    if (!(in >> f.centre[0] >> c1 >> f.centre[1] >> c2 >> f.centre[2] >> c3 >> f.radius) || c1 != ',' || c2 != ',' ||
        c3 != ',' || !(in >> std::ws).eof())
        throw CLI::ValidationError("--focus", "expected x,y,z,radius, got '" + s + "'");
    if (!std::isfinite(f.centre[0]) || !std::isfinite(f.centre[1]) || !std::isfinite(f.centre[2]) ||
        !(f.radius > 0) || !std::isfinite(f.radius))
        throw CLI::ValidationError("--focus", "centre must be finite and radius > 0, got '" + s + "'");
    return f;
}

// --scheme, --boundary, --uv, --crease-angle, --accuracy and --strict as SurfaceOptions.
void set_surface_options(SurfaceOptions& s, const TessellateArgs& a) {
    s.scheme = a.scheme == "loop"       ? SubdivisionScheme::loop
               : a.scheme == "bilinear" ? SubdivisionScheme::bilinear
                                        : SubdivisionScheme::catmark;
    s.boundary = a.boundary == "edge" ? BoundaryInterpolation::edge_only : BoundaryInterpolation::edge_and_corner;
    const std::pair<const char*, UvInterpolation> uv_names[] = {
        {"smooth", UvInterpolation::smooth},         {"corners", UvInterpolation::corners_only},
        {"corners1", UvInterpolation::corners_plus1}, {"corners2", UvInterpolation::corners_plus2},
        {"boundaries", UvInterpolation::boundaries}, {"linear", UvInterpolation::linear}};
    for (const auto& [name, value] : uv_names)
        if (a.uv == name) s.uv_interpolation = value;
    s.crease_angle_degrees = a.crease_angle;
    s.accuracy = a.accuracy;
    s.refuse_bad_topology = a.strict;
}

// The criteria as RateOptions; throws CLI::ValidationError for --near/--far without the other, a view criterion
// without --camera, or no criterion at all.
void set_rate_options(RateOptions& r, const TessellateArgs& a) {
    r.uniform = a.uniform;
    r.max_rate = a.max_rate > 0 ? a.max_rate : std::max(64, a.uniform);
    r.pixel_error = a.pixel_error;
    r.screen_error = a.screen_error;
    r.max_error = a.max_error;
    r.focus = a.focus;
    r.max_triangles = a.max_triangles;
    if (a.near || a.far) {
        if (!a.near || !a.far) throw CLI::ValidationError("--near/--far", "give both --near and --far");
        if (!(*a.near >= 0) || !(*a.near < *a.far))
            throw CLI::ValidationError("--near/--far", "need 0 <= near < far, got near " + number(*a.near) +
                                                           " and far " + number(*a.far));
        r.distance = true;
        r.near = *a.near;
        r.far = *a.far;
    }
    const bool view = r.distance || r.pixel_error > 0 || r.screen_error > 0;
    if (view && !a.camera.eye)
        throw CLI::ValidationError("--camera", "--near/--far, --pixel-error and --screen-error need --camera x,y,z");
    if (a.camera.eye) r.camera = TessellationCamera{*a.camera.eye, a.camera.fov_degrees, a.camera.height};
    if (!view && r.uniform == 0 && r.max_error <= 0 && r.focus.empty())
        throw CLI::ValidationError("criterion", "give at least one of --uniform, --camera with --near/--far, "
                                                "--pixel-error or --screen-error, --max-error, --focus");
}

// The repairs of the input, "3 degenerate faces dropped, 2 faces flipped" ("" when there were none).
std::string repairs_summary(const TessellateStats& s) {
    std::string repairs;
    auto add = [&](size_t n, const char* what) {
        if (n) repairs += (repairs.empty() ? "" : ", ") + std::to_string(n) + " " + what;
    };
    add(s.dropped_faces, "degenerate faces dropped");
    add(s.flipped_faces, "faces flipped");
    add(s.split_vertices, "bowtie vertices split");
    add(s.linear_faces, "faces tessellated linearly");
    add(s.crease_edges, "crease edges");
    return repairs;
}

void report_tessellation(const TessellateArgs& a, const GlobalFlags& g, const SceneTessellateReport& rep, double ms) {
    const TessellateStats& s = rep.totals;
    const std::string repairs = repairs_summary(s);
    info(g, "Wrote " + a.out + " (" + std::to_string(rep.meshes) + " meshes, " + std::to_string(rep.triangles_in) +
                " -> " + std::to_string(rep.triangles_out) + " triangles, rates " + std::to_string(s.min_rate) +
                ".." + std::to_string(s.max_rate) + " mean " + number(s.mean_rate) +
                (s.rate_scale < 1 ? ", scaled by " + number(s.rate_scale) + " for --max-triangles" : "") + ", " +
                number(ms) + " ms)" + (repairs.empty() ? "" : "; " + repairs));
}

} // namespace

// Validates the arguments, tessellates the scene, writes it and prints the report.
void run_tessellate(const TessellateArgs& a, const GlobalFlags& g) {
    require_extension(a.out, "--output", {".glb", ".gltf"});
    TessellateOptions o;
    o.triangle_budget = kDefaultTriangleBudget;
    set_surface_options(o.surface, a);
    set_rate_options(o.rates, a);

    Progress progress(g, "furrow tessellate");
    progress.stage("loading " + a.in);
    Scene scene = load_or_throw(a.in, a.load);
    for (const auto& w : scene.warnings) info(g, "Warning: " + a.in + ": " + w);
    if (same_file(a.out, a.in))
        throw InputError(a.out, "output path is the input file; refusing to overwrite the input");
    const auto t0 = std::chrono::steady_clock::now();
    SceneTessellateReport rep;
    progress.stage("tessellating");
    require_ok(tessellate_scene(scene, o, &rep), a.in);
    // A scene without a face (no mesh, only points or lines) used to be "tessellated" into a copy with exit
    // 0; shells, render and stamp refuse such input, and so does tessellate now.
    if (rep.meshes == 0) throw InputError(a.in, "no triangles or polygons to tessellate");
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    for (const auto& w : rep.warnings) info(g, "Warning: " + a.in + ": " + w);
    progress.stage("writing " + a.out);
    save_or_throw(scene, a.out, a.in, a.save);
    report_tessellation(a, g, rep, ms);
}

void register_tessellate(CLI::App& app, GlobalFlags& g) {
    auto a = std::make_shared<TessellateArgs>();
    CLI::App* cmd = app.add_subcommand(
        "tessellate", "Adaptive, crack-free tessellation of the subdivision surface of every mesh (OpenSubdiv Bfr)");
    cmd->add_option("input", a->in, "Input file (.gltf .glb .obj .ply .off .stl)")->required();
    cmd->add_option("-o,--output", a->out, "Output file (.glb, or .gltf with a .bin beside it)")->required();
    cmd->add_option("--scheme", a->scheme, "Subdivision scheme: catmark (default), loop (triangles only) or bilinear "
                                           "(keeps the shape: terrain)")
        ->check(CLI::IsMember({"catmark", "loop", "bilinear"}));
    cmd->add_option("--uniform", a->uniform, "Criterion: this many segments on every edge")->check(finite_range(1, 32767));
    add_camera_flags(*cmd, a->camera, CameraUse::eye);
    cmd->add_option("--near", a->near, "Criterion (with --far and --camera): Unity's distance-based factor, full rate "
                                       "up to this distance from the camera (>= 0) ...");
    cmd->add_option("--far", a->far, "... falling to 1% of --max-rate at this distance (> --near)");
    cmd->add_option("--pixel-error", a->pixel_error,
                    "Criterion (with --camera): projected segments of at most this many pixels (Cycles' dicing rate)")
        ->check(positive());
    cmd->add_option("--screen-error", a->screen_error,
                    "Criterion (with --camera): projected distance to the limit surface of at most this many pixels")
        ->check(positive());
    cmd->add_option("--max-error", a->max_error,
                    "Criterion: distance to the limit surface of at most this, in world units")
        ->check(positive());
    cmd->add_option_function<std::string>("--focus", [a](const std::string& s) { a->focus.push_back(parse_focus(s)); },
                                          "Criterion: full rate within radius of x,y,z, falling to 1 at twice the "
                                          "radius; repeatable")
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    cmd->add_option("--max-rate", a->max_rate, "Most segments per edge (default 64, or the --uniform rate if larger)")
        ->check(finite_range(1, 32767));
    cmd->add_option("--max-triangles", a->max_triangles,
                    "Scale every rate down until the whole scene has at most this many triangles (default: refuse, "
                    "before evaluating anything, an output the rates would make over 20000000 triangles)")
        ->check(positive());
    cmd->add_option("--crease-angle", a->crease_angle,
                    "Edges where faces meet at more than this angle (degrees) become sharp creases (default: none)")
        ->check(finite_range(0.0, 180.0));
    cmd->add_option("--boundary", a->boundary, "Open boundaries: corner (default: boundary curves, corners kept) or "
                                               "edge (boundary curves, corners smoothed)")
        ->check(CLI::IsMember({"edge", "corner"}));
    cmd->add_option("--uv", a->uv, "UV interpolation: smooth, corners (default), corners1, corners2, boundaries or "
                                   "linear (the UV layout kept exactly)")
        ->check(CLI::IsMember({"smooth", "corners", "corners1", "corners2", "boundaries", "linear"}));
    cmd->add_option("--accuracy", a->accuracy,
                    "Refinement levels near extraordinary vertices, 1..10 (default 2; each level ~8x closer)")
        ->check(finite_range(1, 10));
    cmd->add_flag("--strict", a->strict,
                  "Refuse input that needs repair (degenerate, flipped or non-manifold faces) "
                  "instead of repairing it or tessellating those faces linearly");
    add_load_flags(*cmd, a->load);
    add_save_flags(*cmd, a->save);
    cmd->footer("Criteria combine: each edge takes the largest rate any of them asks for, capped by --max-rate.\n"
                "Only the camera's position, --fov and the height of --size matter (distances are measured from\n"
                "the eye, so the result does not depend on where the camera looks).\n\n"
                "Examples:\n"
                "  furrow tessellate spot.obj -o spot.glb --uniform 4\n"
                "  furrow tessellate terrain.glb -o near.glb --scheme bilinear --camera 0,2,-6 --pixel-error 4\n"
                "  furrow tessellate terrain.glb -o near.glb --camera 0,2,-6 --near 2 --far 12 --max-rate 16\n"
                "  furrow tessellate bunny.off -o bunny.glb --scheme loop --max-error 0.0005 --max-triangles 200000\n"
                "  furrow tessellate box.obj -o box.glb --crease-angle 60 --uniform 8\n"
                "  furrow tessellate fox.glb -o fox.glb --camera 0,50,300 --screen-error 0.5 --focus 0,40,60,20");
    cmd->callback([a, &g] { run_tessellate(*a, g); });
}

} // namespace furrow::cli

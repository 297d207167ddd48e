// `furrow stamp GROUND -o OUT --colliders FILE.json …`: deformable snow (furrow/deform.h) on the command line.
#include "commands.h"

#include <furrow/deform.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

namespace furrow::cli {
namespace {

std::string fmt_num(double v, const char* f = "%.4g") {
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

// The output checks, before anything is read: extensions, and no output that is an input.
void check_outputs(const StampArgs& a) {
    require_extension(a.out, "--output", {".glb", ".gltf"});
    if (!a.heightmap_out.empty()) require_extension(a.heightmap_out, "--heightmap-out", {".pfm", ".png"});
    if (same_file(a.out, a.in)) throw InputError(a.out, "output path is the input file; refusing to overwrite the input");
    // Inputs are never modified (README): not the colliders file, not the --heightmap-in map.
    if (same_file(a.out, a.colliders))
        throw InputError(a.out, "output path is the colliders file; refusing to overwrite an input");
    if (!a.heightmap_out.empty() && !a.heightmap_in.empty() && same_file(a.heightmap_out, a.heightmap_in))
        throw InputError(a.heightmap_out, "--heightmap-out is the --heightmap-in file; refusing to overwrite an input");
}

// The StampOptions of the arguments; `base` is the --heightmap-in map (null without one).
StampOptions stamp_options(const StampArgs& a, const Heightmap* base) {
    StampOptions opt = a.opt;
    opt.base = base;
    opt.tessellate = !a.no_tessellate;
    opt.snow.max_bytes = size_t(a.max_heightmap_mb * 1048576.0);
    if (std::isfinite(a.time)) opt.time = a.time;
    if (a.camera.eye) {
        StampCamera c;
        c.eye = *a.camera.eye;
        c.fov_degrees = a.camera.fov_degrees;
        c.viewport_height = a.camera.height;
        c.pixel_error = a.pixel_error;
        opt.camera = c;
    }
    return opt;
}

// Both outputs or neither: the heightmap goes first and is removed again if the mesh cannot be written.
void write_outputs(const StampArgs& a, const Scene& scene, const Heightmap& out_map) {
    const bool had_map = !a.heightmap_out.empty() && std::filesystem::exists(a.heightmap_out);
    if (!a.heightmap_out.empty()) require_ok(save_heightmap(out_map, a.heightmap_out), a.heightmap_out);
    try {
        save_or_throw(scene, a.out, a.in, a.save);
    } catch (...) {
        if (!a.heightmap_out.empty() && !had_map) std::filesystem::remove(a.heightmap_out);
        throw;
    }
}

void report_stamp(const StampArgs& a, const GlobalFlags& g, const StampReport& r) {
    const auto& s = r.stats;
    const auto& f = r.frame;
    info(g, "Wrote " + a.out + ": " + std::to_string(s.contacts) + " contacts of " + std::to_string(s.samples) + " samples (" +
                std::to_string(s.rays) + " rays" + (s.missed_rays ? ", " + std::to_string(s.missed_rays) + " missed" : std::string()) +
                "), " + std::to_string(s.stamps) + " stamps");
    if (!r.changed) {
        info(g, "  no collider touches the ground: the ground is unchanged");
    } else {
        info(g, "  heightmap " + std::to_string(f.width) + " x " + std::to_string(f.height) + " at " + fmt_num(f.texel) +
                    " m/texel; deepest " + fmt_num(r.max_depth) + " m, rim " + fmt_num(r.max_rim) + " m; removed " +
                    fmt_num(r.removed_volume) + " m3, raised " + fmt_num(r.raised_volume) + " m3");
        info(g, "  triangles " + std::to_string(r.triangles_in) + " -> " + std::to_string(r.triangles_out) + ", " +
                    std::to_string(r.displaced_points) + " of " + std::to_string(r.welded_points) + " points displaced (" +
                    fmt_num(r.stamp_seconds * 1e3, "%.0f") + " ms stamping, " + fmt_num(r.tessellate_seconds * 1e3, "%.0f") +
                    " ms tessellation, " + fmt_num(r.displace_seconds * 1e3, "%.0f") + " ms displacement)");
    }
    if (!a.heightmap_out.empty()) info(g, "Wrote " + a.heightmap_out);
}

} // namespace

// Validates the arguments, stamps the colliders into the ground, writes the outputs and prints the report.
void run_stamp(const StampArgs& a, const GlobalFlags& g) {
    check_outputs(a);
    ColliderSet colliders;
    require_ok(load_colliders(colliders, a.colliders), a.colliders);
    Heightmap base;
    if (!a.heightmap_in.empty()) require_ok(load_heightmap(base, a.heightmap_in), a.heightmap_in);
    Progress progress(g, "furrow stamp");
    progress.stage("loading " + a.in);
    Scene scene = load_or_throw(a.in, a.load);
    for (const auto& w : scene.warnings) info(g, "Warning: " + a.in + ": " + w);
    const StampOptions opt = stamp_options(a, a.heightmap_in.empty() ? nullptr : &base);
    StampReport r;
    Heightmap out_map;
    progress.stage("stamping " + std::to_string(colliders.colliders.size()) + " colliders");
    require_ok(stamp_scene(scene, colliders, opt, &r, a.heightmap_out.empty() ? nullptr : &out_map), a.in);
    for (const auto& w : r.warnings) info(g, "Warning: " + a.in + ": " + w);
    progress.stage("writing " + a.out);
    write_outputs(a, scene, out_map);
    report_stamp(a, g, r);
}

void register_stamp(CLI::App& app, GlobalFlags& g) {
    auto a = std::make_shared<StampArgs>();
    CLI::App* cmd = app.add_subcommand("stamp", "Stamp colliders (footprints, a rolling ball, ...) into snow and displace the ground");
    cmd->add_option("ground", a->in, "Ground mesh (.gltf .glb .obj .ply .off .stl); every mesh the scene draws is snow")->required();
    cmd->add_option("-o,--output", a->out, "Output .glb or .gltf")->required();
    cmd->add_option("--colliders", a->colliders, "Colliders JSON (schema: deform/README.md; example: models/colliders.json)")->required();
    auto* texel = cmd->add_option("--texel", a->opt.snow.texel, "Heightmap texel size in metres (default: from --resolution)")
                      ->check(positive());
    auto* res = cmd->add_option("--resolution", a->opt.snow.resolution,
                                "Heightmap texels along the ground's longer side, 2..1000000 (default 1024)")
                    ->check(finite_range(2, 1000000));
    texel->excludes(res);
    cmd->add_option("--snow-depth", a->opt.snow.snow_depth, "Deepest imprint in metres; 0 = unlimited (default 0)")
        ->check(non_negative());
    cmd->add_option("--rim", a->opt.snow.rim_width, "Rim width in metres: snow heaped around imprints (default 0 = none)")
        ->check(non_negative());
    cmd->add_option("--rim-height", a->opt.snow.rim_height,
                    "Cosmetic rim height as a fraction of the nearby depth, 0..10 (default 0.5; ignored with --conserve-volume)")
        ->check(finite_range(0.0, 10.0));
    cmd->add_flag("--conserve-volume", a->opt.snow.conserve_volume,
                  "Rim volume = removed volume x (1 - compaction), exactly (rim width defaults to 8 texels)");
    cmd->add_option("--rim-max-height", a->opt.snow.rim_max_height,
                    "With --conserve-volume: the rim never rises above this x the local print depth; it widens instead "
                    "(default 1; 0 = no limit)")
        ->check(non_negative());
    cmd->add_option("--repose", a->opt.snow.repose_degrees,
                    "With --conserve-volume: the snow's angle of repose in degrees, the steepest rim slope; the rim widens "
                    "instead (default 40; 0 or 90 = no limit)")
        ->check(finite_range(0.0, 90.0));
    cmd->add_option("--compaction", a->opt.snow.compaction,
                    "With --conserve-volume: fraction of the removed snow compacted, 0..1 (default 0.3)")
        ->check(finite_range(0.0, 1.0));
    cmd->add_option("--refill", a->opt.snow.refill_rate, "Refill rate in 1/s: a stamp of age a keeps exp(-rate a) of its depth (default 0)")
        ->check(non_negative());
    cmd->add_option("--time", a->time, "Evaluation time in seconds for timed paths (default: the latest path time)")
        ->check(non_negative());
    cmd->add_option("--max-error", a->opt.max_error,
                    "Allowed deviation of the displaced mesh from the heightmap surface, metres (default: texel / 4)")
        ->check(non_negative());
    cmd->add_option("--max-rate", a->opt.max_rate, "Most segments per ground edge in one tessellation pass, 1..4096 (default 64)")
        ->check(finite_range(1, 4096));
    cmd->add_option("--max-triangles", a->opt.max_triangles,
                    "Scale tessellation down to fit this many triangles per pass (default: no limit)");
    cmd->add_flag("--no-tessellate", a->no_tessellate, "Displace the ground's own vertices only");
    cmd->add_flag("--along-up", a->opt.along_up, "Displace along up instead of along the ground's normals");
    cmd->add_option("--pixel-error", a->pixel_error, "With --camera: allowed error in pixels; far snow gets coarser (default 1)")
        ->check(positive());
    cmd->add_option("--margin", a->opt.snow.margin, "Extra heightmap extent around the ground, metres (default 0)")
        ->check(non_negative());
    cmd->add_option("--max-heightmap-mb", a->max_heightmap_mb, "Memory guard: refuse heightmaps needing more MiB (default 1024)")
        ->check(positive());
    cmd->add_option("--heightmap-out", a->heightmap_out, "Write the heightmap: .pfm (float32) or .png (16-bit, scale recorded)");
    cmd->add_option("--heightmap-in", a->heightmap_in, "Start from a heightmap written by --heightmap-out (new stamps are min-composited)");
    add_camera_flags(*cmd, a->camera, CameraUse::eye);
    add_load_flags(*cmd, a->load);
    add_save_flags(*cmd, a->save);
    cmd->footer("Examples:\n"
                "  furrow stamp models/ground.glb -o snow.glb --colliders models/colliders.json\n"
                "  furrow stamp models/ground.glb -o snow.glb --colliders models/colliders.json --texel 0.01 --rim 0.08 --conserve-volume\n"
                "  furrow stamp ground.glb -o trail.glb --colliders walk.json --refill 0.05 --time 30 --heightmap-out trail.pfm\n"
                "  furrow stamp ground.glb -o more.glb --colliders step2.json --heightmap-in trail.pfm --camera 0,9,14 --pixel-error 0.5\n"
                "Exit codes: 0 done (also when no collider touches the ground: the output is the input unchanged),\n"
                "1 bad input (malformed or invalid colliders, missing brush image, heightmap above the memory guard, ...),\n"
                "2 bad command line. Nothing is written on error.");
    cmd->callback([a, &g] { run_stamp(*a, g); });
}

} // namespace furrow::cli

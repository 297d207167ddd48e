// `furrow shells IN -o OUT --layers N --length L …`: fur shells (furrow/shells.h) on the command line.
#include "commands.h"

#include <furrow/shells.h>

#include <cmath>
#include <cstdio>

namespace furrow::cli {
namespace {

// "FILE[:r|g|b|a]" -> file and channel letter (0 when none is given).
std::pair<std::string, char> split_channel(const std::string& spec) {
    if (spec.size() > 2 && spec[spec.size() - 2] == ':') {
        char c = spec.back();
        if (c == 'r' || c == 'g' || c == 'b' || c == 'a') return {spec.substr(0, spec.size() - 2), c};
    }
    return {spec, 0};
}

int channel_index(const ImageF& image, char letter, const std::string& file) {
    const int n = image.channels;
    switch (letter) {
    case 0: return 0; // grey, or the red channel
    case 'r': return 0;
    case 'g':
    case 'b':
        if (n < 3) return 0; // a grey image: r = g = b
        return letter == 'g' ? 1 : 2;
    case 'a':
        if (n == 2 || n == 4) return n - 1;
        throw InputError(file, "the mask has no alpha channel (" + std::to_string(n) + " channel(s)); use :r, :g or :b");
    }
    return 0;
}

ImageF load_image_or_throw(const std::string& file, const char* what) {
    ImageF im;
    Status s = load_png(im, file);
    if (!s.ok()) throw InputError(file, std::string("cannot read the ") + what + ": " + s.message);
    return im;
}

std::string plural(size_t n, const char* word) { return std::to_string(n) + " " + word + (n == 1 ? "" : "s"); }

} // namespace

void run_shells(const ShellsArgs& a, const GlobalFlags& g) {
    require_extension(a.out, "--output", {".glb", ".gltf"});
    if (same_file(a.out, a.in)) throw InputError(a.out, "output path is the input file; refusing to overwrite the input");
    FurOptions fur = a.fur; // with the mask, comb and layout the flags name
    fur.layout = a.layout == "engine" ? ShellLayout::engine : a.layout == "instanced" ? ShellLayout::instanced : ShellLayout::viewer;
    if (!a.mask.empty()) {
        auto [file, letter] = split_channel(a.mask);
        fur.mask = load_image_or_throw(file, "mask");
        fur.mask_channel = channel_index(fur.mask, letter, file);
    }
    if (!a.comb.empty()) {
        fur.comb = load_image_or_throw(a.comb, "comb map");
        if (fur.comb.channels < 3) throw InputError(a.comb, "a comb map needs colour channels (r = along u, g = up)");
    }
    Progress progress(g, "furrow shells");
    progress.stage("loading " + a.in);
    Scene scene = load_or_throw(a.in, a.load);
    for (const auto& w : scene.warnings) info(g, "Warning: " + a.in + ": " + w);
    FurReport r;
    progress.stage("growing " + plural(size_t(fur.shells.layers), "shell"));
    require_ok(add_fur_shells(scene, fur, &r), a.in);
    for (const auto& w : r.warnings) info(g, "Warning: " + a.in + ": " + w);
    progress.stage("writing " + a.out);
    save_or_throw(scene, a.out, a.in, a.save);
    std::string line = "Wrote " + a.out + ": " + plural(size_t(fur.shells.layers), "shell") + " on " +
                       plural(r.primitives, "primitive") + ", " + std::to_string(r.shell_triangles) + " triangles added";
    if (fur.layout == ShellLayout::instanced) line += " (instanced: each shell base written once, on a node '<node>_fur_shells')";
    if (r.dropped_triangles) line += " (" + std::to_string(r.dropped_triangles) + " bald shell triangles dropped)";
    if (r.fin_quads) line += ", " + plural(r.fin_quads, "fin");
    if (fur.shells.lod_levels > 1) line += ", " + std::to_string(fur.shells.lod_levels) + " LOD levels";
    if (r.refined_faces)
        line += "; " + plural(r.refined_faces, "base face") + " split where clamped corners starved the fur (" +
                plural(r.refine_rounds, "round") + ")";
    info(g, line);
    if (fur.shells.lod_levels > 1 && fur.lod_simplify_error > 0) {
        std::string lod = "  LOD base triangles (meshopt error, relative to the extent):";
        for (size_t k = 0; k < r.lod_base_triangles.size(); ++k) {
            char err[32];
            std::snprintf(err, sizeof err, "%.4f", r.lod_simplify_error[k]);
            lod += (k ? "; " : " ") + std::string("level ") + std::to_string(k) + " " + std::to_string(r.lod_base_triangles[k]) + " (" + err + ")";
        }
        info(g, lod);
    }
    info(g, "  " + std::to_string(r.clamped_vertices) + " of " + std::to_string(r.welded_vertices) +
                " vertices clamped (" + std::to_string(r.clamped_by_ray) + " by free space, " + std::to_string(r.clamped_by_fold) +
                " by folds, " + std::to_string(r.clamped_by_even_cap) + " at sharp corners), " + std::to_string(r.bald_vertices) +
                " bald");
}

void register_shells(CLI::App& app, GlobalFlags& g) {
    auto a = std::make_shared<ShellsArgs>();
    a->fur.shells.length = NAN; // required
    a->fur.max_triangles = kDefaultTriangleBudget;
    CLI::App* cmd = app.add_subcommand("shells", "Grow fur shells (and fins, LOD levels) on a mesh; writes glTF any viewer shows");
    cmd->add_option("input", a->in, "Input file (.gltf .glb .obj .ply .off .stl)")->required();
    cmd->add_option("-o,--output", a->out, "Output .glb or .gltf")->required();
    cmd->add_option("--layers", a->fur.shells.layers, "Number of shells N, 1..256 (default 16)")->check(finite_range(1, 256));
    cmd->add_option_function<std::string>(
           "--length",
           [a](const std::string& s) {
               double v = 0;
               size_t used = 0;
               try {
                   v = std::stod(s, &used);
               } catch (...) {
                   used = 0;
               }
               if (used != s.size() || !std::isfinite(v) || v < 0)
                   throw CLI::ValidationError("--length", "must be a finite number >= 0, got '" + s + "'");
               a->fur.shells.length = v;
           },
           "Fur length L in world units (metres for the bundled models)")
        ->required();
    cmd->add_option("--mask", a->mask,
                    "Fur length mask PNG (8/16-bit) in TEXCOORD_0 space, 0 = bald .. 1 = full length; FILE:r|g|b|a picks "
                    "a channel (default: grey / red)");
    cmd->add_option("--spacing-power", a->fur.shells.spacing_power,
                    "Shell i at height (i/N)^p: 1 = even (default), > 1 packs shells near the skin")
        ->check(finite_range(0.1, 10.0));
    cmd->add_option("--droop", a->fur.shells.droop, "Gravity bends the strands, keeping their length: the tips turn toward gravity by droop x 17.5 degrees "
                    "(4 hangs a wall's tips down); 0..4 (default 0)")
        ->check(finite_range(0.0, 4.0));
    cmd->add_option("--comb", a->comb, "Comb map PNG (flow-map style: r = lean along +u, g = lean up the image, 0.5 = none)");
    cmd->add_option("--comb-strength", a->fur.shells.comb_strength, "Tip lean per unit comb vector, as a fraction of the length (default 1)")
        ->check(finite_range(0.0, 10.0));
    cmd->add_option("--layout", a->layout,
                    "viewer (default): one MASK material per shell, works in any glTF viewer; engine: one primitive with "
                    "_FUR_LAYER, _FUR_LENGTH, _FUR_DIRECTION; instanced: the base once with _FUR_DIRECTION, _FUR_LENGTH "
                    "(+ _FUR_LEAN, _FUR_SAG) and the layer parameters in extras FURROW_shells, for a shader that draws it N times "
                    "(README \"Instanced layout\")")
        ->check(CLI::IsMember({"viewer", "engine", "instanced"}));
    cmd->add_flag("--fins", a->fur.fins, "Add fins: a textured quad on every manifold edge, with _FUR_FIN_NORMAL for fading");
    cmd->add_option("--lod", a->fur.shells.lod_levels,
                    "LOD levels K, 1..8 (default 1): N, N/2, N/4, ... shells; levels >= 1 on nodes '<node>_fur_lod<k>' "
                    "outside the default scene")
        ->check(finite_range(1, 8));
    cmd->add_option("--lod-simplify", a->fur.lod_simplify_error,
                    "With --lod: level k >= 1 grows on the base simplified (meshoptimizer, UV seams and borders kept) toward "
                    "1/4^k of its triangles within a relative error of ERROR x 2^(k-1) of the model's extent; 0 = off "
                    "(default), e.g. 0.01; 0..1; with --layout instanced, level k's base is a mesh '<mesh>_fur_shells_lod<k>'")
        ->check(finite_range(0.0, 1.0));
    cmd->add_option("--density", a->fur.strands.strands, "Strands per strand-texture tile (default 1400)")->check(finite_range(1, 1 << 22));
    cmd->add_option("--strand-radius", a->fur.strands.radius, "Strand root radius in texels (default 2.2)")->check(finite_range(0.25, 64.0));
    cmd->add_option("--texture-size", a->fur.strands.size, "Strand texture size in pixels, 16..4096 (default 256)")->check(finite_range(16, 4096));
    cmd->add_option("--tile", a->fur.tile_size, "World size of one strand-texture tile (default 4 × length)")->check(positive());
    cmd->add_option("--seed", a->fur.strands.seed, "Seed of the strand textures (default 1)");
    cmd->add_option("--root-shade", a->fur.root_shade, "Brightness at the roots relative to the tips, 0..1 (default 0.45)")
        ->check(finite_range(0.0, 1.0));
    cmd->add_option("--refine-tolerance", a->fur.refine_tolerance,
                    "Coarse faces whose corners the clamps starve are split in rounds, each regrowing the whole frame; "
                    "they stop once two rounds in a row change the share of the fur asked that grows by less than this, "
                    "0..1 (default 0.001; 0 = until nothing is left to split, at most 16 rounds)")
        ->check(finite_range(0.0, 1.0));
    cmd->add_option("--max-triangles", a->fur.max_triangles,
                    "Refuse, before growing anything, when the shells could add more triangles than this "
                    "(default 20000000)")
        ->check(positive());
    add_load_flags(*cmd, a->load);
    add_save_flags(*cmd, a->save);
    cmd->footer("Examples:\n"
                "  furrow shells models/creature.glb -o furry.glb --layers 32 --length 0.04 --mask models/creature_fur_mask.png\n"
                "  furrow shells Fox.glb -o fox_fur.glb --layers 16 --length 3 --fins --lod 3\n"
                "  furrow shells duck.glb -o duck_engine.glb --layers 24 --length 0.02 --layout engine --droop 0.5\n"
                "  furrow shells bunny.obj -o bunny_fur.glb --layers 64 --length 0.004 --spacing-power 1.5 --seed 7\n"
                "Lengths are in world units; each vertex's length is reduced where the fur would otherwise run into the\n"
                "mesh (thin gaps, concave corners); the summary says how many vertices were clamped.");
    cmd->callback([a, &g] { run_shells(*a, g); });
}

} // namespace furrow::cli

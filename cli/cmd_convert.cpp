// `furrow convert IN -o OUT`: any supported input to .glb or .gltf, scene preserved.
#include "commands.h"

namespace furrow::cli {

void run_convert(const ConvertArgs& a, const GlobalFlags& g) {
    require_extension(a.out, "--output", {".glb", ".gltf"});
    LoadOptions lo = a.load;
    lo.recentre = !a.no_recentre;
    Scene scene = load_or_throw(a.in, lo);
    for (const auto& w : scene.warnings) info(g, "Warning: " + a.in + ": " + w);
    refuse_overwriting_input(a.out, a.in);
    SaveOptions so = a.save;
    so.pretty_json = a.pretty;
    require_ok(save_scene(scene, a.out, so), a.out);
    size_t tris = 0;
    for (const auto& m : scene.meshes)
        for (const auto& p : m.primitives) tris += p.triangle_count();
    info(g, "Wrote " + a.out + " (" + std::to_string(scene.meshes.size()) + " meshes, " + std::to_string(tris) +
                " triangles)");
}

void register_convert(CLI::App& app, GlobalFlags& g) {
    auto args = std::make_shared<ConvertArgs>();
    CLI::App* cmd = app.add_subcommand("convert", "Convert a mesh or scene to .glb or .gltf (scene preserved)");
    cmd->add_option("input", args->in, "Input file (.gltf .glb .obj .ply .off .stl)")->required();
    cmd->add_option("-o,--output", args->out, "Output file (.glb, or .gltf with a .bin beside it)")->required();
    cmd->add_flag("--pretty", args->pretty, "Indent the JSON of a .gltf output");
    cmd->add_flag("--no-recentre", args->no_recentre,
                  "Keep far-from-origin positions as they are (default: store them relative to the bounding-box "
                  "centre and move the centre into the node translation)");
    add_load_flags(*cmd, args->load);
    add_save_flags(*cmd, args->save);
    cmd->footer("Examples:\n  furrow convert bunny.obj -o bunny.glb\n  furrow convert Duck.glb -o duck.gltf --pretty");
    cmd->callback([args, &g] { run_convert(*args, g); });
}

} // namespace furrow::cli

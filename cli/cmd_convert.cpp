// `furrow convert IN -o OUT`: any supported input to .glb or .gltf, scene preserved.
#include "cli_common.h"

namespace furrow::cli {

void register_convert(CLI::App& app, GlobalFlags& g) {
    struct Args {
        std::string in, out;
        bool pretty = false;
        bool no_recentre = false;
        LoadOptions load;
    };
    auto args = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand("convert", "Convert a mesh or scene to .glb or .gltf (scene preserved)");
    cmd->add_option("input", args->in, "Input file (.gltf .glb .obj .ply .off .stl)")->required();
    cmd->add_option("-o,--output", args->out, "Output file (.glb, or .gltf with a .bin beside it)")->required();
    cmd->add_flag("--pretty", args->pretty, "Indent the JSON of a .gltf output");
    cmd->add_flag("--no-recentre", args->no_recentre,
                  "Keep far-from-origin positions as they are (default: store them relative to the bounding-box "
                  "centre and move the centre into the node translation)");
    add_load_flags(*cmd, args->load);
    cmd->footer("Examples:\n  furrow convert bunny.obj -o bunny.glb\n  furrow convert Duck.glb -o duck.gltf --pretty");
    cmd->callback([args, &g] {
        LoadOptions lo = args->load;
        lo.recentre = !args->no_recentre;
        Scene scene = load_or_throw(args->in, lo);
        for (const auto& w : scene.warnings) info(g, "Warning: " + args->in + ": " + w);
        refuse_overwriting_input(args->out, args->in);
        SaveOptions so;
        so.pretty_json = args->pretty;
        require_ok(save_scene(scene, args->out, so), args->out);
        size_t tris = 0;
        for (const auto& m : scene.meshes)
            for (const auto& p : m.primitives) tris += p.triangle_count();
        info(g, "Wrote " + args->out + " (" + std::to_string(scene.meshes.size()) + " meshes, " + std::to_string(tris) +
                    " triangles)");
    });
}

} // namespace furrow::cli

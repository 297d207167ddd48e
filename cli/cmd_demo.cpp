// `furrow demo`: the main job on the bundled default scene (models/scene.json). Writes glTF files and PNG
// previews into one folder and prints where they are.
#include "commands.h"
#include "data_dirs.h"

#include <furrow/render.h>
#include <furrow/deform.h>
#include <furrow/shells.h>
#include <furrow/tessellate.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

RenderCamera camera_from_json(const nlohmann::json& j) {
    RenderCamera c;
    if (j.contains("eye")) c.eye = j["eye"].get<std::array<double, 3>>();
    if (j.contains("target")) c.target = j["target"].get<std::array<double, 3>>();
    if (j.contains("fov")) c.fov_degrees = j["fov"].get<double>();
    return c;
}

// The previews share size, supersampling and an opaque sky-grey background.
RenderOptions preview_options(const RenderCamera& cam, const DemoArgs& a) {
    RenderOptions ro;
    ro.width = a.width;
    ro.height = a.height;
    ro.ssaa = a.ssaa;
    ro.camera = cam;
    ro.background = std::array<float, 3>{0.80f, 0.85f, 0.90f};
    return ro;
}

void write_render(const Scene& scene, const RenderOptions& ro, const fs::path& png, std::vector<std::string>& outputs) {
    RenderResult r;
    require_ok(render_scene(r, scene, ro), png.string());
    require_ok(save_png(r.color, png.string(), false), png.string());
    outputs.push_back(png.string());
}

std::string check_summary(const Scene& scene) {
    std::vector<CheckReport> reports;
    for (const auto& m : scene.meshes)
        for (const auto& p : m.primitives) reports.push_back(check_primitive(p));
    CheckReport t = merge_reports(reports);
    return std::to_string(t.triangles) + " triangles, " + (t.closed ? "closed" : std::to_string(t.boundary_edges) + " boundary edges") +
           ", " + std::to_string(t.non_manifold_edges) + " non-manifold edges";
}

// One model of the scene: validity summary, a validator-ready GLB copy, a shaded and a wireframe preview.
void demo_model(const std::string& title, const fs::path& model, const RenderCamera& cam, const DemoArgs& a,
                const fs::path& out, std::vector<std::string>& outputs, const GlobalFlags& g) {
    Scene scene = load_or_throw(model.string());
    info(g, title + ": " + model.filename().string() + ": " + check_summary(scene));
    const fs::path glb = out / (title + ".glb");
    save_or_throw(scene, glb.string(), model.string());
    outputs.push_back(glb.string());
    RenderOptions ro = preview_options(cam, a);
    write_render(scene, ro, out / (title + "_shaded.png"), outputs);
    ro.mode = RenderMode::wireframe;
    write_render(scene, ro, out / (title + "_wireframe.png"), outputs);
}

// The creature's fur: 32 viewer-layout shells driven by the fur mask, saved and rendered.
Scene demo_fur(const fs::path& model, const fs::path& mask, const RenderCamera& cam, const DemoArgs& a,
               const fs::path& out, std::vector<std::string>& outputs, const GlobalFlags& g) {
    Scene scene = load_or_throw(model.string());
    FurOptions fo;
    fo.shells.layers = 32;
    fo.shells.length = 0.04;
    if (!mask.empty()) require_ok(load_png(fo.mask, mask.string()), mask.string());
    FurReport rep;
    require_ok(add_fur_shells(scene, fo, &rep), model.string());
    info(g, "fur: " + std::to_string(fo.shells.layers) + " shells, " + std::to_string(rep.shell_triangles) +
                " shell triangles (" + std::to_string(rep.dropped_triangles) + " bald ones dropped), " +
                std::to_string(rep.clamped_vertices) + " of " + std::to_string(rep.welded_vertices) +
                " vertices clamped");
    const fs::path glb = out / "creature_fur.glb";
    save_or_throw(scene, glb.string(), model.string());
    outputs.push_back(glb.string());
    // A compressed copy beside it (KHR_mesh_quantization + EXT_meshopt_compression, both required): for
    // three.js with its MeshoptDecoder. The plain file stays the one to use elsewhere (Blender 3.4 cannot read
    // EXT_meshopt_compression).
    const fs::path compressed = out / "creature_fur.compressed.glb";
    SaveOptions so;
    so.encoding = Encoding::compress;
    save_or_throw(scene, compressed.string(), model.string(), so);
    outputs.push_back(compressed.string());
    info(g, "fur: " + glb.filename().string() + " " + std::to_string(fs::file_size(glb)) + " bytes, " +
                compressed.filename().string() + " " + std::to_string(fs::file_size(compressed)) + " bytes");
    RenderOptions ro = preview_options(cam, a);
    write_render(scene, ro, out / "creature_fur_shaded.png", outputs);
    return scene;
}

// The snow field: footprints, a rolling ball, a crate and a dragged log stamped into ground.glb, the ground
// tessellated where the imprints are and displaced; a shaded and a wireframe preview.
void demo_snow(const fs::path& ground, const fs::path& colliders, const RenderCamera& cam, const DemoArgs& a,
               const fs::path& out, std::vector<std::string>& outputs, const GlobalFlags& g) {
    Scene scene;
    StampOptions so;
    so.snow.resolution = 512;
    so.snow.rim_width = 0.08;
    StampReport rep;
    require_ok(stamp_files(scene, ground.string(), colliders.string(), so, &rep), colliders.string());
    info(g, "snow: " + std::to_string(rep.stats.contacts) + " contacts, " + std::to_string(rep.triangles_in) + " -> " +
                std::to_string(rep.triangles_out) + " triangles, deepest imprint " + std::to_string(rep.max_depth) + " m");
    const fs::path glb = out / "snow.glb";
    save_or_throw(scene, glb.string(), ground.string());
    outputs.push_back(glb.string());
    RenderOptions ro = preview_options(cam, a);
    write_render(scene, ro, out / "snow_shaded.png", outputs);
    ro.mode = RenderMode::wireframe;
    write_render(scene, ro, out / "snow_wireframe.png", outputs);
}

// The ground tessellated for one view (the same camera as its previews): the surface error is held under
// a fraction of a preview pixel, so near hills get fine triangles and the far side stays coarse.
void demo_terrain(const nlohmann::json& t, const fs::path& models, const DemoArgs& a, const fs::path& out,
                  std::vector<std::string>& outputs, const GlobalFlags& g) {
    const fs::path ground = models / t.at("ground").get<std::string>();
    const RenderCamera cam = camera_from_json(t.value("camera", nlohmann::json::object()));
    Scene scene = load_or_throw(ground.string());
    TessellateOptions o;
    const std::string scheme = t.value("scheme", std::string("catmark"));
    if (scheme == "catmark") o.surface.scheme = SubdivisionScheme::catmark;
    else if (scheme == "loop") o.surface.scheme = SubdivisionScheme::loop;
    else if (scheme == "bilinear") o.surface.scheme = SubdivisionScheme::bilinear;
    else throw InputError(ground.string(), "unknown scheme \"" + scheme + "\" in the demo scene");
    if (!cam.eye) throw InputError(ground.string(), "the demo terrain needs a camera eye (the view it is tessellated for)");
    o.rates.camera = TessellationCamera{*cam.eye, cam.fov_degrees, a.height};
    o.rates.screen_error = t.value("screen_error", 2.0);
    o.rates.max_rate = t.value("max_rate", 8);
    SceneTessellateReport rep;
    require_ok(tessellate_scene(scene, o, &rep), ground.string());
    info(g, "terrain: " + scheme + ", at most " + std::to_string(o.rates.screen_error).substr(0, 4) +
                " px surface error from the camera: " + std::to_string(rep.triangles_in) + " -> " +
                std::to_string(rep.triangles_out) + " triangles, edge rates " + std::to_string(rep.totals.min_rate) +
                ".." + std::to_string(rep.totals.max_rate));
    const fs::path glb = out / "terrain.glb";
    save_or_throw(scene, glb.string(), ground.string());
    outputs.push_back(glb.string());
    RenderOptions ro = preview_options(cam, a);
    write_render(scene, ro, out / "terrain_shaded.png", outputs);
    ro.mode = RenderMode::wireframe;
    write_render(scene, ro, out / "terrain_wireframe.png", outputs);
}

// `from` appended to `into`: its meshes, materials, textures, samplers, images, skins and nodes follow
// those of `into`, every index shifted (nothing of `into` moves, as Scene asks). Its roots are returned, not
// added to the default scene. Only `into`'s source document is kept (`from`'s extras and animations are not).
std::vector<int> append_scene(Scene& into, const Scene& from) {
    const int meshes = int(into.meshes.size()), materials = int(into.materials.size()), textures = int(into.textures.size());
    const int samplers = int(into.samplers.size()), images = int(into.images.size()), skins = int(into.skins.size());
    const int nodes = int(into.nodes.size());
    auto shift = [](int i, int by) { return i >= 0 ? i + by : i; };
    for (Mesh m : from.meshes) {
        for (Primitive& p : m.primitives) p.material = shift(p.material, materials);
        into.meshes.push_back(std::move(m));
    }
    for (Material m : from.materials) {
        m.base_color_texture.texture = shift(m.base_color_texture.texture, textures);
        into.materials.push_back(std::move(m));
    }
    for (Texture t : from.textures) into.textures.push_back({shift(t.image, images), shift(t.sampler, samplers)});
    into.samplers.insert(into.samplers.end(), from.samplers.begin(), from.samplers.end());
    into.images.insert(into.images.end(), from.images.begin(), from.images.end());
    for (Skin k : from.skins) {
        for (int& j : k.joints) j = shift(j, nodes);
        k.skeleton = shift(k.skeleton, nodes);
        into.skins.push_back(std::move(k));
    }
    for (Node n : from.nodes) {
        n.mesh = shift(n.mesh, meshes);
        n.skin = shift(n.skin, skins);
        n.camera = -1; // cameras live in the source document, which is not carried over
        for (int& c : n.children) c = shift(c, nodes);
        into.nodes.push_back(std::move(n));
    }
    std::vector<int> roots;
    for (int r : from.roots) roots.push_back(shift(r, nodes));
    return roots;
}

// The combined scene: the furred creature standing in the snow (models/scene.json "scene": its position and
// heading), the snow stamped by the bundled colliders and by the creature's own trail of paw prints; one
// GLB and one picture.
void demo_combined(const nlohmann::json& d, const nlohmann::json& snow, const fs::path& models, Scene fur, const DemoArgs& a,
                   const fs::path& out, std::vector<std::string>& outputs, const GlobalFlags& g) {
    const fs::path ground = models / snow.at("ground").get<std::string>();
    const fs::path colliders = models / snow.at("colliders").get<std::string>();
    ColliderSet set, trail;
    require_ok(load_colliders(set, colliders.string()), colliders.string());
    require_ok(parse_colliders(trail, d.at("trail").dump(), models.string()), (models / "scene.json").string());
    set.colliders.insert(set.colliders.end(), trail.colliders.begin(), trail.colliders.end());
    Scene scene = load_or_throw(ground.string());
    StampOptions so;
    so.snow.resolution = 1024;
    so.snow.rim_width = 0.05;
    const RenderCamera cam = camera_from_json(d.value("camera", nlohmann::json::object()));
    if (cam.eye) so.camera = StampCamera{*cam.eye, cam.fov_degrees, a.height, 1.0};
    StampReport rep;
    require_ok(stamp_scene(scene, set, so, &rep), ground.string());
    // The creature under one new root node: moved to its place and turned to its heading (about up).
    Node place;
    place.name = "creature_in_snow";
    place.translation = d.at("position").get<std::array<double, 3>>();
    const double h = d.value("heading", 0.0) * std::numbers::pi / 360;
    place.rotation = {0, std::sin(h), 0, std::cos(h)};
    place.children = fur.roots.empty() ? std::vector<int>{} : fur.roots;
    const std::vector<int> ground_roots = append_scene(fur, scene);
    fur.nodes.push_back(place);
    fur.roots = {int(fur.nodes.size() - 1)};
    fur.roots.insert(fur.roots.end(), ground_roots.begin(), ground_roots.end());
    info(g, "scene: the furred creature in the snow, " + std::to_string(trail.colliders.size()) + " paw prints in its trail, " +
                std::to_string(rep.triangles_out) + " snow triangles");
    const fs::path glb = out / "scene.glb";
    save_or_throw(fur, glb.string(), ground.string());
    outputs.push_back(glb.string());
    write_render(fur, preview_options(cam, a), out / "scene_shaded.png", outputs);
}

} // namespace

void run_demo(const DemoArgs& a, const GlobalFlags& g) {
    const fs::path models(a.models);
    const fs::path scene_file = models / "scene.json";
    std::ifstream in(scene_file);
    if (!in) throw InputError(scene_file.string(), "cannot open the demo scene description");
    nlohmann::json desc = nlohmann::json::parse(in, nullptr, false);
    if (desc.is_discarded() || !desc.is_object())
        throw InputError(scene_file.string(), "not a valid JSON object");
    std::error_code ec;
    fs::create_directories(a.out, ec);
    if (ec) throw InputError(a.out, "cannot create the output folder: " + ec.message());
    const fs::path out(a.out);
    std::vector<std::string> outputs;
    std::optional<Scene> fur; // the furred creature, placed again in the combined scene
    Progress progress(g, "furrow demo");
    try {
        if (desc.contains("creature")) {
            const auto& c = desc["creature"];
            const auto cam = camera_from_json(c.value("camera", nlohmann::json::object()));
            progress.stage("creature");
            demo_model("creature", models / c.at("model").get<std::string>(), cam, a, out, outputs, g);
            progress.stage("creature fur");
            fur = demo_fur(models / c.at("model").get<std::string>(),
                           c.contains("fur_mask") ? models / c["fur_mask"].get<std::string>() : fs::path(), cam, a, out,
                           outputs, g);
        }
        if (desc.contains("snow")) {
            const auto& s = desc["snow"];
            const auto cam = camera_from_json(s.value("camera", nlohmann::json::object()));
            progress.stage("ground");
            demo_model("ground", models / s.at("ground").get<std::string>(), cam, a, out, outputs, g);
            progress.stage("snow field");
            if (s.contains("colliders"))
                demo_snow(models / s["ground"].get<std::string>(), models / s["colliders"].get<std::string>(), cam, a,
                          out, outputs, g);
        }
        progress.stage("terrain");
        if (desc.contains("terrain")) demo_terrain(desc["terrain"], models, a, out, outputs, g);
        progress.stage("scene");
        if (desc.contains("scene") && desc.contains("snow") && fur)
            demo_combined(desc["scene"], desc["snow"], models, std::move(*fur), a, out, outputs, g);
    } catch (const nlohmann::json::exception& e) {
        throw InputError(scene_file.string(), std::string("bad scene description: ") + e.what());
    }
    std::printf("furrow demo wrote %zu files to %s:\n", outputs.size(), fs::absolute(out).string().c_str());
    for (const auto& o : outputs) std::printf("  %s\n", o.c_str());
}

void register_demo(CLI::App& app, GlobalFlags& g) {
    auto a = std::make_shared<DemoArgs>();
    CLI::App* cmd = app.add_subcommand("demo", "Run the main job on the bundled default scene (models/scene.json)");
    cmd->add_option("--models", a->models, "Folder with scene.json and the sample assets (default: the bundled models/)");
    cmd->add_option("-o,--output", a->out, "Output folder, created if missing (default: furrow-demo)");
    cmd->add_option("--ssaa", a->ssaa, "Supersampling of the previews (default 2)")->check(finite_range(1, 8));
    cmd->footer("Examples:\n  furrow demo\n  furrow demo -o /tmp/demo");
    cmd->callback([a, &g] { run_demo(*a, g); });
}

} // namespace furrow::cli

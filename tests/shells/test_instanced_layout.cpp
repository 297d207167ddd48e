// The instanced shell layout (ShellLayout::instanced): the shell base written once, rebuilt into every shell
// by instanced_shell_positions (the README's vertex-shader formula), must give the engine layout's shells;
// its file must be valid glTF in every encoding, load back, stay out of the default scene and be about 1/N of
// the engine layout's size.
#include "shells_internal.h"
#include "test_support.h"

#include <furrow/shapes.h>
#include <furrow/shells.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cmath>
#include <cstdio>

namespace furrow {
namespace {

namespace fs = std::filesystem;

const CustomAttribute* attribute(const Primitive& p, const std::string& name) {
    for (const CustomAttribute& c : p.custom)
        if (c.name == name) return &c;
    return nullptr;
}

double diagonal(const Primitive& p) {
    std::array<double, 3> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (size_t i = 0; i < p.positions.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], double(p.positions[i]));
        hi[i % 3] = std::max(hi[i % 3], double(p.positions[i]));
    }
    return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

// Shell `layer` of `layers` rebuilt from an instanced shell base.
std::vector<float> rebuild(const Primitive& b, int layer, int layers, double power) {
    const CustomAttribute *dir = attribute(b, "_FUR_DIRECTION"), *len = attribute(b, "_FUR_LENGTH");
    const CustomAttribute *lean = attribute(b, "_FUR_LEAN"), *sag = attribute(b, "_FUR_SAG");
    EXPECT_TRUE(dir && len);
    std::vector<float> out(b.positions.size());
    if (!dir || !len) return out;
    instanced_shell_positions(out.data(), b.positions.data(), dir->values.data(), len->values.data(),
                              lean ? lean->values.data() : nullptr, sag ? sag->values.data() : nullptr, b.vertex_count(), layer,
                              layers, power);
    return out;
}

// The engine layout's shell primitive and the instanced layout's shell base of the same furred scene.
struct Pair {
    Scene engine, instanced;
    FurReport engine_report, instanced_report;
};

Pair grow_both(const Scene& source, FurOptions o) {
    Pair p{source, source, {}, {}};
    o.layout = ShellLayout::engine;
    EXPECT_TRUE(add_fur_shells(p.engine, o, &p.engine_report).ok());
    o.layout = ShellLayout::instanced;
    EXPECT_TRUE(add_fur_shells(p.instanced, o, &p.instanced_report).ok());
    return p;
}

const Primitive& shell_base(const Scene& s, const FurReport& r) {
    EXPECT_EQ(r.shell_nodes.size(), 1u);
    return s.meshes[size_t(s.nodes[size_t(r.shell_nodes.at(0))].mesh)].primitives.at(0);
}

// Largest distance between shell i of the engine primitive (vertices [i·m, (i+1)·m)) and the rebuilt shell,
// over all shells, divided by the bounding-box diagonal of the engine primitive.
double worst_relative_gap(const Primitive& engine, const Primitive& base, int layers, double power) {
    const size_t m = base.vertex_count();
    EXPECT_EQ(engine.vertex_count(), size_t(layers) * m);
    if (engine.vertex_count() != size_t(layers) * m) return 1e300;
    double worst = 0;
    for (int i = 1; i <= layers; ++i) {
        const std::vector<float> rebuilt = rebuild(base, i, layers, power);
        for (size_t j = 0; j < 3 * m; ++j)
            worst = std::max(worst, std::abs(double(rebuilt[j]) - engine.positions[size_t(i - 1) * 3 * m + j]));
    }
    return worst / diagonal(engine);
}

// After a save and a load each file has its own vertex order: compare every shell as a sorted list of points
// (the engine shell's vertices found by their _FUR_LAYER value).
double worst_relative_gap_loaded(const Primitive& engine, const Primitive& base, int layers, double power) {
    const CustomAttribute* layer = attribute(engine, "_FUR_LAYER");
    EXPECT_TRUE(layer);
    if (!layer) return 1e300;
    double worst = 0;
    for (int i = 1; i <= layers; ++i) {
        const float s = float(shell_height_fraction(i, layers, power));
        std::vector<std::array<float, 3>> a, b;
        for (size_t v = 0; v < engine.vertex_count(); ++v)
            if (layer->values[v] == s) a.push_back({engine.positions[3 * v], engine.positions[3 * v + 1], engine.positions[3 * v + 2]});
        const std::vector<float> rebuilt = rebuild(base, i, layers, power);
        for (size_t v = 0; v < base.vertex_count(); ++v) b.push_back({rebuilt[3 * v], rebuilt[3 * v + 1], rebuilt[3 * v + 2]});
        EXPECT_EQ(a.size(), b.size()) << "shell " << i;
        if (a.size() != b.size()) return 1e300;
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        for (size_t v = 0; v < a.size(); ++v)
            for (size_t k = 0; k < 3; ++k) worst = std::max(worst, std::abs(double(a[v][k]) - b[v][k]));
    }
    return worst / diagonal(engine);
}

Scene load(const fs::path& f) {
    Scene s;
    Status st = load_scene(s, f.string());
    EXPECT_TRUE(st.ok()) << st.message;
    return s;
}

// The bundled creature's fur: `layers` shells of 0.04 under its mask (the demo's options).
FurOptions creature_fur(int layers) {
    FurOptions o;
    o.shells.layers = layers;
    o.shells.length = 0.04;
    EXPECT_TRUE(load_png(o.mask, (test::models_dir() / "creature_fur_mask.png").string()).ok());
    return o;
}

// The mesh whose name ends in `suffix` in a loaded scene (by mesh name: a quantized file moves the mesh from
// its named node to a dequantizing child).
const Mesh* mesh_named(const Scene& s, const std::string& suffix) {
    for (const Mesh& m : s.meshes)
        if (m.name.size() >= suffix.size() && m.name.compare(m.name.size() - suffix.size(), suffix.size(), suffix) == 0) return &m;
    return nullptr;
}

void expect_rebuilds_engine_layout(const Scene& source, const FurOptions& o, const std::string& name) {
    Pair p = grow_both(source, o);
    const Primitive& base = shell_base(p.instanced, p.instanced_report);
    const Primitive& engine = p.engine.meshes[0].primitives.back();
    const int N = o.shells.layers;
    const double power = o.shells.spacing_power;
    EXPECT_LE(worst_relative_gap(engine, base, N, power), 1e-6);
    // In files: save both (the CLI's default options), load, rebuild from the loaded attributes.
    const fs::path fe = test::temp_dir() / (name + "_engine.glb"), fi = test::temp_dir() / (name + "_instanced.glb");
    ASSERT_TRUE(save_scene(p.engine, fe.string()).ok());
    ASSERT_TRUE(save_scene(p.instanced, fi.string()).ok());
    EXPECT_VALID_GLTF(fi);
    const Scene le = load(fe), li = load(fi);
    const Mesh* shells = mesh_named(li, "_fur_shells");
    ASSERT_TRUE(shells);
    ASSERT_FALSE(le.meshes.empty());
    const double gap = worst_relative_gap_loaded(le.meshes[0].primitives.back(), shells->primitives.at(0), N, power);
    std::printf("%s: %d shells rebuilt from the loaded instanced file, largest gap to the engine layout's %.3g x diagonal\n",
                name.c_str(), N, gap);
    EXPECT_LE(gap, 1e-6);
}

TEST(instanced_layout, RebuildsTheEngineShellsOfTheMaskedCreature) {
    const Scene creature = load(test::models_dir() / "creature.glb");
    const FurOptions o = creature_fur(16);
    expect_rebuilds_engine_layout(creature, o, "creature");
}

TEST(instanced_layout, RebuildsCombedDroopingShellsWithSpacing) {
    Scene s = make_scene(shapes::uv_sphere(0.5f, 32, 16), "sphere");
    FurOptions o;
    o.shells.layers = 12;
    o.shells.length = 0.08;
    o.shells.droop = 2.0;
    o.shells.spacing_power = 1.7;
    o.comb = ImageF{2, 2, 3, {0.9f, 0.5f, 0, 0.8f, 0.7f, 0, 0.6f, 0.2f, 0, 0.9f, 0.9f, 0}};
    Pair p = grow_both(s, o);
    const Primitive& base = shell_base(p.instanced, p.instanced_report);
    const CustomAttribute *lean = attribute(base, "_FUR_LEAN"), *sag = attribute(base, "_FUR_SAG");
    ASSERT_TRUE(lean && sag) << "comb and droop must be carried per vertex";
    EXPECT_TRUE(std::any_of(lean->values.begin(), lean->values.end(), [](float x) { return std::abs(x) > 0.05f; }));
    EXPECT_TRUE(std::any_of(sag->values.begin(), sag->values.end(), [](float x) { return std::abs(x) > 0.05f; }));
    // Without them the shells would not match: the check below can fail.
    Primitive straight = base;
    straight.custom.resize(2);
    EXPECT_GT(worst_relative_gap(p.engine.meshes[0].primitives.back(), straight, 12, 1.7), 1e-3);
    expect_rebuilds_engine_layout(s, o, "combed");
}

TEST(instanced_layout, ExtrasCarryTheLayerParametersAndStayOutOfTheScene) {
    Scene s = make_scene(shapes::uv_sphere(0.5f, 32, 16), "sphere");
    FurOptions o;
    o.shells.layers = 6;
    o.shells.length = 0.05;
    o.shells.spacing_power = 1.5;
    o.shells.lod_levels = 2;
    Scene viewer = s;
    ASSERT_TRUE(add_fur_shells(viewer, o).ok()); // its materials hold the cutoffs the instanced layout documents
    o.layout = ShellLayout::instanced;
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, o, &r).ok());
    ASSERT_EQ(r.shell_nodes.size(), 1u);
    EXPECT_EQ(s.meshes[0].primitives.size(), 1u); // the source mesh is untouched (no fins asked for)
    const std::vector<int> drawn = s.drawn_nodes();
    EXPECT_EQ(std::count(drawn.begin(), drawn.end(), r.shell_nodes[0]), 0);
    EXPECT_EQ(s.nodes[size_t(r.shell_nodes[0])].name, "sphere_fur_shells");

    const fs::path f = test::temp_dir() / "instanced.gltf";
    ASSERT_TRUE(save_scene(s, f.string()).ok());
    EXPECT_VALID_GLTF(f);
    const nlohmann::json j = test::gltf_json(f);
    const nlohmann::json& mesh = j["meshes"][size_t(s.nodes[size_t(r.shell_nodes[0])].mesh)];
    ASSERT_TRUE(mesh.contains("extras")) << mesh.dump();
    const nlohmann::json& x = mesh["extras"]["FURROW_shells"];
    EXPECT_EQ(x["version"], 1);
    EXPECT_EQ(x["layers"], 6);
    EXPECT_DOUBLE_EQ(x["spacing_power"].get<double>(), 1.5);
    EXPECT_DOUBLE_EQ(x["root_shade"].get<double>(), o.root_shade);
    const int material = x["material"];
    EXPECT_EQ(mesh["primitives"][0]["material"], material);
    EXPECT_EQ(j["materials"][size_t(material)]["pbrMetallicRoughness"]["baseColorTexture"]["index"], x["strand_texture"]);
    ASSERT_EQ(x["levels"].size(), 2u);
    auto viewer_cutoff = [&](int k, int i) { // of the viewer layout's material "fur_shell_lod<k>_<i>"
        for (const Material& m : viewer.materials)
            if (m.name == "fur_shell_lod" + std::to_string(k) + "_" + std::to_string(i)) return m.alpha_cutoff;
        ADD_FAILURE() << "no viewer material for level " << k << " shell " << i;
        return -1.0f;
    };
    for (int k = 0; k < 2; ++k) {
        const nlohmann::json& level = x["levels"][size_t(k)];
        const int n = level["layers"];
        EXPECT_EQ(n, 6 >> k);
        ASSERT_EQ(level["cutoffs"].size(), size_t(n));
        for (int i = 1; i <= n; ++i) {
            EXPECT_DOUBLE_EQ(level["heights"][size_t(i - 1)].get<double>(), shell_height_fraction(i, n, 1.5));
            EXPECT_EQ(level["cutoffs"][size_t(i - 1)].get<float>(), viewer_cutoff(k, i)) << k << " " << i;
        }
    }
    EXPECT_FALSE(j.contains("extensionsUsed")) << "extras need no extension";
}

// --lod-simplify in the instanced layout: each far level grows on its own simplified base, a mesh
// "<mesh>_fur_shells_lod<k>" outside the scene that level 0's extras name (levels[k].mesh); rebuilt by the
// same formula it gives the engine layout's level-k shells, and it has fewer triangles than level 0's base.
TEST(instanced_layout, SimplifiedLevelsHaveTheirOwnBasesAndRebuildTheEngineLevels) {
    const Scene creature = load(test::models_dir() / "creature.glb");
    FurOptions o = creature_fur(8);
    o.shells.lod_levels = 3;
    o.lod_simplify_error = 0.01;
    Pair p = grow_both(creature, o);
    ASSERT_EQ(p.engine_report.lod_nodes.size(), 2u);
    ASSERT_EQ(p.instanced_report.lod_nodes.size(), 2u);
    const Primitive& level0 = shell_base(p.instanced, p.instanced_report);
    const int own_mesh = p.instanced.nodes[size_t(p.instanced_report.shell_nodes[0])].mesh;
    const nlohmann::json x = nlohmann::json::parse(p.instanced.meshes[size_t(own_mesh)].extras_json)["FURROW_shells"];
    ASSERT_EQ(x["levels"].size(), 3u);
    EXPECT_FALSE(x["levels"][0].contains("mesh")) << "level 0 draws the mesh that holds the extras";
    for (int k = 1; k <= 2; ++k) {
        const Node& in = p.instanced.nodes[size_t(p.instanced_report.lod_nodes[size_t(k - 1)])];
        const Node& en = p.engine.nodes[size_t(p.engine_report.lod_nodes[size_t(k - 1)])];
        EXPECT_EQ(in.name, "creature_fur_shells_lod" + std::to_string(k));
        EXPECT_EQ(x["levels"][size_t(k)]["mesh"], in.mesh);
        const Primitive& base = p.instanced.meshes[size_t(in.mesh)].primitives.at(0);
        EXPECT_LT(base.indices.size(), level0.indices.size() / 2) << "level " << k << " is not simplified";
        const Primitive& engine = p.engine.meshes[size_t(en.mesh)].primitives.back();
        EXPECT_LE(worst_relative_gap(engine, base, 8 >> k, o.shells.spacing_power), 1e-6) << "level " << k;
    }
    const std::vector<int> drawn = p.instanced.drawn_nodes();
    for (int n : p.instanced_report.lod_nodes) EXPECT_EQ(std::count(drawn.begin(), drawn.end(), n), 0);
    const fs::path f = test::temp_dir() / "instanced_lod.glb";
    ASSERT_TRUE(save_scene(p.instanced, f.string()).ok());
    EXPECT_VALID_GLTF(f);
    const Scene back = load(f);
    EXPECT_TRUE(mesh_named(back, "_fur_shells_lod1") && mesh_named(back, "_fur_shells_lod2"));
}

TEST(instanced_layout, EveryEncodingIsValidAndLoads) {
    const Scene creature = load(test::models_dir() / "creature.glb");
    FurOptions o;
    o.shells.layers = 8;
    o.shells.length = 0.04;
    o.shells.droop = 1.0;
    o.fins = true;
    o.layout = ShellLayout::instanced;
    Scene s = creature;
    ASSERT_TRUE(add_fur_shells(s, o).ok());
    for (Encoding e : {Encoding::plain, Encoding::quantize, Encoding::compress}) {
        const fs::path f = test::temp_dir() / ("instanced_" + std::to_string(int(e)) + ".glb");
        SaveOptions so;
        so.encoding = e;
        ASSERT_TRUE(save_scene(s, f.string(), so).ok());
        EXPECT_VALID_GLTF(f);
        const Scene back = load(f);
        const Mesh* shells = mesh_named(back, "_fur_shells");
        ASSERT_TRUE(shells) << int(e);
        for (const char* name : {"_FUR_DIRECTION", "_FUR_LENGTH", "_FUR_SAG"}) EXPECT_TRUE(attribute(shells->primitives.at(0), name)) << name;
    }
}

TEST(instanced_layout, ExtrasMustBeAJsonObject) {
    Scene s = make_scene(shapes::uv_sphere(0.5f, 8, 4), "sphere");
    s.meshes[0].extras_json = "[1, 2]";
    const fs::path f = test::temp_dir() / "bad.glb";
    Status st = save_scene(s, f.string());
    EXPECT_EQ(st.code, StatusCode::invalid_argument);
    EXPECT_NE(st.message.find("extras_json"), std::string::npos) << st.message;
    EXPECT_FALSE(fs::exists(f));
    s.meshes[0].extras_json = R"({"note": "kept"})";
    ASSERT_TRUE(save_scene(s, f.string()).ok());
    EXPECT_EQ(test::gltf_json(f)["meshes"][0]["extras"]["note"], "kept");
}

// About 1/N of the engine layout: what the shells add (file minus the bare model's) with 32 layers.
TEST(instanced_layout, AddsAboutOneNthOfTheEngineLayoutsBytes) {
    const Scene creature = load(test::models_dir() / "creature.glb");
    const FurOptions o = creature_fur(32);
    Pair p = grow_both(creature, o);
    const fs::path d = test::temp_dir();
    ASSERT_TRUE(save_scene(creature, (d / "bare.glb").string()).ok());
    ASSERT_TRUE(save_scene(p.engine, (d / "engine.glb").string()).ok());
    ASSERT_TRUE(save_scene(p.instanced, (d / "instanced.glb").string()).ok());
    const double bare = double(fs::file_size(d / "bare.glb")), engine = double(fs::file_size(d / "engine.glb")),
                 instanced = double(fs::file_size(d / "instanced.glb"));
    const double ratio = (instanced - bare) / (engine - bare);
    std::printf("bytes: bare %.0f, engine %.0f, instanced %.0f; added by the shells: instanced / engine = %.4f (1/N = %.4f)\n", bare,
                engine, instanced, ratio, 1.0 / 32);
    EXPECT_LT(ratio, 2.5 / 32);
}

// instanced_shell_positions computes runs without droop (every sag component 0) in one vectorised loop, and
// the rest vertex by vertex through strand_offset: both must give the reference formula's bits, float of
// root + H·strand_offset, with signed zeros (roots, directions, lean and sag of -0), lean and sag passed or
// null, runs of 1024 vertices with and without droop, and every layer of a curved spacing.
TEST(instanced_layout, StraightRunsGiveTheStrandFormulasBits) {
    const size_t n = 3000; // blocks of 1024: straight, one bent vertex, sag of -0 and +0 only
    uint64_t seed = 71;
    auto uniform = [&seed](double lo, double hi) { return lo + (hi - lo) * double(test::splitmix64(seed) >> 11) * 0x1p-53; };
    std::vector<float> root(3 * n), dir(3 * n), len(n), lean(3 * n), sag(3 * n, 0.0f);
    for (size_t j = 0; j < 3 * n; ++j) {
        auto pick = [&seed] { return test::splitmix64(seed) % 4; }; // zeros in a quarter of each, independently
        root[j] = pick() == 0 ? (pick() % 2 ? -0.0f : 0.0f) : float(uniform(-1e3, 1e3));
        dir[j] = pick() == 0 ? (pick() % 2 ? -0.0f : 0.0f) : float(uniform(-1, 1));
        lean[j] = pick() == 0 ? (pick() % 2 ? -0.0f : 0.0f) : float(uniform(-0.3, 0.3));
    }
    for (size_t v = 0; v < n; ++v) len[v] = test::splitmix64(seed) % 5 == 0 ? 0.0f : float(uniform(0, 0.05));
    sag[3 * 1500 + 1] = 0.7f;                                            // one bent vertex in the second block
    for (size_t j = 3 * 2048; j < 3 * n; j += 2) sag[j] = -0.0f;         // zeros of either sign: straight
    const float zero[3] = {0, 0, 0};
    for (bool with_lean : {false, true})
        for (bool with_sag : {false, true}) {
            const float* l = with_lean ? lean.data() : nullptr;
            const float* g = with_sag ? sag.data() : nullptr;
            const int layers = 7;
            for (int layer = 1; layer <= layers; ++layer) {
                std::vector<float> out(3 * n);
                instanced_shell_positions(out.data(), root.data(), dir.data(), len.data(), l, g, n, layer, layers, 1.7);
                const double s = shell_height_fraction(layer, layers, 1.7);
                for (size_t v = 0; v < n; ++v) {
                    const auto o = shells_detail::strand_offset(&dir[3 * v], l ? l + 3 * v : zero, g ? g + 3 * v : zero, s);
                    for (size_t k = 0; k < 3; ++k) {
                        const float want = float(double(root[3 * v + k]) + double(len[v]) * o[k]);
                        ASSERT_EQ(std::bit_cast<uint32_t>(out[3 * v + k]), std::bit_cast<uint32_t>(want))
                            << "vertex " << v << " axis " << k << " layer " << layer << (with_lean ? " lean" : "") << (with_sag ? " sag" : "");
                    }
                }
            }
        }
}

} // namespace
} // namespace furrow

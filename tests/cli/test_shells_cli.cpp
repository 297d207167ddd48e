// `furrow shells`: outputs valid glTF, reports clamps, identical bytes for any thread count, the error contract.
#include "test_support.h"

#include <furrow/shapes.h>

namespace furrow {
namespace {

namespace fs = std::filesystem;
using test::run_furrow;

fs::path write_sphere(const fs::path& dir, bool with_uv = true) {
    Primitive p = with_uv ? shapes::uv_sphere(0.5f, 24, 12) : shapes::icosphere(0.5f, 2);
    fs::path file = dir / (with_uv ? "sphere.glb" : "ico.glb");
    EXPECT_TRUE(save_scene(make_scene(p), file.string()).ok());
    return file;
}

TEST(furrow_shells, WritesValidViewerAndEngineLayouts) {
    fs::path dir = test::temp_dir(), in = write_sphere(dir);
    auto r = run_furrow({"shells", in.string(), "-o", (dir / "viewer.glb").string(), "--layers", "8", "--length", "0.05"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("8 shells"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("clamped"), std::string::npos) << r.err;
    EXPECT_VALID_GLTF(dir / "viewer.glb");
    auto j = test::gltf_json(dir / "viewer.glb");
    EXPECT_EQ(j["meshes"][0]["primitives"].size(), 9u);
    EXPECT_EQ(j["materials"][1]["alphaMode"], "MASK");

    r = run_furrow({"shells", in.string(), "-o", (dir / "engine.gltf").string(), "--layers", "4", "--length", "0.05", "--layout",
                    "engine", "--fins", "--lod", "2", "--droop", "0.5", "--spacing-power", "1.5", "--seed", "3", "--density", "800"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_VALID_GLTF(dir / "engine.gltf");
    j = test::gltf_json(dir / "engine.gltf");
    EXPECT_TRUE(j["meshes"][0]["primitives"][1]["attributes"].contains("_FUR_LAYER"));
    EXPECT_TRUE(j["meshes"][0]["primitives"][2]["attributes"].contains("_FUR_FIN_NORMAL"));
}

TEST(furrow_shells, InstancedLayoutWritesTheBaseOnceWithItsLayerParameters) {
    fs::path dir = test::temp_dir(), in = write_sphere(dir);
    auto r = run_furrow({"shells", in.string(), "-o", (dir / "instanced.glb").string(), "--layers", "8", "--length", "0.05",
                         "--layout", "instanced", "--droop", "1", "--fins", "--compress"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("instanced"), std::string::npos) << r.err;
    EXPECT_VALID_GLTF(dir / "instanced.glb");
    auto j = test::gltf_json(dir / "instanced.glb");
    EXPECT_EQ(j["meshes"][0]["primitives"].size(), 2u); // the sphere and its fins: stock viewers show no shells
    ASSERT_EQ(j["meshes"].size(), 2u);
    const auto& shells = j["meshes"][1];
    EXPECT_EQ(shells["name"], "mesh_fur_shells");
    for (const char* a : {"_FUR_DIRECTION", "_FUR_LENGTH", "_FUR_SAG"}) EXPECT_TRUE(shells["primitives"][0]["attributes"].contains(a)) << a;
    EXPECT_EQ(shells["extras"]["FURROW_shells"]["layers"], 8);
    EXPECT_EQ(shells["extras"]["FURROW_shells"]["levels"][0]["cutoffs"].size(), 8u);
    for (int root : j["scenes"][0]["nodes"]) EXPECT_NE(j["nodes"][size_t(root)]["name"], "mesh_fur_shells");
}

// Triangles of a mesh's primitives in a written file, by the mesh's name (0 if absent).
size_t mesh_triangles(const nlohmann::json& j, const std::string& name) {
    size_t n = 0;
    for (const auto& m : j["meshes"])
        if (m["name"] == name)
            for (const auto& p : m["primitives"]) n += j["accessors"][p["indices"].get<size_t>()]["count"].get<size_t>() / 3;
    return n;
}

// --lod-simplify: far levels grow on a simplified base in the viewer layout (their meshes have fewer
// triangles than without it) and in the instanced layout (a base mesh per level, named in the extras); the
// report lists the triangles per level; an error outside 0..1 is refused with exit 2 and nothing written.
TEST(furrow_shells, LodSimplifyShrinksTheFarLevelsInEveryLayout) {
    const fs::path dir = test::temp_dir(), creature = test::models_dir() / "creature.glb";
    auto shells = [&](const std::string& out, std::vector<std::string> extra) {
        std::vector<std::string> args{"shells", creature.string(), "-o", (dir / out).string(), "--layers", "8", "--length", "0.04", "--lod", "3"};
        args.insert(args.end(), extra.begin(), extra.end());
        return run_furrow(args);
    };
    auto r = shells("full.glb", {});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    r = shells("simplified.glb", {"--lod-simplify", "0.01"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("LOD base triangles"), std::string::npos) << r.err;
    EXPECT_VALID_GLTF(dir / "simplified.glb");
    const auto full = test::gltf_json(dir / "full.glb"), simplified = test::gltf_json(dir / "simplified.glb");
    for (const char* level : {"creature_fur_lod1", "creature_fur_lod2"}) {
        EXPECT_GT(mesh_triangles(simplified, level), 0u) << level;
        EXPECT_LT(mesh_triangles(simplified, level), mesh_triangles(full, level)) << level;
    }

    r = shells("instanced.glb", {"--lod-simplify", "0.01", "--layout", "instanced"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("LOD base triangles"), std::string::npos) << r.err;
    EXPECT_VALID_GLTF(dir / "instanced.glb");
    const auto inst = test::gltf_json(dir / "instanced.glb");
    const size_t base = mesh_triangles(inst, "creature_fur_shells");
    EXPECT_GT(base, 0u);
    for (int k = 1; k <= 2; ++k) {
        const std::string name = "creature_fur_shells_lod" + std::to_string(k);
        EXPECT_GT(mesh_triangles(inst, name), 0u) << name;
        EXPECT_LT(mesh_triangles(inst, name), base / 2) << name;
    }

    r = shells("refused.glb", {"--lod-simplify", "1.5"});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_FALSE(fs::exists(dir / "refused.glb"));
}

TEST(furrow_shells, MaskWithChannelAndCreature) {
    fs::path dir = test::temp_dir();
    const fs::path models = test::models_dir();
    auto r = run_furrow({"shells", (models / "creature.glb").string(), "-o", (dir / "furry.glb").string(), "--layers", "8", "--length",
                         "0.04", "--mask", (models / "creature_fur_mask.png").string() + ":r", "--fins"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_VALID_GLTF(dir / "furry.glb");
    EXPECT_NE(r.err.find("dropped"), std::string::npos) << r.err; // the bald nose and eyes
    // A grey mask has no alpha channel.
    r = run_furrow({"shells", (models / "creature.glb").string(), "-o", (dir / "x.glb").string(), "--length", "0.04", "--mask",
                    (models / "creature_fur_mask.png").string() + ":a"});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find("alpha"), std::string::npos) << r.err;
}

TEST(furrow_shells, IdenticalBytesForAnyThreadCount) {
    fs::path dir = test::temp_dir();
    const fs::path creature = test::models_dir() / "creature.glb";
    for (const char* layout : {"viewer", "instanced"}) {
        std::vector<std::string> common{"shells", creature.string(), "--layers", "6", "--length", "0.05", "--fins", "--lod", "2",
                                        "--droop", "1", "--mask", (test::models_dir() / "creature_fur_mask.png").string(),
                                        "--layout", layout};
        auto a = common, b = common;
        a.insert(a.begin(), {"-j", "1"});
        a.insert(a.end(), {"-o", (dir / "a.glb").string()});
        b.insert(b.begin(), {"-j", "2"});
        b.insert(b.end(), {"-o", (dir / "b.glb").string()});
        auto ra = run_furrow(a), rb = run_furrow(b);
        ASSERT_EQ(ra.exit_code, 0) << ra.err;
        ASSERT_EQ(rb.exit_code, 0) << rb.err;
        EXPECT_EQ(test::read_bytes(dir / "a.glb"), test::read_bytes(dir / "b.glb")) << layout;
    }
}

TEST(furrow_shells, BadInputFollowsTheErrorContract) {
    fs::path dir = test::temp_dir(), in = write_sphere(dir), ico = write_sphere(dir, false);
    const std::string out = (dir / "out.glb").string();
    // Out-of-range options are usage errors (exit 2).
    for (std::vector<std::string> bad : {std::vector<std::string>{"--layers", "0"}, {"--layers", "257"}, {"--length", "-1"}, {"--length", "nan"},
                                         {"--length", "inf"}, {"--layout", "fancy"}, {"--lod", "0"}, {"--refine-tolerance", "-0.1"},
                                         {"--refine-tolerance", "1.5"}, {"--refine-tolerance", "nan"}}) {
        std::vector<std::string> args{"shells", in.string(), "-o", out};
        if (bad[0] != "--length") args.insert(args.end(), {"--length", "0.05"});
        args.insert(args.end(), bad.begin(), bad.end());
        auto r = run_furrow(args);
        EXPECT_EQ(r.exit_code, 2) << bad[0] << " " << bad[1] << ": " << r.err;
    }
    // Bad files are input errors: one "Error: <file>: <what>" line, exit 1, nothing written.
    auto expect_error = [&](const std::vector<std::string>& args, const std::string& file, const std::string& what) {
        auto r = run_furrow(args);
        EXPECT_EQ(r.exit_code, 1) << r.err;
        EXPECT_EQ(r.err.rfind("Error: " + file + ": ", 0), 0u) << r.err;
        EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_FALSE(fs::exists(out));
    };
    const std::string missing = (dir / "missing.png").string();
    expect_error({"shells", in.string(), "-o", out, "--length", "0.05", "--mask", missing}, missing, "mask");
    test::write_text(dir / "not_a.png", "hello");
    expect_error({"shells", in.string(), "-o", out, "--length", "0.05", "--mask", (dir / "not_a.png").string()},
                 (dir / "not_a.png").string(), "mask");
    ImageF mask;
    mask.width = mask.height = 4, mask.channels = 1, mask.pixels.assign(16, 1.0f);
    ASSERT_TRUE(save_png(mask, (dir / "m.png").string()).ok());
    expect_error({"shells", ico.string(), "-o", out, "--length", "0.05", "--mask", (dir / "m.png").string()}, ico.string(), "TEXCOORD_0");
    // An empty mesh and a mesh without triangles.
    test::write_text(dir / "empty.obj", "# nothing\n");
    auto r = run_furrow({"shells", (dir / "empty.obj").string(), "-o", out, "--length", "0.05"});
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(r.err.rfind("Error: " + (dir / "empty.obj").string() + ": ", 0), 0u) << r.err;
    test::write_text(dir / "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    r = run_furrow({"shells", (dir / "points.obj").string(), "-o", out, "--length", "0.05"});
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_FALSE(fs::exists(out));
    // The input is never overwritten.
    r = run_furrow({"shells", in.string(), "-o", in.string(), "--length", "0.05"});
    EXPECT_EQ(r.exit_code, 1) << r.err;
}

TEST(furrow_shells, HelpShowsExamples) {
    auto r = run_furrow({"shells", "--help"});
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.out.find("Examples:"), std::string::npos);
    EXPECT_NE(r.out.find("--mask"), std::string::npos);
}

} // namespace
} // namespace furrow

// `furrow stamp`: valid output, heightmap files, the error contract (exit codes, one line, no partial output).
#include "test_support.h"

#include <furrow/shapes.h>

namespace furrow {
namespace {

namespace fs = std::filesystem;
using test::run_furrow;

fs::path write_flat(const fs::path& dir, float size = 4, int cells = 8) {
    Primitive g = shapes::grid(size, size, cells, cells);
    fs::path file = dir / "flat.glb";
    EXPECT_TRUE(save_scene(make_scene(g, "ground"), file.string()).ok());
    return file;
}

fs::path write_json(const fs::path& dir, const std::string& name, const std::string& text) {
    test::write_text(dir / name, text);
    return dir / name;
}

const char* kBall = R"({"colliders": [{"shape": "sphere", "radius": 0.3, "path": [[-1, 0.2, 0], [1, 0.2, 0.5]]}]})";

void expect_clean_failure(const test::RunResult& r, int code, const std::string& file, const std::string& fragment,
                          const fs::path& dir, const std::vector<std::string>& expected_files) {
    EXPECT_EQ(r.exit_code, code) << r.err;
    if (code == 1) {
        EXPECT_EQ(r.err.rfind("Error: " + file + ": ", 0), 0u) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    }
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
    EXPECT_EQ(test::list_dir(dir), expected_files);
}

} // namespace

TEST(furrow_stamp, HelpHasExamples) {
    auto r = run_furrow({"stamp", "--help"});
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.out.find("Examples:"), std::string::npos);
    EXPECT_NE(r.out.find("--conserve-volume"), std::string::npos);
    EXPECT_NE(r.out.find("--heightmap-out"), std::string::npos);
}

TEST(furrow_stamp, StampsTheBundledSnowField) {
    fs::path dir = test::temp_dir();
    const fs::path models = test::models_dir();
    auto r = run_furrow({"stamp", (models / "ground.glb").string(), "-o", (dir / "snow.glb").string(), "--colliders",
                         (models / "colliders.json").string(), "--rim", "0.08", "--conserve-volume", "--heightmap-out",
                         (dir / "snow.pfm").string()});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("45 contacts of 45 samples"), std::string::npos) << r.err;
    EXPECT_VALID_GLTF(dir / "snow.glb");
    EXPECT_EQ(test::list_dir(dir), (std::vector<std::string>{"snow.glb", "snow.pfm"}));
    auto j = test::gltf_json(dir / "snow.glb");
    EXPECT_EQ(j["materials"][0]["name"], "snow");
    EXPECT_TRUE(j["meshes"][0]["primitives"][0]["attributes"].contains("TEXCOORD_0"));
}

TEST(furrow_stamp, HeightmapOutAndInChainRuns) {
    fs::path dir = test::temp_dir(), ground = write_flat(dir);
    fs::path first = write_json(dir, "a.json", kBall);
    fs::path second = write_json(dir, "b.json", R"({"colliders": [{"shape": "box", "size": [0.4, 0.2, 0.4], "heading": 15, "path": [[1.2, 0.05, -1.2]]}]})");
    for (const char* ext : {".pfm", ".png"}) {
        const std::string map = (dir / (std::string("a") + ext)).string();
        auto r = run_furrow({"stamp", ground.string(), "-o", (dir / "a.glb").string(), "--colliders", first.string(), "--texel", "0.01",
                             "--heightmap-out", map});
        ASSERT_EQ(r.exit_code, 0) << r.err;
        r = run_furrow({"stamp", ground.string(), "-o", (dir / "b.glb").string(), "--colliders", second.string(), "--texel", "0.01",
                        "--heightmap-in", map});
        ASSERT_EQ(r.exit_code, 0) << r.err;
        EXPECT_VALID_GLTF(dir / "b.glb");
        // Both the old trail and the new box are in the second output.
        Scene s;
        ASSERT_TRUE(load_scene(s, (dir / "b.glb").string()).ok());
        float trail = 1, crate = 1;
        const auto& P = s.meshes[0].primitives[0].positions;
        for (size_t k = 0; k < P.size(); k += 3) {
            if (std::abs(P[k]) < 0.05f && std::abs(P[k + 2] - 0.25f) < 0.05f) trail = std::min(trail, P[k + 1]);
            if (std::abs(P[k] - 1.2f) < 0.1f && std::abs(P[k + 2] + 1.2f) < 0.1f) crate = std::min(crate, P[k + 1]);
        }
        EXPECT_LT(trail, -0.05f) << ext;
        EXPECT_NEAR(crate, -0.05f, 1e-3) << ext;
    }
}

TEST(furrow_stamp, NoContactWritesTheGroundUnchanged) {
    fs::path dir = test::temp_dir(), ground = write_flat(dir);
    fs::path json = write_json(dir, "air.json", R"({"colliders": [{"shape": "sphere", "radius": 0.3, "path": [[0, 2, 0], [1, 2, 0]]}]})");
    auto r = run_furrow({"stamp", ground.string(), "-o", (dir / "out.glb").string(), "--colliders", json.string()});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("0 contacts of 2 samples"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("unchanged"), std::string::npos) << r.err;
    Scene a, b;
    ASSERT_TRUE(load_scene(a, ground.string()).ok());
    ASSERT_TRUE(load_scene(b, (dir / "out.glb").string()).ok());
    EXPECT_EQ(a.meshes[0].primitives[0].positions, b.meshes[0].primitives[0].positions);
    EXPECT_EQ(a.meshes[0].primitives[0].indices, b.meshes[0].primitives[0].indices);
    EXPECT_EQ(test::read_bytes(ground), test::read_bytes(dir / "out.glb"));
}

TEST(furrow_stamp, BadCollidersFailCleanly) {
    fs::path dir = test::temp_dir(), ground = write_flat(dir);
    const std::vector<std::string> base = {"flat.glb"};
    struct Case {
        std::string name, text, fragment;
    };
    const std::vector<Case> cases = {
        {"malformed.json", R"({"colliders": [ {"shape": "sphere", )", "malformed JSON"},
        {"shape.json", R"({"colliders": [{"shape": "cone", "radius": 1, "path": [[0,0,0]]}]})", "unknown shape \"cone\""},
        {"negative.json", R"({"colliders": [{"shape": "sphere", "radius": -1, "path": [[0,0,0]]}]})", "colliders[0].radius: must be a finite number > 0"},
        {"nan.json", R"({"colliders": [{"shape": "box", "size": [1, "NaN", 1], "path": [[0,0,0]]}]})", "colliders[0].size[1]: must be a finite number > 0"},
        {"image.json", R"({"colliders": [{"shape": "image", "image": "foot.png", "size": [0.1, 0.3], "depth": 0.05, "path": [[0,0,0]]}]})",
         "cannot read 'foot.png'"},
    };
    std::vector<std::string> files = base;
    for (const Case& c : cases) {
        fs::path json = write_json(dir, c.name, c.text);
        files.push_back(c.name);
        std::sort(files.begin(), files.end());
        auto r = run_furrow({"stamp", ground.string(), "-o", (dir / "out.glb").string(), "--colliders", json.string(), "--heightmap-out",
                             (dir / "out.pfm").string()});
        expect_clean_failure(r, 1, json.string(), c.fragment, dir, files);
    }
    auto r = run_furrow({"stamp", ground.string(), "-o", (dir / "out.glb").string(), "--colliders", (dir / "none.json").string()});
    expect_clean_failure(r, 1, (dir / "none.json").string(), "cannot open", dir, files);
}

TEST(furrow_stamp, MemoryGuardFailsCleanly) {
    fs::path dir = test::temp_dir(), ground = write_flat(dir, 20, 2);
    fs::path json = write_json(dir, "ball.json", kBall);
    auto r = run_furrow({"stamp", ground.string(), "-o", (dir / "out.glb").string(), "--colliders", json.string(), "--texel", "0.0001"});
    expect_clean_failure(r, 1, ground.string(), "MiB limit", dir, {"ball.json", "flat.glb"});
    r = run_furrow({"stamp", ground.string(), "-o", (dir / "out.glb").string(), "--colliders", json.string(), "--texel", "0.005",
                    "--max-heightmap-mb", "16"});
    expect_clean_failure(r, 1, ground.string(), "MiB limit", dir, {"ball.json", "flat.glb"});
}

TEST(furrow_stamp, OverhangsWarn) {
    fs::path dir = test::temp_dir();
    Primitive g = shapes::grid(4, 4, 8, 8);
    const uint32_t b = uint32_t(g.vertex_count());
    g.positions.insert(g.positions.end(), {1, 1, -1, -1, 1, -1, -1, 1, 1});
    g.normals.insert(g.normals.end(), {0, -1, 0, 0, -1, 0, 0, -1, 0});
    g.uv0.insert(g.uv0.end(), {0, 0, 0, 0, 0, 0});
    g.indices.insert(g.indices.end(), {b, b + 2, b + 1});
    ASSERT_TRUE(save_scene(make_scene(g, "ledge"), (dir / "ledge.glb").string()).ok());
    fs::path json = write_json(dir, "ball.json", R"({"colliders": [{"shape": "sphere", "radius": 0.3, "path": [[1.5, 0.2, 1.5]]}]})");
    auto r = run_furrow({"stamp", (dir / "ledge.glb").string(), "-o", (dir / "out.glb").string(), "--colliders", json.string()});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("Warning: " + (dir / "ledge.glb").string() + ": 1 ground triangles face away from up (overhangs"), std::string::npos)
        << r.err;
    EXPECT_VALID_GLTF(dir / "out.glb");
}

TEST(furrow_stamp, UsageErrors) {
    fs::path dir = test::temp_dir(), ground = write_flat(dir);
    fs::path json = write_json(dir, "ball.json", kBall);
    const std::string out = (dir / "out.glb").string();
    const std::vector<std::vector<std::string>> bad = {
        {"stamp", ground.string(), "-o", out},                                                        // no --colliders
        {"stamp", ground.string(), "-o", out, "--colliders", json.string(), "--texel", "-1"},         // negative texel
        {"stamp", ground.string(), "-o", out, "--colliders", json.string(), "--texel", "0.01", "--resolution", "100"},
        {"stamp", ground.string(), "-o", out, "--colliders", json.string(), "--compaction", "2"},
        {"stamp", ground.string(), "-o", (dir / "out.obj").string(), "--colliders", json.string()},
        {"stamp", ground.string(), "-o", out, "--colliders", json.string(), "--heightmap-out", (dir / "h.exr").string()},
    };
    for (const auto& args : bad) {
        auto r = run_furrow(args);
        EXPECT_EQ(r.exit_code, 2) << r.err;
        EXPECT_EQ(test::list_dir(dir), (std::vector<std::string>{"ball.json", "flat.glb"}));
    }
}

TEST(furrow_stamp, IdenticalBytesForAnyThreadCount) {
    fs::path dir = test::temp_dir();
    const fs::path models = test::models_dir();
    std::vector<std::string> common{"stamp", (models / "ground.glb").string(), "--colliders", (models / "colliders.json").string(),
                                    "--rim", "0.1", "--conserve-volume", "--resolution", "512"};
    auto a = common, b = common;
    a.insert(a.begin(), {"-j", "1"});
    b.insert(b.begin(), {"-j", "2"});
    a.insert(a.end(), {"-o", (dir / "a.glb").string()});
    b.insert(b.end(), {"-o", (dir / "b.glb").string()});
    ASSERT_EQ(run_furrow(a).exit_code, 0);
    ASSERT_EQ(run_furrow(b).exit_code, 0);
    EXPECT_EQ(test::read_bytes(dir / "a.glb"), test::read_bytes(dir / "b.glb"));
}

} // namespace furrow

// `furrow convert` and the CLI contract: exit codes, one Error line, nothing written on failure, inputs
// never modified.
#include "gltf_builder.h"
#include "test_support.h"

#include <cmath>

using namespace furrow::test;
namespace fs = std::filesystem;

namespace {

// Asserts the failure contract: exit 1, exactly one line on stderr starting with "Error: <file>:", and the
// output folder unchanged.
void expect_clean_failure(const RunResult& r, const std::string& file, const std::string& fragment) {
    EXPECT_EQ(r.exit_code, 1) << r.err;
    ASSERT_FALSE(r.err.empty());
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.rfind("Error: " + file + ": ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << "expected '" << fragment << "' in: " << r.err;
}

TEST(convert_cli, ConvertsObjToValidGlbAndGltf) {
    const auto dir = temp_dir();
    write_text(dir / "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    const auto before = read_bytes(dir / "quad.obj");
    for (const char* out : {"quad.glb", "quad.gltf"}) {
        RunResult r = run_furrow({"convert", (dir / "quad.obj").string(), "-o", (dir / out).string()});
        ASSERT_EQ(r.exit_code, 0) << r.err;
        EXPECT_VALID_GLTF(dir / out);
    }
    EXPECT_EQ(read_bytes(dir / "quad.obj"), before);
    EXPECT_EQ(list_dir(dir), (std::vector<std::string>{"quad.bin", "quad.glb", "quad.gltf", "quad.obj"}));
}

// n-gon triangulation (beast.obj: quads, pentagons and hexagons, 0 non-manifold edges, came out with 2): a
// closed, manifold tetrahedron made of one bent quad (1 2 3 4) and two triangles that share the edge 1–3.
// The fan's diagonal 1–3 gave that edge four faces; the other diagonal keeps it manifold and closed.
TEST(convert_cli, NgonTriangulationCreatesNoNonManifoldEdge) {
    const auto dir = temp_dir();
    write_text(dir / "ngons.obj", "v 0 0 0\nv 1 0 0.5\nv 1 1 0\nv 0 1 0.5\nf 1 2 3 4\nf 1 3 2\nf 1 4 3\n");
    RunResult r = run_furrow({"convert", (dir / "ngons.obj").string(), "-o", (dir / "ngons.glb").string()});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_VALID_GLTF(dir / "ngons.glb");
    furrow::Scene s;
    ASSERT_TRUE(furrow::load_scene(s, (dir / "ngons.glb").string()).ok());
    furrow::CheckReport c = furrow::check_primitive(s.meshes[0].primitives[0]);
    EXPECT_EQ(c.non_manifold_edges, 0u);
    EXPECT_TRUE(c.closed);
    EXPECT_EQ(c.triangles, 4u);
}

// --drop-unused-uvs (gltfpack's default): an OBJ's texture coordinates with no material to sample them are
// left out; without the flag they are kept.
TEST(convert_cli, DropUnusedUvsLeavesOutUnsampledCoordinates) {
    const auto dir = temp_dir();
    write_text(dir / "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n");
    for (bool drop : {false, true}) {
        std::vector<std::string> args{"convert", (dir / "quad.obj").string(), "-o", (dir / "quad.glb").string(), "--compress"};
        if (drop) args.push_back("--drop-unused-uvs");
        RunResult r = run_furrow(args);
        ASSERT_EQ(r.exit_code, 0) << r.err;
        EXPECT_VALID_GLTF(dir / "quad.glb");
        EXPECT_EQ(gltf_json(dir / "quad.glb")["meshes"][0]["primitives"][0]["attributes"].contains("TEXCOORD_0"), !drop);
    }
}

TEST(convert_cli, MissingFile) {
    const auto dir = temp_dir();
    const std::string in = (dir / "nope.glb").string();
    RunResult r = run_furrow({"convert", in, "-o", (dir / "out.glb").string()});
    expect_clean_failure(r, in, "not found");
    EXPECT_TRUE(list_dir(dir).empty());
}

TEST(convert_cli, TruncatedGlb) {
    const auto dir = temp_dir();
    const auto good = dir / "good.glb";
    // Build a valid GLB, then cut it in half.
    write_text(dir / "t.gltf", TinyGltf{}.json());
    ASSERT_EQ(run_furrow({"convert", (dir / "t.gltf").string(), "-o", good.string()}).exit_code, 0);
    auto bytes = read_bytes(good);
    bytes.resize(bytes.size() / 2);
    write_bytes(dir / "cut.glb", bytes);
    RunResult r = run_furrow({"convert", (dir / "cut.glb").string(), "-o", (dir / "out.glb").string()});
    expect_clean_failure(r, (dir / "cut.glb").string(), "GLB");
    EXPECT_FALSE(fs::exists(dir / "out.glb"));
    EXPECT_EQ(read_bytes(dir / "cut.glb"), bytes);
}

TEST(convert_cli, InvalidJson) {
    const auto dir = temp_dir();
    write_text(dir / "bad.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [ }");
    RunResult r = run_furrow({"convert", (dir / "bad.gltf").string(), "-o", (dir / "out.glb").string()});
    expect_clean_failure(r, (dir / "bad.gltf").string(), "invalid glTF");
    EXPECT_FALSE(fs::exists(dir / "out.glb"));
}

TEST(convert_cli, IndexOutOfRange) {
    const auto dir = temp_dir();
    TinyGltf g;
    g.indices = {0, 1, 3};
    write_text(dir / "idx.gltf", g.json());
    RunResult r = run_furrow({"convert", (dir / "idx.gltf").string(), "-o", (dir / "out.glb").string()});
    expect_clean_failure(r, (dir / "idx.gltf").string(), "out of range");
    EXPECT_FALSE(fs::exists(dir / "out.glb"));
}

TEST(convert_cli, NanPositions) {
    const auto dir = temp_dir();
    TinyGltf g;
    g.positions[0] = std::nanf("");
    g.min_max = false;
    write_text(dir / "nan.gltf", g.json());
    RunResult r = run_furrow({"convert", (dir / "nan.gltf").string(), "-o", (dir / "out.glb").string()});
    expect_clean_failure(r, (dir / "nan.gltf").string(), "NaN");
    EXPECT_FALSE(fs::exists(dir / "out.glb"));
}

TEST(convert_cli, UnsupportedPrimitiveMode) {
    const auto dir = temp_dir();
    TinyGltf g;
    g.mode = 7;
    write_text(dir / "mode.gltf", g.json());
    RunResult r = run_furrow({"convert", (dir / "mode.gltf").string(), "-o", (dir / "out.glb").string()});
    expect_clean_failure(r, (dir / "mode.gltf").string(), "mode");
    EXPECT_FALSE(fs::exists(dir / "out.glb"));
}

TEST(convert_cli, OutputFolderMissing) {
    const auto dir = temp_dir();
    write_text(dir / "t.gltf", TinyGltf{}.json());
    const std::string out = (dir / "missing" / "out.glb").string();
    RunResult r = run_furrow({"convert", (dir / "t.gltf").string(), "-o", out});
    expect_clean_failure(r, out, "does not exist");
    EXPECT_EQ(list_dir(dir), std::vector<std::string>{"t.gltf"});
}

TEST(convert_cli, OutputEqualToInputIsRefused) {
    const auto dir = temp_dir();
    write_text(dir / "t.gltf", TinyGltf{}.json());
    const auto before = read_bytes(dir / "t.gltf");
    RunResult r = run_furrow({"convert", (dir / "t.gltf").string(), "-o", (dir / "t.gltf").string()});
    expect_clean_failure(r, (dir / "t.gltf").string(), "input");
    EXPECT_EQ(read_bytes(dir / "t.gltf"), before);
}

// A bad output extension is a bad option value: a usage error (exit 2) before anything is read, as in
// shells, render, stamp and tessellate.
TEST(convert_cli, UnsupportedOutputExtension) {
    const auto dir = temp_dir();
    write_text(dir / "t.gltf", TinyGltf{}.json());
    RunResult r = run_furrow({"convert", (dir / "t.gltf").string(), "-o", (dir / "t.fbx").string()});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("Error: --output: must end in .glb or .gltf", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("--output: must end in .glb or .gltf"), std::string::npos) << r.err;
    EXPECT_EQ(list_dir(dir), std::vector<std::string>{"t.gltf"});
}

TEST(convert_cli, UsageErrorsExitTwo) {
    EXPECT_EQ(run_furrow({}).exit_code, 2);
    EXPECT_EQ(run_furrow({"convert"}).exit_code, 2);
    EXPECT_EQ(run_furrow({"no-such-command"}).exit_code, 2);
    EXPECT_EQ(run_furrow({"convert", "a.obj", "-o", "b.glb", "--threads", "0"}).exit_code, 2);
}

TEST(convert_cli, VersionAndHelp) {
    RunResult v = run_furrow({"--version"});
    EXPECT_EQ(v.exit_code, 0);
    EXPECT_NE(v.out.find("furrow "), std::string::npos);
    RunResult h = run_furrow({"convert", "--help"});
    EXPECT_EQ(h.exit_code, 0);
    EXPECT_NE(h.out.find("Examples"), std::string::npos);
}

} // namespace

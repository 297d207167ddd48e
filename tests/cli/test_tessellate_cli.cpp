// `furrow tessellate`: criteria on the command line, scene preserved, validator-clean output, the error
// contract (one "Error: <file>: <what>" line, exit 1; usage errors exit 2).
#include "test_support.h"

#include <algorithm>

using namespace furrow;
using namespace furrow::test;
namespace fs = std::filesystem;

namespace {

// A 2 x 2 quad grid (OBJ keeps the quads for Catmull-Clark): 9 vertices, 4 quads, 8 boundary edges.
const char* k_quads_obj = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 0 1\nv 1 0.3 1\nv 2 0 1\nv 0 0 2\nv 1 0 2\nv 2 0 2\n"
                          "f 1 4 5 2\nf 2 5 6 3\nf 4 7 8 5\nf 5 8 9 6\n";
const char* k_tetra_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

std::string write_model(const fs::path& dir, const std::string& name, const char* text) {
    write_text(dir / name, text);
    return (dir / name).string();
}

void expect_error_line(const RunResult& r, const std::string& file, const std::string& what) {
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.rfind("Error: " + file + ": ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
}

CheckReport report_of(const fs::path& file) {
    Scene s;
    Status st = load_scene(s, file.string());
    EXPECT_TRUE(st.ok()) << st.message;
    std::vector<CheckReport> r;
    for (const auto& m : s.meshes)
        for (const auto& p : m.primitives) r.push_back(check_primitive(p));
    return merge_reports(r);
}

} // namespace

TEST(tessellate_cli, HelpShowsExamples) {
    RunResult r = run_furrow({"tessellate", "--help"});
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.out.find("Examples:"), std::string::npos);
    for (const char* flag : {"--scheme", "--uniform", "--near", "--far", "--pixel-error", "--max-error", "--focus",
                             "--max-rate", "--max-triangles", "--crease-angle", "--camera"})
        EXPECT_NE(r.out.find(flag), std::string::npos) << flag;
}

// Uniform rate on quads: exact counts, open boundary cut into rate segments, validator-clean.
TEST(tessellate_cli, UniformOnQuads) {
    const auto dir = temp_dir();
    const auto in = write_model(dir, "quads.obj", k_quads_obj);
    const auto out = dir / "quads.glb";
    RunResult r = run_furrow({"tessellate", in, "-o", out.string(), "--uniform", "3"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("8 -> 72 triangles"), std::string::npos) << r.err; // 4 quads = 8 triangles in
    EXPECT_VALID_GLTF(out);
    CheckReport c = report_of(out);
    EXPECT_EQ(c.triangles, 72u);
    EXPECT_EQ(c.boundary_edges, 24u);
    EXPECT_EQ(c.non_manifold_edges, 0u);
    EXPECT_EQ(c.inconsistent_edges, 0u);
}

// A closed mesh stays closed under a view-dependent criterion; the summary goes to stderr, -q silences it.
TEST(tessellate_cli, CameraCriteriaKeepClosedMeshClosed) {
    const auto dir = temp_dir();
    const auto in = write_model(dir, "tetra.obj", k_tetra_obj);
    const auto out = dir / "tetra.glb";
    RunResult r = run_furrow({"tessellate", in, "-o", out.string(), "--scheme", "loop", "--camera", "2,0,0", "--size",
                              "640x480", "--pixel-error", "20", "--screen-error", "0.5", "--near", "0.5", "--far", "4",
                              "--max-rate", "12"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("Wrote"), std::string::npos);
    EXPECT_VALID_GLTF(out);
    CheckReport c = report_of(out);
    EXPECT_TRUE(c.closed);
    EXPECT_EQ(c.non_manifold_edges, 0u);
    EXPECT_EQ(c.zero_area_faces, 0u);
    r = run_furrow({"-q", "tessellate", in, "-o", (dir / "quiet.glb").string(), "--max-error", "0.01", "--focus",
                    "1,0,0,0.2", "--focus", "0,1,0,0.2"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
}

// The bundled terrain seen from one corner with a triangle budget: fewer triangles than asked, and the whole
// scene (nodes, materials, textures) is kept.
TEST(tessellate_cli, TerrainWithBudgetKeepsScene) {
    const auto dir = temp_dir();
    const auto in = (models_dir() / "ground.glb").string();
    const auto out = dir / "ground.glb";
    RunResult r = run_furrow({"tessellate", in, "-o", out.string(), "--scheme", "bilinear", "--camera", "-9,1,-9",
                              "--size", "320x240", "--pixel-error", "2", "--max-triangles", "30000"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("scaled by"), std::string::npos) << r.err;
    EXPECT_VALID_GLTF(out);
    CheckReport c = report_of(out);
    EXPECT_LE(c.triangles, 30000u);
    EXPECT_EQ(c.boundary_loops, 1u);
    EXPECT_EQ(c.non_manifold_edges, 0u);
    Scene before, after;
    ASSERT_TRUE(load_scene(before, in).ok());
    ASSERT_TRUE(load_scene(after, out.string()).ok());
    EXPECT_EQ(after.nodes.size(), before.nodes.size());
    EXPECT_EQ(after.materials.size(), before.materials.size());
    EXPECT_EQ(after.images.size(), before.images.size());
    EXPECT_EQ(after.meshes[0].primitives[0].material, before.meshes[0].primitives[0].material);
    EXPECT_FALSE(after.meshes[0].primitives[0].uv0.empty());
    EXPECT_FALSE(after.meshes[0].primitives[0].normals.empty());
}

// The output bytes do not depend on --threads.
TEST(tessellate_cli, SameBytesForAnyThreadCount) {
    const auto dir = temp_dir();
    const auto in = (models_dir() / "creature.glb").string();
    std::vector<std::string> args{"tessellate", in, "--scheme", "loop", "--camera", "0,0.6,2", "--size", "320x240",
                                  "--screen-error", "1"};
    auto one = args, two = args;
    one.insert(one.begin(), {"-j", "1"});
    one.insert(one.end(), {"-o", (dir / "one.glb").string()});
    two.insert(two.begin(), {"-j", "2"});
    two.insert(two.end(), {"-o", (dir / "two.glb").string()});
    ASSERT_EQ(run_furrow(one).exit_code, 0);
    ASSERT_EQ(run_furrow(two).exit_code, 0);
    EXPECT_EQ(read_bytes(dir / "one.glb"), read_bytes(dir / "two.glb"));
    EXPECT_VALID_GLTF(dir / "one.glb");
}

// Usage errors (exit 2): no criterion, near >= far, a view criterion without a camera, bad values.
TEST(tessellate_cli, UsageErrorsExitTwo) {
    const auto dir = temp_dir();
    const auto in = write_model(dir, "tetra.obj", k_tetra_obj);
    const auto out = (dir / "out.glb").string();
    auto code = [&](std::vector<std::string> extra) {
        std::vector<std::string> a{"tessellate", in, "-o", out};
        a.insert(a.end(), extra.begin(), extra.end());
        return run_furrow(a);
    };
    RunResult r = code({});
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("at least one of"), std::string::npos) << r.err;
    r = code({"--camera", "0,0,3", "--near", "5", "--far", "5"});
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("near < far"), std::string::npos) << r.err;
    r = code({"--pixel-error", "2"});
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("need --camera"), std::string::npos) << r.err;
    EXPECT_EQ(code({"--uniform", "0"}).exit_code, 2);
    EXPECT_EQ(code({"--uniform", "2", "--scheme", "sqrt3"}).exit_code, 2);
    EXPECT_EQ(code({"--focus", "1,2,3"}).exit_code, 2);
    EXPECT_EQ(code({"--uniform", "2", "--accuracy", "11"}).exit_code, 2);
    EXPECT_EQ(list_dir(dir), std::vector<std::string>{"tetra.obj"});
}

// Input errors (exit 1, one line, nothing written): loop on quads, a budget below rate 1, strict mode on a
// mesh needing repair, a missing file, output == input.
TEST(tessellate_cli, InputErrorsOneLine) {
    const auto dir = temp_dir();
    const auto quads = write_model(dir, "quads.obj", k_quads_obj);
    const auto out = (dir / "out.glb").string();
    expect_error_line(run_furrow({"tessellate", quads, "-o", out, "--scheme", "loop", "--uniform", "2"}), quads,
                      "loop subdivision needs triangles");
    expect_error_line(run_furrow({"tessellate", quads, "-o", out, "--uniform", "2", "--max-triangles", "3"}), quads,
                      "below the 8 triangles");
    const auto fins = write_model(dir, "fins.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n");
    expect_error_line(run_furrow({"tessellate", fins, "-o", out, "--uniform", "2", "--strict"}), fins, "non-manifold");
    RunResult ok = run_furrow({"tessellate", fins, "-o", out, "--uniform", "2"}); // repaired / linear by default
    EXPECT_EQ(ok.exit_code, 0) << ok.err;
    EXPECT_NE(ok.err.find("faces tessellated linearly"), std::string::npos) << ok.err;
    fs::remove(out);
    const auto missing = (dir / "missing.obj").string();
    RunResult r = run_furrow({"tessellate", missing, "-o", out, "--uniform", "2"});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.err.rfind("Error: " + missing, 0), 0u) << r.err;
    // An output that is the input: a glTF input (an OBJ output is refused for its extension, exit 2).
    const auto glb = (dir / "quads.glb").string();
    ASSERT_EQ(run_furrow({"convert", quads, "-o", glb}).exit_code, 0);
    const auto before = read_bytes(glb);
    r = run_furrow({"tessellate", glb, "-o", glb, "--uniform", "2"});
    expect_error_line(r, glb, "input");
    EXPECT_EQ(read_bytes(glb), before);
    r = run_furrow({"tessellate", quads, "-o", quads, "--uniform", "2"});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("must end in .glb or .gltf"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
}

// `furrow check`: text and JSON reports, --require gates, exit codes and the single Error line.
#include "test_support.h"

#include <algorithm>
#include <cmath>

using namespace furrow::test;
namespace fs = std::filesystem;

namespace {

const char* k_tetrahedron_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
// Two triangles forming an open square: 4 boundary edges.
const char* k_open_quad_obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
// Three triangles on the edge 1–2: 1 non-manifold edge, 6 boundary edges.
const char* k_fins_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n";
// Two triangles crossing each other.
const char* k_crossing_obj = "v 0 0 0\nv 2 0 0\nv 0 2 0\nv 0.5 -1 -1\nv 0.5 -1 1\nv 0.5 1 0\nf 1 2 3\nf 4 5 6\n";

std::string write_model(const fs::path& dir, const std::string& name, const char* text) {
    write_text(dir / name, text);
    return (dir / name).string();
}

// The failure contract: exit 1 and exactly one line on stderr, "Error: <file>: <what>".
void expect_error_line(const RunResult& r, const std::string& file, const std::string& what) {
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err, "Error: " + file + ": " + what + "\n");
}

nlohmann::json parse(const std::string& text) {
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << text;
    return j;
}

} // namespace

// A clean closed mesh: exit 0, a readable report on stdout, nothing on stderr.
TEST(check_cli, TextReportOnCleanMesh) {
    const auto in = write_model(temp_dir(), "tet.obj", k_tetrahedron_obj);
    RunResult r = run_furrow({"check", in});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
    EXPECT_NE(r.out.find(in), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("(closed)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("problems"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("none"), std::string::npos) << r.out;
}

// --json: one object with the documented keys (totals) and a "primitives" array with the same keys.
TEST(check_cli, JsonHasAllKeys) {
    const auto in = write_model(temp_dir(), "tet.obj", k_tetrahedron_obj);
    RunResult r = run_furrow({"check", in, "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    nlohmann::json j = parse(r.out);
    for (const char* key : {"vertices", "faces", "triangles", "welded_vertices", "components", "boundary_edges",
                            "boundary_loops", "non_manifold_edges", "non_manifold_vertices", "degenerate_faces",
                            "zero_area_faces", "slivers", "duplicate_vertices", "unreferenced_vertices", "nan_values",
                            "indices_out_of_range", "inconsistent_edges", "valence2_interior_vertices",
                            "self_intersections", "closed", "has_uv", "uv_min", "uv_max", "bbox_min", "bbox_max",
                            "diagonal", "primitives"})
        EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_EQ(j["vertices"], 4);
    EXPECT_EQ(j["triangles"], 4);
    EXPECT_EQ(j["components"], 1);
    EXPECT_EQ(j["closed"], true);
    EXPECT_TRUE(j["self_intersections"].is_null()); // not asked for
    ASSERT_EQ(j["primitives"].size(), 1u);
    EXPECT_EQ(j["primitives"][0]["boundary_edges"], 0);
    EXPECT_EQ(j["primitives"][0]["mode"], "triangles");
}

// Findings come through: three fins on one edge.
TEST(check_cli, JsonReportsNonManifoldEdge) {
    const auto in = write_model(temp_dir(), "fins.obj", k_fins_obj);
    RunResult r = run_furrow({"check", in, "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    nlohmann::json j = parse(r.out);
    EXPECT_EQ(j["non_manifold_edges"], 1);
    EXPECT_EQ(j["boundary_edges"], 6);
    EXPECT_EQ(j["closed"], false);
    EXPECT_EQ(j["manifold"], false);
}

// --self-intersections fills in the count.
TEST(check_cli, SelfIntersectionsFlag) {
    const auto in = write_model(temp_dir(), "cross.obj", k_crossing_obj);
    RunResult r = run_furrow({"check", in, "--json", "--self-intersections"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(parse(r.out)["self_intersections"], 1);
}

// A met requirement: exit 0.
TEST(check_cli, RequireMet) {
    const auto in = write_model(temp_dir(), "tet.obj", k_tetrahedron_obj);
    RunResult r = run_furrow({"check", in, "--require", "closed,manifold,oriented,no-degenerate,no-nan"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
}

// An unmet requirement: exit 1 with exactly "Error: <file>: requirement 'closed' failed: 4 boundary edges";
// the report is still printed.
TEST(check_cli, RequireClosedFails) {
    const auto in = write_model(temp_dir(), "open.obj", k_open_quad_obj);
    RunResult r = run_furrow({"check", in, "--require", "closed"});
    expect_error_line(r, in, "requirement 'closed' failed: 4 boundary edges");
    EXPECT_NE(r.out.find("(open)"), std::string::npos) << r.out;
}

// Several unmet requirements still make one line; met ones are not mentioned.
TEST(check_cli, SeveralRequirementsFailOnOneLine) {
    const auto in = write_model(temp_dir(), "fins.obj", k_fins_obj);
    RunResult r = run_furrow({"check", in, "--require", "oriented,closed", "--require", "manifold"});
    expect_error_line(r, in,
                      "requirement 'closed' failed: 6 boundary edges; requirement 'manifold' failed: 1 non-manifold edge");
}

// no-self-intersections turns the computation on by itself.
TEST(check_cli, RequireNoSelfIntersections) {
    const auto in = write_model(temp_dir(), "cross.obj", k_crossing_obj);
    RunResult r = run_furrow({"check", in, "--require", "no-self-intersections", "--json"});
    expect_error_line(r, in, "requirement 'no-self-intersections' failed: 1 self-intersecting triangle pair");
    nlohmann::json j = parse(r.out);
    EXPECT_EQ(j["self_intersections"], 1);
    ASSERT_EQ(j["requirements"].size(), 1u);
    EXPECT_EQ(j["requirements"][0]["passed"], false);
}

// An unknown requirement name is a usage error (exit 2), caught before the file is read.
TEST(check_cli, UnknownRequirementIsUsageError) {
    const auto in = write_model(temp_dir(), "tet.obj", k_tetrahedron_obj);
    RunResult r = run_furrow({"check", in, "--require", "closed,watertight"});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("watertight"), std::string::npos) << r.err;
}

// Out-of-range option values and a missing IN are usage errors too.
TEST(check_cli, BadArgumentsAreUsageErrors) {
    const auto in = write_model(temp_dir(), "tet.obj", k_tetrahedron_obj);
    EXPECT_EQ(run_furrow({"check", in, "--sliver-angle", "-1"}).exit_code, 2);
    EXPECT_EQ(run_furrow({"check", in, "--sliver-angle", "abc"}).exit_code, 2);
    EXPECT_EQ(run_furrow({"check"}).exit_code, 2);
}

// --sliver-angle changes the threshold: a 0.29° needle is a sliver at 1° but not at 0.1°.
TEST(check_cli, SliverAngle) {
    const auto in = write_model(temp_dir(), "needle.obj", "v 0 0 0\nv 1 0 0\nv 0 0.005 0\nf 1 2 3\n");
    EXPECT_EQ(parse(run_furrow({"check", in, "--json"}).out)["slivers"], 1);
    EXPECT_EQ(parse(run_furrow({"check", in, "--json", "--sliver-angle", "0.1"}).out)["slivers"], 0);
    RunResult r = run_furrow({"check", in, "--require", "no-slivers", "--sliver-angle", "5"});
    expect_error_line(r, in, "requirement 'no-slivers' failed: 1 sliver triangle");
}

// A missing or unreadable input: exit 1 and one Error line naming the file.
TEST(check_cli, MissingFile) {
    const std::string in = (temp_dir() / "nope.obj").string();
    RunResult r = run_furrow({"check", in});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.rfind("Error: " + in + ": ", 0), 0u) << r.err;
}

// A glTF with two primitives: one block each plus a total; the JSON totals are the sums.
TEST(check_cli, PerPrimitiveAndTotal) {
    furrow::Primitive tet, quad;
    tet.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    tet.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    quad.positions = {5, 0, 0, 6, 0, 0, 6, 1, 0, 5, 1, 0};
    quad.indices = {0, 1, 2, 0, 2, 3};
    furrow::Scene scene = furrow::make_scene(tet, "parts");
    scene.meshes[0].primitives.push_back(quad);
    const std::string in = (temp_dir() / "parts.glb").string();
    ASSERT_TRUE(furrow::save_scene(scene, in).ok());

    RunResult text = run_furrow({"check", in});
    ASSERT_EQ(text.exit_code, 0) << text.err;
    EXPECT_NE(text.out.find("primitive 0"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("primitive 1"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("total (2 primitives)"), std::string::npos) << text.out;

    nlohmann::json j = parse(run_furrow({"check", in, "--json"}).out);
    ASSERT_EQ(j["primitives"].size(), 2u);
    EXPECT_EQ(j["primitives"][0]["closed"], true);
    EXPECT_EQ(j["primitives"][1]["boundary_edges"], 4);
    EXPECT_EQ(j["boundary_edges"], 4);
    EXPECT_EQ(j["components"], 2);
    EXPECT_EQ(j["closed"], false);
    EXPECT_EQ(j["bbox_max"][0], 6.0);

    RunResult gate = run_furrow({"check", in, "--require", "single-component"});
    EXPECT_EQ(gate.exit_code, 0) << gate.err; // each primitive is one piece
}

// -q silences the text report (the exit code still tells), but not an explicitly requested --json.
TEST(check_cli, QuietPrintsNothing) {
    const auto in = write_model(temp_dir(), "open.obj", k_open_quad_obj);
    RunResult r = run_furrow({"-q", "check", in});
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_TRUE(r.out.empty()) << r.out;
    EXPECT_FALSE(run_furrow({"-q", "check", in, "--json"}).out.empty());
    r = run_furrow({"-q", "check", in, "--require", "closed"});
    expect_error_line(r, in, "requirement 'closed' failed: 4 boundary edges");
}

// --help documents the flags, every requirement name and gives examples.
TEST(check_cli, Help) {
    RunResult r = run_furrow({"check", "--help"});
    EXPECT_EQ(r.exit_code, 0);
    for (const char* s : {"--json", "--self-intersections", "--sliver-angle", "--require", "Examples", "closed",
                          "manifold", "oriented", "no-degenerate", "no-nan", "no-self-intersections", "Exit codes"})
        EXPECT_NE(r.out.find(s), std::string::npos) << s;
}

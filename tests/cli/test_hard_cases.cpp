// Hard numerical cases through every command (check, shells, tessellate, stamp, render): procedural meshes far
// from the origin, tiny and huge, with slivers, needles and caps, zero-area faces, duplicate, collinear,
// coincident and isolated vertices, non-manifold edges and vertices, inconsistent winding, a Möbius strip,
// valence-2 interior vertices, and (label `large`) a 5-million-triangle sphere.
//
// Every command must either write valid output (Khronos validator clean, `furrow check --require
// no-nan,valid-indices` passes, no NaN or Inf anywhere) or fail with exactly one "Error:" line — never crash
// (exit 3 or a signal). Where output is written, something meaningful is asserted about it as well.
#include "test_support.h"

#include <furrow/render.h>
#include <furrow/shapes.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <sstream>

namespace furrow {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::run_furrow;

// ---------------------------------------------------------------------------------------------------------
// Mesh builders: positions are computed in double and rounded once.
// ---------------------------------------------------------------------------------------------------------

struct Builder {
    std::vector<double> p; // xyz
    std::vector<uint32_t> t;
    uint32_t vertex(double x, double y, double z) {
        p.insert(p.end(), {x, y, z});
        return uint32_t(p.size() / 3 - 1);
    }
    std::array<double, 3> at(uint32_t i) const { return {p[3 * i], p[3 * i + 1], p[3 * i + 2]}; }
    // Adds triangle (a, b, c) turned so that its normal points along `out`.
    void tri(uint32_t a, uint32_t b, uint32_t c, const std::array<double, 3>& out) {
        auto A = at(a), B = at(b), C = at(c);
        double e1[3] = {B[0] - A[0], B[1] - A[1], B[2] - A[2]}, e2[3] = {C[0] - A[0], C[1] - A[1], C[2] - A[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        if (n[0] * out[0] + n[1] * out[1] + n[2] * out[2] < 0) std::swap(b, c);
        t.insert(t.end(), {a, b, c});
    }
    Primitive primitive() const {
        Primitive prim;
        prim.positions.assign(p.begin(), p.end()); // double -> float, rounded once
        prim.indices = t;
        return prim;
    }
};

Primitive moved(Primitive prim, double scale, double offset) {
    for (float& x : prim.positions) x = float(double(x) * scale + offset);
    return prim;
}

// icosphere of radius r, its centre at (c, c, c): the positions rounded once from double.
Primitive sphere_at(double r, double c, int subdivisions = 3) {
    Primitive unit = shapes::icosphere(1.0f, subdivisions);
    Primitive out = unit;
    for (size_t i = 0; i < unit.positions.size(); ++i) out.positions[i] = float(double(unit.positions[i]) * r + c);
    out.normals.clear();
    return out;
}

// A closed cone of length 1 and radius 1e-6: every side triangle is a needle (apex angle ~1e-5 degrees).
Primitive needles() {
    Builder b;
    const int n = 8;
    const double R = 1e-6;
    uint32_t apex = b.vertex(0, 1, 0), centre = b.vertex(0, 0, 0);
    std::vector<uint32_t> ring;
    for (int i = 0; i < n; ++i) {
        double a = 2 * M_PI * i / n;
        ring.push_back(b.vertex(R * std::cos(a), 0, R * std::sin(a)));
    }
    for (int i = 0; i < n; ++i) {
        double a = 2 * M_PI * (i + 0.5) / n;
        b.tri(apex, ring[size_t(i)], ring[size_t((i + 1) % n)], {std::cos(a), 0, std::sin(a)});
        b.tri(centre, ring[size_t(i)], ring[size_t((i + 1) % n)], {0, -1, 0});
    }
    return b.primitive();
}

// A closed, nearly flat tetrahedron: D sits 1.4e-7 from the middle of edge AB, so face ABD is a cap (an angle
// of ~180 degrees, the other two ~1.6e-5 degrees) and ACD, BCD are slivers.
Primitive caps() {
    Builder b;
    uint32_t A = b.vertex(0, 0, 0), B = b.vertex(1, 0, 0), C = b.vertex(0.5, 1, 0), D = b.vertex(0.5, 1e-7, 1e-7);
    const uint32_t f[4][4] = {{A, B, C, D}, {A, B, D, C}, {A, C, D, B}, {B, C, D, A}}; // face + opposite vertex
    for (const auto& q : f) {
        auto o = b.at(q[3]), a = b.at(q[0]);
        b.tri(q[0], q[1], q[2], {a[0] - o[0], a[1] - o[1], a[2] - o[2]}); // away from the opposite vertex
    }
    return b.primitive();
}

// A unit grid, 8 x 8 cells, with vertex row `row` (z index) edited by `edit(x, z)`.
Primitive edited_grid(int row, std::function<void(float&, float&)> edit) {
    Primitive g = shapes::grid(1, 1, 8, 8);
    for (int i = 0; i <= 8; ++i) {
        size_t v = size_t(row * 9 + i);
        edit(g.positions[3 * v], g.positions[3 * v + 2]);
    }
    return g;
}

// Grid whose column 4 is moved to 1e-7 beside column 3: a column of slivers (angles ~5e-5 degrees).
Primitive sliver_grid() {
    Primitive g = shapes::grid(1, 1, 8, 8);
    for (int j = 0; j <= 8; ++j) {
        size_t v = size_t(j * 9 + 4);
        g.positions[3 * v] = float(-0.125 + 1e-7);
    }
    return g;
}

// Grid with zero-area triangles appended: one repeating a vertex, one through three collinear vertices.
Primitive zero_area() {
    Primitive g = shapes::grid(1, 1, 4, 4);
    const uint32_t m = uint32_t(g.vertex_count());
    g.positions.insert(g.positions.end(), {-0.375f, 0.0f, -0.5f}); // midpoint of vertices 0 and 1
    g.normals.insert(g.normals.end(), {0, 1, 0});
    g.uv0.insert(g.uv0.end(), {0.125f, 0});
    g.indices.insert(g.indices.end(), {0, 0, 1, 0, m, 1});
    return g;
}

// Every triangle of an icosphere with its own three vertices (a triangle soup: closed only after welding).
Primitive soup() {
    Primitive s = shapes::icosphere(1, 2), out;
    for (uint32_t i : s.indices) {
        out.positions.insert(out.positions.end(), &s.positions[3 * i], &s.positions[3 * i] + 3);
        out.indices.push_back(uint32_t(out.indices.size()));
    }
    return out;
}

// Three grid sheets around the y axis sharing their spine: every spine edge has three faces.
Primitive fins() {
    Builder b;
    for (int k = 0; k < 3; ++k) {
        const double phi = 2 * M_PI * k / 3;
        std::vector<uint32_t> id(25);
        for (int j = 0; j <= 4; ++j)
            for (int i = 0; i <= 4; ++i) {
                double r = i / 4.0, y = j / 4.0;
                id[size_t(j * 5 + i)] = i == 0 ? b.vertex(0, y, 0) : b.vertex(r * std::cos(phi), y, r * std::sin(phi));
            }
        const std::array<double, 3> n{-std::sin(phi), 0, std::cos(phi)};
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
                uint32_t a = id[size_t(j * 5 + i)], c = id[size_t((j + 1) * 5 + i + 1)];
                b.tri(a, id[size_t(j * 5 + i + 1)], c, n);
                b.tri(a, c, id[size_t((j + 1) * 5 + i)], n);
            }
    }
    return b.primitive();
}

// Two closed boxes touching at one corner: a non-manifold vertex (its faces form two fans).
Primitive bowtie() {
    Primitive a = shapes::box(1, 1, 1, false), b = moved(shapes::box(1, 1, 1, false), 1, 1.0);
    a.normals.clear();
    const uint32_t base = uint32_t(a.vertex_count());
    a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
    for (uint32_t i : b.indices) a.indices.push_back(base + i);
    return a;
}

// An icosphere with every fifth triangle turned over.
Primitive flipped() {
    Primitive s = shapes::icosphere(1, 2);
    for (size_t f = 0; f * 3 < s.indices.size(); f += 5) std::swap(s.indices[f * 3 + 1], s.indices[f * 3 + 2]);
    s.normals.clear();
    return s;
}

// A Möbius strip: 48 segments around, 3 across, the seam joined with the half twist (non-orientable).
Primitive mobius() {
    Builder b;
    const int N = 48, M = 3;
    const double R = 1, w = 0.3;
    auto id = [&](int i, int j) { return uint32_t(i * (M + 1) + j); };
    for (int i = 0; i < N; ++i)
        for (int j = 0; j <= M; ++j) {
            double u = 2 * M_PI * i / N, v = -w + 2 * w * j / M;
            b.vertex((R + v * std::cos(u / 2)) * std::cos(u), v * std::sin(u / 2), (R + v * std::cos(u / 2)) * std::sin(u));
        }
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < M; ++j) {
            uint32_t a = id(i, j), d = id(i, j + 1), bb, c;
            if (i + 1 < N) bb = id(i + 1, j), c = id(i + 1, j + 1);
            else bb = id(0, M - j), c = id(0, M - j - 1); // the twist
            b.t.insert(b.t.end(), {a, bb, c, a, c, d});
        }
    return b.primitive();
}

// An icosphere plus 100 vertices no face uses.
Primitive isolated() {
    Primitive s = shapes::icosphere(1, 2);
    s.normals.clear();
    uint32_t state = 12345;
    for (int k = 0; k < 300; ++k) {
        state = state * 1664525u + 1013904223u;
        s.positions.push_back(float(int(state >> 8) % 6000) / 1000.0f - 3.0f);
    }
    return s;
}

// Two triangles back to back (a closed "pillow"): every vertex is interior with valence 2.
Primitive pillow() {
    Primitive p;
    p.positions = {0, 0, 0, 1, 0, 0, 0, 0, -1};
    p.indices = {0, 1, 2, 0, 2, 1};
    return p;
}

// A cube as polygons (OBJ) with one edge split by a vertex pushed outward: its two faces become pentagons and
// the new vertex is interior with valence 2 (a fold of the control hull).
const char* k_valence2_obj = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n"
                             "v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n"
                             "v 0.55 0.55 0\n"
                             "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 9 3\nf 2 3 9 7 6\nf 1 5 8 4\n";

// A hexagon with a triangle folded back onto its corner at vertex 2 (OBJ numbering): the triangle has the
// hexagon's edges 1-2 and 2-3 and the diagonal 1-3. A fan from the hexagon's first corner draws 1-3 again
// (three faces on it: a non-manifold edge the source does not have, as `convert` once made on an asset of
// quads, pentagons and hexagons); ear clipping must choose other diagonals. The hexagon is non-convex (a
// notch at vertex 5).
const char* k_folded_hexagon_obj = "v 0 0 0\nv 1 0 0\nv 2 0 1\nv 1 0 2\nv 0.6 0 1\nv 0 0 2\n"
                                   "f 1 2 3 4 5 6\nf 3 2 1\n";

// The inside of a printed cabinet (thingi10k-style): walls as one long quad each, 3 shelves of 2 triangles
// whose corners all meet a wall (T-junctions): every shelf corner clamps, and shells refine the shelves.
Primitive cabinet() {
    Primitive p;
    auto quad = [&](std::array<float, 3> a, std::array<float, 3> b, std::array<float, 3> c, std::array<float, 3> e) {
        const uint32_t base = uint32_t(p.vertex_count());
        for (const auto& q : {a, b, c, e}) p.positions.insert(p.positions.end(), q.begin(), q.end());
        p.indices.insert(p.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    };
    const float w = 1, d = 0.35f, h = 0.3f, t = 0.018f, top = 3 * (h + t);
    quad({0, 0, 0}, {0, top, 0}, {0, top, d}, {0, 0, d});
    quad({w, 0, d}, {w, top, d}, {w, top, 0}, {w, 0, 0});
    quad({0, 0, 0}, {w, 0, 0}, {w, top, 0}, {0, top, 0});
    for (int k = 0; k < 3; ++k) {
        const float y = float(k) * (h + t) + t;
        quad({0, y, d}, {w, y, d}, {w, y, 0}, {0, y, 0});
        quad({0, y - t, 0}, {w, y - t, 0}, {w, y - t, d}, {0, y - t, d});
        quad({0, y - t, d}, {w, y - t, d}, {w, y, d}, {0, y, d});
    }
    return p;
}

// ---------------------------------------------------------------------------------------------------------
// The cases
// ---------------------------------------------------------------------------------------------------------

struct HardCase {
    std::string name;
    std::function<fs::path(const fs::path& dir)> write; // writes the input, returns its path
    double size = 1;                                     // rough extent (fur length and colliders scale with it)
    bool visible = true;                                 // covers pixels in a 64x48 render
    bool offsets_exact = false;                          // a smooth closed sphere: no shell vertex is clamped
    std::function<void(const json&)> check_findings;     // what `furrow check --json` must report
};

fs::path save(const fs::path& dir, const std::string& name, const Primitive& p) {
    fs::path file = dir / (name + ".glb");
    Status s = save_scene(make_scene(p, name), file.string());
    EXPECT_TRUE(s.ok()) << s.message;
    return file;
}

std::function<fs::path(const fs::path&)> glb(const std::string& name, std::function<Primitive()> make) {
    return [=](const fs::path& dir) { return save(dir, name, make()); };
}

void PrintTo(const HardCase& c, std::ostream* os) { *os << c.name; }

std::vector<HardCase> hard_cases() {
    std::vector<HardCase> c;
    // A unit sphere 1e5 m from the origin on every axis (float32 spacing there: 7.8 mm).
    c.push_back({"FarFromOrigin", glb("far", [] { return sphere_at(1, 1e5); }), 1, true, true, [](const json& j) {
                     EXPECT_NEAR(j["bbox_min"][0].get<double>(), 1e5 - 1, 0.01);
                     EXPECT_EQ(j["closed"], true);
                 }});
    // Scale 1e-4: a sphere of radius 0.1 mm.
    c.push_back({"Tiny", glb("tiny", [] { return sphere_at(1e-4, 0); }), 1e-4, true, true, [](const json& j) {
                     EXPECT_NEAR(j["diagonal"].get<double>(), 2e-4 * std::sqrt(3.0), 1e-5);
                     EXPECT_EQ(j["zero_area_faces"], 0); // relative to the mesh's own size
                     EXPECT_EQ(j["closed"], true);
                 }});
    // Scale 1e4: a sphere of radius 10 km.
    c.push_back({"Huge", glb("huge", [] { return sphere_at(1e4, 0); }), 1e4, true, true, [](const json& j) {
                     EXPECT_NEAR(j["diagonal"].get<double>(), 2e4 * std::sqrt(3.0), 1);
                     EXPECT_EQ(j["closed"], true);
                 }});
    c.push_back({"Needles", glb("needles", needles), 1, false, false, [](const json& j) {
                     EXPECT_GE(j["slivers"].get<int>() + j["zero_area_faces"].get<int>(), 8);
                     EXPECT_EQ(j["closed"], true);
                 }});
    c.push_back({"Caps", glb("caps", caps), 1, true, false, [](const json& j) {
                     EXPECT_GE(j["slivers"].get<int>() + j["zero_area_faces"].get<int>(), 1);
                     EXPECT_EQ(j["closed"], true);
                 }});
    c.push_back({"Slivers", glb("slivers", sliver_grid), 1, true, false, [](const json& j) {
                     EXPECT_EQ(j["slivers"].get<int>() + j["zero_area_faces"].get<int>(), 16);
                     EXPECT_EQ(j["boundary_edges"], 32);
                 }});
    c.push_back({"ZeroAreaFaces", glb("zero_area", zero_area), 1, true, false, [](const json& j) {
                     EXPECT_EQ(j["zero_area_faces"], 2);
                     EXPECT_EQ(j["degenerate_faces"], 1);
                 }});
    c.push_back({"DuplicateVertices", glb("soup", soup), 1, true, false, [](const json& j) {
                     EXPECT_EQ(j["duplicate_vertices"], 960 - 162);
                     EXPECT_EQ(j["closed"], true);
                 }});
    // Row 4 of a grid moved onto row 3's line, half a cell along: 16 zero-area triangles of collinear vertices.
    c.push_back({"CollinearVertices", glb("collinear", [] {
                     return edited_grid(4, [](float& x, float& z) { x += 0.0625f, z = -0.125f; });
                 }),
                 1, true, false, [](const json& j) { EXPECT_EQ(j["zero_area_faces"], 16); }});
    // Row 4 of a grid moved onto row 3 exactly: 9 coincident vertex pairs, 16 degenerate triangles.
    c.push_back({"CoincidentVertices", glb("coincident", [] { return edited_grid(4, [](float&, float& z) { z = -0.125f; }); }), 1, true,
                 false, [](const json& j) {
                     EXPECT_EQ(j["duplicate_vertices"], 9);
                     EXPECT_EQ(j["degenerate_faces"], 16);
                 }});
    c.push_back({"NonManifoldEdges", glb("fins", fins), 1, true, false, [](const json& j) { EXPECT_EQ(j["non_manifold_edges"], 4); }});
    c.push_back({"NonManifoldVertex", glb("bowtie", bowtie), 1, true, false, [](const json& j) {
                     EXPECT_EQ(j["non_manifold_vertices"], 1);
                     EXPECT_EQ(j["closed"], true);
                 }});
    c.push_back({"InconsistentWinding", glb("flipped", flipped), 1, true, false, [](const json& j) {
                     EXPECT_GT(j["inconsistent_edges"].get<int>(), 0);
                     EXPECT_EQ(j["closed"], true);
                 }});
    c.push_back({"MobiusStrip", glb("mobius", mobius), 1, true, false, [](const json& j) {
                     EXPECT_GT(j["inconsistent_edges"].get<int>(), 0); // non-orientable: no winding is consistent
                     EXPECT_EQ(j["boundary_loops"], 1);                // a Möbius strip has one boundary curve
                     EXPECT_EQ(j["components"], 1);
                 }});
    c.push_back({"IsolatedVertices", glb("isolated", isolated), 1, true, false, [](const json& j) {
                     EXPECT_EQ(j["unreferenced_vertices"], 100);
                     EXPECT_EQ(j["closed"], true);
                 }});
    // A UV sphere with 256 segments: each pole is one vertex of valence 256 (an extreme extraordinary vertex
    // for subdivision: OpenSubdiv's cost per face around it grows with the valence squared).
    c.push_back({"HighValencePoles", glb("poles", [] { return shapes::uv_sphere(1, 256, 8); }), 1, true, false, [](const json& j) {
                     EXPECT_EQ(j["welded_vertices"], 7 * 256 + 2);
                     EXPECT_EQ(j["closed"], true);
                 }});
    c.push_back({"Valence2Pillow", glb("pillow", pillow), 1, true, false, [](const json& j) {
                     EXPECT_EQ(j["valence2_interior_vertices"], 3);
                     EXPECT_EQ(j["closed"], true);
                 }});
    c.push_back({"FoldedNonConvexHexagon",
                 [](const fs::path& dir) {
                     test::write_text(dir / "folded_hexagon.obj", k_folded_hexagon_obj);
                     return dir / "folded_hexagon.obj";
                 },
                 2, true, false, [](const json& j) {
                     EXPECT_EQ(j["non_manifold_edges"], 0);
                     EXPECT_EQ(j["valence2_interior_vertices"], 1);
                 }});
    c.push_back({"CoarseCabinet", glb("cabinet", cabinet), 1, true, false, [](const json& j) {
                     EXPECT_EQ(j["triangles"], 24);
                     EXPECT_EQ(j["non_manifold_edges"], 0);
                 }});
    c.push_back({"Valence2Polygons",
                 [](const fs::path& dir) {
                     test::write_text(dir / "valence2.obj", k_valence2_obj);
                     return dir / "valence2.obj";
                 },
                 1, true, false, [](const json& j) {
                     EXPECT_EQ(j["valence2_interior_vertices"], 1);
                     EXPECT_EQ(j["closed"], true);
                 }});
    return c;
}

// ---------------------------------------------------------------------------------------------------------
// Assertions shared by the commands
// ---------------------------------------------------------------------------------------------------------

int error_lines(const std::string& err) {
    int n = 0;
    std::istringstream in(err);
    for (std::string line; std::getline(in, line);) n += line.rfind("Error:", 0) == 0;
    return n;
}

// Loaded exactly as written (no recentring, NaN kept so that it can be found).
Scene load_raw(const fs::path& file) {
    Scene s;
    LoadOptions o;
    o.recentre = false;
    o.allow_non_finite = true;
    Status st = load_scene(s, file.string(), o);
    EXPECT_TRUE(st.ok()) << file << ": " << st.message;
    return s;
}

CheckReport report_of(const Scene& s) {
    std::vector<CheckReport> r;
    for (const auto& m : s.meshes)
        for (const auto& p : m.primitives) r.push_back(check_primitive(p));
    return merge_reports(r);
}

// A written glTF: the validator is clean, `furrow check` passes its gates, nothing is NaN or infinite.
void expect_valid_output(const fs::path& file) {
    ASSERT_TRUE(fs::exists(file)) << file;
    EXPECT_VALID_GLTF(file);
    const auto r = run_furrow({"check", file.string(), "--json", "--require", "no-nan,valid-indices"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    json j = json::parse(r.out, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << r.out;
    EXPECT_EQ(j["nan_values"], 0);
    EXPECT_EQ(j["indices_out_of_range"], 0);
    EXPECT_TRUE(test::all_finite(load_raw(file))) << file;
}

// A command either succeeded or refused with one line; returns true when it succeeded.
bool succeeded_or_refused_cleanly(const test::RunResult& r, const std::string& what) {
    EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 1) << what << ": exit " << r.exit_code << "\n" << r.err;
    if (r.exit_code != 0) EXPECT_EQ(error_lines(r.err), 1) << what << ":\n" << r.err;
    else EXPECT_EQ(error_lines(r.err), 0) << what << ":\n" << r.err;
    return r.exit_code == 0;
}

// Distance from each point to the nearest of `targets` (brute force, in double).
std::vector<double> nearest_distances(const std::vector<float>& points, const std::vector<float>& targets) {
    std::vector<double> d(points.size() / 3, INFINITY);
    for (size_t i = 0; i < d.size(); ++i)
        for (size_t k = 0; k < targets.size(); k += 3) {
            double dx = double(points[3 * i]) - targets[k], dy = double(points[3 * i + 1]) - targets[k + 1],
                   dz = double(points[3 * i + 2]) - targets[k + 2];
            d[i] = std::min(d[i], dx * dx + dy * dy + dz * dz);
        }
    for (double& x : d) x = std::sqrt(x);
    return d;
}

// ---------------------------------------------------------------------------------------------------------
// The commands
// ---------------------------------------------------------------------------------------------------------

void run_check(const HardCase& c, const fs::path& in) {
    const auto r = run_furrow({"check", in.string(), "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    json j = json::parse(r.out, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << r.out;
    EXPECT_EQ(j["nan_values"], 0);
    EXPECT_TRUE(std::isfinite(j["diagonal"].get<double>()));
    c.check_findings(j);
}

void run_shells(const HardCase& c, const fs::path& in, const fs::path& dir) {
    const fs::path out = dir / "shells.glb";
    const double L = 0.02 * c.size;
    char len[32];
    std::snprintf(len, sizeof len, "%.17g", L);
    const auto r = run_furrow({"shells", in.string(), "-o", out.string(), "--layers", "4", "--length", len, "--texture-size", "32"});
    if (!succeeded_or_refused_cleanly(r, "shells")) return;
    expect_valid_output(out);
    const Scene s = load_raw(out);
    ASSERT_EQ(s.meshes.size(), 1u);
    const auto& prims = s.meshes[0].primitives;
    if (prims.size() == 1) {
        // Only a surface without any extrusion direction (the pillow's two faces cancel) or one folded onto
        // itself (the triangle lying on the hexagon: fur anywhere near it crosses it) may get no shells, and the
        // summary says so.
        EXPECT_NE(r.err.find("0 triangles added"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("bald"), std::string::npos) << r.err;
        EXPECT_TRUE(c.name == "Valence2Pillow" || c.name == "FoldedNonConvexHexagon") << c.name;
        return;
    }
    ASSERT_EQ(prims.size(), 5u); // the base and 4 shells (viewer layout)
    // Every shell vertex is its base vertex moved by at most 2 L (the even-thickness cap; clamps only shorten).
    for (size_t k = 1; k < prims.size(); ++k) {
        const auto d = nearest_distances(prims[k].positions, prims[0].positions);
        for (double x : d) ASSERT_LE(x, 2 * L * (1 + 1e-3)) << "shell " << k;
    }
    if (c.offsets_exact) {
        // A smooth sphere: the top shell stands at the requested length everywhere (float32 far from the origin
        // would round a 2 cm offset to 7.8 mm steps; the shells are written relative to the mesh's centre).
        const auto d = nearest_distances(prims.back().positions, prims[0].positions);
        for (double x : d) ASSERT_NEAR(x, L, 0.03 * L);
    }
}

void run_tessellate(const HardCase& c, const fs::path& in, const fs::path& dir, const CheckReport& input) {
    const fs::path out = dir / "tess.glb";
    const auto r = run_furrow({"tessellate", in.string(), "-o", out.string(), "--uniform", "2"});
    if (!succeeded_or_refused_cleanly(r, "tessellate")) return;
    expect_valid_output(out);
    const CheckReport o = report_of(load_raw(out));
    EXPECT_GT(o.triangles, 0u);
    if (input.closed && input.boundary_edges == 0) {
        EXPECT_EQ(o.boundary_edges, 0u) << "a closed input must stay closed";
    }
    // The surface stays where the input was (subdivision only shrinks it). The pillow (two triangles back to
    // back, every vertex of valence 2) is on its limit surface since valence-2 vertices stopped falling back
    // to linear faces, and that limit is small: 8 levels of Far uniform refinement give 7.4 % of its diagonal.
    EXPECT_LE(o.diagonal, input.diagonal * 1.001 + 1e-9);
    EXPECT_GE(o.diagonal, input.diagonal * (c.name == "Valence2Pillow" ? 0.05 : 0.25));
}

void run_stamp(const HardCase& c, const fs::path& in, const fs::path& dir, const CheckReport& input, const Scene& scene) {
    // A ball of radius 0.3 size pressed 0.1 size into the highest point of the surface (a vertex some face
    // uses; world space = object space for these files).
    double top[3] = {0, -INFINITY, 0};
    for (const auto& m : scene.meshes)
        for (const auto& p : m.primitives)
            for (uint32_t i : p.indices)
                if (p.positions[3 * i + 1] > top[1]) top[0] = p.positions[3 * i], top[1] = p.positions[3 * i + 1], top[2] = p.positions[3 * i + 2];
    const double s = c.size, cx = top[0], cz = top[2], cy = top[1] + 0.3 * s - 0.1 * s;
    char text[256];
    std::snprintf(text, sizeof text, R"({"colliders": [{"shape": "sphere", "radius": %.17g, "path": [[%.17g, %.17g, %.17g]]}]})", 0.3 * s,
                  cx, cy, cz);
    test::write_text(dir / "ball.json", text);
    const fs::path out = dir / "stamp.glb";
    const auto r = run_furrow({"stamp", in.string(), "-o", out.string(), "--colliders", (dir / "ball.json").string(), "--resolution", "64"});
    if (!succeeded_or_refused_cleanly(r, "stamp")) return;
    expect_valid_output(out);
    // The ground is refined where the heightmap has detail, never finer than what the map resolves: no edge is
    // cut into segments shorter than about a texel in the map's plane (x-z here). So no input triangle becomes
    // more than (L + 9)² triangles, L = the longest input edge in texels, measured in that plane (vertical
    // extent does not count: the map does not vary along up).
    if (size_t at = r.err.find("  heightmap "); at != std::string::npos) {
        int W = 0, H = 0;
        double texel = 0;
        size_t tin = 0, tout = 0;
        ASSERT_EQ(std::sscanf(r.err.c_str() + at, "  heightmap %d x %d at %lf", &W, &H, &texel), 3) << r.err;
        const size_t tri = r.err.find("  triangles ");
        ASSERT_NE(tri, std::string::npos) << r.err;
        ASSERT_EQ(std::sscanf(r.err.c_str() + tri, "  triangles %zu -> %zu", &tin, &tout), 2) << r.err;
        double longest = 0;
        for (const auto& m : scene.meshes)
            for (const auto& p : m.primitives) {
                Primitive t = p;
                triangulate(t);
                for (size_t f = 0; f + 3 <= t.indices.size(); f += 3)
                    for (int e = 0; e < 3; ++e) {
                        const float* a = &t.positions[3 * t.indices[f + size_t(e)]];
                        const float* b = &t.positions[3 * t.indices[f + size_t((e + 1) % 3)]];
                        longest = std::max(longest, std::hypot(double(b[0]) - a[0], double(b[2]) - a[2]));
                    }
            }
        const double L = longest / texel;
        EXPECT_LE(double(tout), double(tin) * (L + 9) * (L + 9)) << "longest edge " << L << " texels\n" << r.err;
    }
    // Nothing moves further than the imprint can push it: the output stays in the input's box grown by the
    // ball's penetration (0.1 size) and a margin.
    const Scene o = load_raw(out);
    const auto world = o.world_matrices();
    for (size_t n = 0; n < o.nodes.size(); ++n) {
        if (o.nodes[n].mesh < 0) continue;
        const auto& M = world[n];
        for (const auto& p : o.meshes[size_t(o.nodes[n].mesh)].primitives)
            for (size_t v = 0; v < p.positions.size(); v += 3) {
                for (int k = 0; k < 3; ++k) {
                    double w = M[size_t(k)] * p.positions[v] + M[size_t(4 + k)] * p.positions[v + 1] + M[size_t(8 + k)] * p.positions[v + 2] +
                               M[size_t(12 + k)];
                    ASSERT_GE(w, input.bbox_min[size_t(k)] - 0.2 * s) << "axis " << k;
                    ASSERT_LE(w, input.bbox_max[size_t(k)] + 0.2 * s) << "axis " << k;
                }
            }
    }
}

void run_render(const HardCase& c, const fs::path& in, const fs::path& dir) {
    const fs::path png = dir / "render.png", pfm = dir / "depth.pfm";
    const auto r = run_furrow({"render", in.string(), "-o", png.string(), "--size", "64x48", "--depth-out", pfm.string()});
    if (!succeeded_or_refused_cleanly(r, "render")) return;
    ImageF im;
    ASSERT_TRUE(load_png(im, png.string()).ok());
    EXPECT_EQ(im.width, 64);
    EXPECT_EQ(im.height, 48);
    if (c.visible) {
        EXPECT_GT(mask_area(silhouette_mask(im)), 20u) << "the mesh should be in view";
    }
    // Depth: positive where something was drawn, +inf elsewhere, never NaN.
    const auto bytes = test::read_bytes(pfm);
    const std::string header = "Pf\n64 48\n-1.0\n";
    ASSERT_EQ(bytes.size(), header.size() + 64 * 48 * 4);
    for (size_t i = header.size(); i < bytes.size(); i += 4) {
        float v;
        std::memcpy(&v, &bytes[i], 4);
        ASSERT_FALSE(std::isnan(v));
        ASSERT_TRUE(v > 0) << v;
    }
}

class HardCases : public ::testing::TestWithParam<HardCase> {};

TEST_P(HardCases, EveryCommand) {
    const HardCase& c = GetParam();
    const fs::path dir = test::temp_dir();
    const fs::path in = c.write(dir);
    const auto before = test::read_bytes(in);
    Scene scene;
    LoadOptions keep_non_finite;
    keep_non_finite.recentre = false;
    keep_non_finite.allow_non_finite = true;
    ASSERT_TRUE(load_scene(scene, in.string(), keep_non_finite).ok());
    const CheckReport input = report_of(scene);
    {
        SCOPED_TRACE("check");
        run_check(c, in);
    }
    {
        SCOPED_TRACE("shells");
        run_shells(c, in, dir);
    }
    {
        SCOPED_TRACE("tessellate");
        run_tessellate(c, in, dir, input);
    }
    {
        SCOPED_TRACE("stamp");
        run_stamp(c, in, dir, input, scene);
    }
    {
        SCOPED_TRACE("render");
        run_render(c, in, dir);
    }
    EXPECT_EQ(test::read_bytes(in), before);
}

INSTANTIATE_TEST_SUITE_P(Meshes, HardCases, ::testing::ValuesIn(hard_cases()),
                         [](const ::testing::TestParamInfo<HardCase>& info) { return info.param.name; });

// 5.2 million triangles (2.6 million vertices, a 126 MB GLB) through every command: each completes with a
// valid result at this size. The suite name ends in _large: CTest gives it the label `large`
// (tests/CMakeLists.txt), so the sanitizer run can leave it out. Each command takes well under a minute in
// Release on 2 cores; the time is printed, not asserted (speed is `furrow bench`'s, memory `furrow bench
// memory`'s). (An icosphere, not a UV sphere: a UV sphere of 5M triangles has poles of valence 2500, and
// OpenSubdiv's irregular patches make `tessellate` take minutes there, see HighValencePoles.)
TEST(hard_cases_large, FiveMillionTriangles) {
    const fs::path dir = test::temp_dir();
    const Primitive sphere = shapes::icosphere(1.0f, 9);
    ASSERT_EQ(sphere.triangle_count(), 5242880u);
    const fs::path in = save(dir, "big", sphere);
    auto timed = [](const std::vector<std::string>& args) { // prints the wall time
        const auto t0 = std::chrono::steady_clock::now();
        auto r = run_furrow(args);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("    furrow %s: %.1f s\n", args[0].c_str(), s);
        return r;
    };
    {
        const auto r = timed({"check", in.string(), "--json"});
        ASSERT_EQ(r.exit_code, 0) << r.err;
        json j = json::parse(r.out, nullptr, false);
        EXPECT_EQ(j["triangles"], 5242880);
        EXPECT_EQ(j["closed"], true);
        EXPECT_EQ(j["nan_values"], 0);
    }
    {
        const fs::path out = dir / "shells.glb";
        const auto r = timed({"shells", in.string(), "-o", out.string(), "--layers", "2", "--length", "0.01", "--texture-size", "32"});
        ASSERT_EQ(r.exit_code, 0) << r.err;
        expect_valid_output(out);
        fs::remove(out);
    }
    {
        const fs::path out = dir / "tess.glb";
        const auto r = timed({"tessellate", in.string(), "-o", out.string(), "--uniform", "1"});
        ASSERT_EQ(r.exit_code, 0) << r.err;
        expect_valid_output(out);
        EXPECT_TRUE(report_of(load_raw(out)).closed);
        fs::remove(out);
    }
    {
        test::write_text(dir / "ball.json", R"({"colliders": [{"shape": "sphere", "radius": 0.3, "path": [[0, 1.2, 0]]}]})");
        const fs::path out = dir / "stamp.glb";
        const auto r = timed({"stamp", in.string(), "-o", out.string(), "--colliders", (dir / "ball.json").string(), "--resolution", "256"});
        ASSERT_EQ(r.exit_code, 0) << r.err;
        expect_valid_output(out);
        fs::remove(out);
    }
    {
        const fs::path png = dir / "big.png";
        const auto r = timed({"render", in.string(), "-o", png.string(), "--size", "320x240"});
        ASSERT_EQ(r.exit_code, 0) << r.err;
        ImageF im;
        ASSERT_TRUE(load_png(im, png.string()).ok());
        EXPECT_GT(mask_area(silhouette_mask(im)), 5000u);
    }
    fs::remove(in); // 126 MB
}

} // namespace
} // namespace furrow

// furrow::tessellate on procedural meshes: counts, watertightness, orientation, rates, attributes, repair,
// bad input, determinism.
#include "tess_test_util.h"
#include "test_support.h"

#include <furrow/shapes.h>
#include <furrow/tessellate.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

using namespace furrow;
using namespace furrow::test;

namespace {

void expect_clean(const TessellateOutput& t, bool closed, const std::string& what) {
    CheckReport r = check_primitive(primitive_of(t));
    if (closed) {
        EXPECT_EQ(r.boundary_edges, 0u) << what;
    }
    EXPECT_EQ(r.non_manifold_edges, 0u) << what;
    EXPECT_EQ(r.inconsistent_edges, 0u) << what;
    EXPECT_EQ(r.zero_area_faces, 0u) << what;
    EXPECT_EQ(r.indices_out_of_range, 0u) << what;
    EXPECT_EQ(r.nan_values, 0u) << what;
    EXPECT_EQ(r.unreferenced_vertices, 0u) << what;
}

// Rates that vary from edge to edge: a focus point at one side of the mesh.
TessellateOptions mixed_rates(SubdivisionScheme scheme, std::array<double, 3> centre, double radius) {
    TessellateOptions o;
    o.surface.scheme = scheme;
    o.rates.focus.push_back({centre, radius, 7});
    o.rates.uniform = 1;
    return o;
}

} // namespace

// An open quad grid: exact triangle, vertex and boundary-edge counts for each scheme.
TEST(tessellate, UniformGridCounts) {
    const int nx = 4, nz = 3, R = 3;
    for (auto scheme : {SubdivisionScheme::catmark, SubdivisionScheme::bilinear}) {
        TessellateOutput t = run_tessellate(shapes::quad_grid(4, 3, nx, nz), uniform_options(scheme, R));
        EXPECT_EQ(t.stats.triangles, size_t(2 * nx * nz * R * R));
        EXPECT_EQ(t.stats.vertices, size_t((nx * R + 1) * (nz * R + 1)));
        CheckReport r = check_primitive(primitive_of(t));
        EXPECT_EQ(r.boundary_edges, size_t(2 * (nx + nz) * R));
        EXPECT_EQ(r.boundary_loops, 1u);
        expect_clean(t, false, "grid");
    }
    TessellateOutput t = run_tessellate(shapes::grid(4, 3, nx, nz), uniform_options(SubdivisionScheme::loop, R));
    EXPECT_EQ(t.stats.triangles, size_t(2 * nx * nz * R * R));
    CheckReport r = check_primitive(primitive_of(t));
    EXPECT_EQ(r.boundary_edges, size_t(2 * (nx + nz) * R));
    expect_clean(t, false, "loop grid");
}

// Rate 1 reproduces the base mesh's faces (triangles for Loop, 2 per quad for Catmull-Clark).
TEST(tessellate, RateOneKeepsFaceCount) {
    TessellateOutput t = run_tessellate(shapes::icosphere(1, 1), uniform_options(SubdivisionScheme::loop, 1));
    EXPECT_EQ(t.stats.triangles, 80u);
    EXPECT_EQ(t.stats.vertices, 42u);
    t = run_tessellate(quad_torus(8, 6), uniform_options(SubdivisionScheme::catmark, 1));
    EXPECT_EQ(t.stats.triangles, 96u);
    EXPECT_EQ(t.stats.vertices, 48u);
}

// Closed in, closed out: uniform and mixed rates, every scheme, triangles / quads / n-gons.
TEST(tessellate, WatertightOnClosedShapes) {
    struct Case {
        const char* name;
        Primitive p;
        SubdivisionScheme scheme;
    };
    Primitive cube = shapes::box(1, 1, 1, false);
    std::vector<Case> cases = {{"icosphere loop", shapes::icosphere(1, 1), SubdivisionScheme::loop},
                               {"icosphere catmark", shapes::icosphere(1, 1), SubdivisionScheme::catmark},
                               {"uv sphere catmark (seams)", shapes::uv_sphere(1, 12, 8), SubdivisionScheme::catmark},
                               {"torus loop", shapes::torus(1, 0.3f, 12, 8), SubdivisionScheme::loop},
                               {"quad torus catmark", quad_torus(8, 6), SubdivisionScheme::catmark},
                               {"cube bilinear", cube, SubdivisionScheme::bilinear}};
    for (const auto& c : cases)
        for (int R : {1, 2, 5}) {
            TessellateOutput t = run_tessellate(c.p, uniform_options(c.scheme, R));
            expect_clean(t, true, std::string(c.name) + " R=" + std::to_string(R));
            EXPECT_EQ(flipped_triangles(t), 0u) << c.name;
        }
    for (const auto& c : cases) {
        TessellateOutput t = run_tessellate(c.p, mixed_rates(c.scheme, {1, 0, 0}, 0.8));
        EXPECT_GT(t.stats.max_rate, t.stats.min_rate) << c.name;
        expect_clean(t, true, std::string(c.name) + " mixed");
        EXPECT_EQ(flipped_triangles(t), 0u) << c.name;
    }
}

// Output triangles keep the input's orientation: on a sphere their normals point outwards.
TEST(tessellate, OrientationOutward) {
    for (auto scheme : {SubdivisionScheme::loop, SubdivisionScheme::catmark}) {
        TessellateOutput t = run_tessellate(shapes::icosphere(1, 1), uniform_options(scheme, 4));
        size_t inward = 0;
        for (size_t i = 0; i < t.indices.size(); i += 3) {
            const float* a = &t.positions[t.indices[i] * 3];
            const float* b = &t.positions[t.indices[i + 1] * 3];
            const float* c = &t.positions[t.indices[i + 2] * 3];
            double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
            if (n[0] * (a[0] + b[0] + c[0]) + n[1] * (a[1] + b[1] + c[1]) + n[2] * (a[2] + b[2] + c[2]) <= 0) ++inward;
        }
        EXPECT_EQ(inward, 0u);
        for (size_t v = 0; v < t.positions.size() / 3; ++v) {
            const float* p = &t.positions[v * 3];
            const float* n = &t.normals[v * 3];
            EXPECT_GT(p[0] * n[0] + p[1] * n[1] + p[2] * n[2], 0.0f);
            EXPECT_NEAR(std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), 1.0, 1e-5);
        }
    }
}

// The same bytes for 1 and 2 threads.
TEST(tessellate, DeterministicForAnyThreadCount) {
    Primitive p = shapes::uv_sphere(1, 24, 12);
    TessellateOptions o;
    o.rates.camera = TessellationCamera{{3, 1, 0}, 45, 800};
    o.rates.pixel_error = 6;
    o.rates.max_error = 1e-3;
    o.keep_parameters = true;
    TessellateOutput a, b;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        a = run_tessellate(p, o);
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        b = run_tessellate(p, o);
    }
    EXPECT_GT(a.stats.max_rate, 1);
    EXPECT_EQ(a.positions, b.positions);
    EXPECT_EQ(a.normals, b.normals);
    EXPECT_EQ(a.uvs, b.uvs);
    EXPECT_EQ(a.indices, b.indices);
    EXPECT_EQ(a.triangle_coords, b.triangle_coords);
}

// Rates never increase with distance from the camera (distance, pixel-error and screen-error criteria).
TEST(tessellate, RatesMonotoneInDistance) {
    Primitive strip = shapes::quad_grid(40, 1, 40, 1); // x from -20 to 20
    Tessellator t;
    ASSERT_TRUE(t.prepare(input_of(strip), {SubdivisionScheme::bilinear}).ok());
    std::vector<RateOptions> criteria(3);
    for (auto& r : criteria) {
        r.camera = TessellationCamera{{-25, 1, 0}, 60, 1080};
        r.max_rate = 64;
    }
    criteria[0].distance = true;
    criteria[0].near = 5;
    criteria[0].far = 45;
    criteria[1].pixel_error = 5;
    criteria[2].screen_error = 0.5;
    criteria[2].uniform = 1;
    for (size_t k = 0; k < 2; ++k) {
        std::vector<EdgeRate> rates;
        ASSERT_TRUE(t.edge_rates(rates, criteria[k]).ok());
        // Edges along x (z = ±0.5 rows), ordered by their midpoint's distance to the eye.
        std::vector<std::pair<double, int>> by_distance;
        for (const auto& e : rates) {
            const float* a = &strip.positions[e.v0 * 3];
            const float* b = &strip.positions[e.v1 * 3];
            if (a[2] != b[2]) continue; // only edges along x
            double mx = 0.5 * (a[0] + b[0]) + 25, my = -1, mz = 0.5 * (a[2] + b[2]);
            by_distance.push_back({std::sqrt(mx * mx + my * my + mz * mz), e.rate});
        }
        std::sort(by_distance.begin(), by_distance.end());
        ASSERT_GT(by_distance.size(), 40u);
        for (size_t i = 1; i < by_distance.size(); ++i) EXPECT_LE(by_distance[i].second, by_distance[i - 1].second) << k;
        EXPECT_GT(by_distance.front().second, by_distance.back().second) << k;
    }
}

// Seed formula: the exact rates of Unity's distance-based factor.
TEST(tessellate, DistanceFormulaMatchesUnity) {
    Primitive seg;
    seg.positions = {0, 0, 0, 10, 0, 0, 0, 0, 1};
    seg.indices = {0, 2, 1};
    Tessellator t;
    ASSERT_TRUE(t.prepare(input_of(seg), {SubdivisionScheme::bilinear}).ok());
    RateOptions r;
    r.camera = TessellationCamera{{0, 0, 0}};
    r.distance = true;
    r.near = 2;
    r.far = 12;
    r.max_rate = 20;
    std::vector<EdgeRate> rates;
    ASSERT_TRUE(t.edge_rates(rates, r).ok());
    auto factor = [&](double d) { return std::clamp(1.0 - (d - 2) / 10, 0.01, 1.0) * 20; };
    for (const auto& e : rates) {
        double d0 = std::sqrt(seg.positions[e.v0 * 3] * seg.positions[e.v0 * 3] + seg.positions[e.v0 * 3 + 2] * seg.positions[e.v0 * 3 + 2]);
        double d1 = std::sqrt(seg.positions[e.v1 * 3] * seg.positions[e.v1 * 3] + seg.positions[e.v1 * 3 + 2] * seg.positions[e.v1 * 3 + 2]);
        EXPECT_EQ(e.rate, int(std::ceil(0.5 * (factor(d0) + factor(d1)) - 1e-9)));
    }
}

// A camera inside the mesh, behind it, or on its surface: finite rates, capped, still watertight.
TEST(tessellate, CameraInsideBehindOrOnSurface) {
    Primitive sphere = shapes::icosphere(1, 2);
    for (std::array<double, 3> eye : {std::array<double, 3>{0, 0, 0}, {0, 0, -5}, {1, 0, 0}}) {
        TessellateOptions o;
        o.surface.scheme = SubdivisionScheme::loop;
        o.rates.camera = TessellationCamera{eye, 60, 1080};
        o.rates.pixel_error = 2;
        o.rates.screen_error = 0.5;
        o.rates.distance = true;
        o.rates.near = 0;
        o.rates.far = 3;
        o.rates.max_rate = 12;
        TessellateOutput t = run_tessellate(sphere, o);
        EXPECT_LE(t.stats.max_rate, 12);
        EXPECT_GE(t.stats.min_rate, 1);
        expect_clean(t, true, "camera");
    }
}

// near >= far, a missing camera, no criterion, rates out of range: clear errors, nothing written.
TEST(tessellate, RejectsBadRateOptions) {
    Primitive p = shapes::icosphere(1, 0);
    auto fails = [&](TessellateOptions o, const std::string& needle) {
        TessellateOutput t;
        t.positions = {1, 2, 3};
        Status s = tessellate(t, input_of(p), o);
        EXPECT_EQ(s.code, StatusCode::invalid_argument) << needle;
        EXPECT_NE(s.message.find(needle), std::string::npos) << s.message;
        EXPECT_TRUE(t.positions.empty());
    };
    TessellateOptions o;
    fails(o, "no rate criterion");
    o.rates.distance = true;
    fails(o, "need a camera");
    o.rates.camera = TessellationCamera{};
    o.rates.near = 5;
    o.rates.far = 5;
    fails(o, "must be less than far");
    o.rates.near = 6;
    fails(o, "must be less than far");
    o = TessellateOptions{};
    o.rates.uniform = 4;
    o.rates.max_rate = 0;
    fails(o, "max rate");
    o.rates.max_rate = 8;
    o.surface.accuracy = 0;
    fails(o, "accuracy");
    o.surface.accuracy = 2;
    o.rates.camera = TessellationCamera{{0, 0, 0}, 180, 100};
    fails(o, "field of view");
}

// Malformed input: NaN, indices out of range, face sizes that do not add up, loop on quads.
TEST(tessellate, RejectsBadInput) {
    TessellateOptions o = uniform_options(SubdivisionScheme::catmark, 2);
    Primitive p = shapes::quad_grid(1, 1, 2, 2);
    TessellateOutput t;
    {
        Primitive q = p;
        q.positions[4] = NAN;
        Status s = tessellate(t, input_of(q), o);
        EXPECT_EQ(s.code, StatusCode::invalid_input);
        EXPECT_NE(s.message.find("non-finite"), std::string::npos) << s.message;
    }
    {
        Primitive q = p;
        q.indices[5] = 99;
        Status s = tessellate(t, input_of(q), o);
        EXPECT_EQ(s.code, StatusCode::invalid_input);
        EXPECT_NE(s.message.find("refers to vertex 99"), std::string::npos) << s.message;
    }
    {
        Primitive q = p;
        q.face_sizes[0] = 5;
        Status s = tessellate(t, input_of(q), o);
        EXPECT_EQ(s.code, StatusCode::invalid_input);
        EXPECT_NE(s.message.find("face sizes add up"), std::string::npos) << s.message;
    }
    {
        Status s = tessellate(t, input_of(p), uniform_options(SubdivisionScheme::loop, 2));
        EXPECT_EQ(s.code, StatusCode::unsupported);
        EXPECT_NE(s.message.find("loop subdivision needs triangles"), std::string::npos) << s.message;
    }
    {
        TessellateInput in = input_of(p);
        in.positions = nullptr;
        EXPECT_EQ(tessellate(t, in, o).code, StatusCode::invalid_input);
    }
    // Empty input is not an error: nothing in, nothing out.
    TessellateInput empty;
    Status s = tessellate(t, empty, o);
    EXPECT_TRUE(s.ok()) << s.message;
    EXPECT_TRUE(t.indices.empty());
}

// Three triangles on one edge: tessellated linearly, the edge's points shared by all three, no crash.
TEST(tessellate, NonManifoldEdgeFallsBackLinear) {
    Primitive fins;
    fins.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1};
    fins.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    TessellateOptions o = uniform_options(SubdivisionScheme::loop, 4);
    TessellateOutput t = run_tessellate(fins, o);
    EXPECT_EQ(t.stats.non_manifold_edges, 1u);
    EXPECT_EQ(t.stats.linear_faces, 3u);
    EXPECT_EQ(t.stats.triangles, 3u * 16u);
    CheckReport r = check_primitive(primitive_of(t));
    EXPECT_EQ(r.non_manifold_edges, 4u); // the 4 segments of the shared edge
    EXPECT_EQ(r.boundary_edges, 3u * 2u * 4u);
    EXPECT_EQ(r.zero_area_faces, 0u);
    SurfaceOptions strict;
    strict.scheme = SubdivisionScheme::loop;
    strict.refuse_bad_topology = true;
    Tessellator tt;
    Status s = tt.prepare(input_of(fins), strict);
    EXPECT_EQ(s.code, StatusCode::invalid_input);
    EXPECT_NE(s.message.find("non-manifold"), std::string::npos) << s.message;
}

// A quad split in two by an interior vertex of valence 2: its faces stay on the limit surface (once they
// fell back to linear; tessellate_reference.Valence2VerticesAreOnTheLimitSurface measures them), and the
// output stays crack-free.
// A 3 × 3 quad grid whose centre quad [5, 9, 10, 6] (a, b, c, d order of quad_grid) is replaced by two quads
// through a new vertex 16 of valence 2; `centre_quad` returns the replaced quad's corners.
static Primitive valence2_grid(std::vector<uint32_t>* centre_quad = nullptr) {
    Primitive p = shapes::quad_grid(3, 3, 3, 3);
    const uint32_t v = 16;
    p.positions.insert(p.positions.end(), {0.1f, 0.0f, 0.05f});
    if (!p.uv0.empty()) p.uv0.insert(p.uv0.end(), {0.52f, 0.5f}); // every array grows with the new vertex
    if (!p.normals.empty()) p.normals.insert(p.normals.end(), {0.0f, 1.0f, 0.0f});
    const size_t centre = 4;
    std::vector<uint32_t> quad(p.indices.begin() + long(centre * 4), p.indices.begin() + long(centre * 4 + 4));
    p.indices.erase(p.indices.begin() + long(centre * 4), p.indices.begin() + long(centre * 4 + 4));
    p.face_sizes.pop_back();
    p.indices.insert(p.indices.end(), {quad[0], quad[1], quad[2], v});
    p.indices.insert(p.indices.end(), {quad[0], v, quad[2], quad[3]});
    p.face_sizes.push_back(4);
    p.face_sizes.push_back(4);
    if (centre_quad) *centre_quad = quad;
    return p;
}

TEST(tessellate, Valence2InteriorVertexStaysSmoothAndCrackFree) {
    Primitive p = valence2_grid();
    TessellateOutput t = run_tessellate(p, uniform_options(SubdivisionScheme::catmark, 3));
    EXPECT_EQ(t.stats.valence2_vertices, 1u);
    EXPECT_EQ(t.stats.linear_faces, 0u);
    CheckReport r = check_primitive(primitive_of(t));
    EXPECT_EQ(r.boundary_edges, size_t(2 * (3 + 3) * 3));
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
}

// The same valence-2 vertex with a crease at a corner of its faces (the tessellate fuzzer's find): OpenSubdiv
// 3.5.0's Bfr reads out of bounds building those faces' irregular patches, so they are tessellated linearly
// (counted as failed faces), and the output stays crack-free around them.
TEST(tessellate, Valence2VertexNextToACreaseFallsBackLinear) {
    std::vector<uint32_t> quad;
    Primitive p = valence2_grid(&quad);
    p.positions[3 * quad[0] + 1] += 0.5f; // a peak at a corner of both faces: the edges around it crease
    TessellateOptions o = uniform_options(SubdivisionScheme::catmark, 3);
    o.surface.crease_angle_degrees = 10;
    TessellateOutput t = run_tessellate(p, o);
    EXPECT_EQ(t.stats.valence2_vertices, 1u);
    EXPECT_GT(t.stats.crease_edges, 0u);
    EXPECT_EQ(t.stats.failed_faces, 2u);
    EXPECT_EQ(t.stats.linear_faces, 2u);
    bool said = false;
    for (const std::string& w : t.stats.warnings) said |= w.find("valence-2 vertices next to a crease") != std::string::npos;
    EXPECT_TRUE(said);
    CheckReport r = check_primitive(primitive_of(t));
    EXPECT_EQ(r.boundary_edges, size_t(2 * (3 + 3) * 3));
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
}

// Two triangles touching at one vertex: the vertex is split per fan; faces repeating a vertex are dropped
// or split.
TEST(tessellate, BowtieAndDegenerateFacesRepaired) {
    Primitive p;
    p.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0, 5, 5, 5};
    p.indices = {0, 1, 2, 0, 3, 4, 0, 0, 5};
    TessellateOutput t = run_tessellate(p, uniform_options(SubdivisionScheme::loop, 2));
    EXPECT_EQ(t.stats.split_vertices, 1u);
    EXPECT_EQ(t.stats.dropped_faces, 1u);
    EXPECT_EQ(t.stats.triangles, 8u);
    expect_clean(t, false, "bowtie");
    // A pentagon visiting vertex 0 twice becomes two triangles.
    Primitive q;
    q.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0};
    q.indices = {0, 1, 2, 0, 3, 4};
    q.face_sizes = {6};
    t = run_tessellate(q, uniform_options(SubdivisionScheme::catmark, 2));
    EXPECT_EQ(t.stats.faces, 2u);
    expect_clean(t, false, "figure eight");
}

// UVs: continuous across faces (no split vertex where the input has none), seams kept where it has them.
TEST(tessellate, UvsContinuousAndSeamsPreserved) {
    for (auto uvi : {UvInterpolation::linear, UvInterpolation::corners_only, UvInterpolation::smooth}) {
        TessellateOptions o = uniform_options(SubdivisionScheme::catmark, 4);
        o.surface.uv_interpolation = uvi;
        // No seam: one output vertex per position.
        TessellateOutput t = run_tessellate(shapes::quad_grid(2, 2, 3, 3), o);
        CheckReport r = check_primitive(primitive_of(t));
        EXPECT_EQ(r.duplicate_vertices, 0u);
        ASSERT_EQ(t.uvs.size(), t.positions.size() / 3 * 2);
        // With linear UVs on a planar grid the UV is an affine function of the position.
        if (uvi == UvInterpolation::linear) {
            for (size_t v = 0; v < t.positions.size() / 3; ++v) {
                EXPECT_NEAR(t.uvs[v * 2], t.positions[v * 3] / 2 + 0.5, 1e-5);
                EXPECT_NEAR(t.uvs[v * 2 + 1], t.positions[v * 3 + 2] / 2 + 0.5, 1e-5);
            }
        }
        // The sphere's seam (u = 0 | 1) and its poles: positions repeat only there, with u exactly 0 and 1.
        Primitive sphere = shapes::uv_sphere(1, 12, 6);
        t = run_tessellate(sphere, o);
        std::map<std::array<float, 3>, std::set<std::pair<float, float>>> uvs_at;
        for (size_t v = 0; v < t.positions.size() / 3; ++v)
            uvs_at[{t.positions[v * 3], t.positions[v * 3 + 1], t.positions[v * 3 + 2]}].insert({t.uvs[v * 2], t.uvs[v * 2 + 1]});
        // Outside the pole fans (v < 1/6 or v > 5/6, split in UV too), repeated positions are the u = 0 | 1
        // seam: its 5 ring vertices and 4 base edges x 3 points, each with exactly two UVs a texture apart.
        size_t seam = 0;
        for (const auto& [pos, set] : uvs_at) {
            const float v = set.begin()->second;
            if (set.size() < 2 || v < 1.0f / 6 - 1e-3f || v > 5.0f / 6 + 1e-3f) continue;
            ++seam;
            EXPECT_EQ(set.size(), 2u);
            EXPECT_GT(set.rbegin()->first - set.begin()->first, 0.9f);
            if (uvi == UvInterpolation::linear) {
                EXPECT_EQ(set.begin()->first, 0.0f);
                EXPECT_EQ(set.rbegin()->first, 1.0f);
            }
        }
        EXPECT_EQ(seam, size_t(5 + 4 * 3)) << int(uvi);
        expect_clean(t, true, "sphere");
    }
}

// Creases from the angle between faces: a cube stays a cube (flat faces, split normals at its edges).
TEST(tessellate, CreaseAngleKeepsCubeSharp) {
    TessellateOptions o = uniform_options(SubdivisionScheme::catmark, 4);
    o.surface.crease_angle_degrees = 30;
    TessellateOutput t = run_tessellate(shapes::box(2, 2, 2, false), o);
    EXPECT_EQ(t.stats.crease_edges, 12u + 6u * 0u);
    for (size_t v = 0; v < t.positions.size() / 3; ++v) {
        const float* p = &t.positions[v * 3];
        const float m = std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2])});
        EXPECT_NEAR(m, 1.0f, 1e-5f); // every point on the cube's surface
        const float* n = &t.normals[v * 3];
        EXPECT_NEAR(std::max({std::abs(n[0]), std::abs(n[1]), std::abs(n[2])}), 1.0f, 1e-5f); // axis-aligned
    }
    expect_clean(t, true, "sharp cube");
}

// The triangle budget: the output fits; an impossible budget is an error.
TEST(tessellate, TriangleBudget) {
    Primitive p = shapes::icosphere(1, 2); // 320 triangles
    TessellateOptions o = uniform_options(SubdivisionScheme::loop, 8);
    o.rates.max_triangles = 5000;
    TessellateOutput t = run_tessellate(p, o);
    EXPECT_LE(t.stats.triangles, 5000u);
    EXPECT_GT(t.stats.triangles, 2500u);
    EXPECT_LT(t.stats.rate_scale, 1.0);
    expect_clean(t, true, "budget");
    o.rates.max_triangles = 100;
    Status s = tessellate(t, input_of(p), o);
    EXPECT_EQ(s.code, StatusCode::invalid_argument);
    EXPECT_NE(s.message.find("below the 320 triangles"), std::string::npos) << s.message;
}

// Skins are blended, the 4 largest kept, renormalised; other attributes interpolated.
TEST(tessellate, SkinWeightsTopFourNormalised) {
    Primitive p = shapes::quad_grid(1, 1, 2, 2);
    const size_t n = p.vertex_count();
    std::vector<uint16_t> joints(n * 4);
    std::vector<float> weights(n * 4), colors(n * 4);
    for (size_t v = 0; v < n; ++v)
        for (int k = 0; k < 4; ++k) {
            joints[v * 4 + size_t(k)] = uint16_t(v + size_t(k)); // different joints everywhere
            weights[v * 4 + size_t(k)] = 0.25f;
            colors[v * 4 + size_t(k)] = float(v) / float(n);
        }
    TessellateInput in = input_of(p);
    in.joints = joints.data();
    in.weights = weights.data();
    in.attributes.push_back({colors.data(), 4});
    TessellateOutput t;
    ASSERT_TRUE(tessellate(t, in, uniform_options(SubdivisionScheme::catmark, 3)).ok());
    ASSERT_EQ(t.joints.size(), t.positions.size() / 3 * 4);
    ASSERT_EQ(t.attributes.size(), 1u);
    for (size_t v = 0; v < t.positions.size() / 3; ++v) {
        float sum = 0;
        for (int k = 0; k < 4; ++k) {
            sum += t.weights[v * 4 + size_t(k)];
            if (k) {
                EXPECT_LE(t.weights[v * 4 + size_t(k)], t.weights[v * 4 + size_t(k) - 1]);
            }
        }
        EXPECT_NEAR(sum, 1.0f, 1e-5f);
        for (int k = 0; k < 4; ++k) {
            EXPECT_GE(t.attributes[0][v * 4 + size_t(k)], -1e-6f);
            EXPECT_LE(t.attributes[0][v * 4 + size_t(k)], 1.0f);
        }
    }
}

// The error measure falls about 4x when the rate doubles (quadratic convergence of chordal error).
TEST(tessellate, MeasuredErrorConverges) {
    Primitive p = quad_torus(8, 6);
    Tessellator t;
    ASSERT_TRUE(t.prepare(input_of(p), {}).ok());
    double previous = 0;
    for (int R : {2, 4, 8}) {
        RateOptions r;
        r.uniform = R;
        TessellateOutput out;
        ASSERT_TRUE(t.tessellate(out, r, true).ok());
        ErrorReport e;
        ASSERT_TRUE(t.measure(e, out).ok());
        EXPECT_EQ(e.samples, out.stats.triangles * 4);
        EXPECT_GT(e.max_error, 0.0);
        if (previous > 0) {
            EXPECT_GT(previous / e.max_error, 3.0) << R;
            EXPECT_LT(previous / e.max_error, 5.0) << R;
        }
        previous = e.max_error;
    }
}

// max_error: the measured chordal error stays within the requested one.
TEST(tessellate, MaxErrorCriterionMeetsTarget) {
    for (auto scheme : {SubdivisionScheme::catmark, SubdivisionScheme::loop}) {
        Primitive p = scheme == SubdivisionScheme::loop ? shapes::torus(1, 0.3f, 12, 8) : quad_torus(8, 6);
        Tessellator t;
        SurfaceOptions so;
        so.scheme = scheme;
        ASSERT_TRUE(t.prepare(input_of(p), so).ok());
        for (double e : {1e-2, 1e-3, 1e-4}) {
            RateOptions r;
            r.max_error = e;
            r.max_rate = 1000;
            TessellateOutput out;
            ASSERT_TRUE(t.tessellate(out, r, true).ok());
            ErrorReport rep;
            ASSERT_TRUE(t.measure(rep, out).ok());
            EXPECT_LE(rep.max_error, e) << int(scheme) << " " << e;
            EXPECT_GT(rep.max_error, e / 10) << int(scheme) << " " << e; // and not wastefully below it
        }
    }
}

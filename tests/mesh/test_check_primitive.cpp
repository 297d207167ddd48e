#include <furrow/mesh.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

using furrow::CheckOptions;
using furrow::CheckReport;
using furrow::Primitive;
using furrow::check_primitive;

namespace {

constexpr float nan_f = std::numeric_limits<float>::quiet_NaN();
constexpr float inf_f = std::numeric_limits<float>::infinity();

Primitive make(std::vector<float> positions, std::vector<uint32_t> indices, std::vector<uint32_t> face_sizes = {}) {
    Primitive p;
    p.positions = std::move(positions);
    p.indices = std::move(indices);
    p.face_sizes = std::move(face_sizes);
    return p;
}

// Appends `b` to `a` (indices shifted), for meshes made of several pieces.
void append(Primitive& a, const Primitive& b, float dx = 0) {
    const uint32_t base = uint32_t(a.positions.size() / 3);
    for (size_t i = 0; i < b.positions.size(); ++i) a.positions.push_back(b.positions[i] + (i % 3 == 0 ? dx : 0.0f));
    for (uint32_t i : b.indices) a.indices.push_back(base + i);
}

// Outward-oriented tetrahedron: the smallest closed, clean mesh.
Primitive tetrahedron() {
    return make({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3});
}

// Unit cube as six outward quads with 24 split vertices (one copy of each corner per face, as in a
// textured glTF cube).
Primitive quad_cube() {
    const int faces[6][4][3] = {
        {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}}, {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}},
        {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}}, {{0, 1, 0}, {0, 1, 1}, {1, 1, 1}, {1, 1, 0}},
        {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {0, 1, 0}}, {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}},
    };
    Primitive p;
    for (const auto& f : faces) {
        for (const auto& c : f) {
            p.indices.push_back(uint32_t(p.positions.size() / 3));
            for (int k = 0; k < 3; ++k) p.positions.push_back(float(c[k]));
        }
        p.face_sizes.push_back(4);
    }
    return p;
}

// W×H quads in z = 0, two counter-clockwise triangles each.
Primitive grid(int w, int h) {
    Primitive p;
    for (int y = 0; y <= h; ++y)
        for (int x = 0; x <= w; ++x) p.positions.insert(p.positions.end(), {float(x), float(y), 0.0f});
    auto v = [&](int x, int y) { return uint32_t(y * (w + 1) + x); };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            p.indices.insert(p.indices.end(), {v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y), v(x + 1, y + 1), v(x, y + 1)});
    return p;
}

// Every finding that a clean closed mesh must not have.
void expect_clean(const CheckReport& r) {
    EXPECT_EQ(r.boundary_edges, 0u);
    EXPECT_EQ(r.boundary_loops, 0u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.degenerate_faces, 0u);
    EXPECT_EQ(r.zero_area_faces, 0u);
    EXPECT_EQ(r.slivers, 0u);
    EXPECT_EQ(r.unreferenced_vertices, 0u);
    EXPECT_EQ(r.nan_values, 0u);
    EXPECT_EQ(r.indices_out_of_range, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_EQ(r.valence2_interior_vertices, 0u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_TRUE(r.closed);
}

CheckOptions with_self_intersections() {
    CheckOptions o;
    o.self_intersections = true;
    return o;
}

} // namespace

// The tetrahedron: closed, manifold, oriented, nothing to report; self-intersections computed as 0
// (adjacent faces share edges and vertices, which is not an intersection).
TEST(check_primitive, ClosedTetrahedronIsClean) {
    CheckReport r = check_primitive(tetrahedron(), with_self_intersections());
    expect_clean(r);
    EXPECT_EQ(r.vertices, 4u);
    EXPECT_EQ(r.faces, 4u);
    EXPECT_EQ(r.triangles, 4u);
    EXPECT_EQ(r.welded_vertices, 4u);
    EXPECT_EQ(r.duplicate_vertices, 0u);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_EQ(r.bbox_min, (std::array<double, 3>{0, 0, 0}));
    EXPECT_EQ(r.bbox_max, (std::array<double, 3>{1, 1, 1}));
    EXPECT_DOUBLE_EQ(r.diagonal, std::sqrt(3.0));
    EXPECT_FALSE(r.has_uv);
}

// A cube of six quads with split corners: topology is measured on welded positions (8 vertices, closed),
// quads count as one face each and as two triangles; the 16 extra copies are duplicates.
TEST(check_primitive, QuadCubeWithSplitVerticesIsClosed) {
    CheckReport r = check_primitive(quad_cube(), with_self_intersections());
    expect_clean(r);
    EXPECT_EQ(r.vertices, 24u);
    EXPECT_EQ(r.welded_vertices, 8u);
    EXPECT_EQ(r.duplicate_vertices, 16u);
    EXPECT_EQ(r.faces, 6u);
    EXPECT_EQ(r.triangles, 12u);
    EXPECT_EQ(r.self_intersections, 0);
}

// Self-intersection is not computed unless asked for.
TEST(check_primitive, SelfIntersectionsOffByDefault) {
    EXPECT_EQ(check_primitive(tetrahedron()).self_intersections, -1);
}

// An open 3×2 grid: the rim has 2·(3+2) = 10 boundary edges in one loop; not closed. Its corners (0,0)
// and (3,2) have valence 2 but are on the boundary, so they are not "interior valence 2".
TEST(check_primitive, OpenGridBoundary) {
    CheckReport r = check_primitive(grid(3, 2));
    EXPECT_EQ(r.boundary_edges, 10u);
    EXPECT_EQ(r.boundary_loops, 1u);
    EXPECT_FALSE(r.closed);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.faces, 12u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_EQ(r.valence2_interior_vertices, 0u);
}

// The boundary loop count agrees with the OpenMesh-based boundary_loops() on a manifold mesh with a hole.
TEST(check_primitive, BoundaryLoopsAgreeWithHalfedgeLoops) {
    Primitive p = grid(3, 3);
    p.indices.erase(p.indices.begin() + 24, p.indices.begin() + 30); // the centre quad: a hole
    CheckReport r = check_primitive(p);
    std::vector<std::vector<uint32_t>> loops;
    EXPECT_EQ(furrow::boundary_loops(loops, p.positions.data(), p.vertex_count(), p.indices.data(), p.indices.size()),
              r.boundary_loops);
    EXPECT_EQ(r.boundary_loops, 2u);
    EXPECT_EQ(r.boundary_edges, 16u);
}

// Three triangles on one edge: 1 non-manifold edge, the 6 other edges are boundary. Vertex 0 is not a
// non-manifold vertex: its three faces are connected through the shared edge (one fan).
TEST(check_primitive, NonManifoldEdge) {
    CheckReport r = check_primitive(make({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1}, {0, 1, 2, 1, 0, 3, 0, 1, 4}));
    EXPECT_EQ(r.non_manifold_edges, 1u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.boundary_edges, 6u);
    EXPECT_EQ(r.inconsistent_edges, 0u); // only two-face edges can be inconsistent
    EXPECT_EQ(r.components, 1u);
    EXPECT_FALSE(r.closed);
}

// Two triangles touching at one vertex (a bowtie): 1 non-manifold vertex with two fans, no non-manifold
// edge, and two separate boundary loops (the rims meet at the vertex but do not continue each other).
TEST(check_primitive, BowtieVertex) {
    CheckReport r = check_primitive(make({0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0}, {0, 1, 2, 0, 3, 4}));
    EXPECT_EQ(r.non_manifold_vertices, 1u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.boundary_edges, 6u);
    EXPECT_EQ(r.boundary_loops, 2u);
    EXPECT_EQ(r.components, 1u); // edge-connected over welded vertices: the shared vertex joins them
}

// Two closed tetrahedra sharing one apex position (welded): the vertex is non-manifold, each cone is a
// closed fan of its own.
TEST(check_primitive, TwoConesSharingAVertex) {
    Primitive p = tetrahedron();
    Primitive q = make({0, 0, 0, -1, 0, 0, 0, -1, 0, 0, 0, -1}, {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2});
    append(p, q);
    CheckReport r = check_primitive(p);
    EXPECT_EQ(r.non_manifold_vertices, 1u);
    EXPECT_EQ(r.duplicate_vertices, 1u);
    EXPECT_EQ(r.boundary_edges, 0u);
    EXPECT_TRUE(r.closed);
}

// A face whose corners weld to a repeated vertex: degenerate (and so zero-area). Degenerate faces stay in
// the edge map, as in the corpus MANIFEST: its edge 0–1 is walked twice more, so that edge has 4 uses and
// is non-manifold (this is the pattern of Thingi10K 73342). The rest of the tetrahedron stays closed.
TEST(check_primitive, DegenerateFace) {
    Primitive p = tetrahedron();
    p.positions.insert(p.positions.end(), {0, 0, 0}); // vertex 4 = copy of vertex 0
    p.indices.insert(p.indices.end(), {0, 1, 4});
    CheckReport r = check_primitive(p, with_self_intersections());
    EXPECT_EQ(r.degenerate_faces, 1u);
    EXPECT_EQ(r.zero_area_faces, 1u);
    EXPECT_EQ(r.duplicate_vertices, 1u);
    EXPECT_EQ(r.non_manifold_edges, 1u);
    EXPECT_EQ(r.boundary_edges, 0u);
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.slivers, 0u);            // zero-area faces are not slivers
    EXPECT_EQ(r.self_intersections, 0); // nor part of the self-intersection test
}

// Three distinct but collinear points: zero area without being degenerate; not a sliver either.
TEST(check_primitive, ZeroAreaCollinearTriangle) {
    Primitive p = tetrahedron();
    append(p, make({0, 0, 0, 1, 1, 1, 2, 2, 2}, {0, 1, 2}), 3.0f);
    CheckReport r = check_primitive(p);
    EXPECT_EQ(r.zero_area_faces, 1u);
    EXPECT_EQ(r.degenerate_faces, 0u);
    EXPECT_EQ(r.slivers, 0u);
    EXPECT_EQ(r.components, 2u);
    EXPECT_EQ(r.boundary_edges, 3u);
}

// A needle with a 0.29° angle is a sliver at the default 1° threshold and not at 0.2°.
TEST(check_primitive, Sliver) {
    Primitive p = make({0, 0, 0, 1, 0, 0, 0, 0.005f, 0}, {0, 1, 2});
    EXPECT_EQ(check_primitive(p).slivers, 1u);
    EXPECT_EQ(check_primitive(p).zero_area_faces, 0u);
    CheckOptions o;
    o.sliver_angle_degrees = 0.2;
    EXPECT_EQ(check_primitive(p, o).slivers, 0u);
}

// The tetrahedron with one corner stored twice (and both copies used): 1 duplicate vertex, and since
// topology is welded the mesh is still closed and clean.
TEST(check_primitive, DuplicateVertices) {
    Primitive p = tetrahedron();
    p.positions.insert(p.positions.end(), {0, 0, 1}); // vertex 4 = copy of vertex 3
    p.indices[5] = 4;                                 // face 1 now uses the copy
    CheckReport r = check_primitive(p);
    EXPECT_EQ(r.duplicate_vertices, 1u);
    EXPECT_EQ(r.welded_vertices, 4u);
    expect_clean(r);
}

// A vertex no face uses is unreferenced; it still counts for the bounding box.
TEST(check_primitive, UnreferencedVertex) {
    Primitive p = tetrahedron();
    p.positions.insert(p.positions.end(), {5, 5, 5});
    CheckReport r = check_primitive(p);
    EXPECT_EQ(r.unreferenced_vertices, 1u);
    EXPECT_EQ(r.bbox_max, (std::array<double, 3>{5, 5, 5}));
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.components, 1u);
}

// NaN/Inf are counted in every float attribute; the bounding box ignores non-finite positions, and a face
// with a NaN corner has no geometry (neither zero-area nor sliver).
TEST(check_primitive, NaNPosition) {
    Primitive p = tetrahedron();
    p.positions.insert(p.positions.end(), {nan_f, 0, inf_f}); // vertex 4: 2 non-finite values
    p.indices.insert(p.indices.end(), {4, 5, 6});
    p.positions.insert(p.positions.end(), {3, 0, 0, 3, 1, 0}); // vertices 5, 6
    p.normals.assign(p.positions.size(), 0.0f);
    p.normals[0] = nan_f; // 1 more
    p.uv0.assign(2 * p.vertex_count(), 0.5f);
    p.uv0[3] = -inf_f; // 1 more
    CheckReport r = check_primitive(p, with_self_intersections());
    EXPECT_EQ(r.nan_values, 4u);
    EXPECT_EQ(r.bbox_min, (std::array<double, 3>{0, 0, 0}));
    EXPECT_EQ(r.bbox_max, (std::array<double, 3>{3, 1, 1}));
    EXPECT_EQ(r.zero_area_faces, 0u);
    EXPECT_EQ(r.slivers, 0u);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_EQ(r.uv_min, (std::array<float, 2>{0.5f, 0.5f})); // the -Inf pair is skipped
}

// An index past the vertex array: counted, and its face takes no part in topology (the tetrahedron stays
// closed) though it still counts as a face.
TEST(check_primitive, IndexOutOfRange) {
    Primitive p = tetrahedron();
    p.indices.insert(p.indices.end(), {0, 1, 99});
    CheckReport r = check_primitive(p, with_self_intersections());
    EXPECT_EQ(r.indices_out_of_range, 1u);
    EXPECT_EQ(r.faces, 5u);
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.self_intersections, 0);
}

// face_sizes that ask for more corners than the index buffer holds: the missing corners count as out of
// range and the truncated face is ignored.
TEST(check_primitive, FaceSizesOverrunIndices) {
    Primitive p = make({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, {0, 1, 2, 3, 0, 2}, {4, 5});
    CheckReport r = check_primitive(p);
    EXPECT_EQ(r.faces, 2u);
    EXPECT_EQ(r.indices_out_of_range, 3u);
    EXPECT_EQ(r.boundary_edges, 4u); // the quad alone
    EXPECT_EQ(r.triangles, 2u + 3u);
}

// One flipped triangle in a tetrahedron: its three edges are each walked twice in the same direction.
TEST(check_primitive, InconsistentWinding) {
    Primitive p = tetrahedron();
    std::swap(p.indices[10], p.indices[11]); // face 3: (1,2,3) -> (1,3,2)
    CheckReport r = check_primitive(p);
    EXPECT_EQ(r.inconsistent_edges, 3u);
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.non_manifold_edges, 0u);
}

// A Möbius strip of 8 quads (16 triangles) with faces oriented consistently along the strip: no
// orientation is possible, so the closing rung is walked in the same direction by both of its faces
// (exactly 1 inconsistent edge). Its single boundary loop runs twice around: 2·8 = 16 edges.
TEST(check_primitive, MoebiusStrip) {
    const int n = 8;
    Primitive p;
    for (int i = 0; i < n; ++i) {
        const double phi = 2 * 3.14159265358979 * i / n, half = phi / 2;
        for (double s : {0.5, -0.5}) { // top_i = 2i, bottom_i = 2i+1
            const double r = 2 + s * std::cos(half);
            p.positions.insert(p.positions.end(), {float(r * std::cos(phi)), float(r * std::sin(phi)), float(s * std::sin(half))});
        }
    }
    for (int i = 0; i < n; ++i) {
        const uint32_t a = uint32_t(2 * i), b = a + 1;
        // After half a turn the strip comes back upside down: top_n is bottom_0 and bottom_n is top_0.
        const uint32_t c = i + 1 < n ? b + 2 : 0, d = i + 1 < n ? a + 2 : 1;
        p.indices.insert(p.indices.end(), {a, b, c, a, c, d});
    }
    CheckReport r = check_primitive(p, with_self_intersections());
    EXPECT_EQ(r.inconsistent_edges, 1u);
    EXPECT_EQ(r.boundary_edges, 16u);
    EXPECT_EQ(r.boundary_loops, 1u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_FALSE(r.closed);
    EXPECT_EQ(r.self_intersections, 0);
}

// The OpenSubdiv 3.5 case: a cube whose edge (0,0,0)–(1,0,0) carries a midpoint, so the two faces along
// it are pentagons and the midpoint is an interior vertex with only two edges. The pentagons start at a
// corner away from the midpoint so no fan triangle is collinear.
TEST(check_primitive, Valence2InteriorVertex) {
    Primitive p = make({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1, 0.5f, 0, 0},
                       {
                           2, 1, 8, 0, 3,    // z = 0 (pentagon, outward -z)
                           4, 5, 6, 7,       // z = 1
                           5, 4, 0, 8, 1,    // y = 0 (pentagon, outward -y)
                           3, 7, 6, 2,       // y = 1
                           0, 4, 7, 3,       // x = 0
                           1, 2, 6, 5,       // x = 1
                       },
                       {5, 4, 5, 4, 4, 4});
    CheckReport r = check_primitive(p, with_self_intersections());
    EXPECT_EQ(r.valence2_interior_vertices, 1u);
    EXPECT_EQ(r.faces, 6u);
    EXPECT_EQ(r.triangles, 14u);
    CheckReport otherwise = r; // everything else is clean
    otherwise.valence2_interior_vertices = 0;
    expect_clean(otherwise);
    EXPECT_EQ(r.self_intersections, 0);
}

// Two separate tetrahedra: two components, both closed.
TEST(check_primitive, TwoComponents) {
    Primitive p = tetrahedron();
    append(p, tetrahedron(), 5.0f);
    CheckReport r = check_primitive(p);
    EXPECT_EQ(r.components, 2u);
    EXPECT_TRUE(r.closed);
}

// Two triangles crossing each other: one self-intersecting pair.
TEST(check_primitive, TwoIntersectingTriangles) {
    Primitive p = make({0, 0, 0, 2, 0, 0, 0, 2, 0, /**/ 0.5f, -1, -1, 0.5f, -1, 1, 0.5f, 1, 0}, {0, 1, 2, 3, 4, 5});
    EXPECT_EQ(check_primitive(p, with_self_intersections()).self_intersections, 1);
    EXPECT_EQ(check_primitive(p).self_intersections, -1);
}

// Sharing a vertex is adjacency, but a triangle that passes through its neighbour beyond the shared
// vertex intersects it.
TEST(check_primitive, SharedVertexButCrossing) {
    // Triangle A in z = 0; B shares A's corner 0 and pierces A's interior.
    Primitive p = make({0, 0, 0, 2, 0, 0, 0, 2, 0, 0.5f, 0.5f, -1, 0.5f, 0.5f, 1}, {0, 1, 2, 0, 3, 4});
    EXPECT_EQ(check_primitive(p, with_self_intersections()).self_intersections, 1);
    // Moved outside A, B only touches it at the shared corner.
    p.positions = {0, 0, 0, 2, 0, 0, 0, 2, 0, -1, -1, -1, -1, -1, 1};
    EXPECT_EQ(check_primitive(p, with_self_intersections()).self_intersections, 0);
}

// Self-intersections on a non-manifold soup (which no halfedge mesh can hold): three fins on one edge,
// one of them pierced by a separate triangle. The fins only share their edge (0 pairs among them).
TEST(check_primitive, SelfIntersectionOnNonManifoldSoup) {
    Primitive p = make({0, 0, 0, 1, 0, 0, 0.5f, 1, 0, 0.5f, -1, 0, 0.5f, 0, 1}, {0, 1, 2, 1, 0, 3, 0, 1, 4});
    append(p, make({0.5f, -0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0, -0.5f}, {0, 1, 2}));
    CheckReport r = check_primitive(p, with_self_intersections());
    EXPECT_EQ(r.non_manifold_edges, 1u);
    // The piercing triangle lies in x = 0.5 and meets z = 0 in y ∈ [-0.25, 0.25] (crossing both flat fins)
    // and y = 0 in z ∈ [-0.5, 0.5] (crossing the upright fin): 3 pairs.
    EXPECT_EQ(r.self_intersections, 3);
}

// UV presence and range over TEXCOORD_0.
TEST(check_primitive, UvRange) {
    Primitive p = tetrahedron();
    p.uv0 = {0, 0, 2.5f, -0.25f, 1, 1, 0.5f, 6};
    CheckReport r = check_primitive(p);
    EXPECT_TRUE(r.has_uv);
    EXPECT_EQ(r.uv_min, (std::array<float, 2>{0, -0.25f}));
    EXPECT_EQ(r.uv_max, (std::array<float, 2>{2.5f, 6}));
}

// Nothing at all: zeros everywhere, not closed, no crash.
TEST(check_primitive, EmptyPrimitive) {
    CheckReport r = check_primitive(Primitive{}, with_self_intersections());
    EXPECT_EQ(r.vertices, 0u);
    EXPECT_EQ(r.faces, 0u);
    EXPECT_EQ(r.components, 0u);
    EXPECT_FALSE(r.closed);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_EQ(r.diagonal, 0.0);
}

// Points and lines have no faces: vertex-level findings only.
TEST(check_primitive, PointsAndLines) {
    Primitive p = make({0, 0, 0, 1, 0, 0, 1, 0, 0}, {});
    p.mode = furrow::PrimitiveMode::points;
    CheckReport r = check_primitive(p);
    EXPECT_EQ(r.faces, 0u);
    EXPECT_EQ(r.unreferenced_vertices, 0u); // non-indexed points use every vertex
    EXPECT_EQ(r.duplicate_vertices, 1u);
    p.mode = furrow::PrimitiveMode::lines;
    p.indices = {0, 1, 1, 5};
    r = check_primitive(p);
    EXPECT_EQ(r.faces, 0u);
    EXPECT_EQ(r.indices_out_of_range, 1u);
    EXPECT_EQ(r.unreferenced_vertices, 1u);
    EXPECT_FALSE(r.closed);
}

// Garbage in (random indices, some out of range, NaNs, odd polygon sizes) never crashes, and the report
// is the same on every run.
TEST(check_primitive, RandomGarbageDoesNotCrash) {
    std::mt19937 rng(123);
    for (int round = 0; round < 50; ++round) {
        Primitive p;
        const size_t n = rng() % 40;
        for (size_t i = 0; i < 3 * n; ++i) {
            uint32_t k = rng() % 20;
            p.positions.push_back(k == 0 ? nan_f : float(rng() % 4));
        }
        const size_t corners = rng() % 200;
        for (size_t i = 0; i < corners; ++i) p.indices.push_back(uint32_t(rng() % (n + 3)));
        if (round % 2) // polygons of 0..6 corners, the last one possibly running past the indices
            for (size_t sum = 0; sum < corners;) {
                p.face_sizes.push_back(uint32_t(rng() % 7));
                sum += p.face_sizes.back();
            }
        CheckReport a = check_primitive(p, with_self_intersections());
        CheckReport b = check_primitive(p, with_self_intersections());
        EXPECT_EQ(a.components, b.components);
        EXPECT_EQ(a.boundary_loops, b.boundary_loops);
        EXPECT_EQ(a.self_intersections, b.self_intersections);
        EXPECT_LE(a.welded_vertices, a.vertices);
    }
}

// merge_reports sums counts, unites boxes and UV ranges, and is closed only if every part is.
TEST(merge_reports, SumsAndUnites) {
    Primitive a = tetrahedron();
    Primitive b = grid(2, 1);
    for (float& x : b.positions) x += 10.0f;
    b.uv0.assign(2 * b.vertex_count(), 3.0f);
    CheckReport ra = check_primitive(a, with_self_intersections()), rb = check_primitive(b);
    CheckReport t = furrow::merge_reports({ra, rb});
    EXPECT_EQ(t.vertices, ra.vertices + rb.vertices);
    EXPECT_EQ(t.faces, 4u + 4u);
    EXPECT_EQ(t.components, 2u);
    EXPECT_EQ(t.boundary_edges, 6u);
    EXPECT_FALSE(t.closed);
    EXPECT_EQ(t.bbox_min, (std::array<double, 3>{0, 0, 0}));
    EXPECT_EQ(t.bbox_max, (std::array<double, 3>{12, 11, 10}));
    EXPECT_DOUBLE_EQ(t.diagonal, std::sqrt(144.0 + 121.0 + 100.0));
    EXPECT_TRUE(t.has_uv);
    EXPECT_EQ(t.uv_min, (std::array<float, 2>{3, 3}));
    EXPECT_EQ(t.self_intersections, 0); // computed for one part: summed over the computed ones
    EXPECT_EQ(furrow::merge_reports({rb}).self_intersections, -1);
    EXPECT_TRUE(furrow::merge_reports({ra, ra}).closed);
    EXPECT_FALSE(furrow::merge_reports({}).closed);
}

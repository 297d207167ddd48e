// triangulate_polygons: ear clipping in the best-fit plane, no duplicated edges, the fan where it was right.
#include <furrow/mesh.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>

using namespace furrow;

namespace {

struct Polygons {
    std::vector<float> positions;
    std::vector<uint32_t> indices, sizes;
    void face(std::initializer_list<uint32_t> c) {
        indices.insert(indices.end(), c);
        sizes.push_back(uint32_t(c.size()));
    }
    std::vector<uint32_t> triangulate() const {
        std::vector<uint32_t> t;
        size_t n = triangulate_polygons(t, indices.data(), indices.size(), sizes.data(), sizes.size(), positions.data(),
                                        positions.size() / 3);
        EXPECT_EQ(n * 3, t.size());
        return t;
    }
};

// Signed area of a triangle of the z = 0 plane (positive counter-clockwise).
double area_xy(const std::vector<float>& p, uint32_t a, uint32_t b, uint32_t c) {
    return 0.5 * ((p[3 * b] - p[3 * a]) * (p[3 * c + 1] - p[3 * a + 1]) - (p[3 * b + 1] - p[3 * a + 1]) * (p[3 * c] - p[3 * a]));
}

// Faces per undirected edge.
std::map<std::pair<uint32_t, uint32_t>, int> edge_faces(const std::vector<uint32_t>& t) {
    std::map<std::pair<uint32_t, uint32_t>, int> m;
    for (size_t i = 0; i < t.size(); i += 3)
        for (int k = 0; k < 3; ++k) {
            uint32_t a = t[i + size_t(k)], b = t[i + size_t((k + 1) % 3)];
            ++m[{std::min(a, b), std::max(a, b)}];
        }
    return m;
}

} // namespace

// A convex pentagon gives exactly the fan from corner 0, as before.
TEST(triangulate_polygons, ConvexPolygonKeepsTheFan) {
    Polygons g;
    for (int i = 0; i < 5; ++i) g.positions.insert(g.positions.end(), {float(std::cos(i * 1.2566)), float(std::sin(i * 1.2566)), 0});
    g.face({0, 1, 2, 3, 4});
    EXPECT_EQ(g.triangulate(), (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4}));
}

// An L-shaped hexagon whose fan from corner 0 runs outside it: ear clipping keeps every triangle inside
// (all counter-clockwise, areas summing to the polygon's 3).
TEST(triangulate_polygons, NonConvexPolygonIsEarClipped) {
    Polygons g;
    // (0,0) (2,0) (2,1) (1,1) (1,2) (0,2), starting at the reflex corner (1,1) so a fan would fold.
    g.positions = {1, 1, 0, 1, 2, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 2, 1, 0};
    g.face({0, 1, 2, 3, 4, 5});
    auto t = g.triangulate();
    ASSERT_EQ(t.size(), 12u);
    double sum = 0;
    for (size_t i = 0; i < t.size(); i += 3) {
        double a = area_xy(g.positions, t[i], t[i + 1], t[i + 2]);
        EXPECT_GT(a, 0) << "triangle " << i / 3 << " is folded";
        sum += a;
    }
    EXPECT_NEAR(sum, 3.0, 1e-12);
}

// A quad (0 1 2 3) next to a triangle (0 2 4) that already owns the edge 0–2: the fan's diagonal would give
// that edge three faces. The other diagonal is taken, and every edge keeps at most two faces.
TEST(triangulate_polygons, DiagonalNeverDuplicatesAnExistingEdge) {
    Polygons g;
    g.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5f, 0.5f, 1};
    g.face({0, 1, 2, 3});
    g.face({0, 2, 4});
    auto t = g.triangulate();
    for (const auto& [e, n] : edge_faces(t)) EXPECT_LE(n, 2) << e.first << "-" << e.second;
    EXPECT_EQ(std::vector<uint32_t>(t.begin(), t.begin() + 6), (std::vector<uint32_t>{1, 2, 3, 1, 3, 0}));
}

// The same after the table of edges has grown (it is sized for a closed mesh): 1000 disjoint quads first,
// whose edges and diagonals outgrow it, then the quad and the triangle that shares its 0-2 diagonal.
TEST(triangulate_polygons, DiagonalNeverDuplicatesAnExistingEdgeAfterTheTableGrows) {
    Polygons g;
    for (uint32_t q = 0; q < 1000; ++q) {
        const float x = float(2 * q);
        g.positions.insert(g.positions.end(), {x, 5, 0, x + 1, 5, 0, x + 1, 6, 0, x, 6, 0});
        g.face({4 * q, 4 * q + 1, 4 * q + 2, 4 * q + 3});
    }
    const uint32_t o = 4000;
    g.positions.insert(g.positions.end(), {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5f, 0.5f, 1});
    g.face({o, o + 1, o + 2, o + 3});
    g.face({o, o + 2, o + 4});
    auto t = g.triangulate();
    ASSERT_EQ(t.size(), 3u * (2000 + 2 + 1));
    for (const auto& [e, n] : edge_faces(t)) EXPECT_LE(n, 2) << e.first << "-" << e.second;
    EXPECT_EQ(std::vector<uint32_t>(t.begin() + 6000, t.begin() + 6006), (std::vector<uint32_t>{o + 1, o + 2, o + 3, o + 1, o + 3, o}));
}

// The same, with the triangle on split copies of the quad's corners (a UV seam): edges are compared by
// welded position, so the seam does not hide the conflict.
TEST(triangulate_polygons, DuplicateEdgesAreFoundAcrossSplitVertices) {
    Polygons g;
    g.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5f, 0.5f, 1, 0, 0, 0, 1, 1, 0};
    g.face({0, 1, 2, 3});
    g.face({5, 6, 4}); // 5 = copy of 0, 6 = copy of 2
    auto t = g.triangulate();
    EXPECT_EQ(std::vector<uint32_t>(t.begin(), t.begin() + 6), (std::vector<uint32_t>{1, 2, 3, 1, 3, 0}));
}

// A non-planar quad, folded along its 1–3 diagonal and seen from above: the best-fit plane is still the
// xy plane's neighbour, the result has two triangles with the quad's winding (normals up), no corner lost.
TEST(triangulate_polygons, NonPlanarPolygonUsesItsBestFitPlane) {
    Polygons g;
    g.positions = {0, 0, 0.4f, 1, 0, 0, 1, 1, 0.4f, 0, 1, 0};
    g.face({0, 1, 2, 3});
    auto t = g.triangulate();
    ASSERT_EQ(t.size(), 6u);
    for (size_t i = 0; i < 6; i += 3) EXPECT_GT(area_xy(g.positions, t[i], t[i + 1], t[i + 2]), 0);
}

// Every face of a closed quad-and-pentagon-and-hexagon mesh (a prism over a non-convex hexagon, capped) stays
// manifold: each edge exactly two faces after triangulation.
TEST(triangulate_polygons, ClosedPolygonMeshStaysManifold) {
    Polygons g;
    const float ring[6][2] = {{1, 1}, {1, 2}, {0, 2}, {0, 0}, {2, 0}, {2, 1}}; // the L, reflex corner first
    for (float z : {0.0f, 1.0f})
        for (const auto& p : ring) g.positions.insert(g.positions.end(), {p[0], p[1], z});
    g.face({5, 4, 3, 2, 1, 0});     // bottom, facing −z
    g.face({6, 7, 8, 9, 10, 11});   // top
    for (uint32_t i = 0; i < 6; ++i) g.face({i, (i + 1) % 6, 6 + (i + 1) % 6, 6 + i});
    auto t = g.triangulate();
    EXPECT_EQ(t.size(), 3u * (4 + 4 + 12));
    for (const auto& [e, n] : edge_faces(t)) EXPECT_EQ(n, 2) << e.first << "-" << e.second;
}

// Degenerate input is fanned or dropped, never read out of range: faces of 1 and 2 corners, an index out of
// range, a face claiming more corners than exist, a polygon with all corners on one point.
TEST(triangulate_polygons, DegenerateFacesAreSafe) {
    Polygons g;
    g.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    g.face({0});
    g.face({0, 1});
    g.face({0, 1, 7, 3});
    g.face({2, 2, 2, 2});
    auto t = g.triangulate();
    EXPECT_EQ(t.size(), 12u);
    g.sizes.push_back(100); // past the end
    EXPECT_EQ(g.triangulate().size(), 12u);
}

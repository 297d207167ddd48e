#include <furrow/mesh.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

using furrow::boundary_loops;

namespace {

struct Soup {
    std::vector<float> p;
    std::vector<uint32_t> idx;
    size_t vertex_count() const { return p.size() / 3; }
};

// W×H quads in the plane z = 0, each split into two counter-clockwise triangles (normal +z).
Soup grid(int w, int h) {
    Soup s;
    for (int y = 0; y <= h; ++y)
        for (int x = 0; x <= w; ++x) s.p.insert(s.p.end(), {float(x), float(y), 0.0f});
    auto v = [&](int x, int y) { return uint32_t(y * (w + 1) + x); };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            s.idx.insert(s.idx.end(), {v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y), v(x + 1, y + 1), v(x, y + 1)});
    return s;
}

size_t loops_of(const Soup& s, std::vector<std::vector<uint32_t>>& loops, size_t* skipped = nullptr) {
    return boundary_loops(loops, s.p.data(), s.vertex_count(), s.idx.data(), s.idx.size(), skipped);
}

// Rotates a loop so that it starts at its smallest vertex (loops have no canonical start).
std::vector<uint32_t> canonical(std::vector<uint32_t> loop) {
    std::rotate(loop.begin(), std::min_element(loop.begin(), loop.end()), loop.end());
    return loop;
}

} // namespace

// A closed tetrahedron has no boundary.
TEST(boundary_loops, ClosedTetrahedronHasNone) {
    Soup s{{0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}};
    std::vector<std::vector<uint32_t>> loops;
    size_t skipped = 99;
    EXPECT_EQ(loops_of(s, loops, &skipped), 0u);
    EXPECT_TRUE(loops.empty());
    EXPECT_EQ(skipped, 0u);
}

// One triangle: one loop of its three vertices, in the face's own winding.
TEST(boundary_loops, SingleTriangleFollowsFaceWinding) {
    Soup s{{0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 1, 2}};
    std::vector<std::vector<uint32_t>> loops;
    ASSERT_EQ(loops_of(s, loops), 1u);
    EXPECT_EQ(canonical(loops[0]), (std::vector<uint32_t>{0, 1, 2}));
}

// A 3×2 grid has one rim of 2·(3+2) = 10 edges; the loop lists the 10 rim vertices in order.
TEST(boundary_loops, OpenGridHasOneRim) {
    Soup s = grid(3, 2);
    std::vector<std::vector<uint32_t>> loops;
    ASSERT_EQ(loops_of(s, loops), 1u);
    // Counter-clockwise around the rim, as the faces run: along y=0, up x=3, back along y=2, down x=0.
    EXPECT_EQ(canonical(loops[0]), (std::vector<uint32_t>{0, 1, 2, 3, 7, 11, 10, 9, 8, 4}));
}

// Loops are found over welded positions: the same grid with every triangle owning its own three vertices
// (a glTF-style soup) gives the same single rim, reported with the first vertex of each position.
TEST(boundary_loops, WeldsSplitVertices) {
    Soup g = grid(3, 2), s;
    for (uint32_t i : g.idx) {
        s.idx.push_back(uint32_t(s.p.size() / 3));
        s.p.insert(s.p.end(), {g.p[3 * i], g.p[3 * i + 1], g.p[3 * i + 2]});
    }
    std::vector<std::vector<uint32_t>> loops;
    ASSERT_EQ(loops_of(s, loops), 1u);
    EXPECT_EQ(loops[0].size(), 10u);
    for (uint32_t v : loops[0]) // a representative: no earlier vertex has its position
        for (uint32_t w = 0; w < v; ++w)
            EXPECT_FALSE(s.p[3 * w] == s.p[3 * v] && s.p[3 * w + 1] == s.p[3 * v + 1]) << v << " " << w;
}

// A 3×3 grid without its centre quad: an outer rim (12 edges) and a hole (4 edges).
TEST(boundary_loops, GridWithHoleHasTwoLoops) {
    Soup s = grid(3, 3);
    s.idx.erase(s.idx.begin() + 6 * 4, s.idx.begin() + 6 * 5); // quad (1,1)
    std::vector<std::vector<uint32_t>> loops;
    ASSERT_EQ(loops_of(s, loops), 2u);
    std::vector<size_t> sizes = {loops[0].size(), loops[1].size()};
    std::sort(sizes.begin(), sizes.end());
    EXPECT_EQ(sizes, (std::vector<size_t>{4, 12}));
}

// Three triangles on one edge: OpenMesh cannot hold the third, which is skipped and counted; the two
// that remain form one rim of 4 edges.
TEST(boundary_loops, NonManifoldEdgeFaceIsSkipped) {
    Soup s{{0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1}, {0, 1, 2, 1, 0, 3, 0, 1, 4}};
    std::vector<std::vector<uint32_t>> loops;
    size_t skipped = 0;
    ASSERT_EQ(loops_of(s, loops, &skipped), 1u);
    EXPECT_EQ(skipped, 1u);
    EXPECT_EQ(loops[0].size(), 4u);
}

// Faces with an out-of-range index or a repeated (welded) vertex are skipped and counted, never used.
TEST(boundary_loops, BadFacesAreSkipped) {
    Soup s{{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 0, 0}, {0, 1, 2, 0, 1, 77, 0, 1, 3}};
    std::vector<std::vector<uint32_t>> loops;
    size_t skipped = 0;
    ASSERT_EQ(loops_of(s, loops, &skipped), 1u);
    EXPECT_EQ(skipped, 2u);
    EXPECT_EQ(canonical(loops[0]), (std::vector<uint32_t>{0, 1, 2}));
}

// Two triangles touching at one vertex (a bowtie) are valid in a halfedge structure: nothing is skipped.
// OpenMesh links both rims into one figure-of-eight cycle through the shared vertex; it is reported as
// two simple loops, one per triangle.
TEST(boundary_loops, BowtieKeepsTwoRims) {
    Soup s{{0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0}, {0, 1, 2, 0, 3, 4}};
    std::vector<std::vector<uint32_t>> loops;
    size_t skipped = 9;
    ASSERT_EQ(loops_of(s, loops, &skipped), 2u);
    EXPECT_EQ(skipped, 0u);
    std::vector<std::vector<uint32_t>> got = {canonical(loops[0]), canonical(loops[1])};
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, (std::vector<std::vector<uint32_t>>{{0, 1, 2}, {0, 3, 4}}));
}

// Degenerate inputs do not crash: nothing at all, indices without vertices, a trailing partial triangle.
TEST(boundary_loops, EmptyAndMalformedInput) {
    std::vector<std::vector<uint32_t>> loops{{1, 2, 3}};
    size_t skipped = 9;
    EXPECT_EQ(boundary_loops(loops, nullptr, 0, nullptr, 0, &skipped), 0u);
    EXPECT_TRUE(loops.empty());
    EXPECT_EQ(skipped, 0u);
    const uint32_t idx[] = {0, 1, 2, 0};
    EXPECT_EQ(boundary_loops(loops, nullptr, 0, idx, 4, &skipped), 0u);
    EXPECT_EQ(skipped, 1u);
    const float p[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    EXPECT_EQ(boundary_loops(loops, p, 3, idx, 4, &skipped), 1u); // the partial fourth index is ignored
    EXPECT_EQ(skipped, 0u);
}

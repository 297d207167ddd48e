// models/lattice.h: the generated non-manifold lattice of `furrow bench shells --lattice` has the quads, the
// shared vertices and the non-manifold edges it promises, and is the same every time.
#include "../../models/lattice.h"

#include <gtest/gtest.h>

using namespace furrow;

TEST(lattice_model, CountsAndNonManifoldEdges) {
    for (int c : {1, 2, 5}) {
        const Primitive p = models::lattice_primitive(c);
        const size_t n = size_t(c) + 1;
        EXPECT_EQ(p.vertex_count(), n * n * n) << c;
        ASSERT_EQ(p.face_sizes.size(), models::lattice_quad_count(c)) << c;
        EXPECT_EQ(p.face_sizes.size(), 3 * n * size_t(c) * size_t(c)) << c;
        EXPECT_EQ(p.indices.size(), 4 * p.face_sizes.size());
        const CheckReport r = check_primitive(p);
        EXPECT_EQ(r.degenerate_faces, 0u) << c;
        EXPECT_EQ(r.unreferenced_vertices, 0u) << c;
        // A grid edge along one axis at (j, k) of the two other axes has one quad on each side within the
        // block: 4 faces unless it lies on the block's outer edge (both j and k on the boundary: 2 faces).
        // Per axis: c segments at (c + 1)^2 - 4 such positions.
        EXPECT_EQ(r.non_manifold_edges, 3 * size_t(c) * (n * n - 4)) << c;
    }
    EXPECT_EQ(models::lattice_quad_count(25), 48750u);
    EXPECT_TRUE(models::lattice_primitive(0).positions.empty());
}

TEST(lattice_model, Deterministic) {
    const Primitive a = models::lattice_primitive(4), b = models::lattice_primitive(4);
    EXPECT_EQ(a.positions, b.positions);
    EXPECT_EQ(a.indices, b.indices);
}

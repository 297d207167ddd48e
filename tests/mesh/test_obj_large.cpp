// A generated ~100 MB OBJ (models/obj_grid.h, the grid `furrow bench io` times) loads exactly: counts,
// corners and a few positions and texture coordinates against the values the generator wrote. Correctness
// only, never time. Suite *_large: label `large`.
#include "../../models/obj_grid.h"
#include "test_support.h"

#include <filesystem>

using namespace furrow;
using namespace furrow::test;

TEST(obj_load_large, HundredMegabyteGridLoadsExactly) {
    const auto dir = temp_dir();
    const int n = models::obj_grid_side_for_bytes(100e6);
    const auto file = dir / "grid.obj";
    ASSERT_TRUE(models::write_obj_grid(file.string(), n));
    ASSERT_GE(std::filesystem::file_size(file), 95'000'000u);
    Scene s;
    Status st = load_scene(s, file.string());
    ASSERT_TRUE(st.ok()) << st.message;
    std::filesystem::remove(file);
    ASSERT_EQ(s.meshes.size(), 1u);
    const Primitive& p = s.meshes[0].primitives.at(0);
    // One texcoord per vertex: no seam splits a vertex. (With corner uvs the vertices are numbered in the order
    // the faces first use them, so they are found through the faces here.)
    ASSERT_EQ(p.vertex_count(), size_t(n) * size_t(n));
    ASSERT_EQ(p.triangle_count(), 2 * size_t(n - 1) * size_t(n - 1));
    EXPECT_TRUE(p.face_sizes.empty());
    EXPECT_EQ(s.nodes[0].translation, (std::array<double, 3>{0, 0, 0})); // near the origin: not recentred
    // Cell (i, j) is triangles (a, b, d) and (a, d, c): a = vertex (i, j), b = (i+1, j), c = (i, j+1), d = (i+1, j+1).
    for (const auto& [i, j] : {std::pair{0, 0}, {n - 2, 0}, {0, n - 2}, {n - 2, n - 2}, {n / 2, n / 3}, {17, 401}}) {
        const size_t cell = size_t(j) * size_t(n - 1) + size_t(i);
        const std::pair<int, int> corners[6] = {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j}, {i + 1, j + 1}, {i, j + 1}};
        for (size_t c = 0; c < 6; ++c) {
            const size_t v = p.indices.at(cell * 6 + c);
            const auto want = models::obj_grid_position(corners[c].first, corners[c].second);
            const auto uv = models::obj_grid_uv(corners[c].first, corners[c].second);
            for (size_t k = 0; k < 3; ++k) EXPECT_EQ(p.positions[v * 3 + k], float(want[k])) << i << "," << j << " corner " << c;
            EXPECT_EQ(p.uv0[v * 2], float(uv[0]));
            EXPECT_EQ(p.uv0[v * 2 + 1], float(1 - uv[1])); // glTF v runs down
            EXPECT_EQ(p.normals[v * 3 + 2], 1.0f);
        }
    }
}

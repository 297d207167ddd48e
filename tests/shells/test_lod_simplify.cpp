// LOD levels on a simplified base (FurOptions::lod_simplify_error, shells/src/simplify_lod.cpp): far levels
// have fewer base triangles, every level's file is valid glTF, the simplified surface stays within the
// documented error of the original, and the bytes do not depend on the thread count.
#include "shells_internal.h"
#include "test_support.h"

#include <furrow/shapes.h>
#include <furrow/shells.h>
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace furrow {
namespace {

namespace fs = std::filesystem;

Scene creature() {
    Scene s;
    Status st = load_scene(s, (test::models_dir() / "creature.glb").string());
    EXPECT_TRUE(st.ok()) << st.message;
    return s;
}

FurOptions lod_fur(double error) {
    FurOptions o;
    o.shells.layers = 32;
    o.shells.length = 0.04;
    o.shells.lod_levels = 3;
    o.lod_simplify_error = error;
    return o;
}

// The first triangle primitive of the scene's first mesh: the creature's skin.
const Primitive& skin(const Scene& s) { return s.meshes[0].primitives[0]; }

TEST(lod_simplify, FarLevelsHaveFewerBaseTrianglesAndValidFiles) {
    Scene s = creature();
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, lod_fur(0.01), &r).ok());
    ASSERT_EQ(r.lod_base_triangles.size(), 3u);
    ASSERT_EQ(r.lod_simplify_error.size(), 3u);
    EXPECT_EQ(r.lod_base_triangles[0], r.base_triangles);
    EXPECT_LT(r.lod_base_triangles[1], r.lod_base_triangles[0]);
    EXPECT_LT(r.lod_base_triangles[2], r.lod_base_triangles[1]);
    EXPECT_EQ(r.lod_simplify_error[0], 0.0);
    EXPECT_LE(r.lod_simplify_error[1], 0.01);
    EXPECT_LE(r.lod_simplify_error[2], 0.02);
    std::printf("creature, 32 shells, 3 levels: base triangles %zu / %zu / %zu, meshopt error %.4f / %.4f\n", r.lod_base_triangles[0],
                r.lod_base_triangles[1], r.lod_base_triangles[2], r.lod_simplify_error[1], r.lod_simplify_error[2]);
    // The shells of level k in the file have that level's triangle count (viewer layout: one primitive per shell).
    ASSERT_EQ(r.lod_nodes.size(), 2u);
    for (size_t k = 1; k < 3; ++k) {
        const Mesh& m = s.meshes[size_t(s.nodes[size_t(r.lod_nodes[k - 1])].mesh)];
        const Primitive& last_shell = m.primitives.back();
        EXPECT_EQ(last_shell.indices.size() / 3, r.lod_base_triangles[k]) << "level " << k;
    }
    // Every level's file: level 0 is the default scene; each far level as the scene's only root.
    for (int k = 0; k < 3; ++k) {
        Scene one = s;
        if (k > 0) one.roots = {r.lod_nodes[size_t(k - 1)]};
        fs::path f = test::temp_dir() / ("creature_lod" + std::to_string(k) + ".glb");
        Status st = save_scene(one, f.string());
        ASSERT_TRUE(st.ok()) << st.message;
        EXPECT_VALID_GLTF(f);
    }
}

TEST(lod_simplify, OffByDefaultEveryLevelOnTheFullBase) {
    Scene s = creature();
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, lod_fur(0.0), &r).ok());
    ASSERT_EQ(r.lod_base_triangles.size(), 3u);
    for (size_t k = 0; k < 3; ++k) {
        EXPECT_EQ(r.lod_base_triangles[k], r.base_triangles);
        EXPECT_EQ(r.lod_simplify_error[k], 0.0);
    }
}

// Both ways between the simplified and the original surface (sampled), measured with CGAL (distances_to_mesh): every
// vertex of the original skin against the simplified triangles, and points on the simplified triangles
// (edge midpoints and centroids) against the original. The simplified corners are original vertices,
// so the second direction measures the faces spanning removed detail.
TEST(lod_simplify, SimplifiedBaseStaysWithinTheDocumentedError) {
    Scene s = creature();
    const Primitive& p = skin(s);
    const std::vector<uint32_t>& tris = p.indices;
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (size_t v = 0; v < p.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p.positions[3 * v + a]), hi[a] = std::max(hi[a], p.positions[3 * v + a]);
    const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}); // meshopt_simplifyScale
    for (int k = 1; k <= 2; ++k) {
        const double bound = 0.01 * std::ldexp(1.0, k - 1);
        const shells_detail::SimplifiedBase sb = shells_detail::simplify_base(p, tris, k, 0.01);
        ASSERT_LT(sb.tris.size(), tris.size());
        EXPECT_LE(sb.relative_error, bound);
        EXPECT_NEAR(sb.absolute_error, sb.relative_error * extent, 1e-6 * extent);
        std::vector<double> d(p.vertex_count());
        distances_to_mesh(d.data(), p.positions.data(), p.vertex_count(), p.positions.data(), p.vertex_count(), sb.tris.data(), sb.tris.size());
        const double to_simplified = *std::max_element(d.begin(), d.end());
        std::vector<float> pts; // per simplified face: its centroid and edge midpoints
        for (size_t f = 0; f + 3 <= sb.tris.size(); f += 3) {
            const float* c[3] = {&p.positions[3 * size_t(sb.tris[f])], &p.positions[3 * size_t(sb.tris[f + 1])], &p.positions[3 * size_t(sb.tris[f + 2])]};
            for (int a = 0; a < 3; ++a) pts.push_back((c[0][a] + c[1][a] + c[2][a]) / 3.0f);
            for (int e = 0; e < 3; ++e)
                for (int a = 0; a < 3; ++a) pts.push_back(0.5f * (c[e][a] + c[(e + 1) % 3][a]));
        }
        std::vector<double> d2(pts.size() / 3);
        distances_to_mesh(d2.data(), pts.data(), d2.size(), p.positions.data(), p.vertex_count(), tris.data(), tris.size());
        const double to_original = *std::max_element(d2.begin(), d2.end());
        std::printf("level %d: %zu -> %zu triangles, meshopt error %.4f (bound %.2f) of extent %.4f; sampled distance: original vertices to "
                    "simplified %.5f (%.4f of extent), simplified faces to original %.5f (%.4f of extent)\n",
                    k, tris.size() / 3, sb.tris.size() / 3, sb.relative_error, bound, extent, to_simplified, to_simplified / extent,
                    to_original, to_original / extent);
        EXPECT_LE(to_simplified, bound * extent) << "level " << k;
        EXPECT_LE(to_original, bound * extent) << "level " << k;
    }
}

TEST(lod_simplify, IdenticalBytesForAnyThreadCount) {
    auto run = [](int threads) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
        Scene s = creature();
        FurOptions o = lod_fur(0.01);
        o.shells.layers = 8;
        o.fins = true;
        EXPECT_TRUE(add_fur_shells(s, o).ok());
        std::string name = std::to_string(threads); // (not "t" + to_string: GCC 12's -Wrestrict false positive)
        name += ".glb";
        fs::path f = test::temp_dir() / name;
        EXPECT_TRUE(save_scene(s, f.string()).ok());
        return test::read_bytes(f);
    };
    EXPECT_EQ(run(1), run(2));
}

TEST(lod_simplify, ErrorOutOfRangeIsRejected) {
    Scene s = creature();
    for (double bad : {-0.01, 1.5, double(NAN)}) {
        Status st = add_fur_shells(s, lod_fur(bad));
        EXPECT_EQ(st.code, StatusCode::invalid_argument) << bad;
    }
}

} // namespace
} // namespace furrow

// The tessellation's vertices equal, bit for bit, OpenSubdiv's own Bfr evaluation of surfaces built afresh per
// face by an uncached factory (the oracle: Tessellator prepares each face's patch points once per evaluation
// and shares factories, and must not change a bit by it); and the generated 32k-quad benchmark mesh
// (models/obj_quad_sphere.h) is the closed quad mesh it says it is. (Keeping every face's surface and patch
// points across tessellations was tried: 4 KB per face, 70 MB on the 16k-triangle creature, for 1-2 % of the
// time; `furrow bench memory` ruled it out.) The normals: at a point shared by several faces where the surface
// is smooth, the output normal is the one face's that evaluates the point (the others skip the evaluation);
// it must be, within 1e-6 rad, the average of every face's own normal there, as before that sharing.
#include "bfr_oracle.h"
#include "tess_test_util.h"

#include <furrow/shapes.h>

#include <tbb/global_control.h>

#include "obj_quad_sphere.h"


#include <cmath>
#include <cstdio>
#include <map>
#include <filesystem>

namespace furrow {
namespace {

Primitive load_quad_sphere(int n) {
    const auto path = std::filesystem::temp_directory_path() / ("furrow_test_quad_sphere_" + std::to_string(n) + ".obj");
    EXPECT_TRUE(models::write_obj_quad_sphere(path.string(), n));
    Scene s;
    const Status st = load_scene(s, path.string());
    std::filesystem::remove(path);
    EXPECT_TRUE(st.ok()) << st.message;
    if (!st.ok() || s.meshes.empty() || s.meshes[0].primitives.empty()) return {};
    return s.meshes[0].primitives[0];
}

TEST(tessellate_bfr_oracle, QuadSphereIsAClosedQuadMesh) {
    const int n = 5;
    const Primitive p = load_quad_sphere(n);
    ASSERT_EQ(p.face_sizes.size(), size_t(6 * n * n));
    for (uint32_t s : p.face_sizes) ASSERT_EQ(s, 4u);
    EXPECT_EQ(p.vertex_count(), size_t(6 * n * n + 2)); // Euler: V - E + F = 2 with E = 2F
    std::map<std::pair<uint32_t, uint32_t>, int> directed;
    std::vector<int> valence(p.vertex_count(), 0);
    for (size_t f = 0; f < p.face_sizes.size(); ++f)
        for (int k = 0; k < 4; ++k) {
            const uint32_t a = p.indices[f * 4 + size_t(k)], b = p.indices[f * 4 + size_t((k + 1) % 4)];
            ++directed[{a, b}];
            ++valence[a];
        }
    for (const auto& [e, count] : directed) {
        EXPECT_EQ(count, 1) << "edge used twice in one direction";
        EXPECT_EQ(directed.count({e.second, e.first}), 1u) << "boundary edge";
    }
    int extraordinary = 0;
    for (int v : valence) extraordinary += v != 4;
    EXPECT_EQ(extraordinary, 8); // the cube's corners, valence 3
}

TEST(tessellate_bfr_oracle, VerticesEqualFreshBfrSurfacesBitForBitCatmark) {
    test::expect_fresh_surfaces_agree(load_quad_sphere(6), SubdivisionScheme::catmark, 5);
}

TEST(tessellate_bfr_oracle, VerticesEqualFreshBfrSurfacesBitForBitLoop) {
    test::expect_fresh_surfaces_agree(shapes::icosphere(1.0f, 2), SubdivisionScheme::loop, 4);
}

TEST(tessellate_bfr_oracle, SharedNormalsAreTheFacesAverageCatmarkQuads) {
    // The cube sphere has valence-3 (extraordinary) vertices, where Bfr's patches are approximations.
    const double worst = test::expect_normals_average_faces(load_quad_sphere(6), SubdivisionScheme::catmark, 5);
    std::printf("quad sphere, rate 5: largest angle %.3g rad\n", worst);
}

TEST(tessellate_bfr_oracle, SharedNormalsAreTheFacesAverageCatmarkTrianglesWithSeams) {
    // Triangles (irregular in Catmark: every face keeps its own normal, averaged), valence-24 poles, UV seams.
    const double worst = test::expect_normals_average_faces(shapes::uv_sphere(1, 24, 12), SubdivisionScheme::catmark, 4);
    std::printf("uv sphere, rate 4: largest angle %.3g rad\n", worst);
}

TEST(tessellate_bfr_oracle, SharedNormalsAreTheFacesAverageOpenGrid) {
    // Boundary points: sectors that end at the boundary, corners of one face; the grid is bent (not flat).
    Primitive p = shapes::quad_grid(2, 1, 7, 4);
    for (size_t v = 0; v < p.vertex_count(); ++v)
        p.positions[v * 3 + 1] = 0.2f * std::sin(3.0f * p.positions[v * 3]) * std::cos(2.0f * p.positions[v * 3 + 2]);
    const double worst = test::expect_normals_average_faces(p, SubdivisionScheme::catmark, 3);
    std::printf("open grid, rate 3: largest angle %.3g rad\n", worst);
}

TEST(tessellate_bfr_oracle, SharedNormalsAreTheFacesAverageLoop) {
    const double worst = test::expect_normals_average_faces(shapes::icosphere(1.0f, 2), SubdivisionScheme::loop, 4);
    std::printf("icosphere (loop), rate 4: largest angle %.3g rad\n", worst);
}

// Shared normals (regular patches: the cube sphere) give the same bytes for 1 and 2 threads.
TEST(tessellate_bfr_oracle, SharedNormalsSameBytesForAnyThreadCount) {
    const Primitive p = load_quad_sphere(12);
    TessellateOptions o;
    o.rates.uniform = 4;
    o.rates.max_rate = 4;
    TessellateOutput a, b;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        a = test::run_tessellate(p, o);
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        b = test::run_tessellate(p, o);
    }
    ASSERT_EQ(a.stats.triangles, size_t(6 * 12 * 12 * 4 * 4 * 2));
    EXPECT_EQ(a.positions, b.positions);
    EXPECT_EQ(a.normals, b.normals);
    EXPECT_EQ(a.indices, b.indices);
}

} // namespace
} // namespace furrow

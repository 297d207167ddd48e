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
#include <cstring>
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

// The cube sphere with one side of the cube left out: regular interior faces (evaluated from basis weights
// cached per rate, evaluate_tessellation.cpp), faces along the open boundary (regular patches with a boundary
// mask: Bfr), and faces at the valence-3 corners (irregular: Bfr), in one mesh.
Primitive open_quad_sphere(int n) {
    const Primitive closed = load_quad_sphere(n);
    Primitive p;
    std::vector<uint32_t> remap(closed.vertex_count(), ~0u);
    for (size_t f = size_t(n) * size_t(n); f < closed.face_sizes.size(); ++f) {
        p.face_sizes.push_back(4);
        for (int k = 0; k < 4; ++k) {
            const uint32_t v = closed.indices[f * 4 + size_t(k)];
            if (remap[v] == ~0u) {
                remap[v] = uint32_t(p.positions.size() / 3);
                p.positions.insert(p.positions.end(), &closed.positions[v * 3], &closed.positions[v * 3 + 3]);
            }
            p.indices.push_back(remap[v]);
        }
    }
    return p;
}

// The fast path for regular interior faces against plain Bfr (Surface::Evaluate on fresh surfaces): every
// position bit for bit, and at every interior point of a face (a normal no other face shares or averages)
// the normal bit for bit too, normalise(Du x Dv) as evaluate_tessellation computes it; so wrong P, Du or Dv
// weights, a boundary face taken for an interior one, or a sum in another order all fail. Rates 3, 4 and 8
// (different caches); at rate 8 also with 2 threads, which must give the same bytes.
TEST(tessellate_bfr_oracle, RegularFastPathEqualsBfrBitForBit) {
    const Primitive p = open_quad_sphere(6);
    ASSERT_EQ(p.face_sizes.size(), size_t(5 * 36));
    for (int rate : {3, 4, 8}) {
        SCOPED_TRACE("rate " + std::to_string(rate));
        test::expect_fresh_surfaces_agree(p, SubdivisionScheme::catmark, rate);
        Tessellator t;
        SurfaceOptions so;
        ASSERT_TRUE(t.prepare(test::input_of(p), so).ok());
        RateOptions r;
        r.uniform = rate;
        r.max_rate = rate;
        TessellateOutput out;
        ASSERT_TRUE(t.tessellate(out, r, true).ok());
        test::FreshSurfaces fresh(p, SubdivisionScheme::catmark, so);
        ASSERT_TRUE(fresh.factory);
        size_t interior = 0, mismatched = 0;
        for (size_t tri = 0; tri < out.triangle_patches.size(); ++tri)
            for (int k = 0; k < 3; ++k) {
                const float* uv = &out.triangle_coords[tri * 6 + size_t(k) * 2];
                if (!(uv[0] > 0.0f && uv[0] < 1.0f && uv[1] > 0.0f && uv[1] < 1.0f)) continue;
                float P[3], Du[3], Dv[3];
                ASSERT_TRUE(fresh.evaluate(int(out.triangle_patches[tri]), uv, P, Du, Dv));
                float n[3] = {Du[1] * Dv[2] - Du[2] * Dv[1], Du[2] * Dv[0] - Du[0] * Dv[2], Du[0] * Dv[1] - Du[1] * Dv[0]};
                const double l = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
                for (float& x : n) x = float(x / l);
                const uint32_t v = out.indices[tri * 3 + size_t(k)];
                ++interior;
                mismatched += std::memcmp(P, &out.positions[size_t(v) * 3], sizeof P) != 0 ||
                              std::memcmp(n, &out.normals[size_t(v) * 3], sizeof n) != 0;
            }
        EXPECT_GT(interior, 0u);
        EXPECT_EQ(mismatched, 0u) << "of " << interior << " interior triangle corners";
        if (rate == 8) {
            TessellateOutput two;
            {
                tbb::global_control g(tbb::global_control::max_allowed_parallelism, 2);
                ASSERT_TRUE(t.tessellate(two, r, true).ok());
            }
            EXPECT_EQ(out.positions, two.positions);
            EXPECT_EQ(out.normals, two.normals);
            EXPECT_EQ(out.indices, two.indices);
        }
    }
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

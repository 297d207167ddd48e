// The tessellation's vertices equal, bit for bit, OpenSubdiv's own Bfr evaluation of surfaces built afresh per
// face by an uncached factory (the oracle: Tessellator prepares each face's patch points once per evaluation
// and shares factories, and must not change a bit by it); and the generated 32k-quad benchmark mesh
// (models/obj_quad_sphere.h) is the closed quad mesh it says it is. (Keeping every face's surface and patch
// points across tessellations was tried: 4 KB per face, 70 MB on the 16k-triangle creature, for 1-2 % of the
// time; `furrow bench memory` ruled it out.)
#include "tess_test_util.h"

#include <furrow/shapes.h>

#include "obj_quad_sphere.h"

#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <memory>

namespace furrow {
namespace {

namespace osd = OpenSubdiv;

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

// Every output vertex equals, bit for bit, one fresh evaluation (uncached factory, InitVertexSurface and
// PreparePatchPoints for that face alone) at the (face, u, v) of a triangle corner that uses it: the owner's.
void expect_fresh_surfaces_agree(const Primitive& p, SubdivisionScheme scheme, int rate) {
    Tessellator t;
    SurfaceOptions so;
    so.scheme = scheme;
    ASSERT_TRUE(t.prepare(test::input_of(p), so).ok());
    RateOptions r;
    r.uniform = rate;
    r.max_rate = rate;
    TessellateOutput out, again;
    ASSERT_TRUE(t.tessellate(out, r, true).ok());
    ASSERT_TRUE(t.tessellate(again, r, true).ok()); // the cached surfaces are reused: the same bytes
    ASSERT_EQ(out.positions, again.positions);
    ASSERT_EQ(out.normals, again.normals);
    ASSERT_EQ(out.indices, again.indices);

    std::vector<int> sizes;
    std::vector<int> corners(p.indices.begin(), p.indices.end());
    for (size_t f = 0; f < p.face_count(); ++f) sizes.push_back(p.face_sizes.empty() ? 3 : int(p.face_sizes[f]));
    osd::Far::TopologyDescriptor desc;
    desc.numVertices = int(p.vertex_count());
    desc.numFaces = int(sizes.size());
    desc.numVertsPerFace = sizes.data();
    desc.vertIndicesPerFace = corners.data();
    osd::Sdc::Options sdc;
    sdc.SetVtxBoundaryInterpolation(osd::Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
    const auto type = scheme == SubdivisionScheme::loop ? osd::Sdc::SCHEME_LOOP : osd::Sdc::SCHEME_CATMARK;
    using Factory = osd::Far::TopologyRefinerFactory<osd::Far::TopologyDescriptor>;
    std::unique_ptr<osd::Far::TopologyRefiner> refiner(Factory::Create(desc, Factory::Options(type, sdc)));
    ASSERT_TRUE(refiner);
    osd::Bfr::RefinerSurfaceFactory<>::Options fo;
    fo.SetApproxLevelSmooth(so.accuracy);
    fo.SetApproxLevelSharp(std::max(6, so.accuracy));
    fo.EnableCaching(false);
    osd::Bfr::RefinerSurfaceFactory<> factory(*refiner, fo);

    std::vector<uint8_t> matched(out.positions.size() / 3, 0);
    std::vector<float> patch;
    osd::Bfr::Surface<float> surface;
    int current = -1;
    for (size_t tri = 0; tri < out.triangle_patches.size(); ++tri) {
        const int f = int(out.triangle_patches[tri]);
        if (f != current) {
            ASSERT_TRUE(factory.InitVertexSurface(f, &surface));
            patch.resize(size_t(surface.GetNumPatchPoints()) * 3);
            surface.PreparePatchPoints(p.positions.data(), 3, patch.data(), 3);
            current = f;
        }
        for (int k = 0; k < 3; ++k) {
            const float* uv = &out.triangle_coords[tri * 6 + size_t(k) * 2];
            float P[3];
            surface.Evaluate(uv, patch.data(), 3, P);
            const uint32_t v = out.indices[tri * 3 + size_t(k)];
            if (std::memcmp(P, &out.positions[size_t(v) * 3], sizeof P) == 0) matched[v] = 1;
        }
    }
    size_t unmatched = 0;
    for (uint8_t m : matched) unmatched += m == 0;
    EXPECT_EQ(unmatched, 0u) << "of " << matched.size() << " vertices";
}

TEST(tessellate_bfr_oracle, VerticesEqualFreshBfrSurfacesBitForBitCatmark) {
    expect_fresh_surfaces_agree(load_quad_sphere(6), SubdivisionScheme::catmark, 5);
}

TEST(tessellate_bfr_oracle, VerticesEqualFreshBfrSurfacesBitForBitLoop) {
    expect_fresh_surfaces_agree(shapes::icosphere(1.0f, 2), SubdivisionScheme::loop, 4);
}

} // namespace
} // namespace furrow

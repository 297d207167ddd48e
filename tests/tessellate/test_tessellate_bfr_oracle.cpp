// The tessellation's vertices equal, bit for bit, OpenSubdiv's own Bfr evaluation of surfaces built afresh per
// face by an uncached factory (the oracle: Tessellator prepares each face's patch points once per evaluation
// and shares factories, and must not change a bit by it); and the generated 32k-quad benchmark mesh
// (models/obj_quad_sphere.h) is the closed quad mesh it says it is. (Keeping every face's surface and patch
// points across tessellations was tried: 4 KB per face, 70 MB on the 16k-triangle creature, for 1-2 % of the
// time; `furrow bench memory` ruled it out.) The normals: at a point shared by several faces where the surface
// is smooth, the output normal is the one face's that evaluates the point (the others skip the evaluation);
// it must be, within 1e-6 rad, the average of every face's own normal there, as before that sharing.
#include "tess_test_util.h"

#include <furrow/shapes.h>

#include "obj_quad_sphere.h"

#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <set>

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

// OpenSubdiv's own Bfr surfaces of a mesh, built afresh per face by an uncached factory over the mesh's
// positions welded by value (the tessellator's refiner sees welded positions too: UV seams are no boundary).
struct FreshSurfaces {
    std::vector<float> positions; // welded
    std::unique_ptr<osd::Far::TopologyRefiner> refiner;
    std::unique_ptr<osd::Bfr::RefinerSurfaceFactory<>> factory;
    osd::Bfr::Surface<float> surface;
    std::vector<float> patch;
    int current = -1;

    FreshSurfaces(const Primitive& p, SubdivisionScheme scheme, const SurfaceOptions& so) {
        std::map<std::array<float, 3>, int> welded;
        std::vector<int> sizes, corners;
        for (uint32_t v : p.indices) {
            const std::array<float, 3> key{p.positions[v * 3], p.positions[v * 3 + 1], p.positions[v * 3 + 2]};
            auto [it, added] = welded.emplace(key, int(welded.size()));
            if (added) positions.insert(positions.end(), key.begin(), key.end());
            corners.push_back(it->second);
        }
        for (size_t f = 0; f < p.face_count(); ++f) sizes.push_back(p.face_sizes.empty() ? 3 : int(p.face_sizes[f]));
        osd::Far::TopologyDescriptor desc;
        desc.numVertices = int(welded.size());
        desc.numFaces = int(sizes.size());
        desc.numVertsPerFace = sizes.data();
        desc.vertIndicesPerFace = corners.data();
        osd::Sdc::Options sdc;
        sdc.SetVtxBoundaryInterpolation(osd::Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
        const auto type = scheme == SubdivisionScheme::loop ? osd::Sdc::SCHEME_LOOP : osd::Sdc::SCHEME_CATMARK;
        using Factory = osd::Far::TopologyRefinerFactory<osd::Far::TopologyDescriptor>;
        refiner.reset(Factory::Create(desc, Factory::Options(type, sdc)));
        if (!refiner) return;
        osd::Bfr::RefinerSurfaceFactory<>::Options fo;
        fo.SetApproxLevelSmooth(so.accuracy);
        fo.SetApproxLevelSharp(std::max(6, so.accuracy));
        fo.EnableCaching(false);
        factory = std::make_unique<osd::Bfr::RefinerSurfaceFactory<>>(*refiner, fo);
    }
    // Position and derivatives of face f at uv; false if the face has no surface.
    bool evaluate(int f, const float* uv, float* P, float* Du = nullptr, float* Dv = nullptr) {
        if (f != current) {
            if (!factory->InitVertexSurface(f, &surface)) return false;
            patch.resize(size_t(surface.GetNumPatchPoints()) * 3);
            surface.PreparePatchPoints(positions.data(), 3, patch.data(), 3);
            current = f;
        }
        if (Du)
            surface.Evaluate(uv, patch.data(), 3, P, Du, Dv);
        else
            surface.Evaluate(uv, patch.data(), 3, P);
        return true;
    }
};

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

    FreshSurfaces fresh(p, scheme, so);
    ASSERT_TRUE(fresh.factory);
    std::vector<uint8_t> matched(out.positions.size() / 3, 0);
    for (size_t tri = 0; tri < out.triangle_patches.size(); ++tri) {
        const int f = int(out.triangle_patches[tri]);
        for (int k = 0; k < 3; ++k) {
            float P[3];
            ASSERT_TRUE(fresh.evaluate(f, &out.triangle_coords[tri * 6 + size_t(k) * 2], P));
            const uint32_t v = out.indices[tri * 3 + size_t(k)];
            if (std::memcmp(P, &out.positions[size_t(v) * 3], sizeof P) == 0) matched[v] = 1;
        }
    }
    size_t unmatched = 0;
    for (uint8_t m : matched) unmatched += m == 0;
    EXPECT_EQ(unmatched, 0u) << "of " << matched.size() << " vertices";
}

// Every output normal is, within 1e-6 rad, the average of the unit normals (Du x Dv, fresh surfaces) of all
// the faces at its position: for a mesh without creases, every face around a point is in its one normal
// sector, so this is the per-face average the output had before shared points were evaluated once.
// Returns the largest angle, for the message.
double expect_normals_average_faces(const Primitive& p, SubdivisionScheme scheme, int rate) {
    Tessellator t;
    SurfaceOptions so;
    so.scheme = scheme;
    EXPECT_TRUE(t.prepare(test::input_of(p), so).ok());
    EXPECT_EQ(t.topology().linear_faces, 0u);
    RateOptions r;
    r.uniform = rate;
    r.max_rate = rate;
    TessellateOutput out;
    EXPECT_TRUE(t.tessellate(out, r, true).ok());
    FreshSurfaces fresh(p, scheme, so);
    EXPECT_TRUE(fresh.factory);
    if (!fresh.factory) return 0;

    // Per position: each face's unit normal there, summed once per face.
    struct Sum {
        std::array<double, 3> n{0, 0, 0};
        std::set<uint32_t> faces;
    };
    std::map<std::array<float, 3>, Sum> at;
    size_t without_tangent_plane = 0;
    for (size_t tri = 0; tri < out.triangle_patches.size(); ++tri) {
        const uint32_t f = out.triangle_patches[tri];
        for (int k = 0; k < 3; ++k) {
            const float* P = &out.positions[size_t(out.indices[tri * 3 + size_t(k)]) * 3];
            Sum& s = at[{P[0], P[1], P[2]}];
            if (!s.faces.insert(f).second) continue;
            float Q[3], Du[3], Dv[3];
            EXPECT_TRUE(fresh.evaluate(int(f), &out.triangle_coords[tri * 6 + size_t(k) * 2], Q, Du, Dv));
            const std::array<double, 3> n{double(Du[1]) * Dv[2] - double(Du[2]) * Dv[1],
                                          double(Du[2]) * Dv[0] - double(Du[0]) * Dv[2],
                                          double(Du[0]) * Dv[1] - double(Du[1]) * Dv[0]};
            const double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (!(l > 0)) {
                ++without_tangent_plane;
                continue;
            }
            for (int i = 0; i < 3; ++i) s.n[size_t(i)] += n[size_t(i)] / l;
        }
    }
    EXPECT_EQ(without_tangent_plane, 0u);
    double worst = 0;
    size_t shared = 0;
    for (size_t v = 0; v < out.positions.size() / 3; ++v) {
        const float* P = &out.positions[v * 3];
        const Sum& s = at[{P[0], P[1], P[2]}];
        shared += s.faces.size() > 1;
        const float* N = &out.normals[v * 3];
        const std::array<double, 3> c{s.n[1] * N[2] - s.n[2] * N[1], s.n[2] * N[0] - s.n[0] * N[2], s.n[0] * N[1] - s.n[1] * N[0]};
        const double angle = std::atan2(std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]),
                                        s.n[0] * N[0] + s.n[1] * N[1] + s.n[2] * N[2]);
        worst = std::max(worst, angle);
    }
    EXPECT_GT(shared, 0u);
    EXPECT_LE(worst, 1e-6) << "largest angle between an output normal and its faces' average";
    return worst;
}

TEST(tessellate_bfr_oracle, VerticesEqualFreshBfrSurfacesBitForBitCatmark) {
    expect_fresh_surfaces_agree(load_quad_sphere(6), SubdivisionScheme::catmark, 5);
}

TEST(tessellate_bfr_oracle, VerticesEqualFreshBfrSurfacesBitForBitLoop) {
    expect_fresh_surfaces_agree(shapes::icosphere(1.0f, 2), SubdivisionScheme::loop, 4);
}

TEST(tessellate_bfr_oracle, SharedNormalsAreTheFacesAverageCatmarkQuads) {
    // The cube sphere has valence-3 (extraordinary) vertices, where Bfr's patches are approximations.
    const double worst = expect_normals_average_faces(load_quad_sphere(6), SubdivisionScheme::catmark, 5);
    std::printf("quad sphere, rate 5: largest angle %.3g rad\n", worst);
}

TEST(tessellate_bfr_oracle, SharedNormalsAreTheFacesAverageCatmarkTrianglesWithSeams) {
    // Triangles (irregular in Catmark: every face keeps its own normal, averaged), valence-24 poles, UV seams.
    const double worst = expect_normals_average_faces(shapes::uv_sphere(1, 24, 12), SubdivisionScheme::catmark, 4);
    std::printf("uv sphere, rate 4: largest angle %.3g rad\n", worst);
}

TEST(tessellate_bfr_oracle, SharedNormalsAreTheFacesAverageOpenGrid) {
    // Boundary points: sectors that end at the boundary, corners of one face; the grid is bent (not flat).
    Primitive p = shapes::quad_grid(2, 1, 7, 4);
    for (size_t v = 0; v < p.vertex_count(); ++v)
        p.positions[v * 3 + 1] = 0.2f * std::sin(3.0f * p.positions[v * 3]) * std::cos(2.0f * p.positions[v * 3 + 2]);
    const double worst = expect_normals_average_faces(p, SubdivisionScheme::catmark, 3);
    std::printf("open grid, rate 3: largest angle %.3g rad\n", worst);
}

TEST(tessellate_bfr_oracle, SharedNormalsAreTheFacesAverageLoop) {
    const double worst = expect_normals_average_faces(shapes::icosphere(1.0f, 2), SubdivisionScheme::loop, 4);
    std::printf("icosphere (loop), rate 4: largest angle %.3g rad\n", worst);
}

} // namespace
} // namespace furrow

// The Bfr oracle of the tessellate tests: OpenSubdiv's own Bfr surfaces of a mesh, built afresh per face by an
// uncached factory, evaluated at the (face, u, v) the tessellation reports for each triangle corner. Positions
// must match bit for bit (the owner of a shared point evaluates it the same way); normals must be, within
// 1e-6 rad, the average of every face's own normal at the point (one face evaluates a shared normal where the
// surface is smooth across the point; before that, every face did and they were averaged).
#pragma once

#include "tess_test_util.h"

#include <furrow/tessellate.h>

#include <gtest/gtest.h>
#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <set>
#include <vector>

namespace furrow::test {

namespace osd = OpenSubdiv;

// OpenSubdiv's own Bfr surfaces of a mesh, built afresh per face by an uncached factory over the mesh's
// positions welded by value (the tessellator's refiner sees welded positions too: UV seams are no boundary).
struct FreshSurfaces {
    std::vector<float> positions; // welded
    std::unique_ptr<osd::Far::TopologyRefiner> refiner;
    std::unique_ptr<osd::Bfr::RefinerSurfaceFactory<>> factory;
    osd::Bfr::Surface<float> surface;
    std::vector<float> patch;
    int current = -1;
    std::vector<double> positions_d; // the same in double precision, for the exact normal
    osd::Bfr::Surface<double> surface_d;
    std::vector<double> patch_d;
    int current_d = -1;

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
        positions_d.assign(positions.begin(), positions.end());
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
    // The unit normal of face f at uv evaluated in double precision; false if the face has no surface.
    bool exact_normal(int f, const float* uv, std::array<double, 3>& n) {
        if (f != current_d) {
            if (!factory->InitVertexSurface(f, &surface_d)) return false;
            patch_d.resize(size_t(surface_d.GetNumPatchPoints()) * 3);
            surface_d.PreparePatchPoints(positions_d.data(), 3, patch_d.data(), 3);
            current_d = f;
        }
        const double st[2] = {uv[0], uv[1]};
        double P[3], Du[3], Dv[3];
        surface_d.Evaluate(st, patch_d.data(), 3, P, Du, Dv);
        n = {Du[1] * Dv[2] - Du[2] * Dv[1], Du[2] * Dv[0] - Du[0] * Dv[2], Du[0] * Dv[1] - Du[1] * Dv[0]};
        const double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (double& x : n) x /= l;
        return l > 0;
    }
};

// The angle between two directions (any lengths).
inline double angle_between(const std::array<double, 3>& a, const float* b) {
    const std::array<double, 3> c{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    return std::atan2(std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
}

// Every output vertex equals, bit for bit, one fresh evaluation (uncached factory, InitVertexSurface and
// PreparePatchPoints for that face alone) at the (face, u, v) of a triangle corner that uses it: the owner's.
inline void expect_fresh_surfaces_agree(const Primitive& p, SubdivisionScheme scheme, int rate) {
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
// And no output normal is further from the exact normal (the faces' average evaluated in double precision)
// than the faces' float average is anywhere, plus 1e-6 rad. `tolerance`: for real meshes with small faces the
// float derivatives disagree between faces by more than 1e-6 rad (cancellation; spot: 4.8e-6 rad) while the
// float average itself is 1.8e-4 rad from the exact normal. Returns the largest angle to the faces' average.
inline double expect_normals_average_faces(const Primitive& p, SubdivisionScheme scheme, int rate, double tolerance = 1e-6) {
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
        std::array<double, 3> n{0, 0, 0}, exact{0, 0, 0};
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
            std::array<double, 3> e;
            if (fresh.exact_normal(int(f), &out.triangle_coords[tri * 6 + size_t(k) * 2], e))
                for (int i = 0; i < 3; ++i) s.exact[size_t(i)] += e[size_t(i)];
        }
    }
    EXPECT_EQ(without_tangent_plane, 0u);
    double worst = 0, worst_exact = 0, average_exact = 0;
    size_t shared = 0;
    for (size_t v = 0; v < out.positions.size() / 3; ++v) {
        const float* P = &out.positions[v * 3];
        const Sum& s = at[{P[0], P[1], P[2]}];
        shared += s.faces.size() > 1;
        const float* N = &out.normals[v * 3];
        worst = std::max(worst, angle_between(s.n, N));
        worst_exact = std::max(worst_exact, angle_between(s.exact, N));
        const std::array<float, 3> average{float(s.n[0]), float(s.n[1]), float(s.n[2])};
        average_exact = std::max(average_exact, angle_between(s.exact, average.data()));
    }
    EXPECT_GT(shared, 0u);
    EXPECT_LE(worst, tolerance) << "largest angle between an output normal and its faces' average";
    EXPECT_LE(worst_exact, average_exact + 1e-6) << "the exact normal is further from the output than from the average";
    std::printf("largest angle to the faces' average %.3g rad; to the exact normal %.3g rad (the average's: %.3g rad)\n",
                worst, worst_exact, average_exact);
    return worst;
}

} // namespace furrow::test

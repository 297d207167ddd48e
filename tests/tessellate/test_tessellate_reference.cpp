// Uniform Bfr tessellation against an independent reference: Far::PrimvarRefiner + limit projection for
// Catmull-Clark and Loop, the analytic bilinear patch for the bilinear scheme. Relative agreement 1e-5.
#include "osd_reference.h"
#include "tess_test_util.h"
#include "test_support.h"

#include <furrow/shapes.h>

#include <cstdio>

using namespace furrow;
using namespace furrow::test;

namespace {

double expect_matches_far(const Primitive& p, SubdivisionScheme scheme, OpenSubdiv::Sdc::SchemeType osd_scheme, int level,
                          int accuracy = 2, int deep_levels = 0) {
    const int rate = 1 << level;
    TessellateOptions o = uniform_options(scheme, rate);
    o.surface.accuracy = accuracy;
    TessellateOutput t = run_tessellate(p, o);
    EXPECT_EQ(t.stats.linear_faces, 0u) << "every face on the limit surface";
    Primitive w = welded(p);
    auto reference = far_limit_points(w.positions, w.indices, w.face_sizes, osd_scheme, level, deep_levels);
    EXPECT_FALSE(reference.empty());
    if (reference.empty()) return INFINITY;
    auto ours = unique_points(t.positions);
    EXPECT_EQ(ours.size(), reference.size()); // the same vertices, one per refined vertex
    const double diag = diagonal_of(w.positions);
    const double worst = std::max(max_nearest_distance(ours, reference), max_nearest_distance(reference, ours)) / diag;
    EXPECT_LE(worst, 1e-5);
    return worst;
}

} // namespace

// Catmull-Clark on a closed all-regular quad mesh (every patch a bicubic B-spline).
TEST(tessellate_reference, CatmarkMatchesPrimvarRefinerLimit) {
    expect_matches_far(quad_torus(8, 6), SubdivisionScheme::catmark, OpenSubdiv::Sdc::SCHEME_CATMARK, 2);
    expect_matches_far(quad_torus(5, 7, 3.0f, 1.1f), SubdivisionScheme::catmark, OpenSubdiv::Sdc::SCHEME_CATMARK, 3);
}

// Loop on a closed all-regular triangle mesh (every vertex of valence 6).
TEST(tessellate_reference, LoopMatchesPrimvarRefinerLimit) {
    expect_matches_far(shapes::torus(1, 0.3f, 12, 8), SubdivisionScheme::loop, OpenSubdiv::Sdc::SCHEME_LOOP, 2);
}

// Open boundaries (EDGE_AND_CORNER) with a regular interior: the quad grid, Catmull-Clark.
TEST(tessellate_reference, CatmarkOpenGridMatchesPrimvarRefinerLimit) {
    Primitive g = shapes::quad_grid(2, 2, 4, 4);
    for (size_t v = 0; v < g.vertex_count(); ++v) g.positions[v * 3 + 1] = 0.3f * std::sin(3.0f * g.positions[v * 3] + 2.0f * g.positions[v * 3 + 2]);
    expect_matches_far(g, SubdivisionScheme::catmark, OpenSubdiv::Sdc::SCHEME_CATMARK, 2);
}

// Bilinear: every output point lies on the bilinear patch of its quad (analytic).
TEST(tessellate_reference, BilinearMatchesAnalyticPatch) {
    const int n = 5;
    Primitive g = shapes::quad_grid(float(n), float(n), n, n); // unit cells, x and z in [-2.5, 2.5]
    auto height = [](float x, float z) { return 0.4f * std::sin(1.3f * x) * std::cos(0.7f * z) + 0.1f * x * z; };
    for (size_t v = 0; v < g.vertex_count(); ++v) g.positions[v * 3 + 1] = height(g.positions[v * 3], g.positions[v * 3 + 2]);
    TessellateOutput t = run_tessellate(g, uniform_options(SubdivisionScheme::bilinear, 7));
    EXPECT_EQ(t.stats.triangles, size_t(2 * n * n * 49));
    double worst = 0;
    for (size_t v = 0; v < t.positions.size() / 3; ++v) {
        const float x = t.positions[v * 3], z = t.positions[v * 3 + 2];
        const float fx = x + 2.5f, fz = z + 2.5f;
        int i = std::min(n - 1, int(std::floor(fx))), j = std::min(n - 1, int(std::floor(fz)));
        const float s = fx - float(i), u = fz - float(j);
        const float x0 = float(i) - 2.5f, z0 = float(j) - 2.5f;
        const float y = (1 - s) * (1 - u) * height(x0, z0) + s * (1 - u) * height(x0 + 1, z0) + s * u * height(x0 + 1, z0 + 1) +
                        (1 - s) * u * height(x0, z0 + 1);
        worst = std::max(worst, double(std::abs(y - t.positions[v * 3 + 1])));
    }
    EXPECT_LE(worst, 1e-5 * diagonal_of(g.positions));
}

namespace {

// A bumpy open quad grid in which three quads are each split in two through a new vertex of valence 2 (a
// doublet: both faces share both of its edges), two of them side by side, one next to the boundary.
Primitive doublet_grid() {
    const int n = 6;
    Primitive g = shapes::quad_grid(2, 2, n, n);
    for (size_t v = 0; v < g.vertex_count(); ++v)
        g.positions[v * 3 + 1] = 0.3f * std::sin(3.0f * g.positions[v * 3]) * std::cos(2.0f * g.positions[v * 3 + 2]);
    g.uv0.clear();
    g.normals.clear();
    std::vector<uint32_t> indices, sizes;
    size_t split = 0;
    for (size_t f = 0; f < g.face_sizes.size(); ++f) {
        const uint32_t* q = &g.indices[4 * f];
        const int i = int(f) % n, j = int(f) / n;
        const bool doublet = (i == 2 && j == 2) || (i == 3 && j == 2) || (i == 0 && j == 4);
        if (!doublet) {
            indices.insert(indices.end(), q, q + 4);
            sizes.push_back(4);
            continue;
        }
        // The new vertex: off the quad's diagonal and lifted, so the fold is real.
        const uint32_t e = uint32_t(g.positions.size() / 3);
        for (int k = 0; k < 3; ++k)
            g.positions.push_back(0.3f * g.positions[3 * q[0] + size_t(k)] + 0.1f * g.positions[3 * q[1] + size_t(k)] +
                                  0.4f * g.positions[3 * q[2] + size_t(k)] + 0.2f * g.positions[3 * q[3] + size_t(k)] + (k == 1 ? 0.15f : 0.0f));
        indices.insert(indices.end(), {q[0], q[1], q[2], e, q[0], e, q[2], q[3]});
        sizes.insert(sizes.end(), {4, 4});
        ++split;
    }
    EXPECT_EQ(split, 3u);
    g.indices = indices;
    g.face_sizes = sizes;
    return g;
}

} // namespace

// Interior vertices of valence 2 are tessellated on the limit surface (they once fell back to linear faces,
// leaving the limit surface by up to 1e-1 of the face size, their neighbours too): every output point within
// 1e-5 of the diagonal of the independent reference, Far's uniform refinement projected to the limit (and 9
// levels of refinement at the valence-2 vertices themselves, where OpenSubdiv 3.5.0's limit mask is off).
// At the default accuracy (2) the faces around the doublets are approximated as around any extraordinary
// vertex; at accuracy 10 they are exact.
TEST(tessellate_reference, Valence2VerticesAreOnTheLimitSurface) {
    const Primitive g = doublet_grid();
    const double exact = expect_matches_far(g, SubdivisionScheme::catmark, OpenSubdiv::Sdc::SCHEME_CATMARK, 2, 10, 9);
    std::printf("valence-2 grid: worst distance to the limit / diagonal: %.3g at accuracy 10\n", exact);
    TessellateOutput t = run_tessellate(g, uniform_options(SubdivisionScheme::catmark, 4));
    EXPECT_EQ(t.stats.valence2_vertices, 3u);
    EXPECT_EQ(t.stats.linear_faces, 0u);
    CheckReport r = check_primitive(primitive_of(t));
    EXPECT_EQ(r.boundary_loops, 1u) << "crack-free";
    EXPECT_EQ(r.non_manifold_edges, 0u);
}

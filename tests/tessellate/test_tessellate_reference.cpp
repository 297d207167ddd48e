// Uniform Bfr tessellation against an independent reference: Far::PrimvarRefiner + limit projection for
// Catmull-Clark and Loop, the analytic bilinear patch for the bilinear scheme. Relative agreement 1e-5.
#include "osd_reference.h"
#include "tess_test_util.h"
#include "test_support.h"

#include <furrow/shapes.h>

using namespace furrow;
using namespace furrow::test;

namespace {

// Welds a primitive by exact position (the reference needs the welded topology).
Primitive welded(const Primitive& p) {
    std::vector<uint32_t> remap(p.vertex_count());
    weld_positions(remap.data(), p.positions.data(), p.vertex_count());
    Primitive w;
    std::vector<uint32_t> id(p.vertex_count(), 0xffffffffu);
    for (size_t v = 0; v < p.vertex_count(); ++v)
        if (remap[v] == v) {
            id[v] = uint32_t(w.positions.size() / 3);
            w.positions.insert(w.positions.end(), &p.positions[v * 3], &p.positions[v * 3 + 3]);
        }
    for (uint32_t i : p.indices) w.indices.push_back(id[remap[i]]);
    w.face_sizes = p.face_sizes;
    if (w.face_sizes.empty()) w.face_sizes.assign(p.indices.size() / 3, 3);
    return w;
}

void expect_matches_far(const Primitive& p, SubdivisionScheme scheme, OpenSubdiv::Sdc::SchemeType osd_scheme, int level) {
    const int rate = 1 << level;
    TessellateOutput t = run_tessellate(p, uniform_options(scheme, rate));
    Primitive w = welded(p);
    auto reference = far_limit_points(w.positions, w.indices, w.face_sizes, osd_scheme, level);
    ASSERT_FALSE(reference.empty());
    auto ours = unique_points(t.positions);
    EXPECT_EQ(ours.size(), reference.size()); // the same vertices, one per refined vertex
    const double diag = diagonal_of(w.positions);
    EXPECT_LE(max_nearest_distance(ours, reference), 1e-5 * diag);
    EXPECT_LE(max_nearest_distance(reference, ours), 1e-5 * diag);
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

// The base of a far LOD level, simplified: meshoptimizer's edge-collapse simplifier (meshopt_simplify, after
// Garland & Heckbert, "Surface Simplification Using Quadric Error Metrics", SIGGRAPH 1997), so a far level has
// fewer triangles per shell as well as fewer shells (issue 14, item 4).
//
// Why each step:
//   - the simplifier only picks a subset of the base vertices (no new positions), so the shell frame computed
//     on the full base (direction, clamped length, lean, sag) applies to the simplified triangles unchanged,
//     and copies of one position still get bit-identical shells (crack-free);
//   - meshopt 0.18 classifies vertices by welded position: UV seams and hard edges (split copies) collapse
//     only along the seam, open borders only along the border, so the level keeps the model's UV layout;
//   - the error bound is relative to the mesh extent as meshopt defines it (meshopt_simplifyScale); it grows
//     ×2 per level (a level with half the shells is drawn at about twice the distance, where twice the
//     geometric error covers the same pixels). The target count 1/4^k stops earlier when the bound is met.
//   - meshopt's error is a quadric (distance to the planes of the removed faces), which can understate the
//     distance between the surfaces (creature, level 2: 1.07 % reported, 2.6 % measured): the bound is checked
//     on a sampled two-sided distance (CGAL, distances_to_mesh) and meshopt asked again with half the error
//     until the level meets it;
//   - meshopt is single-threaded and deterministic: the same bytes at any thread count.
#include "shells_internal.h"

#include <furrow/shells.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>

namespace furrow::shells_detail {

namespace {

// The larger of the two one-sided distances between the surfaces, sampled: every original vertex to the
// simplified triangles, and the centroid and edge midpoints of every simplified triangle to the original
// (the simplified corners are original vertices). CGAL AABB trees (distances_to_mesh), in double.
double sampled_distance(const Primitive& base, const std::vector<uint32_t>& tris, const std::vector<uint32_t>& simple) {
    const float* pos = base.positions.data();
    const size_t n = base.vertex_count();
    std::vector<double> d(n);
    distances_to_mesh(d.data(), pos, n, pos, n, simple.data(), simple.size());
    double worst = d.empty() ? 0.0 : *std::max_element(d.begin(), d.end());
    std::vector<float> pts;
    pts.reserve(4 * simple.size());
    for (size_t f = 0; f + 3 <= simple.size(); f += 3) {
        const float* c[3] = {pos + 3 * size_t(simple[f]), pos + 3 * size_t(simple[f + 1]), pos + 3 * size_t(simple[f + 2])};
        for (int a = 0; a < 3; ++a) pts.push_back((c[0][a] + c[1][a] + c[2][a]) / 3.0f);
        for (int e = 0; e < 3; ++e)
            for (int a = 0; a < 3; ++a) pts.push_back(0.5f * (c[e][a] + c[(e + 1) % 3][a]));
    }
    d.assign(pts.size() / 3, 0.0);
    distances_to_mesh(d.data(), pts.data(), d.size(), pos, n, tris.data(), tris.size());
    for (double x : d) worst = std::max(worst, x);
    return worst;
}

} // namespace

SimplifiedBase simplify_base(const Primitive& base, const std::vector<uint32_t>& tris, int level, double error) {
    SimplifiedBase out;
    out.tris = tris;
    if (level < 1 || !(error > 0) || tris.size() < 6) return out;
    const size_t target = std::max<size_t>(3, 3 * ((tris.size() / 3) >> (2 * std::min(level, 15))));
    const double bound = std::min(1.0, error * std::ldexp(1.0, level - 1));
    const double scale = double(meshopt_simplifyScale(base.positions.data(), base.vertex_count(), 3 * sizeof(float)));
    // meshopt's error is a quadric (distance to the planes of the removed faces), not the distance between the
    // surfaces: the bound is checked on the sampled distance, and meshopt asked again with half the error
    // until the level meets it (at most 8 tries; else the full base).
    std::vector<uint32_t> dst(tris.size());
    double ask = bound;
    for (int attempt = 0; attempt < 8; ++attempt, ask *= 0.5) {
        float result = 0;
        const size_t count = meshopt_simplify(dst.data(), tris.data(), tris.size(), base.positions.data(), base.vertex_count(),
                                              3 * sizeof(float), target, float(ask), 0, &result);
        if (count == 0 || count >= tris.size()) return out; // nothing left, or nothing removed: the full base
        std::vector<uint32_t> simple(dst.begin(), dst.begin() + std::ptrdiff_t(count));
        const double distance = sampled_distance(base, tris, simple);
        if (!(distance <= bound * scale)) continue;
        out.tris = std::move(simple);
        out.relative_error = double(result);
        out.absolute_error = double(result) * scale;
        out.distance = distance / scale;
        return out;
    }
    return out;
}

} // namespace furrow::shells_detail

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
//   - meshopt is single-threaded and deterministic: the same bytes at any thread count.
#include "shells_internal.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>

namespace furrow::shells_detail {

SimplifiedBase simplify_base(const Primitive& base, const std::vector<uint32_t>& tris, int level, double error) {
    SimplifiedBase out;
    out.tris = tris;
    if (level < 1 || !(error > 0) || tris.size() < 6) return out;
    const size_t target = std::max<size_t>(3, 3 * ((tris.size() / 3) >> (2 * std::min(level, 15))));
    const float bound = float(std::min(1.0, error * std::ldexp(1.0, level - 1)));
    std::vector<uint32_t> dst(tris.size());
    float result = 0;
    const size_t count = meshopt_simplify(dst.data(), tris.data(), tris.size(), base.positions.data(), base.vertex_count(),
                                          3 * sizeof(float), target, bound, 0, &result);
    if (count == 0) return out; // nothing left: keep the full base rather than lose the level's fur
    dst.resize(count);
    out.tris = std::move(dst);
    out.relative_error = double(result);
    out.absolute_error = double(result) * double(meshopt_simplifyScale(base.positions.data(), base.vertex_count(), 3 * sizeof(float)));
    return out;
}

} // namespace furrow::shells_detail

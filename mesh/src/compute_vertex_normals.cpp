// Angle-weighted vertex pseudo-normals.
//
// Reference: G. Thürmer and C. A. Wüthrich, "Computing Vertex Normals from Polygonal Facets", Journal of
// Graphics Tools 3(1), 1998. Weighting each face normal by the face's interior angle at the vertex makes
// the result independent of how a surface is triangulated (a fan of thin triangles does not outvote one
// large triangle), which matters for fur shells offset along these normals. What one face contributes, and
// which faces are degenerate (area <= 1e-14 × their longest edge²), is the kernel's
// (furrow_kernel/angle_weighted_normal.h), shared with the fur frame and the displaced snow ground.
//
// The sums are kept per welded position, in double, so that the copies of a position split along UV or
// normal seams receive bit-identical normals and the shells do not crack along those seams.
#include <furrow/mesh.h>

#include <furrow_kernel/angle_weighted_normal.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace furrow {

using kernel::Vec3;
using kernel::cross;
using kernel::dot;
using kernel::norm;

void compute_vertex_normals(float* normals_out, const float* positions, size_t vertex_count,
                            const uint32_t* indices, size_t index_count) {
    if (vertex_count == 0 || !normals_out) return;
    std::fill(normals_out, normals_out + 3 * vertex_count, 0.0f);
    if (!positions) return;

    std::vector<uint32_t> remap(vertex_count);
    weld_positions(remap.data(), positions, vertex_count);
    auto point = [&](uint32_t v) { return kernel::point_at(positions, v); };

    std::vector<Vec3> sum(vertex_count); // indexed by welded representative
    if (indices) {
        for (size_t t = 0; t + 3 <= index_count; t += 3) {
            uint32_t w[3] = {0, 0, 0};
            bool valid = true;
            for (int k = 0; k < 3; ++k) {
                if (indices[t + k] >= vertex_count) valid = false;
                else w[k] = remap[indices[t + k]];
            }
            if (!valid || w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) continue;
            const Vec3 p[3] = {point(w[0]), point(w[1]), point(w[2])};
            const kernel::FaceTerm term = kernel::face_term(p[0], p[1], p[2]);
            if (term.angle[0] < 0) continue; // degenerate
            const Vec3 unit{term.unit[0], term.unit[1], term.unit[2]};
            for (int k = 0; k < 3; ++k) sum[w[k]] = sum[w[k]] + term.angle[k] * unit;
        }
    }
    for (size_t v = 0; v < vertex_count; ++v) {
        const Vec3 s = sum[remap[v]];
        const double len = norm(s);
        if (!(len > 0) || !std::isfinite(len)) continue; // no valid face: (0,0,0), the caller picks a fallback
        normals_out[3 * v] = float(s.x / len);
        normals_out[3 * v + 1] = float(s.y / len);
        normals_out[3 * v + 2] = float(s.z / len);
    }
}

} // namespace furrow

// Angle-weighted vertex pseudo-normals.
//
// Reference: G. Thürmer and C. A. Wüthrich, "Computing Vertex Normals from Polygonal Facets", Journal of
// Graphics Tools 3(1), 1998. Weighting each face normal by the face's interior angle at the vertex makes
// the result independent of how a surface is triangulated (a fan of thin triangles does not outvote one
// large triangle), which matters for fur shells offset along these normals.
//
// The sums are kept per welded position, in double, so that the copies of a position split along UV or
// normal seams receive bit-identical normals and the shells do not crack along those seams.
#include <furrow/mesh.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace furrow {
namespace {

struct V3 {
    double x, y, z;
};
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
double length(V3 a) { return std::sqrt(dot(a, a)); }

} // namespace

void compute_vertex_normals(float* normals_out, const float* positions, size_t vertex_count,
                            const uint32_t* indices, size_t index_count) {
    if (vertex_count == 0 || !normals_out) return;
    std::fill(normals_out, normals_out + 3 * vertex_count, 0.0f);
    if (!positions) return;

    std::vector<uint32_t> remap(vertex_count);
    weld_positions(remap.data(), positions, vertex_count);
    auto point = [&](uint32_t v) {
        return V3{double(positions[3 * v]), double(positions[3 * v + 1]), double(positions[3 * v + 2])};
    };

    // "Degenerate" uses the same relative area threshold as check_primitive (CheckOptions default), so a
    // face that `furrow check` reports as zero-area is exactly one that is ignored here: the normal of an
    // almost-collinear triangle is rounding noise, and it would carry a weight of nearly pi at its obtuse
    // corner.
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (size_t v = 0; v < vertex_count; ++v) {
        V3 q = point(uint32_t(v));
        if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) continue;
        double c[3] = {q.x, q.y, q.z};
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], c[k]), hi[k] = std::max(hi[k], c[k]);
    }
    double diagonal2 = 0;
    for (int k = 0; k < 3; ++k)
        if (hi[k] >= lo[k]) diagonal2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    const double min_double_area = 2.0 * CheckOptions{}.zero_area_relative * diagonal2;

    std::vector<V3> sum(vertex_count, V3{0, 0, 0}); // indexed by welded representative
    if (indices) {
        for (size_t t = 0; t + 3 <= index_count; t += 3) {
            uint32_t w[3] = {0, 0, 0};
            bool valid = true;
            for (int k = 0; k < 3; ++k) {
                if (indices[t + k] >= vertex_count) valid = false;
                else w[k] = remap[indices[t + k]];
            }
            if (!valid || w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) continue;
            V3 p[3] = {point(w[0]), point(w[1]), point(w[2])};
            V3 n = cross(p[1] - p[0], p[2] - p[0]);
            double double_area = length(n);
            if (!std::isfinite(double_area) || !(double_area > min_double_area)) continue;
            n = {n.x / double_area, n.y / double_area, n.z / double_area};
            for (int k = 0; k < 3; ++k) {
                V3 e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
                // atan2 of |e1×e2| (= double_area at every corner) and e1·e2 stays accurate near 0 and pi,
                // where acos of a normalised dot product loses half its digits.
                double angle = std::atan2(double_area, dot(e1, e2));
                sum[w[k]].x += angle * n.x;
                sum[w[k]].y += angle * n.y;
                sum[w[k]].z += angle * n.z;
            }
        }
    }
    for (size_t v = 0; v < vertex_count; ++v) {
        V3 s = sum[remap[v]];
        double len = length(s);
        if (!(len > 0) || !std::isfinite(len)) continue; // no valid face: (0,0,0), the caller picks a fallback
        normals_out[3 * v] = float(s.x / len);
        normals_out[3 * v + 1] = float(s.y / len);
        normals_out[3 * v + 2] = float(s.z / len);
    }
}

} // namespace furrow

// Undeformed ground height per texel by scan conversion: the highest triangle over each texel centre.
//
// Reference: J. Pineda, "A Parallel Algorithm for Polygon Rasterization", SIGGRAPH 1988 (edge functions),
// with the top-left fill rule replaced by a small inclusive tolerance. A ray cast down from above every texel
// would give the same heights (the first hit is the highest surface) but costs a tree walk per texel; a
// million texels are scan-converted in milliseconds. The inclusive tolerance makes texel centres that lie
// exactly on a shared edge or on the ground's outer boundary count as covered (the grid's corner texels sit
// on the extent's corners by construction), at worst writing the same height twice.
#include "deform_internal.h"

#include <algorithm>

namespace furrow::deform_detail {

namespace {

// Triangle t's corners in texel coordinates (i, j, height), or false when an index is out of range.
bool texel_corners(double (&q)[3][3], const HeightmapFrame& f, const float* positions, size_t vertex_count, const uint32_t* tri) {
    for (int k = 0; k < 3; ++k) {
        const uint32_t vi = tri[k];
        if (vi >= vertex_count) return false;
        const double p[3] = {positions[3 * size_t(vi)], positions[3 * size_t(vi) + 1], positions[3 * size_t(vi) + 2]};
        const auto tx = f.to_texel(p);
        q[k][0] = tx[0], q[k][1] = tx[1], q[k][2] = tx[2];
    }
    return true;
}

// Signed area in the plane (axis_u, axis_v): with axis_v = axis_u × up, a counter-clockwise triangle seen
// from above has a negative area in (u, v), so "facing up" is area < 0.
double texel_area(const double (&q)[3][3]) {
    return (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
}

// The highest of the triangle's heights and the cells' at every texel centre it covers (NaN-aware).
void raster_triangle(float* heights, int W, int H, const double (&q)[3][3], double area) {
    const double inv = 1.0 / area;
    const double tol = 1e-7;
    const int i0 = std::max(0, int(std::ceil(std::min({q[0][0], q[1][0], q[2][0]}) - 1e-6)));
    const int i1 = std::min(W - 1, int(std::floor(std::max({q[0][0], q[1][0], q[2][0]}) + 1e-6)));
    const int j0 = std::max(0, int(std::ceil(std::min({q[0][1], q[1][1], q[2][1]}) - 1e-6)));
    const int j1 = std::min(H - 1, int(std::floor(std::max({q[0][1], q[1][1], q[2][1]}) + 1e-6)));
    for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
            const double x = i, y = j;
            // Barycentric weights from the edge functions.
            const double b0 = ((q[1][0] - x) * (q[2][1] - y) - (q[2][0] - x) * (q[1][1] - y)) * inv;
            const double b1 = ((q[2][0] - x) * (q[0][1] - y) - (q[0][0] - x) * (q[2][1] - y)) * inv;
            const double b2 = 1.0 - b0 - b1;
            if (b0 < -tol || b1 < -tol || b2 < -tol) continue;
            const float hgt = float(b0 * q[0][2] + b1 * q[1][2] + b2 * q[2][2]);
            float& cell = heights[size_t(j) * size_t(W) + size_t(i)];
            if (!(cell >= hgt)) cell = hgt; // NaN-aware max
        }
}

} // namespace

size_t rasterize_ground(float* heights, const HeightmapFrame& f, const float* positions, size_t vertex_count,
                        const uint32_t* indices, size_t index_count) {
    const int W = f.width, H = f.height;
    std::fill(heights, heights + size_t(W) * size_t(H), std::numeric_limits<float>::quiet_NaN());
    size_t facing_down = 0;
    double area_sum = 0;
    size_t counted = 0;
    double q[3][3];
    for (size_t t = 0; t + 3 <= index_count; t += 3) {
        if (!texel_corners(q, f, positions, vertex_count, indices + t)) continue;
        const double area = texel_area(q);
        if (!std::isfinite(area)) continue;
        area_sum += std::abs(area);
        ++counted;
        if (area > 0) ++facing_down; // refined below against a relative threshold
        if (area != 0) raster_triangle(heights, W, H, q, area);
    }
    // A triangle counts as facing down only if it is not a sliver seen edge-on: cliffs modelled with vertical
    // faces flip sign by rounding alone.
    if (facing_down && counted) {
        const double threshold = 1e-6 * area_sum / double(counted);
        facing_down = 0;
        for (size_t t = 0; t + 3 <= index_count; t += 3)
            facing_down += texel_corners(q, f, positions, vertex_count, indices + t) && texel_area(q) > threshold;
    }
    return facing_down;
}

} // namespace furrow::deform_detail

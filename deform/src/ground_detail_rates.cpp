// Tessellation rates from heightmap detail: dense where stamps left curvature, coarse on untouched snow.
//
// Reference: the interpolation error bound for linear elements — over a segment of length s, a function with
// second derivative bounded by H deviates from its linear interpolant by at most H·s²/8 (e.g. C. de Boor, "A
// Practical Guide to Splines", 1978, ch. 2). With the curvature H of the heightmap inside a triangle's
// footprint (second differences over texels), segments of s = sqrt(8·e/H) keep the displaced mesh within e of
// the heightmap's surface. A stamp edge that is a kink (box walls, soft brush edges) has an unbounded second
// derivative; there the spacing bottoms out at `min_spacing` (one texel — what the map resolves).
// With a camera, e grows with distance (Cycles' dicing in pixels): e_world = pixel_error × distance / focal.
#include "deform_internal.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace furrow::deform_detail {

void triangle_detail_rates(std::vector<int>& rates, const Heightmap& hm, const float* positions, const uint32_t* indices,
                           size_t triangle_count, const DetailRateOptions& o) {
    rates.assign(triangle_count, 1);
    const HeightmapFrame& f = hm.frame;
    const int W = f.width, H = f.height;
    if (W < 3 || H < 3 || !(o.max_error > 0)) return;
    const double t = f.texel;
    // Curvature per texel (m per m²), 0 on the border row.
    std::vector<float> curv(size_t(W) * size_t(H), 0.0f);
    tbb::parallel_for(1, H - 1, [&](int j) {
        for (int i = 1; i < W - 1; ++i) {
            const double c = hm.at(i, j);
            const double dxx = hm.at(i + 1, j) - 2 * c + hm.at(i - 1, j);
            const double dyy = hm.at(i, j + 1) - 2 * c + hm.at(i, j - 1);
            const double d1 = (hm.at(i + 1, j + 1) - 2 * c + hm.at(i - 1, j - 1)) * 0.5;
            const double d2 = (hm.at(i + 1, j - 1) - 2 * c + hm.at(i - 1, j + 1)) * 0.5;
            curv[size_t(j) * size_t(W) + size_t(i)] = float(std::max({std::abs(dxx), std::abs(dyy), std::abs(d1), std::abs(d2)}) / (t * t));
        }
    });
    double focal = 0;
    if (o.camera) focal = 0.5 * o.camera->viewport_height / std::tan(0.5 * o.camera->fov_degrees * kPi / 180.0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, triangle_count, 64), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
            double tx[3][3];
            Vec3 p[3];
            for (int c = 0; c < 3; ++c) {
                const float* q = positions + 3 * size_t(indices[3 * k + size_t(c)]);
                p[c] = {q[0], q[1], q[2]};
                const double w[3] = {q[0], q[1], q[2]};
                auto a = f.to_texel(w);
                tx[c][0] = a[0], tx[c][1] = a[1], tx[c][2] = a[2];
            }
            const int i0 = std::max(0, int(std::floor(std::min({tx[0][0], tx[1][0], tx[2][0]}))) - 1);
            const int i1 = std::min(W - 1, int(std::ceil(std::max({tx[0][0], tx[1][0], tx[2][0]}))) + 1);
            const int j0 = std::max(0, int(std::floor(std::min({tx[0][1], tx[1][1], tx[2][1]}))) - 1);
            const int j1 = std::min(H - 1, int(std::ceil(std::max({tx[0][1], tx[1][1], tx[2][1]}))) + 1);
            double hmax = 0;
            for (int j = j0; j <= j1; ++j)
                for (int i = i0; i <= i1; ++i) hmax = std::max(hmax, double(curv[size_t(j) * size_t(W) + size_t(i)]));
            if (!(hmax > 0)) continue;
            double e = o.max_error;
            if (o.camera) {
                const Vec3 centre = (p[0] + p[1] + p[2]) * (1.0 / 3.0);
                e = std::max(e, o.camera->pixel_error * norm(centre - d3(o.camera->eye)) / focal);
            }
            const double s = std::max(o.min_spacing, std::sqrt(8.0 * e / hmax));
            // The heightmap varies only across its plane, so an edge needs segments for its length in that
            // plane (texel coordinates × texel), not in 3D: a steep or vertical ground face used to be cut by its
            // full 3D length against a texel that can be tiny (a needle-shaped ground of 16 triangles became
            // 12 million over two passes).
            auto planar = [&](int a, int b) { return t * std::hypot(tx[b][0] - tx[a][0], tx[b][1] - tx[a][1]); };
            const double longest = std::max({planar(0, 1), planar(1, 2), planar(2, 0)});
            rates[k] = int(std::clamp(std::ceil(longest / s), 1.0, double(o.max_rate)));
        }
    });
}

} // namespace furrow::deform_detail

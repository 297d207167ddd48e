// The rim: snow pushed out of an imprint and heaped around it.
//
// Shape: a ridge along the imprint's outline, profile φ(d) = 16·τ²(1 − τ)², τ = d / width, in the distance d
// from the imprint (exact Euclidean distance transform: P. Felzenszwalb, D. Huttenlocher, "Distance Transforms
// of Sampled Functions", Theory of Computing 8, 2012): zero with zero slope at the imprint's edge and at the
// rim's width, highest half-way. The distance is measured between texel centres; a light blur of the result
// (masked to the rim's texels) removes the half-texel staircase it would otherwise print on the ridge. The Last of Us Part II raises
// its footprints' edges the same way (a cone remapped by a quadratic; GDC 2020).
// Height:
//   - cosmetic: rim_height × the local mean depth of the imprint (box-filtered depth over box-filtered
//     imprint mask), so a deep ball trench gets a taller rim than a shallow footprint;
//   - volume-conserving (field notes: compaction, then a normalised ring kernel): the local amplitude is the
//     nearby removed volume × (1 − compaction) over the nearby area under φ — both box-filtered over a radius
//     that spans an imprint and its rims — and a final rescale over the window makes the raised volume equal
//     the removed volume × (1 − compaction) exactly (to rounding). Ratios of two smooth fields keep the ridge
//     even along a staircase outline, where scattering each texel's volume to its nearest outside texel
//     piles it into spikes at the steps.
// The rim is not relaxed to an angle of repose: its width is the caller's (tall rims mean a narrow width for
// the volume moved).
#include "deform_internal.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace furrow::detail {
namespace {

// Separable box sum of radius n (zero outside), applied twice: a smooth (quadratic B-spline) kernel in O(N).
void box_pass(std::vector<double>& v, int w, int h, int n) {
    std::vector<double> tmp(v.size());
    tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& r) {
        std::vector<double> pre(static_cast<size_t>(w) + 1);
        for (int j = r.begin(); j != r.end(); ++j) {
            const double* row = &v[size_t(j) * size_t(w)];
            pre[0] = 0;
            for (int i = 0; i < w; ++i) pre[size_t(i) + 1] = pre[size_t(i)] + row[i];
            for (int i = 0; i < w; ++i) tmp[size_t(j) * size_t(w) + size_t(i)] = pre[size_t(std::min(w, i + n + 1))] - pre[size_t(std::max(0, i - n))];
        }
    });
    tbb::parallel_for(tbb::blocked_range<int>(0, w, 64), [&](const tbb::blocked_range<int>& r) {
        std::vector<double> pre(static_cast<size_t>(h) + 1);
        for (int i = r.begin(); i != r.end(); ++i) {
            pre[0] = 0;
            for (int j = 0; j < h; ++j) pre[size_t(j) + 1] = pre[size_t(j)] + tmp[size_t(j) * size_t(w) + size_t(i)];
            for (int j = 0; j < h; ++j) v[size_t(j) * size_t(w) + size_t(i)] = pre[size_t(std::min(h, j + n + 1))] - pre[size_t(std::max(0, j - n))];
        }
    });
}
void smooth(std::vector<double>& v, int w, int h, int n) {
    box_pass(v, w, h, n);
    box_pass(v, w, h, n);
}

// Nearest texel of a mask (exact Euclidean) for every texel of a w × h window: index into the window, or -1.
void nearest_in_mask(std::vector<int>& nearest, const std::vector<uint8_t>& receiver, int w, int h) {
    const double big = 1e20;
    // Pass 1, per column: distance (in rows) to the nearest receiver in the same column.
    std::vector<double> f(size_t(w) * size_t(h));
    std::vector<int> row_of(size_t(w) * size_t(h), -1);
    tbb::parallel_for(tbb::blocked_range<int>(0, w, 64), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i != r.end(); ++i) {
            int last = -1;
            for (int j = 0; j < h; ++j) {
                const size_t x = size_t(j) * size_t(w) + size_t(i);
                if (receiver[x]) last = j;
                row_of[x] = last;
            }
            last = -1;
            for (int j = h - 1; j >= 0; --j) {
                const size_t x = size_t(j) * size_t(w) + size_t(i);
                if (receiver[x]) last = j;
                if (last >= 0 && (row_of[x] < 0 || last - j < j - row_of[x])) row_of[x] = last;
                f[x] = row_of[x] < 0 ? big : double(row_of[x] - j) * double(row_of[x] - j);
            }
        }
    });
    // Pass 2, per row: lower envelope of the parabolas (i − q)² + f(q).
    nearest.assign(size_t(w) * size_t(h), -1);
    tbb::parallel_for(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& r) {
        std::vector<int> v(static_cast<size_t>(w));
        std::vector<double> z(static_cast<size_t>(w) + 1);
        for (int j = r.begin(); j != r.end(); ++j) {
            const double* fr = &f[size_t(j) * size_t(w)];
            int k = -1;
            for (int q = 0; q < w; ++q) {
                if (fr[q] >= big) continue;
                if (k < 0) {
                    k = 0, v[0] = q, z[0] = -kInf, z[1] = kInf;
                    continue;
                }
                double s;
                while (true) {
                    const int p = v[size_t(k)];
                    s = ((fr[q] + double(q) * q) - (fr[p] + double(p) * p)) / (2.0 * (q - p));
                    if (s <= z[size_t(k)] && k > 0) {
                        --k;
                        continue;
                    }
                    break;
                }
                if (s <= z[size_t(k)]) { // k == 0 and the new parabola wins everywhere
                    v[0] = q, z[0] = -kInf, z[1] = kInf;
                    continue;
                }
                ++k;
                v[size_t(k)] = q, z[size_t(k)] = s, z[size_t(k) + 1] = kInf;
            }
            if (k < 0) continue;
            int m = 0;
            for (int i = 0; i < w; ++i) {
                while (z[size_t(m) + 1] < i) ++m;
                const int q = v[size_t(m)];
                const size_t src = size_t(j) * size_t(w) + size_t(q);
                nearest[size_t(j) * size_t(w) + size_t(i)] = row_of[src] * w + q;
            }
        }
    });
}

} // namespace

double compute_rim(float* rim, const RimInput& in, const TexelRect& win, const TexelRect& write) {
    const int w = win.x1 - win.x0, h = win.y1 - win.y0;
    if (w <= 0 || h <= 0) return 0.0;
    const size_t N = size_t(w) * size_t(h);
    auto gidx = [&](int i, int j) { return size_t(j + win.y0) * size_t(in.width) + size_t(i + win.x0); };
    std::vector<double> source(N, 0.0);
    std::vector<uint8_t> is_source(N, 0), receiver(N, 0);
    bool any_source = false;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const size_t g = gidx(i, j);
            const double base = in.base ? double(in.base[g]) : 0.0;
            const double s = base - double(in.carve[g]);
            const size_t x = size_t(j) * size_t(w) + size_t(i);
            if (s > 0) {
                source[x] = s;
                is_source[x] = 1;
                any_source = true;
            } else if (!std::isnan(in.ground[g])) {
                receiver[x] = 1;
            }
        }
    auto clear_write = [&] {
        for (int j = write.y0; j < write.y1; ++j)
            std::fill(rim + size_t(j) * size_t(in.width) + size_t(write.x0), rim + size_t(j) * size_t(in.width) + size_t(write.x1), 0.0f);
    };
    if (!any_source || in.width_m <= 0) {
        clear_write();
        return 0.0;
    }
    const double t = in.texel;
    // Profile in the distance from the imprint (texel centres; the outline is half a texel out).
    std::vector<int> nearest;
    nearest_in_mask(nearest, is_source, w, h);
    std::vector<double> profile(N, 0.0);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const size_t x = size_t(j) * size_t(w) + size_t(i);
            if (!receiver[x] || nearest[x] < 0) continue;
            const int qi = nearest[x] % w, qj = nearest[x] / w;
            const double d = t * (std::hypot(double(i - qi), double(j - qj)) - 0.5);
            const double tau = d / in.width_m;
            if (tau > 0 && tau < 1) profile[x] = 16 * tau * tau * (1 - tau) * (1 - tau);
        }
    // Gathering radius: an imprint's half-width plus its rim, so that a rim point sees the volume it carries.
    const int n = std::max(2, int(std::ceil((in.width_m + in.gather_m) / t / 2)));
    std::vector<double> num = source, den;
    if (in.conserve) {
        den = profile;
    } else {
        den.assign(N, 0.0);
        for (size_t x = 0; x < N; ++x) den[x] = is_source[x];
    }
    smooth(num, w, h, n);
    smooth(den, w, h, n);
    std::vector<double> result(N, 0.0);
    double raised = 0, removed = 0;
    for (size_t x = 0; x < N; ++x) {
        removed += source[x];
        if (profile[x] > 0 && den[x] > 0) {
            result[x] = profile[x] * num[x] / den[x];
            raised += result[x];
        }
    }
    // Staircase noise of the texel-centre distances, blurred away; imprinted texels stay untouched.
    smooth(result, w, h, 1);
    raised = 0;
    for (size_t x = 0; x < N; ++x) {
        if (!receiver[x]) result[x] = 0;
        raised += result[x];
    }
    if (!in.conserve) {
        // The blur kernel sums to 81 (two 3 x 3 box passes).
        for (double& r : result) r /= 81.0;
    }
    double lost = 0;
    if (in.conserve) {
        const double target = removed * (1.0 - in.compaction);
        if (raised > 0) {
            const double k = target / raised;
            for (double& r : result) r *= k;
        } else {
            lost = target * t * t;
        }
    } else {
        for (double& r : result) r *= in.height_ratio;
    }
    clear_write();
    for (int j = write.y0; j < write.y1; ++j)
        for (int i = write.x0; i < write.x1; ++i)
            rim[size_t(j) * size_t(in.width) + size_t(i)] = float(result[size_t(j - win.y0) * size_t(w) + size_t(i - win.x0)]);
    return lost;
}

} // namespace furrow::detail

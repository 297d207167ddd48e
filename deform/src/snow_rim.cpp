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

// Working arrays, kept between calls (a game calls update() every frame): no allocation, no page faults.
struct Scratch {
    std::vector<float> source, mass, profile, num, den, result, tmp, f;
    std::vector<uint8_t> is_source, receiver;
    std::vector<int> row_of, nearest;
};

template <class T>
void fit(std::vector<T>& v, size_t n) {
    if (v.size() < n) v.resize(n);
}

// Separable box sum of radius n (zero outside). Both passes walk memory row by row (the vertical one keeps a
// running sum per column); sums are carried in double, stored in float.
void box_pass(float* v, float* tmp, int w, int h, int n) {
    tbb::parallel_for(tbb::blocked_range<int>(0, h, 32), [&](const tbb::blocked_range<int>& r) {
        for (int j = r.begin(); j != r.end(); ++j) {
            const float* row = v + size_t(j) * size_t(w);
            float* o = tmp + size_t(j) * size_t(w);
            double acc = 0;
            for (int i = 0; i <= std::min(n, w - 1); ++i) acc += row[i];
            for (int i = 0; i < w; ++i) {
                o[i] = float(acc);
                if (i + n + 1 < w) acc += row[i + n + 1];
                if (i - n >= 0) acc -= row[i - n];
            }
        }
    });
    tbb::parallel_for(tbb::blocked_range<int>(0, w, 256), [&](const tbb::blocked_range<int>& r) {
        const int i0 = r.begin(), i1 = r.end();
        std::vector<double> acc(size_t(i1 - i0), 0.0);
        for (int j = 0; j <= std::min(n, h - 1); ++j)
            for (int i = i0; i < i1; ++i) acc[size_t(i - i0)] += tmp[size_t(j) * size_t(w) + size_t(i)];
        for (int j = 0; j < h; ++j) {
            float* o = v + size_t(j) * size_t(w);
            const float* add = j + n + 1 < h ? tmp + size_t(j + n + 1) * size_t(w) : nullptr;
            const float* sub = j - n >= 0 ? tmp + size_t(j - n) * size_t(w) : nullptr;
            for (int i = i0; i < i1; ++i) {
                double& a = acc[size_t(i - i0)];
                o[i] = float(a);
                if (add) a += add[i];
                if (sub) a -= sub[i];
            }
        }
    });
}

// Two box passes: a smooth (quadratic B-spline) kernel of radius 2n in O(N).
void smooth(float* v, float* tmp, int w, int h, int n) {
    box_pass(v, tmp, w, h, n);
    box_pass(v, tmp, w, h, n);
}

// Nearest texel of a mask (exact Euclidean) for every texel of a w × h window: index into the window, or -1.
void nearest_in_mask(Scratch& S, const uint8_t* mask, int w, int h) {
    const size_t N = size_t(w) * size_t(h);
    const float big = 1e30f;
    fit(S.f, N);
    fit(S.row_of, N);
    fit(S.nearest, N);
    float* f = S.f.data();
    int* row_of = S.row_of.data();
    int* nearest = S.nearest.data();
    // Pass 1, per column: the nearest marked row above and below (row-major sweeps, a running row per column).
    {
        std::vector<int> last(size_t(w), -1);
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const size_t x = size_t(j) * size_t(w) + size_t(i);
                if (mask[x]) last[size_t(i)] = j;
                row_of[x] = last[size_t(i)];
            }
        std::fill(last.begin(), last.end(), -1);
        for (int j = h - 1; j >= 0; --j)
            for (int i = 0; i < w; ++i) {
                const size_t x = size_t(j) * size_t(w) + size_t(i);
                if (mask[x]) last[size_t(i)] = j;
                const int below = last[size_t(i)];
                if (below >= 0 && (row_of[x] < 0 || below - j < j - row_of[x])) row_of[x] = below;
                f[x] = row_of[x] < 0 ? big : float(row_of[x] - j) * float(row_of[x] - j);
            }
    }
    // Pass 2, per row: lower envelope of the parabolas (i − q)² + f(q).
    tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& r) {
        std::vector<int> v(static_cast<size_t>(w));
        std::vector<double> z(static_cast<size_t>(w) + 1);
        for (int j = r.begin(); j != r.end(); ++j) {
            const float* fr = f + size_t(j) * size_t(w);
            int* out = nearest + size_t(j) * size_t(w);
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
                    s = ((double(fr[q]) + double(q) * q) - (double(fr[p]) + double(p) * p)) / (2.0 * (q - p));
                    if (s <= z[size_t(k)] && k > 0) {
                        --k;
                        continue;
                    }
                    break;
                }
                ++k;
                v[size_t(k)] = q, z[size_t(k)] = s, z[size_t(k) + 1] = kInf;
            }
            if (k < 0) {
                std::fill(out, out + w, -1);
                continue;
            }
            int m = 0;
            for (int i = 0; i < w; ++i) {
                while (z[size_t(m) + 1] < i) ++m;
                const int q = v[size_t(m)];
                out[i] = row_of[size_t(j) * size_t(w) + size_t(q)] * w + q;
            }
        }
    });
}

} // namespace

double compute_rim(float* rim, const RimInput& in, const TexelRect& win, const RimOwner& own) {
    const int w = win.x1 - win.x0, h = win.y1 - win.y0;
    if (w <= 0 || h <= 0) return 0.0;
    const size_t N = size_t(w) * size_t(h);
    static thread_local Scratch S;
    for (auto* v : {&S.source, &S.mass, &S.profile, &S.num, &S.den, &S.result, &S.tmp}) fit(*v, N);
    fit(S.is_source, N);
    fit(S.receiver, N);
    float *source = S.source.data(), *mass = S.mass.data(), *profile = S.profile.data();
    uint8_t *is_source = S.is_source.data(), *receiver = S.receiver.data();
    auto gidx = [&](int i, int j) { return size_t(j + win.y0) * size_t(in.width) + size_t(i + win.x0); };
    auto owned = [&](int i, int j) { return own.owns(i + win.x0, j + win.y0); };
    // Every imprinted texel of the window shapes the ridge (distance, local depth); with conserve, only the
    // imprints on owned texels count as volume, so that what is written balances what is owned.
    bool any_source = false;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const size_t g = gidx(i, j);
            const float base = in.base ? in.base[g] : 0.0f;
            const float s = base - in.carve[g];
            const size_t x = size_t(j) * size_t(w) + size_t(i);
            source[x] = mass[x] = 0;
            is_source[x] = receiver[x] = 0;
            if (s > 0) {
                source[x] = s;
                is_source[x] = 1;
                if (owned(i, j)) {
                    mass[x] = s;
                    any_source = true;
                }
            } else if (!std::isnan(in.ground[g])) {
                receiver[x] = 1;
            }
        }
    auto write = [&](const float* result) {
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i)
                if (owned(i, j)) rim[gidx(i, j)] = result ? result[size_t(j) * size_t(w) + size_t(i)] : 0.0f;
    };
    if (!any_source || in.width_m <= 0) {
        write(nullptr);
        return 0.0;
    }
    const double t = in.texel;
    // Profile in the distance from the imprint (texel centres; the outline is half a texel out).
    nearest_in_mask(S, is_source, w, h);
    const int* nearest = S.nearest.data();
    const double reach2 = (in.width_m / t + 0.5) * (in.width_m / t + 0.5);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const size_t x = size_t(j) * size_t(w) + size_t(i);
            profile[x] = 0;
            if (!receiver[x] || nearest[x] < 0) continue;
            const int qi = nearest[x] % w, qj = nearest[x] / w;
            const double d2 = double(i - qi) * (i - qi) + double(j - qj) * (j - qj);
            if (d2 >= reach2) continue;
            const double tau = t * (std::sqrt(d2) - 0.5) / in.width_m;
            if (tau > 0 && tau < 1) profile[x] = float(16 * tau * tau * (1 - tau) * (1 - tau));
        }
    // Gathering radius: an imprint's half-width plus its rim, so that a rim point sees the volume it carries.
    // Beyond the window's size a box covers all of it, so the cap changes nothing but keeps i + n + 1 (below)
    // from overflowing for a collider of 1e30 m.
    const int n = std::max(2, clamped_int(std::ceil((in.width_m + in.gather_m) / t / 2), 0, std::max(w, h)));
    float *num = S.num.data(), *den = S.den.data(), *result = S.result.data(), *tmp = S.tmp.data();
    std::copy(in.conserve ? mass : source, (in.conserve ? mass : source) + N, num);
    if (in.conserve) std::copy(profile, profile + N, den);
    else
        for (size_t x = 0; x < N; ++x) den[x] = is_source[x];
    smooth(num, tmp, w, h, n);
    smooth(den, tmp, w, h, n);
    double removed = 0;
    for (size_t x = 0; x < N; ++x) {
        removed += mass[x];
        result[x] = (profile[x] > 0 && den[x] > 0) ? profile[x] * num[x] / den[x] : 0.0f;
    }
    // Staircase noise of the texel-centre distances, blurred away; imprinted texels stay untouched.
    smooth(result, tmp, w, h, 1);
    double raised = 0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const size_t x = size_t(j) * size_t(w) + size_t(i);
            if (!receiver[x] || !owned(i, j)) result[x] = 0;
            raised += result[x];
        }
    double lost = 0;
    if (in.conserve) {
        // The region owns its imprints and, by its margin, their whole rims: the raised volume written here
        // equals the volume removed here × (1 − compaction).
        const double target = removed * (1.0 - in.compaction);
        if (raised > 0) {
            const float k = float(target / raised);
            for (size_t x = 0; x < N; ++x) result[x] *= k;
        } else {
            lost = target * t * t;
        }
    } else {
        // The blur kernel sums to 81 (two 3 x 3 box passes).
        const float k = float(in.height_ratio / 81.0);
        for (size_t x = 0; x < N; ++x) result[x] *= k;
    }
    write(result);
    return lost;
}

} // namespace furrow::detail

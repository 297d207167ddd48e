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
// Limits (volume-conserving rims): a rim never rises above max_height × the depth of the print it comes from
// (the deepest imprint within its gathering radius), nor slopes steeper than the snow's angle of repose (max_slope_degrees). Where the caller's
// width would break either, the rim widens before it rises: the same volume is spread over a wider ring,
// found in a few rounds (height goes as 1 / width at a fixed volume, slope as 1 / width²), up to the width
// the caller's window holds.
// Windows. A game recomputes the rim only around what it stamped (SnowField::update), in small windows, and
// the result must be the bytes a whole-field computation gives. Everything a cosmetic rim texel reads lies
// within rim_reach of it, and every step gives that texel the same bits in any window that holds its reach:
// the distance transform is exact (integers; the per-frame ring needs it only within the rim's width, where
// a bounded search, nearest row per column then nearest column, gives the same integers); the gathered sums
// are fixed point (2^-20 m) added in 64-bit integers, where a running sum is exact wherever it starts
// (floating-point running sums round differently from different starts); the blur adds its few terms in one
// fixed order per texel. That evaluation (snow_rim_ring.inc) is built three times, for baseline x86-64, AVX2
// and AVX-512, and chosen at run time: per-texel arithmetic with no fused multiply-add gives every build the
// same bits (`furrow -j 1 bench stamp --section 4`, rim 6 cm: rim 8.85-9.29 -> 7.33-7.41 ms a frame with
// AVX-512; the AVX2 build's figures are in deform/README.md).
#include "deform_internal.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <numbers>

namespace furrow::deform_detail {
namespace {

// Working arrays, kept between calls (a game calls update() every frame): no allocation, no page faults.
struct Scratch {
    std::vector<float> source, mass, profile, result, tmp, f, depth;
    std::vector<uint64_t> num, den, tmp_q;
    std::vector<uint8_t> is_source, receiver;
    // The cosmetic rim's ring: second-order prefix sums of the window, the sources near `out`, its result.
    std::vector<uint64_t> num2;
    std::vector<uint32_t> count2;
    std::vector<uint8_t> near_source;
    std::vector<int> near_d2, near_rows, near_run;
    std::vector<uint8_t> near_rows8, near_run8; // near_rows and its running column, for a profile radius up to 253
    std::vector<int64_t> near_d2_wide;     // near_d2 for a rim wider than 32766 texels (its squares pass 2^31)
    std::vector<int16_t> columns16, min16; // the nearest-column search's rows, in 16-, 32- or 64-bit lanes
    std::vector<int> columns32, min32;
    std::vector<int64_t> columns64, min64;
    std::vector<float> profile_of;         // the profile per integer squared distance
    std::vector<int> sum_columns;          // the sums' column indices, per column of the ring
    std::vector<uint8_t> in_reach;         // per texel of a ring row: a receiver within the profile's reach
    std::vector<float> ring, ring_tmp;
    std::vector<float> zeros;              // a run of zeros for compute_rim's writes
    std::vector<int> row_of;
    std::vector<double> dist2;
};

template <class T>
void fit(std::vector<T>& v, size_t n) {
    if (v.size() < n) v.resize(n);
}

// A range of rows or columns in chunks: in parallel, or in order when the caller runs windows in parallel
// (then each window's scratch stays with its thread).
template <class F>
void for_range(bool par, const tbb::blocked_range<int>& range, const F& f) {
    if (par) tbb::parallel_for(range, f);
    else if (!range.empty()) f(range);
}

// Separable box sum of radius n (zero outside the window) of fixed-point values. Both passes walk memory row
// by row (the vertical one keeps a running sum per column). The sums are exact (unsigned 64-bit, where
// wrap-around cancels: the true sums fit, see kRimMaxGather), so a texel's sum is the same in any window that
// holds its neighbourhood: the rim recomputed in a small window around a stamp equals the whole field's.
void box_pass(uint64_t* v, uint64_t* tmp, int w, int h, int n, bool par) {
    for_range(par, tbb::blocked_range<int>(0, h, 32), [&](const tbb::blocked_range<int>& r) {
        for (int j = r.begin(); j != r.end(); ++j) {
            const uint64_t* row = v + size_t(j) * size_t(w);
            uint64_t* o = tmp + size_t(j) * size_t(w);
            uint64_t acc = 0;
            for (int i = 0; i <= std::min(n, w - 1); ++i) acc += row[i];
            for (int i = 0; i < w; ++i) {
                o[i] = acc;
                if (i + n + 1 < w) acc += row[i + n + 1];
                if (i - n >= 0) acc -= row[i - n];
            }
        }
    });
    for_range(par, tbb::blocked_range<int>(0, w, 256), [&](const tbb::blocked_range<int>& r) {
        const int i0 = r.begin(), i1 = r.end();
        std::vector<uint64_t> acc(size_t(i1 - i0), 0);
        for (int j = 0; j <= std::min(n, h - 1); ++j)
            for (int i = i0; i < i1; ++i) acc[size_t(i - i0)] += tmp[size_t(j) * size_t(w) + size_t(i)];
        for (int j = 0; j < h; ++j) {
            uint64_t* o = v + size_t(j) * size_t(w);
            const uint64_t* add = j + n + 1 < h ? tmp + size_t(j + n + 1) * size_t(w) : nullptr;
            const uint64_t* sub = j - n >= 0 ? tmp + size_t(j - n) * size_t(w) : nullptr;
            for (int i = i0; i < i1; ++i) {
                uint64_t& a = acc[size_t(i - i0)];
                o[i] = a;
                if (add) a += add[i];
                if (sub) a -= sub[i];
            }
        }
    });
}


// Running maximum over a (2n + 1)² box (zero outside), separable, O(N) with a monotone queue per line.
void max_pass(float* v, float* tmp, int w, int h, int n, bool par) {
    auto line = [n](const float* in, float* out, int len, size_t stride, std::vector<int>& q) {
        q.clear();
        size_t head = 0;
        for (int i = 0; i < len + n; ++i) {
            if (i < len) {
                while (q.size() > head && in[size_t(q.back()) * stride] <= in[size_t(i) * stride]) q.pop_back();
                q.push_back(i);
            }
            const int c = i - n; // the output this step completes
            if (c < 0) continue;
            while (q[head] < c - n) ++head;
            out[size_t(c) * stride] = in[size_t(q[head]) * stride];
        }
    };
    for_range(par, tbb::blocked_range<int>(0, h, 32), [&](const tbb::blocked_range<int>& r) {
        std::vector<int> q;
        for (int j = r.begin(); j != r.end(); ++j) line(v + size_t(j) * size_t(w), tmp + size_t(j) * size_t(w), w, 1, q);
    });
    for_range(par, tbb::blocked_range<int>(0, w, 64), [&](const tbb::blocked_range<int>& r) {
        std::vector<int> q;
        for (int i = r.begin(); i != r.end(); ++i) line(tmp + size_t(i), v + size_t(i), h, size_t(w), q);
    });
}

// Two box passes: a smooth (quadratic B-spline) kernel of radius 2n in O(N), exact.
void smooth(uint64_t* v, uint64_t* tmp, int w, int h, int n, bool par) {
    box_pass(v, tmp, w, h, n, par);
    box_pass(v, tmp, w, h, n, par);
}


// Squared distance (texels, exact Euclidean) to the nearest texel of a mask for every texel of a w × h window,
// infinite when the mask is empty (S.dist2).
void distance_to_mask(Scratch& S, const uint8_t* mask, int w, int h, bool par) {
    const size_t N = size_t(w) * size_t(h);
    const float big = 1e30f;
    fit(S.f, N);
    fit(S.row_of, N);
    fit(S.dist2, N);
    float* f = S.f.data();
    int* row_of = S.row_of.data();
    double* dist2 = S.dist2.data();
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
    for_range(par, tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& r) {
        std::vector<int> v(static_cast<size_t>(w));
        std::vector<double> z(static_cast<size_t>(w) + 1);
        for (int j = r.begin(); j != r.end(); ++j) {
            const float* fr = f + size_t(j) * size_t(w);
            double* out = dist2 + size_t(j) * size_t(w);
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
                std::fill(out, out + w, kInf);
                continue;
            }
            int m = 0;
            for (int i = 0; i < w; ++i) {
                while (z[size_t(m) + 1] < i) ++m;
                const int q = v[size_t(m)];
                const int row = row_of[size_t(j) * size_t(w) + size_t(q)];
                out[i] = double(i - q) * (i - q) + double(row - j) * (row - j);
            }
        }
    });
}

} // namespace

namespace {

// The window's texels: imprint depth (every imprinted texel shapes the ridge), mass (with conserve, only the
// imprints on owned texels count as volume, so that what is written balances what is owned), receivers.
struct Window {
    int w = 0, h = 0;
    size_t N = 0;
    float *source = nullptr, *mass = nullptr, *profile = nullptr, *result = nullptr, *tmp = nullptr;
    uint64_t *num = nullptr, *den = nullptr, *tmp_q = nullptr;
    uint8_t *is_source = nullptr, *receiver = nullptr;
};

bool gather_sources(Window& W, const RimInput& in, const TexelRect& win, const RimOwner& own) {
    bool any_source = false;
    for (int j = 0; j < W.h; ++j)
        for (int i = 0; i < W.w; ++i) {
            const size_t g = size_t(j + win.y0) * size_t(in.width) + size_t(i + win.x0);
            const float base = in.base ? in.base[g] : 0.0f;
            const float s = base - in.carve[g];
            const size_t x = size_t(j) * size_t(W.w) + size_t(i);
            W.source[x] = W.mass[x] = 0;
            W.is_source[x] = W.receiver[x] = 0;
            if (s > 0) {
                W.source[x] = s;
                W.is_source[x] = 1;
                // A cosmetic rim rises around any imprint; a conserving one counts the owned imprints' volume.
                if (!in.conserve || own.owns(i + win.x0, j + win.y0)) {
                    W.mass[x] = s;
                    any_source = true;
                }
            } else if (!std::isnan(in.ground[g])) {
                W.receiver[x] = 1;
            }
        }
    return any_source;
}

// φ(τ) on the receivers, τ = distance from the imprint over the rim's width (texel centres; the outline is
// half a texel out).
float profile_at(double d2, double texel, double width_m) {
    const double reach2 = (width_m / texel + 0.5) * (width_m / texel + 0.5);
    if (!(d2 < reach2)) return 0.0f;
    const double tau = texel * (std::sqrt(d2) - 0.5) / width_m;
    return tau > 0 && tau < 1 ? float(16 * tau * tau * (1 - tau) * (1 - tau)) : 0.0f;
}
void rim_profile(Window& W, const double* dist2, double texel, double width_m) {
    for (size_t x = 0; x < W.N; ++x) W.profile[x] = W.receiver[x] ? profile_at(dist2[x], texel, width_m) : 0.0f;
}

// Fixed point of the gathered sums: 2^-20 m (about a micrometre) per unit, each value capped so that the
// smoothed sum (a box of box sums, (2n + 1)⁴ terms, n <= kRimMaxGather) stays below 2^62: 16 km of depth
// per texel at the largest radius.
constexpr double kQuantum = 1.0 / 1048576.0;
double quantum_cap(int n) {
    const double side = 2.0 * n + 1;
    return std::floor(4.6e18 / (side * side * side * side));
}
// Half up. Through int64 (the capped value is below 2^62): SSE2 has no unsigned conversion, and the compiler's
// emulation of one cost a branch per texel in the rim's sums.
uint64_t quantized(double x, double cap) { return x > 0 ? uint64_t(int64_t(std::min(x / kQuantum, cap) + 0.5)) : 0; }

// A computed rim for compute_rim's writes: texel (x, y) of the window (x >= x0, y >= y0) at
// data[(y − y0) × stride + x − x0]; no data: zero everywhere.
struct RimValues {
    const float* data = nullptr;
    size_t stride = 0;
    int x0 = 0, y0 = 0;
    const float* at(int x, int y) const { return data + size_t(y - y0) * stride + size_t(x - x0); }
};

// The ring's three builds (snow_rim_ring.inc). Clang (the fuzzing build) and other targets get the baseline one.
namespace ring {
#include "snow_rim_ring.inc"
} // namespace ring
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define FURROW_RIM_WIDE 1
#pragma GCC push_options
#pragma GCC target("avx2,bmi,bmi2,lzcnt,popcnt")
namespace ring_avx2 {
#include "snow_rim_ring.inc"
} // namespace ring_avx2
#pragma GCC pop_options
#pragma GCC push_options
#pragma GCC target("avx512f,avx512bw,avx512dq,avx512vl")
namespace ring_avx512 {
#include "snow_rim_ring.inc"
} // namespace ring_avx512
#pragma GCC pop_options
#endif

// The build of the ring that runs here: the widest this processor has, or a narrower one a test asks for.
RingBuild ring_build_here(const RimInput& in) {
#ifdef FURROW_RIM_WIDE
    static const RingBuild widest = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                                            __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl")
                                        ? RingBuild::avx512
                                    : __builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi2") ? RingBuild::avx2
                                                                                                        : RingBuild::baseline;
    return std::min(widest, in.ring_build);
#else
    (void)in;
    return RingBuild::baseline;
#endif
}

// The rim for one width: local amplitude (ratio of two smoothed fields) × profile, blurred, kept on owned
// receivers, scaled (conserve: to the removed volume × (1 − compaction); cosmetic: by rim_height). Returns
// the volume that could not be placed.
double rim_amplitude(Window& W, const RimInput& in, const TexelRect& win, const RimOwner& own, double width_m) {
    const size_t N = W.N;
    const int n = rim_gather_radius(width_m, in.gather_m, in.texel);
    const double cap = quantum_cap(n);
    for (size_t x = 0; x < N; ++x) {
        W.num[x] = quantized(in.conserve ? W.mass[x] : W.source[x], cap);
        W.den[x] = quantized(in.conserve ? W.profile[x] : double(W.is_source[x]), cap);
    }
    smooth(W.num, W.tmp_q, W.w, W.h, n, in.parallel);
    smooth(W.den, W.tmp_q, W.w, W.h, n, in.parallel);
    double removed = 0;
    for (size_t x = 0; x < N; ++x) {
        removed += W.mass[x];
        // The true sums are < 2^62: the wrapped unsigned sums read back as themselves.
        const double num = double(int64_t(W.num[x])), den = double(int64_t(W.den[x]));
        W.result[x] = (W.profile[x] > 0 && den > 0) ? float(double(W.profile[x]) * num / den) : 0.0f;
    }
    // Staircase noise of the texel-centre distances, blurred away (over a radius that grows with a widened
    // rim: its stripes are as long as it is wide); imprinted texels stay untouched.
    ring::blur(W.result, W.tmp, W.w, W.h, in.conserve ? clamped_int(width_m / (6 * in.texel), 1, 16) : 1, in.parallel);
    if (!in.conserve) { // kept on receivers (the caller writes only its owned texels)
        const float k = float(in.height_ratio / 81.0); // the blur kernel sums to 81 (two 3 x 3 box passes)
        for (size_t x = 0; x < N; ++x) W.result[x] = W.receiver[x] ? W.result[x] * k : 0.0f;
        return 0.0;
    }
    double raised = 0;
    for (int j = 0; j < W.h; ++j)
        for (int i = 0; i < W.w; ++i) {
            const size_t x = size_t(j) * size_t(W.w) + size_t(i);
            if (!W.receiver[x] || !own.owns(i + win.x0, j + win.y0)) W.result[x] = 0;
            raised += W.result[x];
        }
    // The region owns its imprints and, by its margin, their whole rims: the raised volume written here
    // equals the volume removed here × (1 − compaction).
    const double target = removed * (1.0 - in.compaction);
    if (!(raised > 0)) return target * in.texel * in.texel;
    const float k = float(target / raised);
    for (size_t x = 0; x < N; ++x) W.result[x] *= k;
    return 0.0;
}


// How far the rim breaks its limits: max over rim texels of height / (max_height × the local print depth) and of (slope / tan(repose))^½ (height goes as 1/width at a fixed volume, slope as 1/width²). <= 1:
// within both.
double rim_excess(Window& W, const RimInput& in, const float* local_depth) {
    double excess = 0;
    const double tan_repose = in.max_slope_degrees > 0 && in.max_slope_degrees < 90
                                  ? std::tan(in.max_slope_degrees * std::numbers::pi / 180) : kInf;
    for (int j = 0; j < W.h; ++j)
        for (int i = 0; i < W.w; ++i) {
            const size_t x = size_t(j) * size_t(W.w) + size_t(i);
            const double r = W.result[x];
            if (!(r > 0)) continue;
            if (in.max_height > 0 && local_depth[x] > 0) excess = std::max(excess, r / (in.max_height * local_depth[x]));
            // Forward differences between rim texels (the imprint's own wall is not the rim's slope).
            double g2 = 0;
            if (i + 1 < W.w && W.receiver[x + 1]) g2 += (W.result[x + 1] - r) * (W.result[x + 1] - r);
            if (j + 1 < W.h && W.receiver[x + size_t(W.w)]) g2 += (W.result[x + size_t(W.w)] - r) * (W.result[x + size_t(W.w)] - r);
            excess = std::max(excess, std::sqrt(std::sqrt(g2) / in.texel / tan_repose));
        }
    return excess;
}

} // namespace

double compute_rim(float* rim, const RimInput& in, const TexelRect& win, const RimOwner& own, const TexelRect& out) {
    const int w = win.x1 - win.x0, h = win.y1 - win.y0;
    if (w <= 0 || h <= 0) return 0.0;
    const size_t N = size_t(w) * size_t(h);
    static thread_local Scratch S;
    Window W{w, h, N};
    // The owned texels of `out`, a tile's run of columns at a time (its owner and changed flag looked up once):
    // a run that is already those bits (most of a frame's) is only compared; else its first and last changed
    // texels are found from its two ends and the run is copied. The runs' tiles are stepped along the row, and
    // a run compared word by word in a loop the compiler vectorises: a division for each run's tile and a
    // memcmp call per run took most of this loop's time.
    fit(S.zeros, size_t(own.tile)); // (never written: zero)
    auto same_bits = [](const float* a, const float* b, size_t n) {
        uint32_t differ = 0;
        for (size_t k = 0; k < n; ++k) differ |= std::bit_cast<uint32_t>(a[k]) ^ std::bit_cast<uint32_t>(b[k]);
        return differ == 0;
    };
    auto write = [&](const RimValues& result) {
        const int i0 = std::max(0, out.x0 - win.x0), i1 = std::min(w, out.x1 - win.x0);
        if (i0 >= i1) return;
        const int first_end = std::min(i1, ((i0 + win.x0) / own.tile + 1) * own.tile - win.x0); // end of the first run
        for (int j = std::max(0, out.y0 - win.y0); j < std::min(h, out.y1 - win.y0); ++j) {
            size_t t = own.tile_of(i0 + win.x0, j + win.y0);
            float* row = rim + size_t(j + win.y0) * size_t(in.width) + size_t(win.x0);
            for (int a = i0, b = first_end; a < i1; a = b, b = std::min(i1, b + own.tile), ++t) {
                if (!own.tiles[t]) continue;
                const float* src = result.data ? result.at(a, j) : S.zeros.data();
                float* dst = row + a;
                const size_t n = size_t(b - a);
                if (same_bits(dst, src, n)) continue;
                size_t first = 0, last = n - 1; // bits differ somewhere in the run
                while (same_bits(dst + first, src + first, 1)) ++first;
                while (same_bits(dst + last, src + last, 1)) --last;
                std::memcpy(dst, src, n * sizeof(float));
                if (own.changed_box)
                    own.changed_box[t].unite({a + int(first) + win.x0, j + win.y0, a + int(last) + 1 + win.x0, j + 1 + win.y0});
            }
        }
    };
    if (in.width_m <= 0) {
        write({});
        return 0.0;
    }
    if (!in.conserve && !in.full_window) { // (a window without imprints comes out zero here too)
        RimValues ring_values;
        switch (ring_build_here(in)) {
#ifdef FURROW_RIM_WIDE
        case RingBuild::avx512: ring_values = ring_avx512::cosmetic_ring(S, W, in, win, out); break;
        case RingBuild::avx2: ring_values = ring_avx2::cosmetic_ring(S, W, in, win, out); break;
#endif
        default: ring_values = ring::cosmetic_ring(S, W, in, win, out); break;
        }
        write(ring_values);
        return 0.0;
    }
    fit(S.result, N);
    W.result = S.result.data();
    for (auto* v : {&S.source, &S.mass, &S.profile, &S.tmp, &S.depth}) fit(*v, N);
    for (auto* v : {&S.num, &S.den, &S.tmp_q}) fit(*v, N);
    fit(S.is_source, N);
    fit(S.receiver, N);
    W = Window{w, h, N, S.source.data(), S.mass.data(), S.profile.data(), S.result.data(), S.tmp.data(), S.num.data(),
               S.den.data(), S.tmp_q.data(), S.is_source.data(), S.receiver.data()};
    if (!gather_sources(W, in, win, own)) {
        write({});
        return 0.0;
    }
    distance_to_mask(S, W.is_source, w, h, in.parallel);
    double width = in.width_m;
    rim_profile(W, S.dist2.data(), in.texel, width);
    double lost = rim_amplitude(W, in, win, own, width);
    if (in.conserve && (in.max_height > 0 || (in.max_slope_degrees > 0 && in.max_slope_degrees < 90))) {
        // The local print depth a rim point may rise to: the deepest imprint within the gathering radius
        // of the caller's width (what the rim's volume comes from).
        float* depth = S.depth.data();
        std::copy(W.source, W.source + N, depth);
        max_pass(depth, W.tmp, w, h, 2 * rim_gather_radius(in.width_m, in.gather_m, in.texel), in.parallel);
        // The rim widens before it rises: while it is taller than the print is deep, or steeper than the
        // snow's angle of repose, the same volume is spread over a wider ring (up to max_width_m, what the
        // caller's window holds).
        for (int round = 0; round < 12; ++round) {
            const double excess = rim_excess(W, in, depth);
            if (excess <= 1.0 || width >= in.max_width_m) break;
            width = std::min(in.max_width_m, width * std::max(1.05, 1.02 * excess));
            rim_profile(W, S.dist2.data(), in.texel, width);
            lost = rim_amplitude(W, in, win, own, width);
        }
    }
    write({W.result, size_t(w), 0, 0});
    return lost;
}

} // namespace furrow::deform_detail

// The cosmetic rim's per-frame evaluation (deform/src/snow_rim.cpp): only around the texels a window writes,
// with prefix-summed gathers, it must give the bytes of the whole-window reference path (every step over the
// whole window, box-filtered sums), on random imprints, in small windows and whole, at 1 and 2 threads.
#include "deform_internal.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

using namespace furrow;
using namespace furrow::deform_detail;

namespace {

// A random frame: pits of random radius and depth (some overlapping, some at the border), a few texels with
// no ground, optionally a base layer with old pits.
struct RimFrame {
    int w = 0, h = 0;
    std::vector<float> carve, base, ground;
};

RimFrame random_frame(unsigned seed, int w, int h, bool with_base) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(0, 1);
    RimFrame f;
    f.w = w, f.h = h;
    const size_t N = size_t(w) * size_t(h);
    f.carve.assign(N, 0.0f);
    f.ground.assign(N, 0.0f);
    if (with_base) {
        f.base.assign(N, 0.0f);
        for (size_t x = 0; x < N; ++x)
            if (U(rng) < 0.01) f.base[x] = f.carve[x] = -0.02f;
    }
    for (size_t x = 0; x < N; ++x)
        if (U(rng) < 0.003) f.ground[x] = std::nanf("");
    const int pits = 6 + int(U(rng) * 10);
    for (int k = 0; k < pits; ++k) {
        const double cx = U(rng) * w, cy = U(rng) * h, r = 2 + U(rng) * 9, depth = 0.01 + U(rng) * 0.1;
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const double d = std::hypot(i - cx, j - cy);
                if (d >= r) continue;
                float& c = f.carve[size_t(j) * size_t(w) + size_t(i)];
                c = std::min(c, float(-depth * (1 - d * d / (r * r))));
            }
    }
    return f;
}

RimInput input_of(const RimFrame& f, double width_m, bool full_window, bool parallel) {
    RimInput in;
    in.carve = f.carve.data();
    in.base = f.base.empty() ? nullptr : f.base.data();
    in.ground = f.ground.data();
    in.width = f.w, in.height = f.h;
    in.texel = 0.02;
    in.width_m = width_m;
    in.gather_m = 0.12;
    in.height_ratio = 0.5;
    in.full_window = full_window;
    in.parallel = parallel;
    return in;
}

} // namespace

TEST(SnowRim, RingOnlyCosmeticRimEqualsTheWholeWindowPathByteForByte) {
    const int w = 150, h = 110, T = 16, TX = (w + T - 1) / T, TY = (h + T - 1) / T;
    const std::vector<uint8_t> all(size_t(TX) * size_t(TY), 1);
    const TexelRect grid{0, 0, w, h};
    for (unsigned seed = 1; seed <= 6; ++seed)
        // 2.6 m: a profile radius past the 16-bit lanes (126 texels); 700 m: past the 32-bit ones (35001 texels,
        // 2 (r + 1)² over 2^31); 30 km: at the radius's clamp (2^20 texels, the fuzzer's rim), wider than the
        // window: the nearest-column search takes only the shifts that reach it, and its rows are padded by the
        // block's width, not the radius. (At these radii the 32-bit lanes overflowed; in a plain build the bytes
        // happened to agree here, so UBSan, in CI's second job, is what catches that.)
        for (double width_m : {0.04, 0.06, 0.15, 2.6, 700.0, 30000.0}) {
            SCOPED_TRACE("seed " + std::to_string(seed) + ", width " + std::to_string(width_m));
            const RimFrame f = random_frame(seed, w, h, seed % 2 == 0);
            std::vector<float> ref(size_t(w) * size_t(h), -1.0f);
            compute_rim(ref.data(), input_of(f, width_m, true, true), grid, RimOwner{all.data(), TX, T}, grid);
            ASSERT_GT(*std::max_element(ref.begin(), ref.end()), 0.0f); // a rim rose
            // The ring's AVX-512, AVX2 and baseline builds (each where it runs), at one and two threads.
            for (int run = 0; run < 6; ++run) {
                const int threads = 1 + run % 2;
                const RingBuild build = run < 2 ? RingBuild::avx512 : run < 4 ? RingBuild::avx2 : RingBuild::baseline;
                SCOPED_TRACE(run < 2 ? "AVX-512 ring" : run < 4 ? "AVX2 ring" : "baseline ring");
                auto ring_input = [&](bool parallel) {
                    RimInput in = input_of(f, width_m, false, parallel);
                    in.ring_build = build;
                    return in;
                };
                tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
                // Whole grid in one window.
                std::vector<float> ring(ref.size(), -1.0f);
                compute_rim(ring.data(), ring_input(true), grid, RimOwner{all.data(), TX, T}, grid);
                EXPECT_EQ(std::memcmp(ring.data(), ref.data(), ref.size() * sizeof(float)), 0) << threads << " threads, whole";
                // Random tile-aligned output rectangles, each in a window holding its reach (as SnowField::update).
                std::mt19937 rng(seed * 31 + unsigned(run));
                const int reach = rim_reach(width_m, 0.12, 0.02);
                for (int k = 0; k < 8; ++k) {
                    const int tx0 = int(rng() % unsigned(TX)), ty0 = int(rng() % unsigned(TY));
                    const int tx1 = tx0 + 1 + int(rng() % 3u), ty1 = ty0 + 1 + int(rng() % 3u);
                    const TexelRect out{tx0 * T, ty0 * T, std::min(w, tx1 * T), std::min(h, ty1 * T)};
                    const TexelRect win{std::max(0, out.x0 - reach), std::max(0, out.y0 - reach), std::min(w, out.x1 + reach),
                                        std::min(h, out.y1 + reach)};
                    std::vector<float> part(ref.size(), -1.0f);
                    compute_rim(part.data(), ring_input(threads == 2), win, RimOwner{all.data(), TX, T}, out);
                    for (int j = out.y0; j < out.y1; ++j)
                        ASSERT_EQ(std::memcmp(&part[size_t(j) * size_t(w) + size_t(out.x0)], &ref[size_t(j) * size_t(w) + size_t(out.x0)],
                                              size_t(out.x1 - out.x0) * sizeof(float)),
                                  0)
                            << "window " << k << ", row " << j;
                }
            }
        }
}

// Heightmap::sample and the inline split-texel sampler DisplacedGround calls per point (deform_internal.h), against
// a plain bilinear reference written from the documented rule: texel centres at integer coordinates, zero
// beyond the grid, so the last texel ramps to 0 over one texel; coordinates at or beyond −1 and the size
// sample 0.
#include "deform_internal.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <vector>

using namespace furrow;
using namespace furrow::deform_detail;

namespace {

double reference_sample(const Heightmap& h, double ti, double tj) {
    const int w = h.frame.width, hh = h.frame.height;
    if (!(ti > -1.0 && tj > -1.0 && ti < double(w) && tj < double(hh))) return 0.0;
    const double fi0 = std::floor(ti), fj0 = std::floor(tj);
    const int i0 = int(fi0), j0 = int(fj0);
    const double fi = ti - fi0, fj = tj - fj0;
    auto v = [&](int i, int j) -> double {
        if (i < 0 || j < 0 || i >= w || j >= hh) return 0.0;
        return double(h.values[size_t(j) * size_t(w) + size_t(i)]);
    };
    return (v(i0, j0) * (1 - fi) + v(i0 + 1, j0) * fi) * (1 - fj) + (v(i0, j0 + 1) * (1 - fi) + v(i0 + 1, j0 + 1) * fi) * fj;
}

Heightmap bumpy(int w, int hh) {
    Heightmap h;
    h.frame.width = w, h.frame.height = hh, h.frame.texel = 0.1;
    h.values.resize(size_t(w) * size_t(hh));
    for (int j = 0; j < hh; ++j)
        for (int i = 0; i < w; ++i) h.values[size_t(j) * size_t(w) + size_t(i)] = float(std::sin(0.7 * i) * std::cos(0.3 * j) - 0.05 * (i + j));
    return h;
}

} // namespace

TEST(HeightmapSample, SplitSamplerEqualsThePlainBilinearRuleBitForBit) {
    const Heightmap h = bumpy(13, 7);
    test::Lcg next(11);
    std::vector<double> coords;
    // Random points over and around the grid, and the border cases exactly: −1, 0, the last centre, the size.
    for (int k = 0; k < 4000; ++k) coords.push_back(-3.0 + 19.0 * double(next(1u << 30)) / double(1u << 30));
    for (double c : {-2.0, -1.5, -1.0, -0.5, -1e-300, 0.0, 0.5, 6.0, 6.5, 7.0, 12.0, 12.999999999, 13.0, 14.0, 1e9, -1e9, 1e300, -1e300,
                     std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()})
        coords.push_back(c);
    size_t differ = 0, inside = 0;
    for (size_t a = 0; a < coords.size(); ++a)
        for (size_t b = a % 7; b < coords.size(); b += 97) {
            const double ti = coords[a], tj = coords[b];
            const double want = reference_sample(h, ti, tj);
            const double got = h.sample(ti, tj), cached = sample_split(h, split_texel(ti, tj));
            differ += std::bit_cast<uint64_t>(got) != std::bit_cast<uint64_t>(want) || std::bit_cast<uint64_t>(cached) != std::bit_cast<uint64_t>(want);
            inside += want != 0;
        }
    EXPECT_EQ(differ, 0u);
    EXPECT_GT(inside, 1000u); // the cases exercised the interior, not only the zero border
}

TEST(HeightmapSample, SplitTexelIsExactAndClampsFarCoordinates) {
    for (double t : {-1.75, -0.25, 0.0, 3.5, 1e6 + 0.125, 2147483645.5}) {
        const SplitTexel s = split_texel(t, -t);
        EXPECT_EQ(double(s.i) + s.fi, t);
        EXPECT_EQ(double(s.j) + s.fj, -t < -2 ? -2.0 : -t);
        EXPECT_GE(s.fi, 0.0);
        EXPECT_LT(s.fi, 1.0);
    }
    const SplitTexel far = split_texel(1e300, -1e300);
    EXPECT_EQ(far.i, 2147483646);
    EXPECT_EQ(far.j, -2);
    EXPECT_EQ(far.fi, 0.0);
    const SplitTexel nan = split_texel(std::nan(""), 0.5);
    EXPECT_EQ(nan.i, -2);
    // A heightmap whose values do not match its frame samples 0, as before.
    Heightmap broken = bumpy(4, 4);
    broken.values.pop_back();
    EXPECT_EQ(broken.sample(1.5, 1.5), 0.0);
}

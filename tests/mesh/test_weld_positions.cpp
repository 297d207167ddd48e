#include <furrow/mesh.h>
#include <gtest/gtest.h>

#include "weld_exact.h"

#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <limits>
#include <random>
#include <vector>

using furrow::weld_positions;

// Identical positions map to the first vertex that has them; others map to themselves.
TEST(weld_positions, ExactDuplicatesMapToFirstIndex) {
    const std::vector<float> p = {0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0, 2, 0, 0};
    std::vector<uint32_t> remap(5);
    EXPECT_EQ(weld_positions(remap.data(), p.data(), 5), 3u);
    EXPECT_EQ(remap, (std::vector<uint32_t>{0, 1, 0, 1, 4}));
}

// Exact mode compares bits, so positions 1 ulp apart stay separate.
TEST(weld_positions, ExactIsBitEquality) {
    const float a = 1.0f, b = std::nextafter(1.0f, 2.0f);
    const std::vector<float> p = {a, 0, 0, b, 0, 0};
    std::vector<uint32_t> remap(2);
    EXPECT_EQ(weld_positions(remap.data(), p.data(), 2), 2u);
    EXPECT_EQ(remap, (std::vector<uint32_t>{0, 1}));
}

// -0 and +0 are the same position (mirror modifiers write both).
TEST(weld_positions, NegativeZeroEqualsPositiveZero) {
    const std::vector<float> p = {0.0f, -0.0f, 1.0f, -0.0f, 0.0f, 1.0f};
    std::vector<uint32_t> remap(2);
    EXPECT_EQ(weld_positions(remap.data(), p.data(), 2), 1u);
    EXPECT_EQ(remap[1], 0u);
}

// The result depends on positions and indices only: the representative is always the lowest index,
// wherever it sits in the array.
TEST(weld_positions, RepresentativeIsLowestIndex) {
    const std::vector<float> p = {5, 5, 5, 1, 1, 1, 5, 5, 5, 1, 1, 1, 5, 5, 5};
    std::vector<uint32_t> remap(5);
    EXPECT_EQ(weld_positions(remap.data(), p.data(), 5), 2u);
    EXPECT_EQ(remap, (std::vector<uint32_t>{0, 1, 0, 1, 0}));
}

// stride_floats skips interleaved attributes (xyz + uv here).
TEST(weld_positions, Stride) {
    const std::vector<float> p = {1, 2, 3, 0.0f, 0.0f, 4, 5, 6, 0.5f, 0.5f, 1, 2, 3, 0.9f, 0.1f};
    std::vector<uint32_t> remap(3);
    EXPECT_EQ(weld_positions(remap.data(), p.data(), 3, 5), 2u);
    EXPECT_EQ(remap, (std::vector<uint32_t>{0, 1, 0}));
}

// With a tolerance, points closer than it (Euclidean, absolute) weld, farther ones do not.
TEST(weld_positions, ToleranceWeldsNearPoints) {
    const std::vector<float> p = {0, 0, 0, 0.0009f, 0, 0, 0, 0.0011f, 0, 3, 3, 3};
    std::vector<uint32_t> remap(4);
    EXPECT_EQ(weld_positions(remap.data(), p.data(), 4, 3, 1e-3), 3u);
    EXPECT_EQ(remap, (std::vector<uint32_t>{0, 0, 2, 3}));
}

// Points on opposite sides of a grid cell boundary are still found (neighbouring cells are searched).
TEST(weld_positions, ToleranceAcrossCellBoundary) {
    const std::vector<float> p = {0.0999f, 0, 0, 0.1001f, 0, 0}; // cell boundary at 0.1 for tolerance 0.01
    std::vector<uint32_t> remap(2);
    EXPECT_EQ(weld_positions(remap.data(), p.data(), 2, 3, 0.01), 1u);
    EXPECT_EQ(remap[1], 0u);
}

// "Within tolerance" is not transitive: a chain a–b–c with |ab|,|bc| < t < |ac| welds b to a, while c
// stays on its own (it joins representatives only, never a vertex that was itself welded away).
TEST(weld_positions, ToleranceChainIsNotTransitive) {
    const std::vector<float> p = {0, 0, 0, 0.6f, 0, 0, 1.2f, 0, 0};
    std::vector<uint32_t> remap(3);
    EXPECT_EQ(weld_positions(remap.data(), p.data(), 3, 3, 1.0), 2u);
    EXPECT_EQ(remap, (std::vector<uint32_t>{0, 0, 2}));
}

// NaN has no distance to anything: bit-identical NaN positions weld (exact rule), nothing else does.
TEST(weld_positions, NonFinite) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    const std::vector<float> p = {nan, 0, 0, nan, 0, 0, 0, 0, 0, inf, 0, 0, inf, 0, 0};
    for (double tol : {0.0, 1e9}) {
        std::vector<uint32_t> remap(5);
        EXPECT_EQ(weld_positions(remap.data(), p.data(), 5, 3, tol), 3u) << tol;
        EXPECT_EQ(remap, (std::vector<uint32_t>{0, 0, 2, 3, 3})) << tol;
    }
}

// Nothing to weld: returns 0 and touches nothing.
TEST(weld_positions, Empty) {
    EXPECT_EQ(weld_positions(nullptr, nullptr, 0), 0u);
}

// A tolerance weld of many random points agrees with the brute-force definition, and repeated runs
// agree with each other (determinism).
TEST(weld_positions, ToleranceMatchesBruteForce) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const size_t n = 2000;
    std::vector<float> p(3 * n);
    for (float& x : p) x = u(rng);
    const double tol = 0.03;
    std::vector<uint32_t> remap(n), again(n);
    size_t unique = weld_positions(remap.data(), p.data(), n, 3, tol);
    weld_positions(again.data(), p.data(), n, 3, tol);
    EXPECT_EQ(remap, again);

    std::vector<uint32_t> expect(n);
    size_t expect_unique = 0;
    for (size_t i = 0; i < n; ++i) {
        expect[i] = uint32_t(i);
        for (size_t j = 0; j < i; ++j) {
            if (expect[j] != j) continue;
            double d2 = 0;
            for (int k = 0; k < 3; ++k) d2 += std::pow(double(p[3 * i + k]) - double(p[3 * j + k]), 2);
            if (d2 <= tol * tol) {
                expect[i] = uint32_t(j);
                break;
            }
        }
        expect_unique += expect[i] == i;
    }
    EXPECT_EQ(unique, expect_unique);
    EXPECT_EQ(remap, expect);
}

// Exact mode against a reference (std::map of the bit patterns, -0 folded into +0, lowest index first) on
// 20000 vertices drawn from 3000 positions whose bits are random in all 96 (every radix digit varies,
// negative values, NaN and infinity patterns included), and on a grid whose high bits are all alike (the
// passes whose digit is the same everywhere are skipped).
TEST(weld_positions, ExactMatchesAMapOfTheBits) {
    std::mt19937 rng(20261126);
    auto fold = [](float f) { return f == 0.0f ? 0.0f : f; };
    auto bits = [&](float f) {
        f = fold(f);
        uint32_t u;
        std::memcpy(&u, &f, 4);
        return u;
    };
    for (int shape = 0; shape < 2; ++shape) {
        std::vector<float> pool;
        for (int i = 0; i < 3000; ++i)
            for (int k = 0; k < 3; ++k) {
                float f;
                if (shape == 0) {
                    const uint32_t u = rng();
                    std::memcpy(&f, &u, 4);
                    if (rng() % 16 == 0) f = rng() % 2 ? 0.0f : -0.0f;
                } else {
                    f = float(int(rng() % 64)) * 0.25f; // a grid: few distinct high digits
                }
                pool.push_back(f);
            }
        std::vector<float> p;
        for (int v = 0; v < 20000; ++v) {
            const size_t i = rng() % 3000;
            p.insert(p.end(), pool.begin() + std::ptrdiff_t(3 * i), pool.begin() + std::ptrdiff_t(3 * i + 3));
        }
        std::map<std::array<uint32_t, 3>, uint32_t> first;
        std::vector<uint32_t> want(20000);
        for (uint32_t v = 0; v < 20000; ++v)
            want[v] = first.emplace(std::array<uint32_t, 3>{bits(p[3 * v]), bits(p[3 * v + 1]), bits(p[3 * v + 2])}, v).first->second;
        std::vector<uint32_t> remap(20000);
        EXPECT_EQ(weld_positions(remap.data(), p.data(), 20000), first.size()) << "shape " << shape;
        EXPECT_EQ(remap, want) << "shape " << shape;
        // Each of the exact weld's two ways alone (weld_positions hashes, and sorts when the probes run out).
        std::vector<uint32_t> hashed(20000, 0), sorted(20000, 0);
        size_t unique = 0;
        ASSERT_TRUE(furrow::mesh_detail::weld_exact_hashed(hashed.data(), unique, p.data(), 20000, 3, 16 * 20000));
        EXPECT_EQ(unique, first.size());
        EXPECT_EQ(hashed, want) << "hashed, shape " << shape;
        EXPECT_EQ(furrow::mesh_detail::weld_exact_sorted(sorted.data(), p.data(), 20000, 3), first.size());
        EXPECT_EQ(sorted, want) << "sorted, shape " << shape;
        // Out of probes (the budget crafted collisions would exhaust): the hash gives up, the caller sorts.
        EXPECT_FALSE(furrow::mesh_detail::weld_exact_hashed(hashed.data(), unique, p.data(), 20000, 3, 10));
    }
}

// The fold clamp's roots (shell_frame.cpp): first_root_in_unit, split into its shortcuts
// (settled_root_in_unit) and a bisection that runs kBisectionLanes quadratics side by side
// (first_roots_by_bisection). The clamp's limits, and so the shells' bytes, depend on every bit of the
// roots: both must give what the one-function version gave, held here against a copy of it on random
// quadratics with a root in (0, 1), dips below zero inside, near-double roots and scales from 1e-12 to 1e3.
#include "../../shells/src/shells_internal.h"

#include <gtest/gtest.h>

#include "test_support.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

using namespace furrow;

namespace {

// first_root_in_unit as it was written before the split (main 4b9d36d).
double reference_root(double a, double b, double c) {
    if (a <= 0) return 0;
    auto q = [&](double k) { return a + b * k + c * k * k; };
    if (q(1) >= 0) {
        if (c > 0) {
            double km = -b / (2 * c);
            if (!(km > 0 && km < 1 && q(km) < 0)) return 1;
        } else {
            return 1;
        }
    }
    double lo = 0, hi = 1;
    if (q(1) >= 0) hi = -b / (2 * c);
    for (int i = 0; i < 60; ++i) {
        double mid = 0.5 * (lo + hi);
        (q(mid) >= 0 ? lo : hi) = mid;
    }
    return lo;
}

using furrow::test::splitmix64;
double uniform(uint64_t& s, double lo, double hi) { return lo + (hi - lo) * furrow::test::unit_uniform(s); }

bool same_bits(double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; }

struct Quadratic {
    double a, b, c;
};

// A·(x − r1)·(x − r2), with r1 mostly in (0, 1) and r2 anywhere, near r1 or past the unit interval.
std::vector<Quadratic> random_quadratics(size_t n) {
    uint64_t s = 7;
    std::vector<Quadratic> out;
    for (size_t i = 0; i < n; ++i) {
        const double scale = std::pow(10.0, uniform(s, -12, 3)) * (splitmix64(s) % 4 == 0 ? -1 : 1);
        const double r1 = uniform(s, -0.1, 1.1);
        const double r2 = splitmix64(s) % 3 == 0 ? r1 + uniform(s, -1e-6, 1e-6) : uniform(s, -3, 3);
        out.push_back({scale * r1 * r2, -scale * (r1 + r2), scale});
    }
    return out;
}

} // namespace

TEST(fold_roots, ShortcutsAndScalarBisectionAreTheOneFunctionBitForBit) {
    size_t bisected = 0;
    for (const Quadratic& q : random_quadratics(200000)) {
        const double want = reference_root(q.a, q.b, q.c);
        ASSERT_TRUE(same_bits(shells_detail::first_root_in_unit(q.a, q.b, q.c), want)) << q.a << " " << q.b << " " << q.c;
        double k = -1, hi = -1;
        if (shells_detail::settled_root_in_unit(q.a, q.b, q.c, k, hi)) ASSERT_TRUE(same_bits(k, want));
        else ++bisected;
    }
    EXPECT_GT(bisected, 50000u); // the bisection is exercised, dips included
}

TEST(fold_roots, SideBySideBisectionIsTheScalarBitForBit) {
    constexpr int L = shells_detail::kBisectionLanes;
    std::vector<Quadratic> pending;
    std::vector<double> hi_of;
    size_t dips = 0, compared = 0;
    for (const Quadratic& q : random_quadratics(200000)) {
        double k, hi;
        if (shells_detail::settled_root_in_unit(q.a, q.b, q.c, k, hi)) continue;
        dips += hi < 1;
        pending.push_back(q), hi_of.push_back(hi);
    }
    for (size_t first = 0; first + L <= pending.size(); first += L) {
        double a[L], b[L], c[L], hi[L], out[L];
        for (int j = 0; j < L; ++j) a[j] = pending[first + j].a, b[j] = pending[first + j].b, c[j] = pending[first + j].c, hi[j] = hi_of[first + j];
        shells_detail::first_roots_by_bisection(out, a, b, c, hi);
        for (int j = 0; j < L; ++j, ++compared)
            ASSERT_TRUE(same_bits(out[j], reference_root(a[j], b[j], c[j]))) << a[j] << " " << b[j] << " " << c[j] << " lane " << j;
    }
    EXPECT_GT(compared, 50000u);
    EXPECT_GT(dips, 1000u);
}

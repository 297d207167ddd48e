// shells_detail::squared_distance (point_triangle_distance.h) must return CGAL's Simple_cartesian<double>
// point-triangle squared distance bit for bit: the medial-axis clamp compares these values, and its answers
// are held to CGAL's. Millions of queries over the cases where the arithmetic differs most: random triangles
// and points, needles, exactly collinear and zero-area triangles (CGAL's three-edge fallback), a 1e6 offset,
// scales 1e-9..1e9, overflowing coordinates (NaN paths), and points on or a hair off the corners, the edges
// and the plane (the region tests' ties). One prepared triangle answers many points, as owned_lengths uses it.
#include "../../shells/src/point_triangle_distance.h"

#include <gtest/gtest.h>

#include "test_support.h"

#include <CGAL/Simple_cartesian.h>

#include <bit>
#include <cmath>
#include <cstdint>

namespace {

using K = CGAL::Simple_cartesian<double>;

using furrow::test::splitmix64;
using furrow::test::unit_uniform;
double signed_unit(uint64_t& s) { return 2 * unit_uniform(s) - 1; }

// Corners t[0..2] and a point p, by kind; every coordinate then scaled and offset.
struct Case {
    double t[3][3], p[3];
};

void lerp(double* out, const double* a, const double* b, double s) {
    for (int k = 0; k < 3; ++k) out[k] = a[k] + s * (b[k] - a[k]);
}

Case make_case(uint64_t& s, int kind) {
    Case c;
    for (auto& v : c.t)
        for (double& x : v) x = signed_unit(s);
    for (double& x : c.p) x = 2 * signed_unit(s);
    switch (kind) {
    case 0: break; // random
    case 1: // needle: two corners 1e-8..1e-14 apart
        for (int k = 0; k < 3; ++k) c.t[1][k] = c.t[0][k] + std::ldexp(signed_unit(s), -27 - int(splitmix64(s) % 20));
        break;
    case 2: { // exactly collinear: integer steps along an integer direction (the normal is exactly zero)
        const double o[3] = {double(splitmix64(s) % 9) - 4, double(splitmix64(s) % 9) - 4, double(splitmix64(s) % 9) - 4};
        const double d[3] = {double(splitmix64(s) % 5) - 2, double(splitmix64(s) % 5) - 2, double(splitmix64(s) % 5) - 2};
        for (int i = 0; i < 3; ++i) {
            const double step = double(splitmix64(s) % 7) - 3;
            for (int k = 0; k < 3; ++k) c.t[i][k] = o[k] + step * d[k];
        }
        for (double& x : c.p) x = 4 * signed_unit(s);
        break;
    }
    case 3: // zero area: a repeated corner, or all three the same
        for (int k = 0; k < 3; ++k) c.t[splitmix64(s) % 3 == 0 ? 2 : 1][k] = c.t[0][k];
        break;
    case 4: { // a hair off a corner
        const int v = int(splitmix64(s) % 3);
        for (int k = 0; k < 3; ++k) c.p[k] = c.t[v][k] + std::ldexp(signed_unit(s), -20 - int(splitmix64(s) % 30));
        break;
    }
    case 5: { // on or a hair off an edge (and outside it along the edge's line)
        const int v = int(splitmix64(s) % 3);
        lerp(c.p, c.t[v], c.t[(v + 1) % 3], 1.5 * unit_uniform(s) - 0.25);
        if (splitmix64(s) % 2)
            for (double& x : c.p) x += std::ldexp(signed_unit(s), -25 - int(splitmix64(s) % 25));
        break;
    }
    case 6: { // in the plane (inside or just outside), or just above it
        double q[3];
        lerp(q, c.t[0], c.t[1], unit_uniform(s));
        lerp(c.p, q, c.t[2], 1.2 * unit_uniform(s) - 0.1);
        if (splitmix64(s) % 2)
            for (double& x : c.p) x += std::ldexp(signed_unit(s), -30);
        break;
    }
    case 7: // on a corner exactly
        for (int k = 0; k < 3; ++k) c.p[k] = c.t[splitmix64(s) % 3][k];
        break;
    default: break;
    }
    return c;
}

double cgal_distance(const Case& c) {
    auto pt = [](const double* x) { return K::Point_3(x[0], x[1], x[2]); };
    return CGAL::squared_distance(pt(c.p), K::Triangle_3(pt(c.t[0]), pt(c.t[1]), pt(c.t[2])));
}

void transform(Case& c, double scale, double offset) {
    for (auto& v : c.t)
        for (double& x : v) x = x * scale + offset;
    for (double& x : c.p) x = x * scale + offset;
}

} // namespace

TEST(point_triangle_distance, CgalBitsOnMillionsOfQueries) {
    uint64_t seed = 13;
    const double scales[] = {1.0, 1e-9, 1e-3, 1e3, 1e9, 1e160};
    const double offsets[] = {0.0, 1e6, -1e6 + 0.5};
    size_t checked = 0, flat = 0;
    for (int round = 0; round < 2'000'000; ++round) {
        const int kind = round % 8;
        Case c = make_case(seed, kind);
        const size_t si = splitmix64(seed) % 12; // mostly unit scale
        const double scale = si < 6 ? 1.0 : scales[si - 6];
        const double offset = splitmix64(seed) % 3 == 0 ? offsets[splitmix64(seed) % 3] : 0.0;
        transform(c, scale, offset);
        const double want = cgal_distance(c);
        const double got = furrow::shells_detail::squared_distance(c.p, c.t[0], c.t[1], c.t[2]);
        ASSERT_EQ(std::bit_cast<uint64_t>(got), std::bit_cast<uint64_t>(want))
            << "round " << round << " kind " << kind << ": " << got << " vs CGAL " << want;
        furrow::shells_detail::PreparedTriangle T;
        furrow::shells_detail::prepare_triangle(T, c.t[0], c.t[1], c.t[2]);
        flat += T.flat;
        ++checked;
        if (round % 64 == 0) { // one prepared triangle, many points around it
            for (int i = 0; i < 32; ++i) {
                Case q = make_case(seed, 4 + i % 4);
                for (int v = 0; v < 3; ++v)
                    for (int k = 0; k < 3; ++k) q.t[v][k] = c.t[v][k];
                if (i % 4 == 0)
                    for (double& x : q.p) x = x * scale + offset;
                const double w = cgal_distance(q), g = furrow::shells_detail::squared_distance(T, q.p);
                ASSERT_EQ(std::bit_cast<uint64_t>(g), std::bit_cast<uint64_t>(w)) << "round " << round << " point " << i;
                ++checked;
            }
        }
    }
    EXPECT_GT(flat, 250'000u); // the collinear and zero-area kinds reached CGAL's three-edge fallback
    EXPECT_GT(checked, 2'900'000u);
}

// The region tests' branches each return CGAL's answer: points placed in each of the seven regions of a
// fixed triangle (inside, beyond each edge, beyond each corner) give CGAL's bits, and their distances are
// the expected ones (so a region swap in the code cannot hide behind equal distances).
TEST(point_triangle_distance, EveryRegionIsCgals) {
    const double a[3] = {0, 0, 0}, b[3] = {4, 0, 0}, c[3] = {0, 4, 0};
    const double points[][4] = { // x, y, z, expected squared distance
        {1, 1, 3, 9},     {2, -3, 1, 10},  {-2, 2, -1, 5}, {3, 3, 0, 2}, // inside; beyond edge ab, ca, bc
        {-1, -2, 0, 5},   {6, -1, 2, 9},   {-1, 7, 0, 10}, // beyond corner a, b, c
    };
    for (const auto& q : points) {
        Case cs;
        for (int k = 0; k < 3; ++k) cs.t[0][k] = a[k], cs.t[1][k] = b[k], cs.t[2][k] = c[k], cs.p[k] = q[k];
        const double got = furrow::shells_detail::squared_distance(cs.p, a, b, c);
        EXPECT_EQ(std::bit_cast<uint64_t>(got), std::bit_cast<uint64_t>(cgal_distance(cs))) << q[0] << " " << q[1] << " " << q[2];
        EXPECT_EQ(got, q[3]) << q[0] << " " << q[1] << " " << q[2];
    }
}

// squared_distance_pair (two triangles, one per lane, the region chosen by masks) gives each lane CGAL's bits,
// over the same kinds of triangles and points, the two lanes of different kinds.
TEST(point_triangle_distance, PairLanesAreCgals) {
    uint64_t seed = 77;
    const double scales[] = {1.0, 1e-9, 1e-3, 1e3, 1e9, 1e160};
    for (int round = 0; round < 1'000'000; ++round) {
        Case c[2];
        const double scale = scales[splitmix64(seed) % 6 < 3 ? 0 : splitmix64(seed) % 6];
        const double offset = splitmix64(seed) % 3 == 0 ? 1e6 : 0.0;
        for (int i = 0; i < 2; ++i) {
            c[i] = make_case(seed, int(splitmix64(seed) % 8));
            transform(c[i], scale, offset);
        }
        c[1].p[0] = c[0].p[0], c[1].p[1] = c[0].p[1], c[1].p[2] = c[0].p[2]; // one point, two triangles
        if (round % 2) // the point placed for the second triangle
            for (int k = 0; k < 3; ++k) c[0].p[k] = c[1].p[k] = c[1].t[0][k] + (c[1].t[1][k] - c[1].t[0][k]) * 0.5;
        const double* a[2] = {c[0].t[0], c[1].t[0]};
        const double* b[2] = {c[0].t[1], c[1].t[1]};
        const double* t[2] = {c[0].t[2], c[1].t[2]};
        double got[2];
        furrow::shells_detail::squared_distance_pair(got, c[0].p, a, b, t);
        for (int i = 0; i < 2; ++i)
            ASSERT_EQ(std::bit_cast<uint64_t>(got[i]), std::bit_cast<uint64_t>(cgal_distance(c[i])))
                << "round " << round << " lane " << i << ": " << got[i] << " vs CGAL " << cgal_distance(c[i]);
    }
}

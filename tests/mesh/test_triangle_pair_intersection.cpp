// kernel::triangles_intersect (mesh/kernel/furrow_kernel/triangle_pair_intersection.h) against CGAL's own
// predicates, pair for pair: its certified shortcuts (CertainSide, the separating axes of certainly_apart,
// the axis-plane fold test) may only skip work whose outcome they have proven. The cases are the ones those
// shortcuts exist for: corners exactly on the other triangle's plane (integer lattices and their copies
// translated by one vector, as the lattice's shells are), coplanar neighbours, pairs that touch exactly, and
// the same moved by a few ulps (where a filter with too small an error bound answers wrongly), plus random
// pairs. The tests also check that their cases are the hard ones (both answers, every kind of shared corner,
// many pairs touching within their boxes) and that the separating axes answer a good share of them (a filter
// that never answers would pass the comparison vacuously). Removing the rounding bound of the separating
// axes, or flipping the sign of the axis-plane fold test, makes them fail.
#include <furrow_kernel/triangle_pair_intersection.h>

#include <gtest/gtest.h>

#include <CGAL/intersections.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

namespace {

using furrow::kernel::ExactKernel;
using furrow::kernel::ExactPoint;
using Tri = std::array<uint32_t, 3>;

// The decision triangles_intersect documents, with CGAL's predicates only.
bool reference(const std::vector<ExactPoint>& p, const Tri& a, const Tri& b) {
    int shared = 0;
    for (uint32_t x : a)
        for (uint32_t y : b) shared += x == y;
    const ExactKernel::Triangle_3 ta(p[a[0]], p[a[1]], p[a[2]]), tb(p[b[0]], p[b[1]], p[b[2]]);
    if (shared >= 2) {
        // The shared edge (u, v) and the two apices; three shared: a's corners, the apex against itself.
        std::vector<uint32_t> common, rest_a, rest_b;
        for (uint32_t x : a) (std::find(b.begin(), b.end(), x) != b.end() ? common : rest_a).push_back(x);
        for (uint32_t y : b)
            if (std::find(a.begin(), a.end(), y) == a.end()) rest_b.push_back(y);
        const uint32_t u = common[0], v = common[1];
        const uint32_t pa = rest_a.empty() ? common[2] : rest_a[0], pb = rest_b.empty() ? pa : rest_b[0];
        return CGAL::coplanar(p[u], p[v], p[pa], p[pb]) && CGAL::coplanar_orientation(p[u], p[v], p[pa], p[pb]) == CGAL::POSITIVE;
    }
    if (shared == 1) {
        int ia = 0, ib = 0;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                if (a[i] == b[j]) ia = i, ib = j;
        const ExactKernel::Segment_3 sa(p[a[(ia + 1) % 3]], p[a[(ia + 2) % 3]]), sb(p[b[(ib + 1) % 3]], p[b[(ib + 2) % 3]]);
        return CGAL::do_intersect(ta, sb) || CGAL::do_intersect(tb, sa);
    }
    return CGAL::do_intersect(ta, tb);
}

double ulps(double x, int k) {
    for (; k > 0; --k) x = std::nextafter(x, HUGE_VAL);
    for (; k < 0; ++k) x = std::nextafter(x, -HUGE_VAL);
    return x;
}

// Points of a small integer grid, a copy of it translated by t (a shell of the grid), and the same points
// moved by a few ulps: corner-on-plane, coplanar and exactly touching pairs in quantity.
struct Cloud {
    std::vector<ExactPoint> pts;
    explicit Cloud(std::mt19937& rng) {
        std::uniform_int_distribution<int> coin(0, 3), nudge(-3, 3);
        const double shifts[] = {0.45, 0.5, 0.225, 1.0 / 3.0, 0.0070312500000000007, 1e-9};
        const double t = shifts[rng() % 6];
        for (int copy = 0; copy < 3; ++copy)
            for (int k = 0; k < 3; ++k)
                for (int j = 0; j < 3; ++j)
                    for (int i = 0; i < 3; ++i) {
                        double x[3] = {double(i), double(j), double(k)};
                        for (double& c : x) {
                            if (copy >= 1) c += t;
                            if (copy == 2 && coin(rng) == 0) c = ulps(c, nudge(rng));
                        }
                        pts.emplace_back(x[0], x[1], x[2]);
                    }
    }
};

bool non_degenerate(const std::vector<ExactPoint>& p, const Tri& t) {
    return t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && !CGAL::collinear(p[t[0]], p[t[1]], p[t[2]]);
}

TEST(triangle_pair_intersection, AgreesWithCgalOnLatticesTheirShellsAndUlpMoves) {
    std::mt19937 rng(7);
    size_t pairs = 0, meeting = 0, by_shared[3] = {0, 0, 0};
    for (int cloud = 0; cloud < 60; ++cloud) {
        const Cloud c(rng);
        std::uniform_int_distribution<uint32_t> pick(0, uint32_t(c.pts.size() - 1)), near(0, 26);
        for (int n = 0; n < 4000; ++n) {
            // Corners near each other (one 3x3x3 block of one copy, or of two), so that most pairs touch.
            const uint32_t base_a = 27 * (rng() % 3), base_b = 27 * (rng() % 3);
            Tri a{base_a + near(rng), base_a + near(rng), base_a + near(rng)};
            Tri b{base_b + near(rng), base_b + near(rng), base_b + near(rng)};
            if (rng() % 4 == 0) b[rng() % 3] = a[rng() % 3]; // a shared corner
            if (rng() % 6 == 0) b[0] = a[0], b[1] = a[1];    // a shared edge
            if (rng() % 50 == 0) b = {pick(rng), pick(rng), pick(rng)};
            if (!non_degenerate(c.pts, a) || !non_degenerate(c.pts, b)) continue;
            int shared = 0;
            for (uint32_t x : a)
                for (uint32_t y : b) shared += x == y;
            const bool want = reference(c.pts, a, b);
            ASSERT_EQ(furrow::kernel::triangles_intersect(c.pts, a, b), want) << "cloud " << cloud << " pair " << n;
            ++pairs, meeting += want, ++by_shared[std::min(shared, 2)];
        }
    }
    // Both answers in quantity, and every kind of pair.
    EXPECT_GT(pairs, 100000u);
    EXPECT_GT(meeting, pairs / 10);
    EXPECT_LT(meeting, pairs * 9 / 10);
    for (size_t k : by_shared) EXPECT_GT(k, pairs / 20);
}

// certainly_apart (both forms) is never wrong, and decides many of the pairs whose corners lie on the other's
// plane (where CGAL's filters fail): the translated lattice's touching and near-touching pairs.
TEST(triangle_pair_intersection, SeparatingAxesNeverClaimAPairThatMeets) {
    std::mt19937 rng(11);
    size_t tried = 0, claimed = 0, segment_claimed = 0, touching = 0;
    for (int cloud = 0; cloud < 60; ++cloud) {
        const Cloud c(rng);
        std::uniform_int_distribution<uint32_t> near(0, 26);
        for (int n = 0; n < 4000; ++n) {
            const uint32_t base_a = 27 * (rng() % 3), base_b = 27 * (rng() % 3);
            const Tri a{base_a + near(rng), base_a + near(rng), base_a + near(rng)};
            const Tri b{base_b + near(rng), base_b + near(rng), base_b + near(rng)};
            if (!non_degenerate(c.pts, a) || !non_degenerate(c.pts, b)) continue;
            const auto& p = c.pts;
            const ExactKernel::Triangle_3 ta(p[a[0]], p[a[1]], p[a[2]]), tb(p[b[0]], p[b[1]], p[b[2]]);
            const bool meet = CGAL::do_intersect(ta, tb);
            const bool apart = furrow::kernel::certainly_apart(p[a[0]], p[a[1]], p[a[2]], p[b[0]], p[b[1]], p[b[2]]);
            ASSERT_FALSE(meet && apart) << "cloud " << cloud << " pair " << n;
            const bool seg_meet = CGAL::do_intersect(ta, ExactKernel::Segment_3(p[b[0]], p[b[1]]));
            const bool seg_apart = furrow::kernel::certainly_apart(p[a[0]], p[a[1]], p[a[2]], p[b[0]], p[b[1]]);
            ASSERT_FALSE(seg_meet && seg_apart) << "cloud " << cloud << " pair " << n;
            // Touching exactly or within ulps: the boxes meet (a filter without its error bound fails here).
            touching += CGAL::do_overlap(ta.bbox(), tb.bbox()) && !meet;
            ++tried, claimed += apart, segment_claimed += seg_apart;
        }
    }
    EXPECT_GT(tried, 100000u);
    EXPECT_GT(touching, tried / 10);
    EXPECT_GT(claimed, tried / 4);
    EXPECT_GT(segment_claimed, tried / 4);
}

// Random pairs in general position, of any size: the comparison without the lattice's structure.
TEST(triangle_pair_intersection, AgreesWithCgalOnRandomPairs) {
    std::mt19937 rng(3);
    size_t meeting = 0, pairs = 0;
    for (double scale : {1e-6, 1.0, 1e6}) {
        std::uniform_real_distribution<double> u(-scale, scale);
        std::vector<ExactPoint> p;
        for (int i = 0; i < 6000; ++i) p.emplace_back(u(rng), u(rng), u(rng));
        for (uint32_t i = 0; i + 6 <= p.size(); i += 6) {
            const Tri a{i, i + 1, i + 2};
            Tri b{i + 3, i + 4, i + 5};
            if (i % 18 == 6) b[0] = a[0];
            if (i % 18 == 12) b[0] = a[0], b[1] = a[1];
            ASSERT_EQ(furrow::kernel::triangles_intersect(p, a, b), reference(p, a, b));
            meeting += reference(p, a, b), ++pairs;
        }
    }
    EXPECT_GT(meeting, pairs / 10);
}

} // namespace

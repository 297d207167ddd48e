// feature_distance.cpp's ray query with a reach (free_distances(..., reach)): the bound lets the traversal stop
// early, and must never let the feature clamp miss a hit it would act on. Property test against the
// unbounded query on random meshes: within the reach, the same distance bit for bit; beyond it, +infinity (or
// the same distance); and the clamp compute_shell_frame derives from it (min(H, safe_fraction · distance /
// need) with reach = 2 · H · need / safe_fraction) identical.
#include "../../shells/src/shells_internal.h"
#include "../../shells/src/triangle_bvh.h"
#include "../../models/lattice.h"

#include <furrow/shapes.h>

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "test_support.h"

#include <CGAL/Simple_cartesian.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <iterator>
#include <limits>
#include <utility>
#include <vector>

using namespace furrow;

namespace {

using furrow::test::splitmix64;
using furrow::test::unit_uniform;

struct TriSoup {
    std::vector<double> points;
    std::vector<std::array<uint32_t, 3>> triangles;
};

// Vertex -> incident triangles (CSR, faces in increasing order), as compute_shell_frame hands the queries.
struct Rings {
    std::vector<uint32_t> start, faces;
};
Rings rings_of(const TriSoup& m) {
    const size_t W = m.points.size() / 3;
    Rings r;
    r.start.assign(W + 1, 0);
    for (const auto& t : m.triangles)
        for (uint32_t v : t) ++r.start[v + 1];
    for (size_t v = 0; v < W; ++v) r.start[v + 1] += r.start[v];
    r.faces.resize(r.start[W]);
    std::vector<uint32_t> fill(r.start.begin(), r.start.end() - 1);
    for (size_t f = 0; f < m.triangles.size(); ++f)
        for (uint32_t v : m.triangles[f]) r.faces[fill[v]++] = uint32_t(f);
    return r;
}

// One query per vertex (vertex order, or reversed), along a random unit direction, with a random length below
// max_length: the per-vertex clamps' input.
struct VertexQueries {
    std::vector<uint32_t> vertex;
    std::vector<double> dirs, lengths;
};
VertexQueries vertex_queries(size_t W, uint64_t seed, double max_length, bool reversed) {
    VertexQueries q;
    for (size_t k = 0; k < W; ++k) {
        const uint32_t v = uint32_t(reversed ? W - 1 - k : k);
        double d[3], len = 0;
        for (double& x : d) x = 2 * unit_uniform(seed) - 1, len += x * x;
        len = std::sqrt(len);
        q.vertex.push_back(v);
        q.dirs.insert(q.dirs.end(), {d[0] / len, d[1] / len, d[2] / len});
        q.lengths.push_back(max_length * unit_uniform(seed));
    }
    return q;
}

// A primitive's triangles on its welded positions (exact weld), faces with a repeated corner left out.
TriSoup from_primitive(Primitive p) {
    if (!p.face_sizes.empty()) triangulate(p);
    TriSoup m;
    std::vector<uint32_t> remap(p.vertex_count());
    weld_positions(remap.data(), p.positions.data(), p.vertex_count());
    for (size_t v = 0; v < p.vertex_count(); ++v)
        if (remap[v] == v) {
            m.points.insert(m.points.end(), {p.positions[3 * v], p.positions[3 * v + 1], p.positions[3 * v + 2]});
            remap[v] = uint32_t(m.points.size() / 3 - 1);
        } else {
            remap[v] = remap[remap[v]];
        }
    for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
        const std::array<uint32_t, 3> t{remap[p.indices[i]], remap[p.indices[i + 1]], remap[p.indices[i + 2]]};
        if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) m.triangles.push_back(t);
    }
    return m;
}

// Each triangle's box and its CGAL triangle: what the hierarchy tests build, and their brute-force reference.
void boxes_and_triangles(const TriSoup& m, std::vector<shells_detail::Box3>& boxes,
                         std::vector<CGAL::Simple_cartesian<double>::Triangle_3>& tris) {
    using Point = CGAL::Simple_cartesian<double>::Point_3;
    boxes.assign(m.triangles.size(), shells_detail::Box3{});
    tris.clear();
    for (size_t f = 0; f < m.triangles.size(); ++f) {
        std::array<Point, 3> c;
        for (size_t k = 0; k < 3; ++k) {
            const double* x = &m.points[3 * size_t(m.triangles[f][k])];
            boxes[f].add(x);
            c[k] = Point(x[0], x[1], x[2]);
        }
        tris.emplace_back(c[0], c[1], c[2]);
    }
}

// A soup's boxes and triangles with their bounds, largest extent and binary hierarchy: what the wide-node
// checks compare the 4-wide descents against.
struct SoupHierarchy {
    std::vector<shells_detail::Box3> boxes;
    std::vector<CGAL::Simple_cartesian<double>::Triangle_3> tris;
    shells_detail::Box3 all;
    double size = 0;
    shells_detail::BoxBvh binary;
};
SoupHierarchy soup_hierarchy(const TriSoup& m) {
    SoupHierarchy h;
    boxes_and_triangles(m, h.boxes, h.tris);
    for (const shells_detail::Box3& b : h.boxes) h.all.add(b);
    h.size = std::max({h.all.hi[0] - h.all.lo[0], h.all.hi[1] - h.all.lo[1], h.all.hi[2] - h.all.lo[2]});
    h.binary.build(h.boxes);
    return h;
}

// A soup of random triangles in the unit cube, sharing corners at random (so that rays start on surfaces).
TriSoup random_soup(uint64_t seed, size_t points, size_t triangles) {
    TriSoup m;
    for (size_t i = 0; i < 3 * points; ++i) m.points.push_back(unit_uniform(seed));
    while (m.triangles.size() < triangles) {
        const uint32_t a = uint32_t(splitmix64(seed) % points);
        std::array<uint32_t, 3> t{a, a, a};
        // Small triangles: corners near a (the nearest of a few random picks), so that rays meet some.
        for (int k = 1; k < 3; ++k) {
            double best = HUGE_VAL;
            for (int tries = 0; tries < 8; ++tries) {
                const uint32_t b = uint32_t(splitmix64(seed) % points);
                double d = 0;
                for (int c = 0; c < 3; ++c) d += std::pow(m.points[3 * b + c] - m.points[3 * a + c], 2);
                if (b != a && b != t[1] && d < best) best = d, t[size_t(k)] = b;
            }
        }
        if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) m.triangles.push_back(t);
    }
    return m;
}

void check_reach(const TriSoup& m, uint64_t seed, double scale) {
    const shells_detail::SurfaceIndex index(m.points, m.triangles);
    const size_t W = m.points.size() / 3;
    std::vector<uint32_t> qv;
    std::vector<double> dirs, reach, H, need;
    for (uint32_t v = 0; v < W; ++v)
        for (int k = 0; k < 2; ++k) {
            double d[3], len = 0;
            do {
                len = 0;
                for (double& x : d) x = 2 * unit_uniform(seed) - 1, len += x * x;
            } while (!(len > 1e-6 && len <= 1));
            len = std::sqrt(len);
            qv.push_back(v);
            dirs.insert(dirs.end(), {d[0] / len, d[1] / len, d[2] / len});
            H.push_back(scale * unit_uniform(seed));
            need.push_back(1 + unit_uniform(seed));
        }
    const double safe = 0.45;
    for (size_t q = 0; q < qv.size(); ++q) reach.push_back(2.0 * H[q] * need[q] / safe);
    std::vector<double> full(qv.size()), bounded(qv.size());
    shells_detail::free_distances(full.data(), index, qv.data(), dirs.data(), qv.size());
    shells_detail::free_distances(bounded.data(), index, qv.data(), dirs.data(), qv.size(), reach.data());
    size_t within = 0, beyond = 0;
    for (size_t q = 0; q < qv.size(); ++q) {
        if (full[q] <= reach[q]) {
            ++within;
            EXPECT_EQ(bounded[q], full[q]) << "query " << q;
        } else {
            ++beyond;
            EXPECT_TRUE(bounded[q] == full[q] || bounded[q] == std::numeric_limits<double>::infinity()) << "query " << q;
        }
        // The clamp as compute_shell_frame applies it.
        EXPECT_EQ(std::min(H[q], safe * bounded[q] / need[q]), std::min(H[q], safe * full[q] / need[q])) << "query " << q;
    }
    // Both cases occur, or the test would prove nothing.
    EXPECT_GT(within, qv.size() / 50);
    EXPECT_GT(beyond, qv.size() / 50);
}

} // namespace

TEST(free_distances_reach, RandomSoupsMatchTheUnboundedQuery) {
    for (uint64_t seed = 1; seed <= 6; ++seed) check_reach(random_soup(seed, 400, 600), seed * 77, 0.05);
}

TEST(free_distances_reach, ClosedAndNonManifoldMeshesMatchTheUnboundedQuery) {
    check_reach(from_primitive(shapes::torus(1.0f, 0.3f, 48, 24)), 11, 0.5);
    check_reach(from_primitive(shapes::icosphere(1.0f, 3)), 12, 1.0);
    // Axis-aligned walls meeting at non-manifold edges: rays along and across coplanar faces.
    check_reach(from_primitive(models::lattice_primitive(3)), 13, 1.0);
}

TEST(free_distances_reach, ZeroReachFindsOnlyWhatTouchesTheOrigin) {
    const TriSoup m = from_primitive(shapes::icosphere(1.0f, 2));
    const shells_detail::SurfaceIndex index(m.points, m.triangles);
    // Straight through the centre: the far side is 2 away.
    const uint32_t v = 0;
    const double* p = &m.points[0];
    const double len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    const double d[3] = {-p[0] / len, -p[1] / len, -p[2] / len};
    double full = 0, near = 0, far = 0;
    const double short_reach = 1.0, long_reach = 3.0;
    shells_detail::free_distances(&full, index, &v, d, 1);
    shells_detail::free_distances(&near, index, &v, d, 1, &short_reach);
    shells_detail::free_distances(&far, index, &v, d, 1, &long_reach);
    EXPECT_GT(full, 1.9);
    EXPECT_LT(full, 2.0 + 1e-9);
    EXPECT_EQ(near, std::numeric_limits<double>::infinity());
    EXPECT_EQ(far, full);
}

// CrossingTest::run's halvings: each crossing pair re-tested alone with its blamed corners' fur halved 1, 2, ...
// times (verify_crossings shortens by that many halvings in one round).
namespace {

// Runs the crossing test once with every vertex v moved by offset(v) (a zero offset: not moving).
template <class Offset>
size_t run_crossings(const TriSoup& m, Offset offset, std::vector<uint8_t>& hit, std::vector<uint8_t>& halvings) {
    const size_t W = m.points.size() / 3;
    const shells_detail::SurfaceIndex index(m.points, m.triangles);
    const Rings rings = rings_of(m);
    shells_detail::CrossingTest crossing(index, rings.start.data(), rings.faces.data());
    std::vector<double> shell(m.points);
    std::vector<uint8_t> moving(W, 0);
    for (size_t v = 0; v < W; ++v) {
        const std::array<double, 3> d = offset(v);
        for (size_t k = 0; k < 3; ++k) shell[3 * v + k] += d[k];
        moving[v] = d[0] != 0 || d[1] != 0 || d[2] != 0;
    }
    hit.assign(W, 0);
    halvings.assign(W, 0);
    return crossing.run(hit.data(), shell, moving, nullptr, halvings.data(), 6);
}

} // namespace

TEST(crossing_halvings, APairClearsAtItsOwnScale) {
    // A floor triangle whose shell tilts up through a ceiling triangle 1 above: corners lifted by 0.2, 0.2
    // and 2.4 cross the ceiling, so do 0.1, 0.1 and 1.2 (one halving); 0.05, 0.05, 0.6 (two) clear it.
    TriSoup m;
    m.points = {0, 0, 0, 4, 0, 0, 0, 4, 0, -1, -1, 1, 6, -1, 1, -1, 6, 1};
    m.triangles = {{0, 1, 2}, {3, 4, 5}};
    std::vector<uint8_t> hit, halvings;
    const size_t pairs = run_crossings(m, [](size_t v) {
        return v < 2 ? std::array<double, 3>{0, 0, 0.2} : v == 2 ? std::array<double, 3>{0, 0, 2.4} : std::array<double, 3>{0, 0, 0};
    }, hit, halvings);
    EXPECT_EQ(pairs, 1u);
    for (size_t v = 0; v < 3; ++v) {
        EXPECT_EQ(hit[v], 1) << v;
        EXPECT_EQ(halvings[v], 2) << v;
    }
    for (size_t v = 3; v < 6; ++v) EXPECT_EQ(halvings[v], 0) << v; // the ceiling is not blamed
    // Lifted 0.2, 0.2, 1.6 instead: one halving (0.8 at most) clears it.
    run_crossings(m, [](size_t v) {
        return v < 2 ? std::array<double, 3>{0, 0, 0.2} : v == 2 ? std::array<double, 3>{0, 0, 1.6} : std::array<double, 3>{0, 0, 0};
    }, hit, halvings);
    for (size_t v = 0; v < 3; ++v) EXPECT_EQ(halvings[v], 1) << v;
}

TEST(crossing_halvings, FourWallEdgesCrossAtEveryScale) {
    // The non-manifold lattice moved as a whole along (1, 1, 1): every wall's shell cuts the perpendicular
    // walls through its edges however small the move (the crossing scales with it), so no number of
    // halvings clears a pair: 6 + 1 for every blamed corner.
    const TriSoup m = from_primitive(models::lattice_primitive(2));
    std::vector<uint8_t> hit, halvings;
    const size_t pairs = run_crossings(m, [](size_t) { return std::array<double, 3>{0.1, 0.1, 0.1}; }, hit, halvings);
    ASSERT_GT(pairs, 0u);
    size_t blamed = 0;
    for (size_t v = 0; v < hit.size(); ++v) {
        if (!hit[v]) continue;
        ++blamed;
        EXPECT_EQ(halvings[v], 7) << v;
    }
    EXPECT_GT(blamed, 0u);
}

// The medial-axis clamp's bisection test (shells_detail::witness_takes) answers as its definition does: the
// witness face's squared distance below ratio² × the smallest of the own faces' (CGAL's Simple_cartesian
// distances), whichever own face it tries first and however early it stops. Random fans of own faces around a
// corner, a random witness face, points around them; both answers occur.
TEST(witness_takes, AnswersAsTheDefinition) {
    using K = CGAL::Simple_cartesian<double>;
    uint64_t seed = 2026;
    size_t taken = 0, trials = 20000;
    for (size_t trial = 0; trial < trials; ++trial) {
        const uint32_t own_count = uint32_t(1 + trial % 7);
        std::vector<double> pts{0, 0, 0};
        std::vector<std::array<uint32_t, 3>> tris;
        for (uint32_t k = 0; k < own_count; ++k) {
            for (int c = 0; c < 6; ++c) pts.push_back(2 * unit_uniform(seed) - 1);
            tris.push_back({0, 1 + 2 * k, 2 + 2 * k});
        }
        const uint32_t witness = uint32_t(tris.size());
        for (int c = 0; c < 9; ++c) pts.push_back(2 * unit_uniform(seed) - 1 + 0.5);
        tris.push_back({uint32_t(pts.size() / 3 - 3), uint32_t(pts.size() / 3 - 2), uint32_t(pts.size() / 3 - 1)});
        std::vector<uint32_t> own(own_count);
        for (uint32_t k = 0; k < own_count; ++k) own[k] = k;
        const double x[3] = {2 * unit_uniform(seed) - 0.5, 2 * unit_uniform(seed) - 0.5, 2 * unit_uniform(seed) - 0.5};
        const double ratio = trial % 5 == 0 ? 1.0 : 0.98;
        auto tri = [&](uint32_t f) {
            auto p = [&](uint32_t v) { return K::Point_3(pts[3 * v], pts[3 * v + 1], pts[3 * v + 2]); };
            return K::Triangle_3(p(tris[f][0]), p(tris[f][1]), p(tris[f][2]));
        };
        const K::Point_3 px(x[0], x[1], x[2]);
        double nearest = std::numeric_limits<double>::infinity();
        for (uint32_t f : own) nearest = std::min(nearest, CGAL::squared_distance(px, tri(f)));
        const bool expected = CGAL::squared_distance(px, tri(witness)) < ratio * ratio * nearest;
        uint32_t hint = uint32_t(trial % own_count);
        ASSERT_EQ(shells_detail::witness_takes(pts, tris, x, witness, own, ratio, &hint), expected) << "trial " << trial;
        ASSERT_LT(hint, own_count);
        taken += expected;
    }
    EXPECT_GT(taken, trials / 10);
    EXPECT_LT(taken, trials - trials / 10);
}

// The crossing test's shortcut (shells_detail::planes_rule_out): the pair's planes alone rule a crossing out
// only where the full pair test finds none, and they do so for most pairs that do not cross. Random triangle
// pairs sharing 0, 1 or 2 corners, crossing and not, some exactly coplanar (a wall and its translated shell).
TEST(crossing_planes, RuleOutOnlyPairsThatDoNotCross) {
    uint64_t seed = 99;
    size_t ruled_out = 0, apart = 0, crossing = 0;
    for (int trial = 0; trial < 30000; ++trial) {
        std::vector<double> pts(18);
        for (double& x : pts) x = 2 * unit_uniform(seed) - 1;
        if (trial % 7 == 0) // all six corners in the plane z = 0.25
            for (size_t v = 0; v < 6; ++v) pts[3 * v + 2] = 0.25;
        std::array<uint32_t, 3> a{0, 1, 2}, b{3, 4, 5};
        const int shared = trial % 3;
        if (shared >= 1) b[0] = 0;
        if (shared == 2) b[1] = 1;
        bool crosses = false;
        const bool out = shells_detail::planes_rule_out(pts, a, b, &crosses);
        ASSERT_FALSE(out && crosses) << "trial " << trial << ": ruled out a crossing pair";
        ruled_out += out;
        apart += !crosses;
        crossing += crosses;
    }
    EXPECT_GT(crossing, 1000u);
    EXPECT_GT(ruled_out, apart / 2); // the shortcut must also work, not only be safe
}

// The crossing test's neighbour shortcut (shells_detail::fan_rules_out): a fan it certifies has no two
// triangles that cross (the full pair test, through planes_rule_out's answer), and it certifies most gently
// curved fans. Random fans around a centre: 4 to 12 spokes at sorted angles, heights from gentle to steep, the whole
// fan turned at random; some wound the other way, some folded (two spokes swapped), some wound twice, some
// exactly flat, some open (a border vertex) and some with a spoke repeated.
TEST(crossing_fans, CertifiedFansHaveNoCrossingPair) {
    uint64_t seed = 7;
    int certified = 0, crossing = 0, gentle = 0, gentle_certified = 0;
    const int trials = 6000;
    for (int trial = 0; trial < trials; ++trial) {
        const int kind = trial % 8; // 0-2 plain, 3 reversed, 4 folded, 5 twice around, 6 flat, 7 open or repeated
        const size_t n = 4 + splitmix64(seed) % 9;
        const double steep = kind == 0 ? 0.05 : 2.0 * unit_uniform(seed);
        const double turns = kind == 5 ? 2.0 : 1.0;
        // Evenly spread with a jitter (every sector under half a turn), or anywhere (kinds 1 and 2).
        std::vector<double> angle(n);
        for (size_t i = 0; i < n; ++i)
            angle[i] = kind == 1 || kind == 2 ? 2 * M_PI * unit_uniform(seed) : 2 * M_PI * turns * (double(i) + 0.6 * unit_uniform(seed) - 0.3) / double(n);
        std::sort(angle.begin(), angle.end());
        std::vector<double> local(3 * (n + 1), 0.0); // centre at 0, spoke ends at 1..n
        for (size_t i = 0; i < n; ++i) {
            const double r = 0.2 + unit_uniform(seed);
            local[3 * (i + 1)] = r * std::cos(angle[i]);
            local[3 * (i + 1) + 1] = r * std::sin(angle[i]);
            local[3 * (i + 1) + 2] = kind == 6 ? 0.0 : steep * (2 * unit_uniform(seed) - 1);
        }
        // A random rotation (kept off for the exactly flat fans), then a translation.
        std::vector<double> pts(local.size());
        const double a = 2 * M_PI * unit_uniform(seed), b = M_PI * unit_uniform(seed), c = 2 * M_PI * unit_uniform(seed);
        const double R[3][3] = {{std::cos(a) * std::cos(c) - std::sin(a) * std::cos(b) * std::sin(c), -std::cos(a) * std::sin(c) - std::sin(a) * std::cos(b) * std::cos(c), std::sin(a) * std::sin(b)},
                                {std::sin(a) * std::cos(c) + std::cos(a) * std::cos(b) * std::sin(c), -std::sin(a) * std::sin(c) + std::cos(a) * std::cos(b) * std::cos(c), -std::cos(a) * std::sin(b)},
                                {std::sin(b) * std::sin(c), std::sin(b) * std::cos(c), std::cos(b)}};
        for (size_t v = 0; v <= n; ++v)
            for (size_t k = 0; k < 3; ++k)
                pts[3 * v + k] = kind == 6 ? local[3 * v + k] + 0.25 : 3.0 + R[k][0] * local[3 * v] + R[k][1] * local[3 * v + 1] + R[k][2] * local[3 * v + 2];
        std::vector<std::array<uint32_t, 2>> spokes(n);
        for (uint32_t i = 0; i < n; ++i) spokes[i] = {i + 1, uint32_t((i + 1) % n + 1)};
        if (kind == 3)
            for (auto& s : spokes) std::swap(s[0], s[1]);
        if (kind == 4 && n >= 4) { // spokes 1 and 2 trade places: the fan folds over itself
            for (size_t k = 0; k < 3; ++k) std::swap(pts[3 + k], pts[6 + k]);
        }
        if (kind == 7) {
            if (trial % 16 == 7) spokes.pop_back();
            else spokes[n - 1][1] = spokes[0][1];
        }
        const bool ok = shells_detail::fan_rules_out(pts, 0, spokes);
        bool crosses = false;
        for (size_t i = 0; i < spokes.size(); ++i)
            for (size_t j = 0; j < i; ++j) {
                bool cross = false;
                (void)shells_detail::planes_rule_out(pts, {0, spokes[i][0], spokes[i][1]}, {0, spokes[j][0], spokes[j][1]}, &cross);
                crosses = crosses || cross;
            }
        ASSERT_FALSE(ok && crosses) << "trial " << trial << " (kind " << kind << ", " << n << " spokes): certified a fan that crosses itself";
        if (kind == 7) {
            ASSERT_FALSE(ok) << "trial " << trial << ": an open or repeated fan";
        }
        certified += ok;
        crossing += crosses;
        if (kind == 0) gentle_certified += ok, ++gentle;
    }
    EXPECT_GT(crossing, trials / 20);
    EXPECT_GT(certified, trials / 4);
    EXPECT_GT(gentle_certified, gentle * 9 / 10); // gently curved fans with wide enough sectors
}

// spokes_close (SSE2 compares) against its definition: random spoke sets around centre 0, most of them a
// cyclic fan of 3 to 32 spokes (some with the centre, a repeated corner, a spoke removed or reversed, or two
// fans together), others random pairs; next[i] checked where the fan closes.
TEST(crossing_fans, SpokesCloseAsTheDefinition) {
    uint64_t seed = 77;
    size_t closed = 0, open = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        const size_t n = 1 + splitmix64(seed) % 34;
        std::vector<std::array<uint32_t, 2>> spokes;
        if (splitmix64(seed) % 4) { // a fan: a permutation of ring corners 1..n, a_i -> b_i one cycle (or two)
            std::vector<uint32_t> ring(n);
            for (size_t i = 0; i < n; ++i) ring[i] = uint32_t(1 + i * 7);
            for (size_t i = n; i > 1; --i) std::swap(ring[i - 1], ring[splitmix64(seed) % i]);
            const size_t cut = splitmix64(seed) % 5 == 0 ? n / 2 : n; // two cycles
            for (size_t i = 0; i < n; ++i) {
                const size_t next = i < cut ? (i + 1 < cut ? i + 1 : 0) : (i + 1 < n ? i + 1 : cut);
                spokes.push_back({ring[i], ring[next]});
            }
            switch (splitmix64(seed) % 8) {
            case 0: spokes[splitmix64(seed) % n][splitmix64(seed) % 2] = 0; break;               // the centre
            case 1: spokes[splitmix64(seed) % n][1] = spokes[splitmix64(seed) % n][0]; break;   // a repeat
            case 2: spokes.erase(spokes.begin() + std::ptrdiff_t(splitmix64(seed) % n)); break; // open
            case 3: std::swap(spokes[0][0], spokes[0][1]); break;                                // reversed
            default: break;
            }
            for (size_t i = spokes.size(); i > 1; --i) std::swap(spokes[i - 1], spokes[splitmix64(seed) % i]);
        } else {
            for (size_t i = 0; i < n; ++i) spokes.push_back({uint32_t(splitmix64(seed) % 6), uint32_t(splitmix64(seed) % 6)});
        }
        // The definition.
        const size_t m = spokes.size();
        bool expected = m >= 3 && m <= 32;
        for (size_t i = 0; i < m; ++i) {
            const auto [a, b] = spokes[i];
            size_t as = 0, bs = 0, closes = 0;
            for (const auto& s : spokes) as += s[0] == a, bs += s[1] == b, closes += s[1] == a;
            expected = expected && a != 0 && b != 0 && a != b && as == 1 && bs == 1 && closes == 1;
        }
        std::vector<uint8_t> next;
        ASSERT_EQ(shells_detail::spokes_close_into_fan(0, spokes, next), expected) << "trial " << trial;
        for (size_t i = 0; expected && i < m; ++i) ASSERT_EQ(spokes[next[i]][0], spokes[i][1]) << "trial " << trial;
        closed += expected, open += !expected;
    }
    EXPECT_GT(closed, 5000u);
    EXPECT_GT(open, 5000u);
}

// The per-vertex queries answer in a spatially coherent order (coherent_order): a batch answers every query as
// that query alone does.
TEST(coherent_order, ABatchAnswersEachQueryAsAlone) {
    const TriSoup m = from_primitive(shapes::torus(1.0f, 0.3f, 48, 24));
    const shells_detail::SurfaceIndex index(m.points, m.triangles);
    const size_t W = m.points.size() / 3;
    const Rings rings = rings_of(m);
    const std::vector<uint32_t>&start = rings.start, &faces = rings.faces;
    // Every vertex (in reverse, so that query order and vertex order differ), along a random direction.
    const VertexQueries vq = vertex_queries(W, 5, 0.8, true);
    const std::vector<uint32_t>& qv = vq.vertex;
    const std::vector<double>&dirs = vq.dirs, &lengths = vq.lengths;
    const size_t n = qv.size();
    std::vector<double> owned(n, -1), rays(n, -1);
    shells_detail::owned_lengths(owned.data(), index, start.data(), faces.data(), qv.data(), dirs.data(), lengths.data(), 0.98, n);
    shells_detail::free_distances(rays.data(), index, qv.data(), dirs.data(), n);
    size_t clamped = 0;
    for (size_t q = 0; q < n; ++q) {
        double one = -1, ray = -1;
        shells_detail::owned_lengths(&one, index, start.data(), faces.data(), &qv[q], &dirs[3 * q], &lengths[q], 0.98, 1);
        shells_detail::free_distances(&ray, index, &qv[q], &dirs[3 * q], 1);
        ASSERT_EQ(owned[q], one) << "query " << q;
        ASSERT_EQ(rays[q], ray) << "query " << q;
        clamped += one < lengths[q];
    }
    EXPECT_GT(clamped, n / 20); // the bisection ran, not only the first test
}

// owned_lengths against its definition, over every face: a length is kept whole exactly where no other face
// comes nearer to x = p + h·d than `ratio` × x's distance to v's own faces, and a clamped length ends where x
// is still owned. The first test searches within a bound from one own face and measures the others only when
// a face comes within it (any_within_bounded): held here to the distances to all faces (CGAL's, whose bits the
// clamp's own distance reproduces). A torus (inner corners: the hole) with random directions and lengths.
TEST(owned_lengths, KeepsExactlyTheLengthsEveryFaceAllows) {
    using K = CGAL::Simple_cartesian<double>;
    const TriSoup m = from_primitive(shapes::torus(1.0f, 0.3f, 32, 16));
    const shells_detail::SurfaceIndex index(m.points, m.triangles);
    const size_t W = m.points.size() / 3;
    const Rings rings = rings_of(m);
    const VertexQueries vq = vertex_queries(W, 17, 0.6, false);
    const std::vector<uint32_t>& qv = vq.vertex;
    const std::vector<double>&dirs = vq.dirs, &lengths = vq.lengths;
    const double ratio = 0.98;
    std::vector<double> out(qv.size(), -1);
    shells_detail::owned_lengths(out.data(), index, rings.start.data(), rings.faces.data(), qv.data(), dirs.data(), lengths.data(), ratio,
                                 qv.size());
    auto tri = [&](uint32_t f) {
        auto pt = [&](uint32_t v) { return K::Point_3(m.points[3 * v], m.points[3 * v + 1], m.points[3 * v + 2]); };
        return K::Triangle_3(pt(m.triangles[f][0]), pt(m.triangles[f][1]), pt(m.triangles[f][2]));
    };
    auto owned_at = [&](size_t q, double t) {
        const uint32_t v = qv[q];
        const K::Point_3 x = K::Point_3(m.points[3 * v], m.points[3 * v + 1], m.points[3 * v + 2]) +
                             t * K::Vector_3(dirs[3 * q], dirs[3 * q + 1], dirs[3 * q + 2]);
        double own = HUGE_VAL, other = HUGE_VAL;
        const uint32_t* begin = &rings.faces[rings.start[v]];
        const uint32_t* end = &rings.faces[0] + rings.start[v + 1];
        for (uint32_t f = 0; f < m.triangles.size(); ++f) {
            double& nearest = std::find(begin, end, f) != end ? own : other;
            nearest = std::min(nearest, CGAL::squared_distance(x, tri(f)));
        }
        return !(other < ratio * ratio * own);
    };
    size_t whole = 0, clamped = 0;
    for (size_t q = 0; q < qv.size(); ++q) {
        const bool kept = out[q] == lengths[q];
        ASSERT_EQ(kept, owned_at(q, lengths[q])) << "vertex " << qv[q];
        ASSERT_TRUE(owned_at(q, out[q])) << "vertex " << qv[q];
        ASSERT_LE(out[q], lengths[q]);
        whole += kept, clamped += !kept;
    }
    EXPECT_GT(whole, qv.size() / 4);
    EXPECT_GT(clamped, qv.size() / 20);
}

// BoxBvh::build (binned SAH down to kSahDepth, median below) depends on nothing but the input (the clamps'
// searches report the first face they meet, so the tree's order is part of their answer): the same boxes give
// the same leaf order, which holds every box once, and every box is found by a query on itself (the
// bottom-up node boxes hold their leaves). Random boxes with many ties (centres on a coarse grid), and a
// grid where every centre is the same (no bin boundary to split at: the median split alone).
TEST(box_bvh, BuildIsDeterminedByTheInput) {
    using shells_detail::Box3;
    uint64_t seed = 31;
    for (size_t n : {1u, 3u, 4u, 5u, 17u, 1000u, 4099u}) {
        for (bool same_centre : {false, true}) {
            std::vector<Box3> boxes(n);
            for (Box3& b : boxes) {
                double lo[3], hi[3];
                for (int k = 0; k < 3; ++k) {
                    const double half = double(splitmix64(seed) % 3);
                    lo[k] = (same_centre ? 8.0 : double(splitmix64(seed) % 16)) - half, hi[k] = lo[k] + 2 * half;
                }
                b.add(lo), b.add(hi);
            }
            shells_detail::BoxBvh a, b;
            a.build(boxes);
            b.build(std::vector<Box3>(boxes));
            EXPECT_EQ(a.leaf_order(), b.leaf_order()) << n << " boxes";
            std::vector<uint32_t> ids = a.leaf_order();
            std::sort(ids.begin(), ids.end());
            ASSERT_EQ(ids.size(), n);
            for (uint32_t i = 0; i < n; ++i) ASSERT_EQ(ids[i], i);
            for (uint32_t i = 0; i < n; ++i) {
                bool found = false;
                a.for_overlapping(boxes[i], [&](uint32_t f) { found = found || f == i; });
                ASSERT_TRUE(found) << i;
            }
        }
    }
}

// On more than one thread, BoxBvh::build splits the first levels, builds the subtrees of at most 4096 boxes
// in parallel and places every node where one thread numbers it: the same tree, node for node and bit for
// bit, as one thread builds. Random boxes of mixed sizes (tens of thousands, so that there are subtrees to
// share out), a coarse grid with many ties, and one where every centre is the same (median splits only).
TEST(box_bvh, BuildOnTwoThreadsIsTheOneThreadTree) {
    using shells_detail::Box3;
    uint64_t seed = 77;
    for (int shape = 0; shape < 3; ++shape) {
        const size_t n = shape == 0 ? 50000 : 12000;
        std::vector<Box3> boxes(n);
        for (Box3& b : boxes) {
            double lo[3], hi[3];
            for (int k = 0; k < 3; ++k) {
                const double u = double(splitmix64(seed) % 1000000) / 1e6, size = double(splitmix64(seed) % 1000) / 1e5;
                lo[k] = shape == 0 ? u : shape == 1 ? double(splitmix64(seed) % 32) : 5.0;
                hi[k] = lo[k] + (shape == 0 ? size : double(splitmix64(seed) % 3));
            }
            b.add(lo), b.add(hi);
        }
        shells_detail::BoxBvh one, two;
        tbb::task_arena(1).execute([&] { one.build(boxes); });
        {
            const tbb::global_control allow(tbb::global_control::max_allowed_parallelism, 2); // (on a 1-core machine too)
            tbb::task_arena(2).execute([&] { two.build(boxes); });
        }
        EXPECT_TRUE(one.same_tree(two)) << "shape " << shape;
        EXPECT_EQ(one.leaf_order().size(), n);
    }
}

// The surface area heuristic can split one box off at a time (boxes doubling in size and distance: every
// bin boundary but the last few leaves one side nearly empty), so the build falls back to the median below
// kSahDepth: the depth, and with it every descent's stack, stays bounded. 400 boxes at x = 2^(i/2), each
// descent (box, ray, nearest on binary and wide nodes, the paired one) meets what it should (ASan would
// report a stack overflow).
TEST(box_bvh, SkewedBoxesStayWithinTheStacks) {
    using shells_detail::Box3;
    const size_t n = 400;
    std::vector<Box3> boxes(n);
    for (size_t i = 0; i < n; ++i) {
        const double x = std::ldexp(1.0, int(i / 2)) * (i % 2 ? 1.5 : 1.0);
        const double lo[3] = {x, 0, 0}, hi[3] = {2 * x, 1, 1};
        boxes[i].add(lo), boxes[i].add(hi);
    }
    shells_detail::BoxBvh bvh;
    bvh.build(boxes);
    EXPECT_GT(bvh.depth(), 24); // a balanced tree of 400 boxes has 8 levels: the heuristic peeled boxes off
    EXPECT_LE(bvh.depth(), shells_detail::BoxBvh::kMaxDepth);
    // The searches (boxes grown by a margin of 1e-9 of the extent: they meet more than these boxes overlap)
    // meet every box they should.
    auto contains = [](std::vector<uint32_t> v, uint32_t i) { return std::find(v.begin(), v.end(), i) != v.end(); };
    for (uint32_t i = 0; i < n; ++i) {
        std::vector<uint32_t> found;
        bvh.for_overlapping(boxes[i], [&](uint32_t f) { found.push_back(f); });
        for (uint32_t j = 0; j < n; ++j) {
            if (boxes[j].overlaps(boxes[i])) {
                ASSERT_TRUE(contains(found, j)) << i << " " << j;
            }
        }
    }
    std::vector<std::pair<uint32_t, uint32_t>> pairs;
    bvh.overlapping_pairs(bvh, [](uint32_t a, uint32_t b, uint32_t, uint32_t, std::vector<std::pair<uint32_t, uint32_t>>& list) {
        list.emplace_back(std::min(a, b), std::max(a, b));
    }, pairs);
    std::sort(pairs.begin(), pairs.end());
    for (uint32_t a = 0; a + 1 < n; ++a) {
        if (boxes[a].overlaps(boxes[a + 1])) {
            ASSERT_TRUE(std::binary_search(pairs.begin(), pairs.end(), std::make_pair(a, a + 1))) << a;
        }
    }
    for (bool wide : {false, true}) {
        if (wide) bvh.widen();
        for (uint32_t i = 0; i < n; ++i) {
            const double p[3] = {boxes[i].lo[0], 0.5, 0.5};
            double r2 = 1e-6;
            std::vector<uint32_t> met;
            bvh.for_near(p, r2, [&](uint32_t f, double&) { met.push_back(f); return false; });
            ASSERT_TRUE(contains(met, i)) << i << (wide ? " (wide)" : "");
            const double o[3] = {p[0], -1.0, 0.5}, d[3] = {0, 1, 0};
            double t_max = HUGE_VAL;
            std::vector<uint32_t> hit;
            bvh.for_ray(o, d, t_max, [&](uint32_t f, double&) { hit.push_back(f); });
            ASSERT_TRUE(contains(hit, i)) << i << (wide ? " (wide)" : "");
        }
    }
}

// The build splits by keys in float (each box rounded, clamped to +-1e37): boxes beyond float's range (all
// one key), spread over float's denormals (a bin scale that overflows), or mixing both, still make a tree
// whose every descent meets each box, built the same from the same input.
TEST(box_bvh, FloatKeysOutOfRangeStillHoldEveryBox) {
    using shells_detail::Box3;
    struct Case {
        const char* name;
        double origin, step, size;
    };
    for (const Case& c : {Case{"beyond float", 1e300, 1e298, 1e297}, Case{"float denormals", 0.0, 1e-42, 1e-43},
                          Case{"mixed", -1e38, 3e37, 1e36}}) {
        const size_t n = 300;
        std::vector<Box3> boxes(n);
        for (size_t i = 0; i < n; ++i) {
            const double x = c.origin + c.step * double(i % 37) * (i % 2 ? 1 : -1), y = c.step * double(i / 37);
            const double lo[3] = {x, y, -c.size}, hi[3] = {x + c.size, y + c.size, c.size};
            boxes[i].add(lo), boxes[i].add(hi);
        }
        shells_detail::BoxBvh bvh, again;
        bvh.build(boxes);
        again.build(boxes);
        EXPECT_EQ(bvh.leaf_order(), again.leaf_order()) << c.name;
        EXPECT_LE(bvh.depth(), shells_detail::BoxBvh::kMaxDepth) << c.name;
        for (bool wide : {false, true}) {
            if (wide) bvh.widen();
            for (uint32_t i = 0; i < n; ++i) {
                bool found = false;
                bvh.for_overlapping(boxes[i], [&](uint32_t f) { found = found || f == i; });
                ASSERT_TRUE(found) << c.name << " " << i;
                const double p[3] = {boxes[i].lo[0], boxes[i].lo[1], 0.0};
                double r2 = c.size * c.size;
                bool near = false;
                bvh.for_near(p, r2, [&](uint32_t f, double&) { near = near || f == i; return false; });
                ASSERT_TRUE(near) << c.name << " " << i << (wide ? " (wide)" : "");
            }
        }
    }
}

// Box3::ray_entry_oblique (for_ray's test for a ray with no zero component) gives Box3::ray_entry's parameter bit
// for bit: random boxes and rays of either sign, origins on a box's faces and inside it, infinite and NaN
// coordinates, inverse directions that overflow, and t_max from 0 to infinity.
TEST(box_bvh, ObliqueRayEntryIsTheSlabTestsBits) {
    using shells_detail::Box3;
    uint64_t seed = 53;
    const double specials[] = {0.0, -0.0, 1.0, -1.0, 1e-310, -1e-310, 1e300, -1e300, HUGE_VAL, -HUGE_VAL, std::nan("")};
    auto value = [&](bool wild) {
        if (wild && splitmix64(seed) % 8 == 0) return specials[splitmix64(seed) % std::size(specials)];
        return double(int(splitmix64(seed) % 9) - 4) * (splitmix64(seed) % 2 ? 1.0 : 0.25);
    };
    size_t entered = 0, missed = 0;
    for (int trial = 0; trial < 200000; ++trial) {
        const bool wild = trial % 4 == 0;
        Box3 b;
        double c[2][3];
        for (auto& corner : c)
            for (double& x : corner) x = value(wild);
        b.add(c[0]), b.add(c[1]);
        double o[3], d[3], inv[3];
        for (int k = 0; k < 3; ++k) {
            o[k] = splitmix64(seed) % 3 == 0 ? (splitmix64(seed) % 2 ? b.lo[k] : b.hi[k]) : value(wild); // often on a face
            do d[k] = value(wild);
            while (d[k] == 0);
            inv[k] = 1.0 / d[k];
        }
        const double t_max = trial % 5 == 0 ? HUGE_VAL : double(splitmix64(seed) % 6);
        const double want = b.ray_entry(o, inv, d, t_max), got = b.ray_entry_oblique(o, inv, t_max);
        ASSERT_EQ(std::memcmp(&want, &got, sizeof want), 0) << "trial " << trial << ": " << want << " against " << got;
        (want == HUGE_VAL ? missed : entered) += 1;
    }
    EXPECT_GT(entered, 20000u);
    EXPECT_GT(missed, 20000u);
}

// BoxBvh::overlapping_pairs (the crossing test's candidates): every pair of primitives whose boxes overlap, each
// once, with their positions in the leaf order, against a brute-force reference: a tree with itself (each unordered pair of distinct primitives) and
// a tree against another shape's tree refitted to other boxes (as the shells' boxes on the base's shape), with
// empty boxes among them (primitives that take no part). Boxes on an integer grid: touching counts, and the
// trees' margins cannot join boxes a whole unit apart. Sizes from one leaf to enough node pairs that the
// parallel tasks' own descents do most of the work.
TEST(box_bvh, PairedDescentMeetsEveryOverlappingPair) {
    using shells_detail::Box3;
    using Pair = std::pair<uint32_t, uint32_t>;
    uint64_t seed = 47;
    auto random_boxes = [&](size_t n, bool with_empty) {
        std::vector<Box3> boxes(n);
        for (Box3& b : boxes) {
            if (with_empty && splitmix64(seed) % 7 == 0) continue; // empty: no part
            double lo[3], hi[3];
            for (int k = 0; k < 3; ++k) lo[k] = double(splitmix64(seed) % 24), hi[k] = lo[k] + double(splitmix64(seed) % 3);
            b.add(lo), b.add(hi);
        }
        return boxes;
    };
    for (size_t n : {1u, 5u, 17u, 300u, 4099u}) {
        const std::vector<Box3> base = random_boxes(n, false), other_boxes = random_boxes(n, true);
        shells_detail::BoxBvh a;
        a.build(base);
        shells_detail::BoxBvh b;
        b.refit(a, other_boxes);
        auto collect = [](const shells_detail::BoxBvh& x, const shells_detail::BoxBvh& y) {
            std::vector<Pair> found;
            const std::vector<uint32_t>&xl = x.leaf_order(), &yl = y.leaf_order();
            x.overlapping_pairs(y, [&](uint32_t f, uint32_t g, uint32_t i, uint32_t j, std::vector<Pair>& out) {
                EXPECT_EQ(xl[i], f); // the positions in the leaf order, as the caller's leaf-ordered data expects
                EXPECT_EQ(yl[j], g);
                out.emplace_back(f, g);
            }, found);
            return found;
        };
        // With itself: each unordered pair once, in either order.
        std::vector<Pair> self = collect(b, b), want_self;
        for (Pair& p : self) p = {std::min(p.first, p.second), std::max(p.first, p.second)};
        std::sort(self.begin(), self.end());
        for (uint32_t i = 0; i < n; ++i)
            for (uint32_t j = i + 1; j < n; ++j)
                if (other_boxes[i].overlaps(other_boxes[j])) want_self.emplace_back(i, j);
        EXPECT_EQ(self, want_self) << n << " boxes, with itself";
        // Against the other tree: every (b's, a's) pair once.
        std::vector<Pair> across = collect(b, a), want_across;
        std::sort(across.begin(), across.end());
        for (uint32_t i = 0; i < n; ++i)
            for (uint32_t j = 0; j < n; ++j)
                if (other_boxes[i].overlaps(base[j])) want_across.emplace_back(i, j);
        EXPECT_EQ(across, want_across) << n << " boxes, across";
        if (n == 4099) {
            EXPECT_GT(want_self.size(), 2 * n); // the trees overlap deeply, not only at a few leaves
        }
    }
}

// The paired descent tests leaf pairs on float copies of the boxes (rounded to nearest, which keeps lo <= hi
// between boxes): it meets every pair whose boxes overlap, and besides (within float's range) only pairs that
// miss by about the float rounding (here: pairs that overlap once each box grows by 1e-6 of the scale).
// Coordinates in float's denormals, around 1, near float's largest and beyond it (the float boxes then reach
// infinity: more pairs, none missed), with boxes that touch exactly, boxes that overlap by a quarter of a
// float's spacing, and boxes at +-0.
TEST(box_bvh, PairedDescentInFloatMissesNoOverlap) {
    using shells_detail::Box3;
    using Pair = std::pair<uint32_t, uint32_t>;
    uint64_t seed = 59;
    for (double scale : {1e-41, 1.0, 3e37, 1e39}) {
        const size_t n = 600;
        std::vector<Box3> boxes(n);
        for (size_t i = 0; i < n; ++i) {
            double lo[3], hi[3];
            for (int k = 0; k < 3; ++k) {
                const double u = double(splitmix64(seed) % 6001) / 1000 - 3, w = double(splitmix64(seed) % 1001) / 1000;
                lo[k] = i % 50 == 0 ? (i % 100 ? -0.0 : 0.0) : scale * u, hi[k] = lo[k] + scale * w;
            }
            if (i % 7 == 3) // touching the previous box exactly on x
                lo[0] = boxes[i - 1].hi[0], hi[0] = lo[0] + scale;
            if (i % 7 == 5) { // overlapping the previous box on x by a quarter of a float's spacing there
                const double x = boxes[i - 1].hi[0];
                lo[0] = x - std::abs(x) * 0x1p-26, hi[0] = lo[0] + scale;
                for (int k = 1; k < 3; ++k) lo[k] = boxes[i - 1].lo[k], hi[k] = boxes[i - 1].hi[k];
            }
            boxes[i].add(lo), boxes[i].add(hi);
        }
        shells_detail::BoxBvh a, b;
        a.build(boxes);
        b.refit(a, boxes); // refit: the leaf blocks the paired descent reads
        std::vector<Pair> found;
        b.overlapping_pairs(b, [](uint32_t f, uint32_t g, uint32_t, uint32_t, std::vector<Pair>& out) {
            out.emplace_back(std::min(f, g), std::max(f, g));
        }, found);
        std::sort(found.begin(), found.end());
        EXPECT_TRUE(std::adjacent_find(found.begin(), found.end()) == found.end()) << scale << ": a pair met twice";
        auto grown = [&](Box3 x, double by) {
            for (int k = 0; k < 3; ++k) x.lo[k] -= by, x.hi[k] += by;
            return x;
        };
        size_t overlapping = 0;
        for (uint32_t i = 0; i < n; ++i)
            for (uint32_t j = i + 1; j < n; ++j) {
                const bool met = std::binary_search(found.begin(), found.end(), Pair{i, j});
                if (boxes[i].overlaps(boxes[j])) {
                    ++overlapping;
                    ASSERT_TRUE(met) << scale << ": " << i << " " << j << " overlap";
                } else if (met && scale < 1e38) {
                    ASSERT_TRUE(grown(boxes[i], 1e-6 * scale).overlaps(grown(boxes[j], 1e-6 * scale))) << scale << ": " << i << " " << j;
                }
            }
        EXPECT_GT(overlapping, n) << scale; // (the test has pairs to miss)
    }
}

// BoxBvh::add_slabs: for_near skips nodes whose slab lies out of reach; every primitive within reach is still
// met, in the same order (the clamps' searches report the first face they meet), and the slabs do skip
// nodes. Queries above the torus's surface (the medial-axis clamp's kind) and anywhere around it.
TEST(box_bvh, SlabsSkipOnlyWhatIsOutOfReach) {
    using K = CGAL::Simple_cartesian<double>;
    using shells_detail::Box3;
    const TriSoup m = from_primitive(shapes::torus(1.0f, 0.3f, 96, 48));
    std::vector<Box3> boxes;
    std::vector<K::Triangle_3> tris;
    boxes_and_triangles(m, boxes, tris);
    shells_detail::BoxBvh plain, slabbed;
    plain.build(boxes);
    slabbed.build(boxes);
    slabbed.add_slabs([&](uint32_t f, double* out) {
        for (size_t c = 0; c < 3; ++c)
            for (size_t k = 0; k < 3; ++k) out[3 * c + k] = m.points[3 * size_t(m.triangles[f][c]) + k];
    }, 256);
    uint64_t seed = 8;
    size_t plain_visits = 0, slab_visits = 0, found = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        // A surface point lifted along its face's normal by h, reach r just short of h (or anything).
        const size_t f = splitmix64(seed) % tris.size();
        const K::Vector_3 n = CGAL::unit_normal(tris[f][0], tris[f][1], tris[f][2]);
        const double h = 0.02 + 0.2 * unit_uniform(seed);
        const K::Point_3 x = CGAL::centroid(tris[f]) + h * n;
        const double p[3] = {x.x(), x.y(), x.z()};
        const double r = trial % 4 == 0 ? 0.5 * unit_uniform(seed) : h * (0.9 + 0.1 * unit_uniform(seed));
        std::vector<uint32_t> near_plain, near_slab;
        auto run = [&](const shells_detail::BoxBvh& bvh, std::vector<uint32_t>& within, size_t& visits) {
            double r2 = r * r;
            bvh.for_near(p, r2, [&](uint32_t g, double&) {
                ++visits;
                if (CGAL::squared_distance(x, tris[g]) < r * r) within.push_back(g);
                return false;
            });
        };
        run(plain, near_plain, plain_visits);
        run(slabbed, near_slab, slab_visits);
        ASSERT_EQ(near_slab, near_plain) << "trial " << trial;
        found += !near_plain.empty();
    }
    EXPECT_GT(found, 300u);
    EXPECT_LT(slab_visits, plain_visits - plain_visits / 200); // the slabs prune
}

namespace {
// The slabs of a soup's faces (add_slabs over its corners), as SurfaceIndex gives them.
void add_soup_slabs(shells_detail::BoxBvh& bvh, const TriSoup& m) {
    bvh.add_slabs([&](uint32_t f, double* out) {
        for (size_t c = 0; c < 3; ++c)
            for (size_t k = 0; k < 3; ++k) out[3 * c + k] = m.points[3 * size_t(m.triangles[f][c]) + k];
    }, 256);
}
// A test ball for the near searches: with `lifted`, the centroid of face f lifted along its normal by h and a
// reach just short of h (owned_lengths' kind: the ball nearly touches the surface), else anywhere around the
// soup's box `all` (size: its extent) with a reach up to `reach` x size.
std::pair<CGAL::Simple_cartesian<double>::Point_3, double> test_ball(const std::vector<CGAL::Simple_cartesian<double>::Triangle_3>& tris,
                                                                      const shells_detail::Box3& all, double size, size_t f, bool lifted,
                                                                      double reach, uint64_t& seed) {
    using K = CGAL::Simple_cartesian<double>;
    if (lifted) {
        const double h = size * (0.01 + 0.1 * unit_uniform(seed));
        return {CGAL::centroid(tris[f]) + h * CGAL::unit_normal(tris[f][0], tris[f][1], tris[f][2]), h * (0.9 + 0.1 * unit_uniform(seed))};
    }
    const K::Point_3 x(all.lo[0] + (all.hi[0] - all.lo[0]) * (1.4 * unit_uniform(seed) - 0.2),
                       all.lo[1] + (all.hi[1] - all.lo[1]) * (1.4 * unit_uniform(seed) - 0.2),
                       all.lo[2] + (all.hi[2] - all.lo[2]) * (1.4 * unit_uniform(seed) - 0.2));
    return {x, size * reach * unit_uniform(seed)};
}
// The soup moved 1e6 from the origin (where the boxes' margin is largest against the faces).
TriSoup far_off(TriSoup m) {
    for (size_t i = 0; i < m.points.size(); i += 3) m.points[i] += 1e6, m.points[i + 1] -= 1e6, m.points[i + 2] += 1e6;
    return m;
}
} // namespace

// BoxBvh::widen: for_near on the 4-wide nodes meets every primitive within reach that the binary descent
// meets (the same set, in nearest-box-first order of its own), finds the same nearest distance, and never
// drops a primitive that lies within reach (brute force over all faces). Random soups, queries just above a
// torus's surface (the medial-axis clamp's kind) and anywhere around it, and the torus 1e6 from the origin
// (where the boxes' margin is largest against the faces).
namespace {
void check_wide(const TriSoup& m, uint64_t seed, bool lifted) {
    auto [boxes, tris, all, size, binary] = soup_hierarchy(m);
    add_soup_slabs(binary, m);
    shells_detail::BoxBvh wide = binary;
    wide.widen();
    size_t found = 0;
    for (int trial = 0; trial < 1500; ++trial) {
        const size_t f = splitmix64(seed) % tris.size();
        const auto [x, r] = test_ball(tris, all, size, f, lifted && trial % 4 != 0, 0.3, seed);
        const double p[3] = {x.x(), x.y(), x.z()};
        auto within = [&](const shells_detail::BoxBvh& bvh, bool wide_nodes) {
            std::vector<uint32_t> met;
            double r2 = r * r;
            auto f = [&](uint32_t g, double&) {
                if (CGAL::squared_distance(x, tris[g]) < r * r) met.push_back(g);
                return false;
            };
            wide_nodes ? bvh.for_near_wide(p, r2, f) : bvh.for_near_binary(p, r2, f);
            std::sort(met.begin(), met.end());
            return met;
        };
        const std::vector<uint32_t> a = within(binary, false), b = within(wide, true);
        ASSERT_EQ(b, a) << "trial " << trial;
        std::vector<uint32_t> brute;
        for (uint32_t g = 0; g < tris.size(); ++g)
            if (CGAL::squared_distance(x, tris[g]) < r * r) brute.push_back(g);
        ASSERT_EQ(b, brute) << "trial " << trial;
        found += !b.empty();
        // The nearest-point search (bound shrinking as it goes): the same distance as brute force.
        double best = HUGE_VAL, exact = HUGE_VAL;
        wide.for_near(p, best, [&](uint32_t g, double& bound) {
            bound = std::min(bound, CGAL::squared_distance(x, tris[g]));
            return false;
        });
        for (const auto& t : tris) exact = std::min(exact, CGAL::squared_distance(x, t));
        ASSERT_EQ(best, exact) << "trial " << trial;
    }
    EXPECT_GT(found, 150u);
}
} // namespace

TEST(box_bvh, WideNodesMeetWhatTheBinaryDescentMeets) {
    for (uint64_t seed = 1; seed <= 3; ++seed) check_wide(random_soup(seed, 400, 600), seed * 31, false);
    const TriSoup torus = from_primitive(shapes::torus(1.0f, 0.3f, 96, 48));
    check_wide(torus, 5, true);
    check_wide(far_off(torus), 6, true);
}

// BoxBvh::for_near_packet (owned_lengths' first tests, eight balls at once): each ball of a packet meets
// exactly the primitives for_near_wide meets for it alone, on AVX-512 and AVX2 lanes (where the processor has
// them) and ball by ball; and a ball is settled exactly when its own search returns true, with f settling a ball at
// primitives within a fraction of its reach (so that some balls settle early and others never do). Packets of
// 1 to 8 balls around neighbouring surface points, lifted as owned_lengths lifts them or anywhere around,
// far from the origin too.
namespace {
void check_packets(const TriSoup& m, uint64_t seed, bool lifted) {
    using K = CGAL::Simple_cartesian<double>;
    auto [boxes, tris, all, size, binary] = soup_hierarchy(m);
    add_soup_slabs(binary, m);
    shells_detail::BoxBvh bvh = binary;
    bvh.widen();
    constexpr int P = shells_detail::BoxBvh::kPacket;
    size_t met_total = 0, settled_total = 0, balls_total = 0;
    for (int trial = 0; trial < 400; ++trial) {
        double centre[P][3], r2[P];
        unsigned balls = 0;
        const int n = 1 + int(splitmix64(seed) % P);
        const size_t f0 = splitmix64(seed) % tris.size();
        for (int k = 0; k < n; ++k) {
            if (splitmix64(seed) % 5 == 0) continue; // a lane left out
            const size_t f = std::min(tris.size() - 1, f0 + splitmix64(seed) % 8); // neighbours in the soup's order
            const auto [x, r] = test_ball(tris, all, size, f, lifted && trial % 4 != 0, 0.2, seed);
            centre[k][0] = x.x(), centre[k][1] = x.y(), centre[k][2] = x.z(), r2[k] = r * r;
            balls |= 1u << k;
        }
        const double settle = 0.25 + 0.5 * unit_uniform(seed); // f settles a ball at a primitive within settle x its reach
        auto takes = [&](int k, uint32_t g) {
            const K::Point_3 x(centre[k][0], centre[k][1], centre[k][2]);
            return CGAL::squared_distance(x, tris[g]) < settle * settle * r2[k];
        };
        for (int lanes : {8, 4, 1}) { // (at most what the processor runs)
            // Every primitive met, per ball, against each ball searched alone.
            std::vector<std::vector<uint32_t>> met(P);
            const unsigned none = bvh.for_near_packet(centre, r2, balls, [&](int k, uint32_t g, uint32_t) {
                met[size_t(k)].push_back(g);
                return false;
            }, lanes);
            ASSERT_EQ(none, 0u);
            unsigned settled_alone = 0;
            for (int k = 0; k < P; ++k) {
                std::vector<uint32_t> alone;
                if (balls >> k & 1) {
                    double rr = r2[k];
                    bvh.for_near_wide(centre[k], rr, [&](uint32_t g, double&) {
                        alone.push_back(g);
                        return false;
                    });
                    double rs = r2[k];
                    if (bvh.for_near_wide(centre[k], rs, [&](uint32_t g, double&) { return takes(k, g); })) settled_alone |= 1u << k;
                }
                std::sort(alone.begin(), alone.end());
                std::sort(met[size_t(k)].begin(), met[size_t(k)].end());
                ASSERT_EQ(met[size_t(k)], alone) << "trial " << trial << " ball " << k << " lanes " << lanes;
                met_total += alone.size();
            }
            // Settling: the same balls as their own searches, each ball meeting nothing once settled.
            unsigned done = 0;
            const unsigned settled = bvh.for_near_packet(centre, r2, balls, [&](int k, uint32_t g, uint32_t) {
                EXPECT_FALSE(done >> k & 1) << "trial " << trial << " ball " << k;
                if (!takes(k, g)) return false;
                done |= 1u << k;
                return true;
            }, lanes);
            ASSERT_EQ(settled, settled_alone) << "trial " << trial << " lanes " << lanes;
            settled_total += size_t(__builtin_popcount(settled));
            balls_total += size_t(__builtin_popcount(balls));
        }
    }
    EXPECT_GT(met_total, 1000u);
    EXPECT_GT(settled_total, balls_total / 20); // both kinds of ball, settled and not, in every call
    EXPECT_LT(settled_total, balls_total * 19 / 20);
}
} // namespace

TEST(box_bvh, PacketMeetsWhatEachBallMeetsAlone) {
    for (uint64_t seed = 1; seed <= 2; ++seed) check_packets(random_soup(seed, 400, 600), seed * 41, false);
    const TriSoup torus = from_primitive(shapes::torus(1.0f, 0.3f, 96, 48));
    check_packets(torus, 9, true);
    check_packets(far_off(torus), 10, true);
}

// BoxBvh::for_ray after widen (for_ray_wide, oblique rays): the same primitives as the binary descent, each
// once, with t_max fixed (every box the ray enters before it) and, with t_max lowered to each hit as it is found
// (free_distances' nearest-hit search), the same nearest hit as brute force over all faces. Rays from the faces'
// corners (free_distances' kind: they start inside their neighbours' boxes) and from anywhere around, short and
// unbounded, some along an axis (those take the binary descent either way).
namespace {
void check_wide_rays(const TriSoup& m, uint64_t seed) {
    using K = CGAL::Simple_cartesian<double>;
    using shells_detail::Box3;
    auto [boxes, tris, all, size, binary] = soup_hierarchy(m);
    shells_detail::BoxBvh wide = binary;
    wide.widen();
    size_t met_some = 0, hits = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        double o[3], d[3];
        if (trial % 2 == 0) {
            const double* c = &m.points[3 * size_t(m.triangles[splitmix64(seed) % tris.size()][splitmix64(seed) % 3])];
            std::copy(c, c + 3, o);
        } else {
            for (int k = 0; k < 3; ++k) o[k] = all.lo[k] + (all.hi[k] - all.lo[k]) * (1.4 * unit_uniform(seed) - 0.2);
        }
        for (double& x : d) x = 2 * unit_uniform(seed) - 1;
        if (trial % 10 == 0) d[splitmix64(seed) % 3] = 0;
        const double t_max = trial % 3 == 0 ? HUGE_VAL : size * 0.2 * unit_uniform(seed);
        auto met = [&](const shells_detail::BoxBvh& bvh) {
            std::vector<uint32_t> ids;
            double t = t_max;
            bvh.for_ray(o, d, t, [&](uint32_t g, double&) { ids.push_back(g); });
            std::sort(ids.begin(), ids.end());
            return ids;
        };
        const std::vector<uint32_t> a = met(binary), b = met(wide);
        ASSERT_EQ(b, a) << "trial " << trial;
        met_some += !b.empty();
        // The nearest hit (ray parameter of CGAL's intersection point), t_max lowered as hits are found.
        const K::Ray_3 ray(K::Point_3(o[0], o[1], o[2]), K::Vector_3(d[0], d[1], d[2]));
        auto param = [&](const K::Triangle_3& t) {
            const auto hit = CGAL::intersection(ray, t);
            const K::Point_3* p = hit ? boost::get<K::Point_3>(&*hit) : nullptr;
            if (!p) return HUGE_VAL;
            const double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            return std::max(0.0, ((p->x() - o[0]) * d[0] + (p->y() - o[1]) * d[1] + (p->z() - o[2]) * d[2]) / dd); // at the origin: rounded below 0
        };
        double best = HUGE_VAL, t = HUGE_VAL, brute = HUGE_VAL;
        wide.for_ray(o, d, t, [&](uint32_t g, double& limit) {
            const double h = param(tris[g]);
            if (h < best) best = h, limit = std::min(limit, h * (1 + 1e-9) + 1e-300);
        });
        for (const auto& tri : tris) brute = std::min(brute, param(tri));
        ASSERT_EQ(best, brute) << "trial " << trial;
        hits += best != HUGE_VAL;
    }
    EXPECT_GT(met_some, 1000u);
    EXPECT_GT(hits, 300u);
}
} // namespace

TEST(box_bvh, WideNodesMeetWhatTheBinaryRayDescentMeets) {
    for (uint64_t seed = 1; seed <= 3; ++seed) check_wide_rays(random_soup(seed, 400, 600), seed * 37);
    const TriSoup torus = from_primitive(shapes::torus(1.0f, 0.3f, 96, 48));
    check_wide_rays(torus, 7);
    check_wide_rays(far_off(torus), 8);
}

// BoxBvh::widen's leaf blocks (near_in_block): a leaf's boxes tested four at once, the slots within reach met
// in slot order, a slot skipped once f has lowered the reach below its box, and the empty slots of a leaf of
// fewer than four never met. One leaf (at most four boxes), then a nearest search over random boxes whose
// every call must find its box still within the reach as f left it.
TEST(box_bvh, WideLeafBlocksMeetTheirSlotsInOrder) {
    using shells_detail::Box3;
    auto box = [](double x, double y, double z, double s) {
        Box3 b;
        const double lo[3] = {x, y, z}, hi[3] = {x + s, y + s, z + s};
        b.add(lo), b.add(hi);
        return b;
    };
    const double origin[3] = {0, 0, 0};
    for (size_t n = 1; n <= 4; ++n) {
        std::vector<Box3> boxes;
        for (size_t i = 0; i < n; ++i) boxes.push_back(box(0.3 * double(n - i), 0.1, 0.2, 0.05)); // nearest last
        shells_detail::BoxBvh bvh;
        bvh.build(boxes);
        bvh.widen();
        std::vector<uint32_t> met, slots;
        double r2 = 100;
        bvh.for_near_wide(origin, r2, [&](uint32_t g, double&, uint32_t j) {
            met.push_back(g), slots.push_back(j);
            return false;
        });
        ASSERT_EQ(met.size(), n);
        for (size_t k = 0; k < n; ++k) {
            EXPECT_EQ(slots[k], k) << n << " boxes"; // slot order, whatever the distances
            EXPECT_EQ(met[k], bvh.leaf_order()[k]);
        }
        // The first slot's f lowers the reach to nothing: no other slot is met.
        size_t calls = 0;
        r2 = 100;
        bvh.for_near_wide(origin, r2, [&](uint32_t, double& bound) {
            ++calls, bound = 0;
            return false;
        });
        EXPECT_EQ(calls, 1u) << n << " boxes";
        // An early stop at the second slot.
        calls = 0;
        r2 = 100;
        EXPECT_EQ(bvh.for_near_wide(origin, r2, [&](uint32_t, double&) { return ++calls == 2; }), n >= 2);
        EXPECT_EQ(calls, std::min<size_t>(n, 2));
    }
    uint64_t seed = 17;
    std::vector<Box3> boxes;
    for (int i = 0; i < 3000; ++i) boxes.push_back(box(unit_uniform(seed), unit_uniform(seed), unit_uniform(seed), 0.02 * unit_uniform(seed)));
    shells_detail::BoxBvh bvh;
    bvh.build(boxes);
    bvh.widen();
    for (int trial = 0; trial < 300; ++trial) {
        const double p[3] = {unit_uniform(seed), unit_uniform(seed), unit_uniform(seed)};
        double best = 0.01 + 0.1 * unit_uniform(seed), brute = best;
        for (const Box3& b : boxes) brute = std::min(brute, b.squared_distance(p) + 1e-12);
        bvh.for_near_wide(p, best, [&](uint32_t g, double& bound) {
            EXPECT_LT(boxes[g].squared_distance(p), bound + 2e-9) << "trial " << trial; // still within reach
            bound = std::min(bound, boxes[g].squared_distance(p) + 1e-12);
            return false;
        });
        ASSERT_EQ(best, brute) << "trial " << trial;
    }
}

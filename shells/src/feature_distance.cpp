// Ray casts, point-to-mesh distances and the shell/base intersection test of compute_shell_frame.
//
// References: P. Alliez, S. Tayeb, C. Wormser, "3D Fast Intersection and Distance Computation", CGAL User and
// Reference Manual (AABB Tree package), 5.5 (distances_to_mesh, what the benchmark measures with); the
// geometric tests at the leaves are CGAL's (Simple_cartesian constructions; Epick exact predicates for the
// intersection test; the point-triangle distances of the medial-axis clamp are CGAL's bits computed by
// point_triangle_distance.h), the traversal is triangle_bvh.h's. T. Möller, B. Trumbore, "Fast, Minimum Storage
// Ray/Triangle Intersection", JGT 2(1), 1997 (only as a loose pre-filter in front of CGAL's construction).
// The exact test of one pair of triangles is the kernel's (triangle_pair_intersection.h), shared with
// furrow::mesh's self-intersection count.
//
// One SurfaceIndex (hierarchy + CGAL triangles) is built per frame and shared by every query; every query
// loop is a TBB parallel_for writing only its own entries, so results do not depend on the thread count.
// The fast paths (box and plane pre-filters, certified signs) only ever skip work whose outcome they have
// proven; every answer is the one CGAL's own test gives.
//
// The per-vertex queries run in the hierarchy's leaf order (coherent_order), which no answer depends on: the
// queries wait on memory more than on arithmetic, and neighbouring queries read the same nodes.
//
// The only CGAL file of furrow::shells (its headers dominate compile time).
#include "point_triangle_distance.h"
#include "shells_internal.h"
#include "triangle_bvh.h"

#include <furrow_kernel/triangle_pair_intersection.h>

#include <furrow/shells.h>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Simple_cartesian.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <type_traits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace furrow {
namespace {

// Constructions (ray hit points, closest points) are all the clamps need, and they need them fast: the
// results only scale an offset by a safety fraction, so double rounding is harmless.
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using Ray = Kernel::Ray_3;
using Segment = Kernel::Segment_3;
using Triangle = Kernel::Triangle_3;

using Exact = CGAL::Exact_predicates_inexact_constructions_kernel;

// The pair decision of CGAL Polygon_mesh_processing::self_intersections (kernel::triangles_intersect, as in
// furrow::mesh's check), except for two triangles on the same three vertices: the shells of a duplicated
// base face coincide, which is one surface twice, not fur running into fur (check counts such a pair, as
// CGAL does; here it would shorten the fur of every duplicated face to nothing).
bool pair_intersects(const std::vector<Exact::Point_3>& pts, const std::array<uint32_t, 3>& a, const std::array<uint32_t, 3>& b) {
    const bool same_corners = std::is_permutation(a.begin(), a.end(), b.begin());
    return !same_corners && kernel::triangles_intersect(pts, a, b);
}

// The triangle with its corners moved `by` of the way toward `toward` (where `moved` says so).
Exact::Triangle_3 pulled(const std::vector<Exact::Point_3>& pts, const std::array<uint32_t, 3>& t, const std::array<bool, 3>& moved,
                         const std::array<double, 3>& toward, double by) {
    std::array<Exact::Point_3, 3> q;
    for (size_t k = 0; k < 3; ++k) {
        const Exact::Point_3& p = pts[t[k]];
        q[k] = moved[k] ? Exact::Point_3(p.x() + by * (toward[0] - p.x()), p.y() + by * (toward[1] - p.y()), p.z() + by * (toward[2] - p.z())) : p;
    }
    return Exact::Triangle_3(q[0], q[1], q[2]);
}

// A shell triangle (corner ids into pts: v < W at the base, W + v lifted) against a base triangle. Where the
// base face under the shell only *touches* that triangle in the input, at its border (a T-junction: a corner
// lying on another face without being one of its vertices, as printed models are often built: the stationary
// corner lies on the other face), the shell touches it there too: that contact is the input's, not the fur's. Such a pair is tested
// with the stationary corners moved a hair (1e-3 of the way) toward the moving ones, so that only the fur's
// own crossings count. A base face that crosses the other (a self-intersecting input) keeps the strict test.
bool shell_meets_base(const std::vector<Exact::Point_3>& pts, size_t W, const std::array<uint32_t, 3>& base_face,
                      const std::array<uint32_t, 3>& other, const std::array<uint32_t, 3>& shell) {
    if (!pair_intersects(pts, other, shell)) return false;
    size_t stationary = 0;
    for (uint32_t v : shell) stationary += v < W;
    if (stationary == 0 || stationary == 3 || !pair_intersects(pts, other, base_face)) return true;
    const Exact::Triangle_3 g(pts[other[0]], pts[other[1]], pts[other[2]]);
    bool corner_on_g = false; // the T-junction itself: a stationary corner lying on the other face
    for (uint32_t v : shell) corner_on_g = corner_on_g || (v < W && CGAL::do_intersect(g, pts[v]));
    if (!corner_on_g) return true;
    std::array<double, 3> centre{0, 0, 0};
    for (uint32_t v : base_face) centre[0] += pts[v].x() / 3, centre[1] += pts[v].y() / 3, centre[2] += pts[v].z() / 3;
    if (CGAL::do_intersect(g, pulled(pts, base_face, {true, true, true}, centre, 1e-3))) return true; // a real crossing
    std::array<double, 3> lifted{0, 0, 0};
    for (uint32_t v : shell)
        if (v >= W) lifted[0] += pts[v].x(), lifted[1] += pts[v].y(), lifted[2] += pts[v].z();
    for (double& x : lifted) x /= double(3 - stationary);
    return CGAL::do_intersect(g, pulled(pts, shell, {shell[0] < W, shell[1] < W, shell[2] < W}, lifted, 1e-3));
}

// Certainly no crossing between triangles a and b (ids into pts, neither collinear), decided from their
// planes alone (kernel::CertainSide; side_a is a's plane, b's is built only if a's does not decide): a
// certified sign is the exact one, so a triangle whose corners off the other's plane all lie strictly on one
// side of it meets that plane (and so the other triangle) at most in their shared corners, which the pair
// decision (kernel::triangles_intersect) does not count. False where the planes do not decide it: the full
// test then runs, so every answer is still that test's. Sharing two corners, the pair crosses only when it
// folds onto itself (coplanar): one apex certainly off the other's plane rules that out. Why: on the Stanford
// bunny (length 0.003) 450 k of the 452 k candidate pairs are shell against shell, 421 k of them neighbours
// sharing a corner or an edge, which the full test answered with two to four planes built per pair; the
// planes rule out 422 k pairs, and the candidate loop went from 316 M to 170 M instructions.
bool certainly_apart_by_planes(const std::vector<Exact::Point_3>& pts, const std::array<uint32_t, 3>& a, const kernel::CertainSide& side_a,
                               const std::array<uint32_t, 3>& b) {
    // The corners of `t` that are not corners of `u`, all strictly on one side of u's plane `side_u`?
    auto off_one_side = [&](const std::array<uint32_t, 3>& t, const std::array<uint32_t, 3>& u, const kernel::CertainSide& side_u) {
        int seen = 0;
        for (uint32_t v : t) {
            if (v == u[0] || v == u[1] || v == u[2]) continue;
            const int s = side_u(pts[v]);
            if (s == 0 || (seen != 0 && s != seen)) return false;
            seen = s;
        }
        return seen != 0; // all three shared: one triangle twice, left to the full test
    };
    return off_one_side(b, a, side_a) || off_one_side(a, b, kernel::CertainSide(pts[b[0]], pts[b[1]], pts[b[2]]));
}

// The most triangles a certified fan may have (the checks are quadratic in them; a mesh's fans have about 6).
constexpr size_t kMaxFan = 32;

// Do the spokes (a_i, b_i), i < n (the corners after c of each triangle (c, a_i, b_i) around c, in the mesh's
// winding) close into a fan: no corner is c, every a_i is distinct, every b_i is distinct and each a_i is some b_j?
// Then a_i -> b_i is a permutation of the ring (one or more cycles). Topology only: checked once per vertex.
// next[i]: the spoke j whose a_j is b_i (where they close).
bool spokes_close(uint32_t c, const std::array<uint32_t, 2>* spokes, size_t n, uint8_t* next) {
    if (n < 3 || n > kMaxFan) return false;
    // Each spoke against all: the corners side by side (padded with an id no vertex has), four compared at once,
    // the matches as bits (SSE2, the x86-64 baseline). Bunny callgrind (`furrow -j 1 -q shells --layers 2
    // --length 0.004`), the crossing test's state: 46.1 -> 36.4 M instructions (spokes_close 31.4 -> 20.9 M).
    alignas(16) uint32_t A[kMaxFan], B[kMaxFan];
    const size_t lanes = (n + 3) & ~size_t(3);
    for (size_t i = 0; i < lanes; ++i) A[i] = i < n ? spokes[i][0] : UINT32_MAX, B[i] = i < n ? spokes[i][1] : UINT32_MAX;
    auto one = [](uint32_t m) { return m != 0 && (m & (m - 1)) == 0; };
    bool ok = true; // decided without branches: which spokes match is unpredictable
    for (size_t i = 0; i < n; ++i) {
        const uint32_t a = A[i], b = B[i];
        uint32_t as = 0, bs = 0, closes = 0, at = 0; // bit j: a_j == a, b_j == b, b_j == a, a_j == b
#if defined(__SSE2__)
        const __m128i av = _mm_set1_epi32(int(a)), bv = _mm_set1_epi32(int(b));
        auto bits = [](__m128i x, __m128i y) { return uint32_t(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(x, y)))); };
        for (size_t j = 0; j < lanes; j += 4) {
            const __m128i x = _mm_load_si128(reinterpret_cast<const __m128i*>(&A[j]));
            const __m128i y = _mm_load_si128(reinterpret_cast<const __m128i*>(&B[j]));
            as |= bits(x, av) << j, bs |= bits(y, bv) << j, closes |= bits(y, av) << j, at |= bits(x, bv) << j;
        }
#else
        for (size_t j = 0; j < n; ++j)
            as |= uint32_t(A[j] == a) << j, bs |= uint32_t(B[j] == b) << j, closes |= uint32_t(B[j] == a) << j, at |= uint32_t(A[j] == b) << j;
#endif
        ok &= (a != c) & (b != c) & (a != b) & one(as) & one(bs) & one(closes);
        next[i] = uint8_t(at ? 31 - __builtin_clz(at) : 0); // the spoke whose a is b (the only one, when the fan closes)
    }
    return ok;
}

// Is the closed fan of triangles (c, a_i, b_i) (ids into pts through `at`; spokes_close holds) certainly
// embedded, so that any two of its triangles meet only in the corners they share? Then they never cross
// (kernel::triangles_intersect does not count shared corners), and the crossing test drops every pair of shell
// triangles around c without building a plane.
// The certificate: drop the coordinate along which the fan's normal is largest (an exact projection) and
// require, with exact signs, (1) that every projected triangle turns the same way around c and (2) that the
// spokes wind around c exactly once. Then the projected triangles are sectors that tile a neighbourhood of c
// with disjoint interiors; the projection is one-to-one on each (non-degenerate) triangle, so a point common to
// two of them projects into their common sector boundary, which is their shared edge or c itself. The winding
// is counted exactly: a step that turns by less than half a turn passes from the lower to the upper half-plane
// (around c) only through the positive first axis, so the number of such passes is the number of turns; each
// cycle of the spoke permutation makes at least one, so one pass also means one cycle.
// Why: most of the crossing test's candidate pairs are such neighbours (bunny, length 0.003: 421 k of 452 k),
// which the plane filter answered with one or two planes each. Dropped as the paired descent meets them
// (Stanford bunny, `furrow -j 1 shells --length 0.004`, stage timers, three interleaved runs): candidate loop
// 17.4-19.1 -> 4.0-4.3 ms, for 3.6-3.8 ms of certificates and 2.5-3 ms more in the descent.
template <class At>
bool fan_certainly_embedded(At at, uint32_t c, const std::array<uint32_t, 2>* spokes, const uint8_t* next, size_t n) {
    if (n > kMaxFan) return false;
    const Exact::Point_3& o = at(c);
    const double oc[3] = {o.x(), o.y(), o.z()};
    double end[kMaxFan][3]; // each spoke's a (its b is spoke next[i]'s a)
    for (size_t i = 0; i < n; ++i) {
        const Exact::Point_3& p = at(spokes[i][0]);
        end[i][0] = p.x(), end[i][1] = p.y(), end[i][2] = p.z();
    }
    double normal[3] = {0, 0, 0};
    for (size_t i = 0; i < n; ++i) {
        const double* a = end[i];
        const double* b = end[next[i]];
        const double e[3] = {a[0] - oc[0], a[1] - oc[1], a[2] - oc[2]}, f[3] = {b[0] - oc[0], b[1] - oc[1], b[2] - oc[2]};
        normal[0] += e[1] * f[2] - e[2] * f[1], normal[1] += e[2] * f[0] - e[0] * f[2], normal[2] += e[0] * f[1] - e[1] * f[0];
    }
    int k = 0;
    for (int j = 1; j < 3; ++j)
        if (std::abs(normal[j]) > std::abs(normal[k])) k = j;
    if (!(std::abs(normal[k]) > 0)) return false;
    // The two other coordinates, in the order that makes the 2D orientation the sign of normal[k], relative to
    // c: the differences CGAL's filter forms (and a difference has the exact sign of the comparison).
    const int u = (k + 1) % 3, w = (k + 2) % 3;
    const double turn = normal[k] > 0 ? 1 : -1;
    double X[kMaxFan], Y[kMaxFan];
    for (size_t i = 0; i < n; ++i) X[i] = end[i][u] - oc[u], Y[i] = end[i][w] - oc[w];
    // Each triangle's orientation by CGAL's semi-static filter (Static_filters/Orientation_2.h, 5.5: the same
    // expression and bound), without branches; Epick's exact predicate where it does not decide.
    unsigned wrong = 0, unsure = 0;
    int turns = 0;
    for (size_t i = 0; i < n; ++i) {
        const size_t j = next[i];
        const double det = turn * (X[i] * Y[j] - Y[i] * X[j]);
        const double mx = std::max(std::abs(X[i]), std::abs(X[j])), my = std::max(std::abs(Y[i]), std::abs(Y[j]));
        const double lo = std::min(mx, my), hi = std::max(mx, my);
        const double eps = 8.8872057372592798e-16 * lo * hi;
        const bool filtered = lo >= 1e-146 && hi < 1e153, along = det > eps, against = det < -eps;
        wrong += filtered & against;
        unsure += !(filtered & (along | against));
        const bool from = Y[i] > 0 || (Y[i] == 0 && X[i] > 0), to = Y[j] > 0 || (Y[j] == 0 && X[j] > 0);
        turns += turn > 0 ? !from & to : from & !to; // clockwise: the same steps walked backwards
    }
    if (wrong || turns != 1) return false;
    for (size_t i = 0; unsure && i < n; ++i) {
        const double* a = end[i];
        const double* b = end[next[i]];
        const CGAL::Orientation s = CGAL::orientation(Exact::Point_2(oc[u], oc[w]), Exact::Point_2(a[u], a[w]), Exact::Point_2(b[u], b[w]));
        if (s != (turn > 0 ? CGAL::LEFT_TURN : CGAL::RIGHT_TURN)) return false;
    }
    return true;
}

// Möller–Trumbore with a generous tolerance: false only where the ray clearly misses the triangle (or hits
// it behind the origin), so that CGAL's construction, which decides, runs on a handful of triangles per
// ray instead of on every triangle of every leaf reached. Near-parallel rays always pass.
bool may_hit(const double* o, const double* d, const Triangle& tri) {
    const double a[3] = {tri[0].x(), tri[0].y(), tri[0].z()};
    const double e1[3] = {tri[1].x() - a[0], tri[1].y() - a[1], tri[1].z() - a[2]};
    const double e2[3] = {tri[2].x() - a[0], tri[2].y() - a[1], tri[2].z() - a[2]};
    const double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
    const double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    const double l1 = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    const double l2 = std::sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
    if (!(std::abs(det) > 1e-6 * l1 * l2)) return true; // within ~1e-6 rad of the plane's direction: let CGAL decide
    const double inv = 1.0 / det;
    const double s[3] = {o[0] - a[0], o[1] - a[1], o[2] - a[2]};
    constexpr double tol = 1e-6;
    const double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv;
    if (u < -tol || u > 1 + tol) return false;
    const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
    const double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
    if (v < -tol || u + v > 1 + tol) return false;
    const double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv;
    const double sl = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    return !(t < -tol * (sl + l1 + l2));
}

// A point's coordinates in place (Simple_cartesian keeps them in a std::array): what point_triangle_distance.h
// reads.
static_assert(std::is_same_v<Kernel::Cartesian_const_iterator_3, std::array<double, 3>::const_iterator>);
const double* xyz(const Point& p) { return &*p.cartesian_begin(); }

// CGAL::squared_distance(x, t), the same bits (point_triangle_distance.h).
double squared_distance_to(const Point& x, const Triangle& t) {
    return shells_detail::squared_distance(xyz(x), xyz(t[0]), xyz(t[1]), xyz(t[2]));
}

shells_detail::Box3 box_of(const Point& a, const Point& b, const Point& c) {
    shells_detail::Box3 box;
    for (const Point* p : {&a, &b, &c}) {
        const double x[3] = {p->x(), p->y(), p->z()};
        box.add(x);
    }
    return box;
}

} // namespace

namespace shells_detail {

bool planes_rule_out(const std::vector<double>& points, const std::array<uint32_t, 3>& a, const std::array<uint32_t, 3>& b, bool* crosses) {
    std::vector<Exact::Point_3> pts(points.size() / 3);
    for (size_t v = 0; v < pts.size(); ++v) pts[v] = Exact::Point_3(points[3 * v], points[3 * v + 1], points[3 * v + 2]);
    if (crosses) *crosses = pair_intersects(pts, a, b);
    return certainly_apart_by_planes(pts, a, kernel::CertainSide(pts[a[0]], pts[a[1]], pts[a[2]]), b);
}

bool spokes_close_into_fan(uint32_t centre, const std::vector<std::array<uint32_t, 2>>& spokes, std::vector<uint8_t>& next) {
    next.assign(spokes.size(), 0);
    return spokes_close(centre, spokes.data(), spokes.size(), next.data());
}

bool fan_rules_out(const std::vector<double>& points, uint32_t centre, const std::vector<std::array<uint32_t, 2>>& spokes) {
    std::vector<Exact::Point_3> pts(points.size() / 3);
    for (size_t v = 0; v < pts.size(); ++v) pts[v] = Exact::Point_3(points[3 * v], points[3 * v + 1], points[3 * v + 2]);
    std::vector<uint8_t> next(spokes.size());
    return spokes_close(centre, spokes.data(), spokes.size(), next.data()) &&
           fan_certainly_embedded([&](uint32_t v) -> const Exact::Point_3& { return pts[v]; }, centre, spokes.data(), next.data(), spokes.size());
}

// The medial-axis clamp's bisection test, taken_by_witness(x, owned_r2(x)) in owned_lengths (is x nearer than
// `ratio` × its distance to v's own faces (own: their ids) to the witness face?), with the fewest distances:
// the witness's first, then the own faces, the one that decided the last call first (*hint, a position in
// own). An own face whose scaled distance is not above the witness's decides "not taken" on its own (the
// scaled minimum can only be smaller: rounding is monotone); only "taken" needs them all. NaN distances are
// skipped, as std::min skips them in owned_r2: the same answer, bit for bit. Stanford bunny at the bench's
// length: 161 k bisection steps, 7 distances each before; now 92.6 k steps, 3.8 distances each. The faces come
// prepared (point_triangle_distance.h: CGAL's bits, the per-triangle part computed once per vertex).
bool witness_takes(const PreparedTriangle& witness, const PreparedTriangle* own, uint32_t own_count, const double* x, double ratio,
                   uint32_t* hint) {
    const double w = squared_distance(witness, x);
    const double rr = ratio * ratio;
    double nearest = std::numeric_limits<double>::infinity();
    for (uint32_t k = 0; k < own_count; ++k) {
        const uint32_t i = (*hint + k) % own_count;
        const double d = squared_distance(own[i], x);
        if (d == d && !(w < rr * d)) {
            *hint = i;
            return false;
        }
        nearest = std::min(nearest, d);
    }
    return w < rr * nearest;
}

// The smallest of x's squared distances to the faces ids[0..count), min'd in that order (as std::min over
// CGAL's distances would): two faces at a time (squared_distance_pair), the same bits.
double nearest_of(const std::vector<Triangle>& tris, const Point& x, const uint32_t* ids, uint32_t count) {
    double nearest = std::numeric_limits<double>::infinity();
    uint32_t i = 0;
    for (; i + 2 <= count; i += 2) {
        const Triangle &s = tris[ids[i]], &t = tris[ids[i + 1]];
        const double* a[2] = {xyz(s[0]), xyz(t[0])};
        const double* b[2] = {xyz(s[1]), xyz(t[1])};
        const double* c[2] = {xyz(s[2]), xyz(t[2])};
        double d[2];
        squared_distance_pair(d, xyz(x), a, b, c);
        nearest = std::min(nearest, d[0]);
        nearest = std::min(nearest, d[1]);
    }
    if (i < count) nearest = std::min(nearest, squared_distance_to(x, tris[ids[i]]));
    return nearest;
}

void prepare_face(PreparedTriangle& out, const Triangle& t) { prepare_triangle(out, xyz(t[0]), xyz(t[1]), xyz(t[2])); }

bool witness_takes(const std::vector<double>& points, const std::vector<std::array<uint32_t, 3>>& triangles, const double* x,
                   uint32_t witness, const std::vector<uint32_t>& own, double ratio, uint32_t* hint) {
    auto pt = [&](uint32_t v) { return &points[3 * size_t(v)]; };
    auto prepared = [&](uint32_t f) {
        PreparedTriangle t;
        prepare_triangle(t, pt(triangles[f][0]), pt(triangles[f][1]), pt(triangles[f][2]));
        return t;
    };
    std::vector<PreparedTriangle> own_faces;
    for (uint32_t f : own) own_faces.push_back(prepared(f));
    return witness_takes(prepared(witness), own_faces.data(), uint32_t(own_faces.size()), x, ratio, hint);
}

// Nodes of at most this many triangles get a slab (BoxBvh::add_slabs): larger ones are seldom flat.
constexpr uint32_t kSlabPrims = 256;

struct SurfaceIndex::Impl {
    const std::vector<double>& points;
    const std::vector<std::array<uint32_t, 3>>& triangles;
    std::vector<Triangle> tris;
    // Each triangle's plane (unit normal through its first corner) and a bound on the rounding of the plane
    // distance |n·(x − a)| per unit of |x − a|₁ (large for slivers, whose normal is inaccurate): the plane
    // distance bounds the triangle distance from below, so most triangles are ruled out without CGAL.
    struct Plane {
        double a[3], n[3], slack;
    };
    std::vector<Plane> planes; // in the hierarchy's leaf order (bvh.leaf_order()), as the searches meet them
    Box3 bounds;               // of all triangles
    BoxBvh bvh;

    Impl(const std::vector<double>& p, const std::vector<std::array<uint32_t, 3>>& t) : points(p), triangles(t) {
        tris.reserve(t.size());
        std::vector<Box3> boxes(t.size());
        for (size_t f = 0; f < t.size(); ++f) {
            tris.emplace_back(pt(t[f][0]), pt(t[f][1]), pt(t[f][2]));
            boxes[f] = box_of(tris[f][0], tris[f][1], tris[f][2]);
            bounds.add(boxes[f]);
        }
        bvh.build(std::move(boxes));
        // The corners in leaf order, gathered once for the slabs and the planes (each gathered them itself, the
        // slabs into a zeroed buffer): bunny callgrind, the build outside BoxBvh::build 59.4 -> 54.4 M instructions.
        const std::vector<uint32_t>& leaf = bvh.leaf_order();
        const std::unique_ptr<double[]> c(new double[9 * leaf.size()]); // every entry written below
        for (size_t j = 0; j < leaf.size(); ++j)
            for (size_t k = 0; k < 3; ++k) std::memcpy(&c[9 * j + 3 * k], &p[3 * size_t(t[leaf[j]][k])], 3 * sizeof(double));
        bvh.add_slabs_gathered(c.get(), kSlabPrims);
        bvh.widen(); // for_near on 4-wide nodes (owned_lengths' ball queries)
        // A leaf's planes side by side: a search reads one or two cache lines for a leaf's four instead of four
        // scattered ones (bunny owned_lengths 70.3-72.2 -> 67.9-68.7 ms, stage timer).
        planes.resize(leaf.size());
        for (size_t j = 0; j < leaf.size(); ++j) {
            const double* a = &c[9 * j];
            const double* b = a + 3;
            const double* cc = a + 6;
            const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {cc[0] - a[0], cc[1] - a[1], cc[2] - a[2]};
            const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
            const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            const double l1 = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
            const double l2 = std::sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
            Plane& pl = planes[j];
            for (int k = 0; k < 3; ++k) pl.a[k] = a[k], pl.n[k] = len > 0 ? n[k] / len : 0.0;
            pl.slack = len > 0 && std::isfinite(len) ? 1e-14 * (l1 * l2 / len + 1) : HUGE_VAL;
        }
    }
    Point pt(uint32_t v) const { return Point(points[3 * size_t(v)], points[3 * size_t(v) + 1], points[3 * size_t(v) + 2]); }

    // Is some triangle nearer than sqrt(r2) to x (squared distance < r2)? Early exit on the first found,
    // which is written to *witness (a caller asking again nearby tries it first).
    // Faces listed in [skip, skip_end) are left out: a caller that has already measured them (and knows
    // them to be no nearer than r2) does not pay for them twice.
    bool any_within(const Point& x, double r2, uint32_t* witness = nullptr, const uint32_t* skip = nullptr,
                    const uint32_t* skip_end = nullptr) const {
        const double p[3] = {x.x(), x.y(), x.z()};
        const double r = std::sqrt(r2) * (1 + 1e-12);
        return bvh.for_near(p, r2, [&](uint32_t f, double&, uint32_t j) {
            if (!within(planes[j], f, x, p, r, r2, skip, skip_end)) return false;
            if (witness) *witness = f;
            return true;
        });
    }
    // any_within(x, r2(), witness, skip, skip_end) for a caller that knows a bound >= r2() but would rather
    // not compute r2() (owned_lengths: it takes a distance to each of a vertex's faces): the search runs within
    // the bound, and r2() is asked for (once) when a face comes within the bound. The faces met within r2() are
    // those any_within meets, in the same order (the descent is ordered by box distances, which r2 only
    // prunes): the same answer and witness.
    template <class R2>
    bool any_within_bounded(const Point& x, double bound, R2&& r2, uint32_t* witness, const uint32_t* skip, const uint32_t* skip_end) const {
        const double p[3] = {x.x(), x.y(), x.z()};
        const double r = bounded_reach(bound);
        double exact = -1;
        return bvh.for_near(p, bound, [&](uint32_t f, double&, uint32_t j) {
            if (!within_bounded(f, j, x, p, r, bound, exact, r2, skip, skip_end)) return false;
            *witness = f;
            return true;
        });
    }
    // any_within_bounded's test of face f (at leaf-order position j) for x (= p): past its plane and the
    // skipped faces within r = bounded_reach(bound), its distance below the bound, then below r2() (asked for
    // once, kept in `exact`, -1 until then).
    template <class R2>
    bool within_bounded(uint32_t f, uint32_t j, const Point& x, const double* p, double r, double bound, double& exact, R2&& r2,
                        const uint32_t* skip, const uint32_t* skip_end) const {
        if (!may_be_within(planes[j], f, p, r, skip, skip_end)) return false;
        const double d2 = squared_distance_to(x, tris[f]);
        if (!(d2 < bound)) return false;
        if (exact < 0) exact = r2();
        return d2 < exact;
    }
    static double bounded_reach(double bound) { return std::sqrt(bound) * (1 + 1e-12); }
    // Squared distance from x (= p) to triangle f below r2 (r: sqrt(r2), rounded up), f not in [skip, skip_end)?
    // Its plane first, then the list (a caller's own faces mostly pass the plane test: it is the cheaper
    // filter), then the distance.
    bool within(const Plane& pl, uint32_t f, const Point& x, const double* p, double r, double r2, const uint32_t* skip = nullptr,
                const uint32_t* skip_end = nullptr) const {
        return may_be_within(pl, f, p, r, skip, skip_end) && squared_distance_to(x, tris[f]) < r2;
    }
    // within's filters: f's plane within r of p (within the rounding allowed), f not in [skip, skip_end).
    static bool may_be_within(const Plane& pl, uint32_t f, const double* p, double r, const uint32_t* skip, const uint32_t* skip_end) {
        const double d[3] = {p[0] - pl.a[0], p[1] - pl.a[1], p[2] - pl.a[2]};
        const double plane = std::abs(pl.n[0] * d[0] + pl.n[1] * d[1] + pl.n[2] * d[2]);
        if (plane > r + pl.slack * (std::abs(d[0]) + std::abs(d[1]) + std::abs(d[2]))) return false;
        return std::find(skip, skip_end, f) == skip_end;
    }
    // Squared distance from x to the mesh.
    double squared_distance(const Point& x) const {
        const double p[3] = {x.x(), x.y(), x.z()};
        double best = HUGE_VAL;
        bvh.for_near(p, best, [&](uint32_t f, double& bound) {
            bound = std::min(bound, CGAL::squared_distance(x, tris[f]));
            return false;
        });
        return best;
    }
    // Does the segment cross any triangle?
    bool crosses(const Segment& s) const {
        const Box3 box = box_of(s.source(), s.target(), s.target());
        bool found = false;
        // Short segments (a tip's bend): their box is a tight enough filter.
        bvh.for_overlapping(box, [&](uint32_t f) {
            if (!found && CGAL::do_intersect(s, tris[f])) found = true;
        });
        return found;
    }
};

SurfaceIndex::SurfaceIndex(const std::vector<double>& points, const std::vector<std::array<uint32_t, 3>>& triangles)
    : impl_(std::make_unique<Impl>(points, triangles)) {}
SurfaceIndex::~SurfaceIndex() = default;

// What stays from one intersection test to the next: the base (points, boxes, vertex -> faces), and the
// shell triangles of the previous call, of which only those around changed vertices are rebuilt.
struct CrossingTest::State {
    const SurfaceIndex::Impl& ix;
    size_t W = 0, T = 0;
    std::vector<Exact::Point_3> pts;                // base vertex v at v, its shell point at W + v
    std::vector<uint32_t> shell_id;                 // v or W + v (a vertex that does not move is shared)
    std::vector<uint8_t> base_ok;                   // per face: not collinear (a collinear base face takes no part)
    std::vector<std::array<uint32_t, 3>> stri;      // per face: its shell triangle
    std::vector<uint8_t> is_shell;                  // per face: has a moving corner and is not collinear
    std::vector<Box3> sbox;                         // per face: the shell triangle's box (empty if none)
    const uint32_t* ring_start;                     // vertex -> its faces (CSR, the caller's): and its spokes
    std::vector<std::array<uint32_t, 2>> spokes;    // per face around a vertex: its two other corners, in winding order
    std::vector<uint8_t> spoke_next;                // per spoke: the spoke that follows it (spokes_close)
    std::vector<uint8_t> fan_closes;                // per vertex: its spokes close into a fan (spokes_close)
    std::vector<uint8_t> flat_fan;                  // per vertex: its shell fan certainly embedded (certify_fan)
    std::vector<uint32_t> slot;                     // per face: its position in the hierarchy's leaf order
    std::vector<std::array<uint32_t, 3>> leaf_stri; // stri in that order, as the paired descent meets them
    // A shell triangle lies near its base face: the base hierarchy's shape, refitted to the shell boxes,
    // serves the shell without a second build (one tree holding both would have boxes as tall as the fur).
    BoxBvh shells;

    State(const SurfaceIndex::Impl& index, const uint32_t* rings, const uint32_t* ring_faces)
        : ix(index), W(index.points.size() / 3), T(index.triangles.size()), ring_start(rings) {
        pts.resize(2 * W);
        for (size_t v = 0; v < W; ++v)
            pts[v] = pts[W + v] = Exact::Point_3(ix.points[3 * v], ix.points[3 * v + 1], ix.points[3 * v + 2]);
        shell_id.resize(W);
        std::iota(shell_id.begin(), shell_id.end(), 0u);
        base_ok.resize(T);
        for (size_t f = 0; f < T; ++f) {
            const auto& t = ix.triangles[f];
            base_ok[f] = !CGAL::collinear(pts[t[0]], pts[t[1]], pts[t[2]]);
        }
        stri.resize(T);
        is_shell.assign(T, 0);
        sbox.resize(T);
        shells.take_shape(ix.bvh); // refitted by run, to the shell boxes
        // Each vertex's spokes (its faces' other corners, in their winding), kept where they close into a fan.
        spokes.resize(ring_start[W]);
        for (uint32_t v = 0; v < W; ++v)
            for (uint32_t i = ring_start[v]; i < ring_start[v + 1]; ++i) {
                const auto& t = ix.triangles[ring_faces[i]];
                const size_t at = t[0] == v ? 0 : t[1] == v ? 1 : 2;
                spokes[i] = {t[(at + 1) % 3], t[(at + 2) % 3]};
            }
        fan_closes.resize(W);
        spoke_next.resize(spokes.size());
        for (uint32_t v = 0; v < W; ++v)
            fan_closes[v] = spokes_close(v, &spokes[ring_start[v]], ring_start[v + 1] - ring_start[v], &spoke_next[ring_start[v]]);
        flat_fan.assign(W, 0);
        slot.resize(T);
        const std::vector<uint32_t>& leaves = ix.bvh.leaf_order();
        for (size_t j = 0; j < leaves.size(); ++j) slot[leaves[j]] = uint32_t(j);
        leaf_stri.resize(leaves.size());
    }
    // flat_fan[v]: the shell triangles around v's shell point form a certainly embedded fan.
    void certify_fan(uint32_t v) {
        flat_fan[v] = fan_closes[v] && fan_certainly_embedded([&](uint32_t u) -> const Exact::Point_3& { return pts[shell_id[u]]; }, v,
                                                              &spokes[ring_start[v]], &spoke_next[ring_start[v]],
                                                              ring_start[v + 1] - ring_start[v]);
    }
    // Every fan (touched_face null: the first run), or those whose shell points moved: every corner of a
    // rebuilt face (touched_face).
    void certify_fans(const std::vector<uint8_t>* touched_face) {
        if (!touched_face) {
            tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(W), 1024), [&](const tbb::blocked_range<uint32_t>& r) {
                for (uint32_t v = r.begin(); v != r.end(); ++v) certify_fan(v);
            });
            return;
        }
        std::vector<uint8_t> again(W, 0);
        for (size_t f = 0; f < T; ++f)
            if ((*touched_face)[f])
                for (uint32_t v : ix.triangles[f]) again[v] = 1;
        for (uint32_t v = 0; v < W; ++v)
            if (again[v]) certify_fan(v);
    }
    // Do shell triangles a and b share a corner whose fan is certainly embedded (then they do not cross)?
    bool share_flat_fan(const std::array<uint32_t, 3>& a, const std::array<uint32_t, 3>& b) const {
        unsigned apart = 0; // without branches: which corners are shared is a coin toss to the predictor
        for (uint32_t id : a) {
            const unsigned shared = unsigned(id == b[0]) | unsigned(id == b[1]) | unsigned(id == b[2]);
            apart |= shared & flat_fan[id >= W ? id - W : id];
        }
        return apart != 0;
    }
    Box3 box_of_ids(const std::array<uint32_t, 3>& t) const {
        Box3 box;
        for (uint32_t v : t) {
            const double x[3] = {pts[v].x(), pts[v].y(), pts[v].z()};
            box.add(x);
        }
        return box;
    }
    // The fewest halvings (1..max_halvings) of the shell offsets of the blamed corners (the shell point
    // pulled toward its base point: the offset is linear in the length) after which the crossing pair (f,
    // other) (other: as in run's candidates) no longer crosses, tested on the pair alone with the same
    // decision as run's; max_halvings + 1 if it still crosses after max_halvings (taken as a crossing at
    // every scale, as at a non-manifold edge shared by four walls, whose walls' shells meet however short
    // the fur).
    uint8_t halvings_to_clear(uint32_t f, uint32_t other, bool blame_f, bool blame_g, int max_halvings) const {
        const bool shell_pair = other >= T;
        const uint32_t g = shell_pair ? other - uint32_t(T) : other;
        // The pair's distinct vertices at local ids 0..5, their shell points at 6 + id (shell_meets_base tells
        // a stationary corner by an id below its W, here 6).
        constexpr uint32_t kW = 6;
        std::array<uint32_t, kW> ids{};
        std::array<bool, kW> blamed{};
        uint32_t n = 0;
        auto local = [&](uint32_t v) {
            for (uint32_t i = 0; i < n; ++i)
                if (ids[i] == v) return i;
            ids[n] = v;
            return n++;
        };
        std::array<uint32_t, 3> bf, bg, sf, sg;
        for (size_t c = 0; c < 3; ++c) bf[c] = local(ix.triangles[f][c]);
        for (size_t c = 0; c < 3; ++c) bg[c] = local(ix.triangles[g][c]);
        for (size_t c = 0; c < 3; ++c) blamed[bf[c]] = blamed[bf[c]] || blame_f, blamed[bg[c]] = blamed[bg[c]] || (shell_pair && blame_g);
        auto lifted = [&](const std::array<uint32_t, 3>& b) {
            std::array<uint32_t, 3> s;
            for (size_t c = 0; c < 3; ++c) s[c] = shell_id[ids[b[c]]] >= W ? kW + b[c] : b[c];
            return s;
        };
        sf = lifted(bf), sg = lifted(bg);
        std::vector<Exact::Point_3> q(2 * kW);
        auto crosses_at = [&](int k) {
            const double s = std::ldexp(1.0, -k);
            for (uint32_t i = 0; i < n; ++i) {
                const Exact::Point_3 &b = pts[ids[i]], &t = pts[W + ids[i]];
                q[i] = b;
                q[kW + i] = blamed[i] ? Exact::Point_3(b.x() + s * (t.x() - b.x()), b.y() + s * (t.y() - b.y()), b.z() + s * (t.z() - b.z())) : t;
            }
            return shell_pair ? pair_intersects(q, sf, sg) : shell_meets_base(q, kW, bf, bg, sf);
        };
        // One halving, the common case, first; then the smallest scale: a crossing still there is taken to
        // be there at every scale (the lattice's pairs need no more than these two tests).
        if (!crosses_at(1)) return 1;
        if (max_halvings <= 1 || crosses_at(max_halvings)) return uint8_t(max_halvings + 1);
        for (int k = 2; k < max_halvings; ++k)
            if (!crosses_at(k)) return uint8_t(k);
        return uint8_t(max_halvings);
    }
    // Each crossing pair on its own: how many halvings of its blamed corners' fur clear it (the caller's next
    // round re-tests everything around what it shortened, so this only saves rounds, it decides nothing); a
    // corner's halvings rise to the most its pairs need. No pair needs more than max_halvings + 1: a pair
    // whose blamed corners all have that already cannot change anything and is not tested. Which pairs are
    // skipped depends on the threads' timing, the maximum does not (the corners only ever rise, through
    // atomic maxima): the same halvings for any thread count. Lattice (25 cells, -j 1, first round, 450 k
    // pairs): blame and halvings 181 ms before the skip, 34 ms after (29 of them the blame).
    void raise_halvings(uint8_t* halvings, const std::vector<std::pair<uint32_t, uint32_t>>& pairs,
                        const std::vector<std::array<bool, 2>>& blame, int max_halvings) const {
        const uint8_t ceiling = uint8_t(max_halvings + 1);
        auto corners = [&](size_t k, int side) -> const std::array<uint32_t, 3>& {
            return ix.triangles[side == 0 ? pairs[k].first : pairs[k].second - uint32_t(T)];
        };
        tbb::parallel_for(tbb::blocked_range<size_t>(0, pairs.size(), 64), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t k = r.begin(); k != r.end(); ++k) {
                bool open = false;
                for (int side = 0; side < 2; ++side)
                    if (blame[k][size_t(side)])
                        for (uint32_t v : corners(k, side)) open = open || std::atomic_ref<uint8_t>(halvings[v]).load(std::memory_order_relaxed) < ceiling;
                if (!open) continue;
                const uint8_t need = halvings_to_clear(pairs[k].first, pairs[k].second, blame[k][0], blame[k][1], max_halvings);
                for (int side = 0; side < 2; ++side)
                    if (blame[k][size_t(side)])
                        for (uint32_t v : corners(k, side)) {
                            std::atomic_ref<uint8_t> h(halvings[v]);
                            uint8_t seen = h.load(std::memory_order_relaxed);
                            while (seen < need && !h.compare_exchange_weak(seen, need, std::memory_order_relaxed)) {
                            }
                        }
            }
        });
    }
    // Blame, per crossing pair (f, other) as run lists them: a shell that crosses the base is at fault. Where
    // two shells cross and only one of them also crosses the base (a wall's fur running through a shelf, and so
    // through the shelf's fur), only that one is shortened; the other's fur is where it belongs. The blamed
    // triangles' corners are marked in hit.
    std::vector<std::array<bool, 2>> blame(uint8_t* hit, const std::vector<std::pair<uint32_t, uint32_t>>& pairs) const {
        std::vector<uint8_t> into_base(T, 0);
        for (const auto& [f, other] : pairs)
            if (other < T) into_base[f] = 1;
        std::vector<std::array<bool, 2>> out(pairs.size());
        for (size_t k = 0; k < pairs.size(); ++k) {
            const auto [f, other] = pairs[k];
            const bool shell_pair = other >= T;
            const uint32_t g = shell_pair ? other - uint32_t(T) : 0;
            const bool blame_f = !shell_pair || into_base[f] || !into_base[g];
            const bool blame_g = shell_pair && (into_base[g] || !into_base[f]);
            out[k] = {blame_f, blame_g};
            if (blame_f)
                for (uint32_t v : ix.triangles[f]) hit[v] = 1;
            if (blame_g)
                for (uint32_t v : ix.triangles[g]) hit[v] = 1;
        }
        return out;
    }
    void rebuild_face(size_t f, const std::vector<uint8_t>& moving) {
        const auto& t = ix.triangles[f];
        stri[f] = {shell_id[t[0]], shell_id[t[1]], shell_id[t[2]]};
        leaf_stri[slot[f]] = stri[f];
        // Only triangles with a moving corner are shell triangles; a collinear one can cross nothing properly.
        is_shell[f] = (moving[t[0]] || moving[t[1]] || moving[t[2]]) && !CGAL::collinear(pts[stri[f][0]], pts[stri[f][1]], pts[stri[f][2]]);
        sbox[f] = is_shell[f] ? box_of_ids(stri[f]) : Box3{};
    }
};

CrossingTest::CrossingTest(const SurfaceIndex& index, const uint32_t* ring_start, const uint32_t* ring_faces)
    : state_(std::make_unique<State>(index.impl(), ring_start, ring_faces)) {}
CrossingTest::~CrossingTest() = default;

size_t CrossingTest::run(uint8_t* hit, const std::vector<double>& shell, const std::vector<uint8_t>& moving,
                         const std::vector<uint8_t>* changed, uint8_t* halvings, int max_halvings) {
    State& st = *state_;
    const size_t W = st.W, T = st.T;
    const auto& triangles = st.ix.triangles;
    // Shell points and triangles: all of them without `changed` (the first run), afterwards only those
    // around vertices that changed (nothing else moved).
    for (size_t v = 0; v < W; ++v) {
        if (changed && !(*changed)[v]) continue;
        if (moving[v]) st.pts[W + v] = Exact::Point_3(shell[3 * v], shell[3 * v + 1], shell[3 * v + 2]);
        st.shell_id[v] = moving[v] ? uint32_t(W + v) : uint32_t(v);
    }
    std::vector<uint8_t> touched_face(T, 1); // the faces around a changed vertex
    if (changed)
        for (size_t f = 0; f < T; ++f) {
            const auto& t = triangles[f];
            touched_face[f] = (*changed)[t[0]] || (*changed)[t[1]] || (*changed)[t[2]];
        }
    std::vector<uint32_t> touched; // shell triangles (by face) whose pairs are tested
    for (size_t f = 0; f < T; ++f) {
        if (!touched_face[f]) continue;
        st.rebuild_face(f, moving);
        if (st.is_shell[f]) touched.push_back(uint32_t(f));
    }
    if (touched.empty()) return 0;
    st.certify_fans(changed ? &touched_face : nullptr);
    st.shells.refit(st.sbox);
    const BoxBvh& shells = st.shells;

    // Candidate pairs with a touched shell triangle: against the base, and against the other shell triangles
    // (each unordered pair once). The base's own overlapping neighbours are never enumerated. Many touched
    // triangles: both trees descended together; a few (after a repair): one query each.
    struct Candidate {
        uint32_t f;     // shell triangle (by base face)
        uint32_t other; // < T: base face; else T + shell triangle (by base face), either side of f
    };
    std::vector<Candidate> cand;
    // The hierarchies' boxes (grown by a margin) are the only box test: a pair whose own boxes miss by less
    // than the margin goes to the exact test, which says so; a shell triangle's box is empty where it is not
    // one, so both of a pair are shell triangles (and the descents need not look that up). Reading the boxes
    // again by face id was a cache miss per candidate (bunny: 452 k shell candidates).
    auto add_base = [&](uint32_t f, uint32_t g, std::vector<Candidate>& out) {
        if (st.base_ok[g]) out.push_back({f, g});
    };
    // once: the enumeration yields each unordered pair once already; otherwise a pair of two touched
    // triangles comes from both and is kept from the lower one.
    // sf, sg: their shell triangles (the descent passes them from leaf_stri, in the order it meets them).
    auto add_shell = [&](uint32_t f, uint32_t g, const std::array<uint32_t, 3>& sf, const std::array<uint32_t, 3>& sg, bool once,
                         std::vector<Candidate>& out) { // f touched
        if (g == f || (!once && touched_face[g] && g < f)) return;
        if (st.share_flat_fan(sf, sg)) return; // neighbours around an embedded fan: apart
        // As the descent met it: a leaf's triangle f meets the other leaf's triangles one after the other, and
        // the filter below builds f's plane once for them (bunny: 342 k planes built for 452 k candidates when
        // kept as (lower, higher)).
        out.push_back({f, uint32_t(T) + g});
    };
    if (touched.size() * 8 > T) {
        BoxBvh asking;
        if (changed) {
            std::vector<Box3> touched_box(T);
            for (uint32_t f : touched) touched_box[f] = st.sbox[f];
            asking.refit(st.ix.bvh, touched_box);
        }
        const BoxBvh& query = changed ? asking : shells;
        // The candidates are kept in the traversal's tasks, each into its task's list (on the lattice, 25
        // cells, first round: 0.73 M base and 2.96 M shell candidates, which were listed, joined and only then
        // filtered one by one).
        query.overlapping_pairs(st.ix.bvh, [&](uint32_t f, uint32_t g, uint32_t, uint32_t, std::vector<Candidate>& out) {
            add_base(f, g, out);
        }, cand);
        query.overlapping_pairs(shells, [&](uint32_t f, uint32_t g, uint32_t i, uint32_t j, std::vector<Candidate>& out) {
            add_shell(f, g, st.leaf_stri[i], st.leaf_stri[j], !changed, out); // query == shells: each pair once, in either order
        }, cand);
    } else {
        for (uint32_t f : touched) {
            st.ix.bvh.for_overlapping(st.sbox[f], [&](uint32_t g) { add_base(f, g, cand); });
            shells.for_overlapping(st.sbox[f], [&](uint32_t g) { add_shell(f, g, st.stri[f], st.stri[g], false, cand); });
        }
    }
    std::vector<uint8_t> crossing(cand.size(), 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cand.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
        // The shell triangle's plane, kept while consecutive candidates share it (a leaf pair's candidates come
        // together).
        uint32_t plane_of = UINT32_MAX;
        std::optional<kernel::CertainSide> side_f;
        for (size_t k = r.begin(); k != r.end(); ++k) {
            const Candidate& c = cand[k];
            const bool base = c.other < T;
            const uint32_t g = base ? c.other : c.other - uint32_t(T);
            const std::array<uint32_t, 3>& other = base ? triangles[g] : st.stri[g];
            // shell_meets_base starts with the pair test of the shell triangle and the other face: apart there,
            // apart.
            const auto& sf = st.stri[c.f];
            if (plane_of != c.f) side_f.emplace(st.pts[sf[0]], st.pts[sf[1]], st.pts[sf[2]]), plane_of = c.f;
            if (certainly_apart_by_planes(st.pts, sf, *side_f, other)) continue;
            crossing[k] = base ? shell_meets_base(st.pts, W, triangles[c.f], other, sf)
                               : pair_intersects(st.pts, st.stri[std::min(c.f, g)], st.stri[std::max(c.f, g)]);
        }
    });
    std::vector<std::pair<uint32_t, uint32_t>> pairs;
    for (size_t k = 0; k < cand.size(); ++k)
        if (crossing[k]) {
            const uint32_t f = cand[k].f, other = cand[k].other;
            if (other < T) {
                pairs.emplace_back(f, other);
            } else { // a shell pair as (lower, T + higher)
                const uint32_t g = other - uint32_t(T);
                pairs.emplace_back(std::min(f, g), uint32_t(T) + std::max(f, g));
            }
        }
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    const std::vector<std::array<bool, 2>> blame = st.blame(hit, pairs);
    if (halvings) st.raise_halvings(halvings, pairs, blame, max_halvings);
    return pairs.size();
}

// The order in which the per-vertex queries below are answered: by where the vertex's first face comes in the
// hierarchy's leaf order (a counting sort, ties in query order), so that consecutive queries descend through the
// same nodes and read the same triangles while they are still in cache. Each query's answer depends on nothing
// but its own input, so the order changes no result, only the time: the welded ids follow the input's index
// buffer. Not fewer instructions but fewer cache misses: `bench shells` set-up on the Stanford bunny (-j 1,
// one interleaved run of three) 259-262 -> 243-245 ms.
std::vector<uint32_t> coherent_order(const SurfaceIndex::Impl& ix, const uint32_t* query_vertex, size_t query_count) {
    const size_t W = ix.points.size() / 3;
    const std::vector<uint32_t>& leaves = ix.bvh.leaf_order();
    const uint32_t none = uint32_t(leaves.size()); // a vertex on no face of the hierarchy: last
    std::vector<uint32_t> rank(W, none);
    for (size_t j = leaves.size(); j-- > 0;)
        for (uint32_t v : ix.triangles[leaves[j]]) rank[v] = uint32_t(j);
    std::vector<uint32_t> start(size_t(none) + 2, 0);
    for (size_t q = 0; q < query_count; ++q) ++start[size_t(rank[query_vertex[q]]) + 1];
    for (size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
    std::vector<uint32_t> order(query_count);
    for (size_t q = 0; q < query_count; ++q) order[start[rank[query_vertex[q]]]++] = uint32_t(q);
    return order;
}

void free_distances(double* out, const SurfaceIndex& index, const uint32_t* query_vertex, const double* dirs, size_t query_count,
                    const double* reach) {
    const double inf = std::numeric_limits<double>::infinity();
    const SurfaceIndex::Impl& ix = index.impl();
    if (ix.triangles.empty()) {
        std::fill(out, out + query_count, inf);
        return;
    }
    // CGAL builds the ray from its source and source + direction: with a unit direction on a mesh far below
    // unit size, those two points hold almost none of the mesh's precision (exact arithmetic showed hits on
    // triangles the ray misses by far), and far above it the second point rounds back onto the first. Meshes
    // that extreme get a direction of about their own size (a power of two: the scaling is exact); any
    // other mesh keeps the unit direction.
    double extent = 0;
    for (int k = 0; k < 3; ++k) extent = std::max(extent, ix.bounds.hi[k] - ix.bounds.lo[k]);
    const int level = extent > 0 && std::isfinite(extent) ? std::ilogb(extent) : 0;
    const double ray_scale = std::abs(level) > 20 ? std::ldexp(1.0, level) : 1.0;
    const std::vector<uint32_t> order = coherent_order(ix, query_vertex, query_count);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, query_count, 256), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
            const size_t q = order[k];
            const uint32_t v = query_vertex[q];
            const Vector d(dirs[3 * q], dirs[3 * q + 1], dirs[3 * q + 2]);
            if (!(d.squared_length() > 0)) {
                out[q] = inf;
                continue;
            }
            const Point origin = ix.pt(v);
            const Ray ray(origin, ray_scale * d);
            // CGAL's first_intersection ranks hits by this ray parameter (the largest direction component).
            const Vector rv = ray.to_vector();
            int max_i = 0;
            for (int i = 1; i < 3; ++i)
                if (std::abs(rv[i]) > std::abs(rv[max_i])) max_i = i;
            auto param = [&](const Point& p) { return Vector(origin, p)[max_i] / rv[max_i]; };
            const double o[3] = {origin.x(), origin.y(), origin.z()}, dd[3] = {d.x(), d.y(), d.z()};
            const double unit = std::sqrt(d.squared_length());
            double best_param = inf, best = inf;
            bool failed = false;
            // along dd, in units of |d|. A reach bounds it (with slack: the hit found is ranked by its
            // parameter along one axis): every box holding a hit within the reach is entered before it.
            const double t_max_reach = reach && reach[q] >= 0 ? reach[q] * (1 + 1e-6) : inf;
            double t_max = t_max_reach / unit;
            ix.bvh.for_ray(o, dd, t_max, [&](uint32_t f, double& limit) {
                // Faces around the vertex touch the ray at its origin; they are the surface being offset,
                // not an obstacle in front of it.
                const auto& t = ix.triangles[f];
                if (failed || t[0] == v || t[1] == v || t[2] == v) return;
                if (!may_hit(o, dd, ix.tris[f])) return;
                try {
                    auto hit = CGAL::intersection(ray, ix.tris[f]);
                    if (!hit) return;
                    double pr, dist;
                    if (const Point* p = boost::get<Point>(&*hit)) {
                        pr = param(*p);
                        dist = std::sqrt(CGAL::squared_distance(origin, *p));
                    } else if (const Segment* s = boost::get<Segment>(&*hit)) {
                        // The ray runs inside a coplanar face: its nearer end is where it is blocked.
                        pr = std::min(param(s->source()), param(s->target()));
                        dist = std::sqrt(std::min(CGAL::squared_distance(origin, s->source()), CGAL::squared_distance(origin, s->target())));
                    } else {
                        pr = 0, dist = 0;
                    }
                    // Ties on the parameter (a hit on an edge two faces share) go to the nearer point: the
                    // answer does not depend on which face the descent meets first.
                    if (pr < best_param || (pr == best_param && dist < best)) {
                        best_param = pr;
                        best = dist;
                        // Boxes entered beyond the nearest hit so far cannot hold a nearer one (slack for
                        // the parameter being measured along one axis).
                        limit = std::min(limit, (dist * (1 + 1e-9) + 1e-300) / unit);
                    }
                } catch (...) {
                    failed = true; // a failed construction: be safe, treat the vertex as blocked
                }
            });
            // A hit found beyond the reach (in a box entered before it) need not be the first one: only the
            // hits within the reach are certain to have been seen.
            out[q] = failed ? 0.0 : best <= t_max_reach ? best : inf;
        }
    });
}

// owned_lengths' first test's bound: ratio² × the squared distance from x to v's first own face (at least
// owned_r2, with 1e-12 to spare for rounding); false where that distance is not finite (no own face, or NaN).
bool first_test_bound(const SurfaceIndex::Impl& ix, const Point& x, const uint32_t* own_begin, uint32_t own_count, double ratio, double& bound) {
    const double first = own_count ? squared_distance_to(x, ix.tris[*own_begin]) : HUGE_VAL;
    bound = ratio * ratio * first * (1 + 1e-12);
    return first < HUGE_VAL;
}

// owned_lengths' first test (owned_first: is x = p + h·d owned, h the full length?) for the n <= 8 queries
// qs[0..n) at once, their balls in one packet through the hierarchy (BoxBvh::for_near_packet): each ball
// meets the faces its own search meets, and is decided by the same tests (the plane, the distance within the
// bound from v's first own face, then within ratio² × the distance to all of v's own faces), so bit i is set
// exactly where owned_first(h) holds for query qs[i] (h > 0, a first own face at a finite distance; 0 where the
// query needs its whole path).
constexpr size_t kPacketQueries = BoxBvh::kPacket;
unsigned first_tests_owned(const SurfaceIndex::Impl& ix, const uint32_t* ring_start, const uint32_t* ring_faces, const uint32_t* query_vertex,
                           const double* dirs, const double* lengths, double ratio, const uint32_t* qs, size_t n) {
    constexpr int P = BoxBvh::kPacket;
    double centre[P][3], bound[P], reach[P], exact[P];
    const uint32_t *own_begin[P], *own_end[P];
    unsigned balls = 0;
    for (size_t i = 0; i < n; ++i) {
        const size_t q = qs[i];
        const uint32_t v = query_vertex[q];
        const double h = lengths[q];
        own_begin[i] = ring_faces + ring_start[v], own_end[i] = ring_faces + ring_start[v + 1];
        const Point x = ix.pt(v) + h * Vector(dirs[3 * q], dirs[3 * q + 1], dirs[3 * q + 2]);
        if (!(h > 0) || !first_test_bound(ix, x, own_begin[i], uint32_t(own_end[i] - own_begin[i]), ratio, bound[i])) continue;
        centre[i][0] = x.x(), centre[i][1] = x.y(), centre[i][2] = x.z();
        reach[i] = SurfaceIndex::Impl::bounded_reach(bound[i]);
        exact[i] = -1;
        balls |= 1u << i;
    }
    const unsigned taken = ix.bvh.for_near_packet(centre, bound, balls, [&](int i, uint32_t f, uint32_t j) {
        const Point x(centre[i][0], centre[i][1], centre[i][2]);
        auto owned_r2 = [&] { return ratio * ratio * nearest_of(ix.tris, x, own_begin[i], uint32_t(own_end[i] - own_begin[i])); };
        // The searches leave v's own faces out (ratio <= 1: they are no nearer than owned_r2, which measures them).
        return ix.within_bounded(f, j, x, centre[i], reach[i], bound[i], exact[i], owned_r2, own_begin[i], ratio <= 1 ? own_end[i] : own_begin[i]);
    });
    return balls & ~taken;
}

void owned_lengths(double* out, const SurfaceIndex& index, const uint32_t* ring_start, const uint32_t* ring_faces,
                   const uint32_t* query_vertex, const double* dirs, const double* lengths, double ratio, size_t query_count) {
    const SurfaceIndex::Impl& ix = index.impl();
    if (ix.triangles.empty()) {
        std::copy(lengths, lengths + query_count, out);
        return;
    }
    const std::vector<uint32_t> order = coherent_order(ix, query_vertex, query_count);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, query_count, 128), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<PreparedTriangle> own; // v's own faces, prepared once for all of v's distances
        PreparedTriangle witness_face;
        // One query, whole: its first test, then the bisection where that test fails.
        auto one = [&](size_t q) {
            const uint32_t v = query_vertex[q];
            const Point p = ix.pt(v);
            const Vector d(dirs[3 * q], dirs[3 * q + 1], dirs[3 * q + 2]);
            const uint32_t own_count = ring_start[v + 1] - ring_start[v];
            const uint32_t* own_begin = ring_faces + ring_start[v];
            // The searches leave v's own faces out: they are no nearer than owned_r2 (ratio <= 1), which
            // measured them.
            const uint32_t* own_skip_end = ratio <= 1 ? own_begin + own_count : own_begin;
            own.clear(); // prepared once v is clamped (most vertices need one distance per own face)
            // Owned: no part of the mesh is nearer than `ratio` × the distance to v's own faces. v's own faces
            // are never nearer than that (ratio < 1), so "anything nearer?" with an early exit decides it.
            // The triangle that broke ownership last time is the likeliest to break it again along the same
            // ray: tried first, it saves the search on about half of the bisection steps.
            uint32_t witness = UINT32_MAX, prepared_witness = UINT32_MAX; // witness_face holds prepared_witness
            // ratio² × the squared distance from x to v's own faces: what another face must come within.
            auto owned_r2 = [&](const Point& x) {
                double nearest = std::numeric_limits<double>::infinity();
                if (own.empty())
                    nearest = nearest_of(ix.tris, x, own_begin, own_count);
                else
                    for (const PreparedTriangle& t : own) nearest = std::min(nearest, squared_distance(t, xyz(x)));
                return ratio * ratio * nearest;
            };
            auto witness_prepared = [&]() -> const PreparedTriangle& {
                if (prepared_witness != witness) prepare_face(witness_face, ix.tris[witness]), prepared_witness = witness;
                return witness_face;
            };
            auto taken_by_witness = [&](const Point& x, double r2) {
                return witness != UINT32_MAX && squared_distance(witness_prepared(), xyz(x)) < r2;
            };
            uint32_t hint = 0; // witness_takes' first own face to try
            auto owned = [&](double t) {
                const Point x = p + t * d;
                const double r2 = owned_r2(x);
                if (taken_by_witness(x, r2)) return false;
                return !ix.any_within(x, r2, &witness, own_begin, own_skip_end);
            };
            // The first test, at the full length (own faces not prepared yet: most vertices need nothing more),
            // searches within ratio² × the squared distance to v's first own face, a bound on owned_r2 (with
            // 1e-12 to spare for rounding), and measures the other own faces only if a face comes within it:
            // the same answer and witness as owned(t). Bunny callgrind (`furrow -j 1 -q shells --layers 2
            // --length 0.004`): owned_lengths 256.9 -> 221.9 M instructions; stage timer 46.1-49.3 -> 45.3-45.9 ms.
            auto owned_first = [&](double t) {
                const Point x = p + t * d;
                double bound;
                if (!first_test_bound(ix, x, own_begin, own_count, ratio, bound)) return owned(t);
                return !ix.any_within_bounded(x, bound, [&] { return owned_r2(x); }, &witness, own_begin, own_skip_end);
            };
            const double h = lengths[q];
            if (!(h > 0) || owned_first(h)) {
                out[q] = h;
                return;
            }
            own.resize(own_count);
            for (uint32_t i = 0; i < own_count; ++i) prepare_face(own[i], ix.tris[own_begin[i]]);
            // Ownership is lost once along the ray and (in practice) not regained: the boundary is bracketed
            // to 1/4096 of the length, owned at lo (a whole search says so), not at hi (a face comes within).
            // Bisected against the witness alone (v's own faces and one more distance, no search), then one
            // search at the bracket's owned end, which confirms it or names an earlier witness to bisect
            // against in turn: one or two searches per clamped vertex instead of about six (a search at every
            // step that the witness did not decide). Most searches are the first one, owned(h), of every
            // vertex: `bench shells` set-up, Stanford bunny (69k triangles, 32 layers, -j 1) 274-280 -> 266-271
            // ms, every length within the same 1/4096 bracket.
            const double step = h / 4096;
            double lo = 0, hi = h;
            while (hi - lo > step) {
                double a = lo, b = hi; // the witness takes x over at b (it broke ownership there), not at a
                while (b - a > step) {
                    const double mid = 0.5 * (a + b);
                    const Point x = p + mid * d;
                    (witness_takes(witness_prepared(), own.data(), own_count, xyz(x), ratio, &hint) ? b : a) = mid;
                }
                hi = b;
                if (owned(a)) {
                    lo = a;
                    break;
                }
                hi = a; // another face takes x over before the witness did: it is the witness now
            }
            out[q] = lo;
        };
        // The first tests of neighbouring queries (consecutive in the coherent order) as one packet
        // (first_tests_owned): a query it finds owned keeps its length; any other runs whole as before, its
        // first test again (it names the witness the bisection starts from), so every answer is the same.
        // Without vector lanes (ball by ball) a packet is slower than the searches one at a time, so there
        // every query runs whole.
        const bool packets = BoxBvh::packet_width() >= 4;
        for (size_t k0 = r.begin(); k0 < r.end(); k0 += kPacketQueries) {
            const size_t n = std::min(kPacketQueries, r.end() - k0);
            const unsigned owned_now =
                packets ? first_tests_owned(ix, ring_start, ring_faces, query_vertex, dirs, lengths, ratio, &order[k0], n) : 0u;
            for (size_t i = 0; i < n; ++i) {
                const size_t q = order[k0 + i];
                if (owned_now >> i & 1) out[q] = lengths[q];
                else one(q);
            }
        }
    });
}

void bend_limits(double* out, const SurfaceIndex& index, const uint32_t* ring_start, const uint32_t* ring_faces,
                 const uint32_t* query_vertex, const double* straight, const double* bent, double clearance, size_t query_count) {
    const SurfaceIndex::Impl& ix = index.impl();
    if (ix.triangles.empty()) {
        std::fill(out, out + query_count, 1.0);
        return;
    }
    const auto& triangles = ix.triangles;
    const std::vector<uint32_t> order = coherent_order(ix, query_vertex, query_count);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, query_count, 64), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<uint32_t> faces, verts, next;
        for (size_t k = r.begin(); k != r.end(); ++k) {
            const size_t q = order[k];
            const uint32_t v = query_vertex[q];
            const Point p = ix.pt(v);
            const Vector a(straight[3 * q], straight[3 * q + 1], straight[3 * q + 2]);
            const Vector b(bent[3 * q], bent[3 * q + 1], bent[3 * q + 2]);
            // The neighbourhood the bent tip may still belong to: rings of faces around v, as many as the
            // bend is long in edges (at most 6), grown in a fixed order.
            double edge = 0;
            int edges = 0;
            for (uint32_t i = ring_start[v]; i < ring_start[v + 1]; ++i)
                for (uint32_t u : triangles[ring_faces[i]])
                    if (u != v) edge += std::sqrt(CGAL::squared_distance(p, ix.pt(u))), ++edges;
            edge = edges ? edge / edges : 0;
            const double bend = std::sqrt((b - a).squared_length());
            // Capped while still a double: a bend 1e9 edges long made int(ceil(bend / edge)) overflow
            // (undefined behaviour, found by fuzz_shells); NaN takes the widest neighbourhood.
            const double wanted = std::ceil(bend / edge);
            const int rings = !(edge > 0) ? 1 : wanted < 5 ? 1 + int(wanted) : 6;
            faces.clear();
            verts.assign(1, v);
            for (int k = 0; k < rings; ++k) {
                next.clear();
                for (uint32_t u : verts)
                    for (uint32_t i = ring_start[u]; i < ring_start[u + 1]; ++i) {
                        const uint32_t f = ring_faces[i];
                        if (std::find(faces.begin(), faces.end(), f) != faces.end()) continue;
                        faces.push_back(f);
                        for (uint32_t w : triangles[f]) next.push_back(w);
                    }
                verts.swap(next);
            }
            const double need = clearance * clearance * ix.squared_distance(p + a);
            // The tip keeps its clearance (distance to the mesh >= need), stays nearer to its own
            // neighbourhood than to any other part of the surface (>= 0.98² × own), and does not pass through
            // the surface on the way (a tip pushed through a thin wall can be far from the mesh again on the
            // other side). The first two are one "anything nearer?" test.
            auto ok = [&](double sigma) {
                const Point tip = p + a + sigma * (b - a);
                double own = std::numeric_limits<double>::infinity();
                for (uint32_t f : faces) own = std::min(own, CGAL::squared_distance(tip, ix.tris[f]));
                if (ix.any_within(tip, std::max(need, 0.98 * 0.98 * own))) return false;
                return !ix.crosses(Segment(p + a, tip));
            };
            if (ok(1.0)) {
                out[q] = 1.0;
                continue;
            }
            double lo = 0, hi = 1;
            for (int i = 0; i < 10; ++i) {
                const double mid = 0.5 * (lo + hi);
                (ok(mid) ? lo : hi) = mid;
            }
            out[q] = lo;
        }
    });
}

} // namespace shells_detail

void distances_to_mesh(double* out, const float* points, size_t point_count, const float* positions, size_t vertex_count,
                       const uint32_t* indices, size_t index_count) {
    using Iterator = std::vector<Triangle>::const_iterator;
    using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, CGAL::AABB_triangle_primitive<Kernel, Iterator>>>;
    std::vector<Triangle> tris;
    tris.reserve(index_count / 3);
    auto pt = [&](uint32_t v) { return Point(positions[3 * size_t(v)], positions[3 * size_t(v) + 1], positions[3 * size_t(v) + 2]); };
    for (size_t t = 0; t + 3 <= index_count; t += 3) {
        if (indices[t] >= vertex_count || indices[t + 1] >= vertex_count || indices[t + 2] >= vertex_count) continue;
        Triangle tri(pt(indices[t]), pt(indices[t + 1]), pt(indices[t + 2]));
        if (!tri.is_degenerate()) tris.push_back(tri);
    }
    if (tris.empty()) {
        std::fill(out, out + point_count, std::numeric_limits<double>::infinity());
        return;
    }
    // The benchmark's reference measurement: CGAL's own tree and closest-point query, independent of the
    // hierarchy the clamps use.
    Tree tree(tris.begin(), tris.end());
    tree.build();
    tree.accelerate_distance_queries();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, point_count, 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i)
            out[i] = std::sqrt(tree.squared_distance(Point(points[3 * i], points[3 * i + 1], points[3 * i + 2])));
    });
}

} // namespace furrow

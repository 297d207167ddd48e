// furrow's private geometry kernel: do two triangles of one mesh intersect? The pair decision of CGAL's
// Polygon_mesh_processing::self_intersections, with adjacency read from vertex ids instead of halfedges, in
// one place. Shared because `furrow check` (mesh/src/self_intersections.cpp, on a triangle soup that a
// Surface_mesh cannot hold) and the shells' intersection test (shells/src/feature_distance.cpp, shell
// against shell and base) must agree pair for pair with each other and with CGAL. Include it only from a
// file that already pays for the CGAL headers. Not installed and not part of any public header.
//
// References: CGAL User and Reference Manual 5.5, Polygon Mesh Processing (the decision: a shared edge
// intersects only when the two triangles fold onto each other; a shared vertex when anything else meets);
// A. Meyer, S. Pion, "FPG: A code generator for fast and certified geometric predicates", RNC 2008 (the
// error bound of CGAL's semi-static orientation filter, reused by CertainSide); T. Möller, "A Fast
// Triangle-Triangle Intersection Test", JGT 2(2), 1997, and O. Devillers, P. Guigue, "Faster
// Triangle-Triangle Intersection Tests", INRIA RR-4488, 2002 (the segment test); S. Gottschalk, M. Lin,
// D. Manocha, "OBBTree", SIGGRAPH 1996, and C. Ericson, "Real-Time Collision Detection", 2005, section 5.2.1
// (the separating-axis theorem, used by Separation). The fast paths only ever skip work whose outcome they
// have proven: every answer is the one CGAL's own predicates give.
//
// Why Separation and the axis-plane fold test: where a corner lies exactly on the other triangle's plane (a
// lattice's or a CAD model's axis-aligned walls, their shells translated by one vector), CGAL's filters
// cannot certify the zero and every such pair went to multi-precision arithmetic (an interval failure, an
// exception, Mpzf). On the 48,750-quad lattice (`furrow -j 1 bench shells /tmp/empty --lattice 25
// --layers 8 --no-lod-table`, /tmp/empty an empty folder) the first intersection round's 3.7 M candidate
// pairs held 2.1 M segment tests with an end on the plane (none met) and 132 k coplanar folds; with these
// shortcuts the set-up went from 1051-1155 ms to 906-940 ms (runs interleaved, the same shells' bytes).
#pragma once

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <vector>

namespace furrow::kernel {

using ExactKernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using ExactPoint = ExactKernel::Point_3;

// The sign of orientation(p, q, r, s) where CGAL's semi-static filter certifies it (the same expression and
// error bound as CGAL/Filtered_kernel/internal/Static_filters/Orientation_3.h, 5.5), 0 where it does not
// (or the sign is 0), for one plane (p, q, r) and several s. Most candidate pairs lie on one side of each
// other's plane; deciding that here skips building the CGAL objects and the full predicate.
class CertainSide {
public:
    CertainSide(const ExactPoint& p, const ExactPoint& q, const ExactPoint& r)
        : px(p.x()), py(p.y()), pz(p.z()), pqx(q.x() - px), pqy(q.y() - py), pqz(q.z() - pz), prx(r.x() - px), pry(r.y() - py),
          prz(r.z() - pz), m01(pqx * pry - prx * pqy), ax(std::max(std::abs(pqx), std::abs(prx))),
          ay(std::max(std::abs(pqy), std::abs(pry))), az(std::max(std::abs(pqz), std::abs(prz))) {}
    [[gnu::always_inline]] int operator()(const ExactPoint& s) const {
        const double psx = s.x() - px, psy = s.y() - py, psz = s.z() - pz;
        const double maxx = std::max(ax, std::abs(psx)), maxy = std::max(ay, std::abs(psy)), maxz = std::max(az, std::abs(psz));
        const double m02 = pqx * psy - psx * pqy, m12 = prx * psy - psx * pry;
        const double det = m01 * psz - m02 * prz + m12 * pqz;
        const double eps = 5.1107127829973299e-15 * maxx * maxy * maxz;
        // CGAL's guards against underflow of eps and overflow of det (on the smallest and largest maximum).
        const double lo = std::min(std::min(maxx, maxy), maxz), hi = std::max(std::max(maxx, maxy), maxz);
        if (lo < 1e-97 || !(hi < 1e102)) return 0;
        return det > eps ? 1 : det < -eps ? -1 : 0;
    }

private:
    double px, py, pz, pqx, pqy, pqz, prx, pry, prz, m01, ax, ay, az;
};

// Do two convex point sets (a segment or triangle each, at most six points) certainly not meet? They do not if
// their projections onto some axis are disjoint (the separating-axis theorem). The axis may be any vector:
// it is computed in double from the edges and its own rounding proves nothing wrong; only the projections
// are bounded. A projection (x - o)·L of a difference from the first point o takes four roundings (the
// difference, the products, two sums): within 4.0001 u · sum_k |x - o|_k |L_k| <= 0.45e-15 · bound with
// bound = sum_k max_x |x - o|_k · |L_k| (u = 2^-53). Disjoint computed intervals with a gap of three times
// 1e-15 · bound (one more rounding in the comparison) are disjoint exactly. Below 1e-290 (subnormal
// products) or above 1e290 (overflow) no axis is trusted.
class Separation {
public:
    Separation(std::initializer_list<const ExactPoint*> a, std::initializer_list<const ExactPoint*> b)
        : na_(int(a.size())), n_(int(a.size() + b.size())) {
        const ExactPoint& o = **a.begin();
        int i = 0;
        for (std::initializer_list<const ExactPoint*> set : {a, b})
            for (const ExactPoint* x : set) {
                d_[i][0] = x->x() - o.x(), d_[i][1] = x->y() - o.y(), d_[i][2] = x->z() - o.z();
                for (int k = 0; k < 3; ++k) m_[k] = std::max(m_[k], std::abs(d_[i][k]));
                ++i;
            }
    }
    // Edge e of set 0 (a) or 1 (b): from its point e to the next (a segment's one edge: e = 0).
    void edge(int set, int e, double* out) const {
        const int first = set ? na_ : 0, count = set ? n_ - na_ : na_;
        const double *p = d_[first + e], *q = d_[first + (e + 1) % count];
        for (int k = 0; k < 3; ++k) out[k] = q[k] - p[k];
    }
    // Certainly apart along u × v?
    bool along_cross(const double* u, const double* v) const {
        return along(u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]);
    }
    bool along(double lx, double ly, double lz) const {
        const double bound = m_[0] * std::abs(lx) + m_[1] * std::abs(ly) + m_[2] * std::abs(lz);
        if (!(bound > 1e-290 && bound < 1e290)) return false;
        double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
        for (int i = 0; i < n_; ++i) {
            const double t = d_[i][0] * lx + d_[i][1] * ly + d_[i][2] * lz;
            const int set = i >= na_;
            lo[set] = std::min(lo[set], t), hi[set] = std::max(hi[set], t);
        }
        const double gap = 3e-15 * bound;
        return hi[0] + gap < lo[1] || hi[1] + gap < lo[0];
    }

private:
    double d_[6][3];
    double m_[3] = {0, 0, 0};
    int na_, n_;
};

// Triangle (a, b, c) and segment (p, q) certainly apart: axes in the triangle's plane first (the normal
// crossed with each edge and with the segment: a segment lying in the plane), then each edge crossed with
// the segment.
inline bool certainly_apart(const ExactPoint& a, const ExactPoint& b, const ExactPoint& c, const ExactPoint& p,
                            const ExactPoint& q) {
    const Separation s({&a, &b, &c}, {&p, &q});
    double e[3][3], f[3], n[3];
    for (int i = 0; i < 3; ++i) s.edge(0, i, e[i]);
    s.edge(1, 0, f);
    n[0] = e[0][1] * e[1][2] - e[0][2] * e[1][1], n[1] = e[0][2] * e[1][0] - e[0][0] * e[1][2], n[2] = e[0][0] * e[1][1] - e[0][1] * e[1][0];
    for (int i = 0; i < 3; ++i)
        if (s.along_cross(n, e[i])) return true;
    if (s.along_cross(n, f)) return true;
    for (int i = 0; i < 3; ++i)
        if (s.along_cross(e[i], f)) return true;
    return false;
}

// Two triangles certainly apart: each edge of one crossed with each of the other (the axes of two triangles
// in general position), then the in-plane axes (each normal crossed with its own edges: coplanar pairs).
inline bool certainly_apart(const ExactPoint& a0, const ExactPoint& a1, const ExactPoint& a2, const ExactPoint& b0,
                            const ExactPoint& b1, const ExactPoint& b2) {
    const Separation s({&a0, &a1, &a2}, {&b0, &b1, &b2});
    double e[2][3][3], n[2][3];
    for (int set = 0; set < 2; ++set) {
        for (int i = 0; i < 3; ++i) s.edge(set, i, e[set][i]);
        const double *u = e[set][0], *v = e[set][1];
        n[set][0] = u[1] * v[2] - u[2] * v[1], n[set][1] = u[2] * v[0] - u[0] * v[2], n[set][2] = u[0] * v[1] - u[1] * v[0];
    }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (s.along_cross(e[0][i], e[1][j])) return true;
    for (int set = 0; set < 2; ++set)
        for (int i = 0; i < 3; ++i)
            if (s.along_cross(n[set], e[set][i])) return true;
    return false;
}

// The sign of the 2D orientation (p, q, r) in coordinates (i, j) where CGAL's semi-static filter certifies it
// (CGAL/Filtered_kernel/internal/Static_filters/Orientation_2.h, 5.5: the same expression and bound), else 0.
inline int certain_orientation_2(const ExactPoint& p, const ExactPoint& q, const ExactPoint& r, int i, int j) {
    const double pqx = q[i] - p[i], pqy = q[j] - p[j], prx = r[i] - p[i], pry = r[j] - p[j];
    const double det = pqx * pry - pqy * prx;
    double maxx = std::max(std::abs(pqx), std::abs(prx)), maxy = std::max(std::abs(pqy), std::abs(pry));
    if (maxx > maxy) std::swap(maxx, maxy);
    if (maxx < 1e-146 || !(maxy < 1e153)) return 0;
    const double eps = 8.8872057372592798e-16 * maxx * maxy;
    return det > eps ? 1 : det < -eps ? -1 : 0;
}

// CGAL::coplanar(u, v, a, b) && CGAL::coplanar_orientation(u, v, a, b) == POSITIVE (a and b on the same side
// of the line uv in their common plane: two triangles on the edge uv folded onto each other). Four points
// with one coordinate equal are exactly coplanar (a zero column in the orientation determinant), and the side
// is then the 2D orientation in the two other coordinates (the plane's projection along that axis is
// one-to-one, so the product of the two signs is the one coplanar_orientation computes in its own
// projection); certified signs decide, anything else goes to CGAL.
inline bool folded(const ExactPoint& u, const ExactPoint& v, const ExactPoint& a, const ExactPoint& b) {
    for (int k = 0; k < 3; ++k)
        if (u[k] == v[k] && u[k] == a[k] && u[k] == b[k]) {
            const int i = (k + 1) % 3, j = (k + 2) % 3;
            const int sa = certain_orientation_2(u, v, a, i, j), sb = certain_orientation_2(u, v, b, i, j);
            if (sa != 0 && sb != 0) return sa == sb;
            break;
        }
    return CGAL::coplanar(u, v, a, b) && CGAL::coplanar_orientation(u, v, a, b) == CGAL::POSITIVE;
}

// CGAL::do_intersect(Triangle_3(a, b, c), Segment_3(p, q)), answered without CGAL where certified signs
// suffice: p and q strictly on one side of the plane cannot meet the triangle; strictly on opposite sides,
// the segment crosses the plane inside the closed triangle if and only if orientation(p, q, ·, ·) over its
// three edges has no two opposite signs. An end not certainly off the plane (on it: CGAL's exact path) is
// first tried for a separating axis.
[[gnu::always_inline]] inline bool segment_meets_triangle(const ExactPoint& a, const ExactPoint& b, const ExactPoint& c,
                                                          const ExactPoint& p, const ExactPoint& q) {
    const CertainSide plane(a, b, c);
    const int sp = plane(p), sq = plane(q);
    if (sp != 0 && sp == sq) return false;
    if (sp != 0 && sq != 0) {
        const int s1 = CertainSide(p, q, a)(b), s2 = CertainSide(p, q, b)(c), s3 = CertainSide(p, q, c)(a);
        if (s1 != 0 && s2 != 0 && s3 != 0) return s1 == s2 && s2 == s3;
        if ((s1 * s2 < 0) || (s2 * s3 < 0) || (s1 * s3 < 0)) return false;
    } else if (certainly_apart(a, b, c, p, q)) {
        return false;
    }
    return CGAL::do_intersect(ExactKernel::Triangle_3(a, b, c), ExactKernel::Segment_3(p, q));
}

// Do triangles a and b (vertex ids into pts, three distinct ids each, neither collinear) intersect?
// Sharing an edge, they do only when they fold onto each other (coplanar, both apices on the same side of
// the edge); sharing one vertex, when anything else meets; sharing all three (one triangle twice, e.g. the
// two faces of a closed two-triangle "pillow"), they overlap in their common plane, as CGAL decides it on
// a Surface_mesh. Sharing nothing, when they meet anywhere.
inline bool triangles_intersect(const std::vector<ExactPoint>& pts, const std::array<uint32_t, 3>& a,
                                const std::array<uint32_t, 3>& b) {
    int shared = 0, ia = -1, ib = -1; // ia/ib: position of the (first) shared vertex in a and b
    bool in_b[3] = {false, false, false};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (a[i] == b[j]) {
                if (shared == 0) ia = i, ib = j;
                ++shared;
                in_b[i] = true;
            }
    if (shared >= 2) {
        int u = -1, v = -1, apex = -1;
        for (int i = 0; i < 3; ++i) {
            if (!in_b[i]) apex = i;
            else if (u < 0) u = i;
            else if (v < 0) v = i;
        }
        if (apex < 0) apex = 3 - u - v; // all three shared: the "apex" is the remaining corner
        uint32_t apex_b = b[0];
        for (int j = 0; j < 3; ++j)
            if (b[j] != a[u] && b[j] != a[v]) apex_b = b[j];
        if (shared == 3) apex_b = a[apex];
        const ExactPoint &pu = pts[a[u]], &pv = pts[a[v]], &pa = pts[a[apex]], &pb = pts[apex_b];
        if (CertainSide(pu, pv, pa)(pb) != 0) return false; // certainly not coplanar: no fold
        return folded(pu, pv, pa, pb);
    }
    const ExactPoint &a0 = pts[a[0]], &a1 = pts[a[1]], &a2 = pts[a[2]], &b0 = pts[b[0]], &b1 = pts[b[1]], &b2 = pts[b[2]];
    if (shared == 1) {
        // Touching at the shared vertex is adjacency; anything more means the opposite edge of one triangle
        // reaches the other.
        const ExactPoint &oa0 = pts[a[(ia + 1) % 3]], &oa1 = pts[a[(ia + 2) % 3]];
        const ExactPoint &ob0 = pts[b[(ib + 1) % 3]], &ob1 = pts[b[(ib + 2) % 3]];
        return segment_meets_triangle(a0, a1, a2, ob0, ob1) || segment_meets_triangle(b0, b1, b2, oa0, oa1);
    }
    // A triangle wholly on one side of the other's plane cannot meet it. A corner not certainly off the other's
    // plane (on it: CGAL's exact path) first tries the separating axes.
    const CertainSide side_a(a0, a1, a2), side_b(b0, b1, b2);
    const int sa[3] = {side_b(a0), side_b(a1), side_b(a2)}, sb[3] = {side_a(b0), side_a(b1), side_a(b2)};
    auto apart = [](const int* s) { return s[0] != 0 && s[0] == s[1] && s[1] == s[2]; };
    if (apart(sa) || apart(sb)) return false;
    const bool on_plane = sa[0] * sa[1] * sa[2] * sb[0] * sb[1] * sb[2] == 0;
    if (on_plane && certainly_apart(a0, a1, a2, b0, b1, b2)) return false;
    return CGAL::do_intersect(ExactKernel::Triangle_3(a0, a1, a2), ExactKernel::Triangle_3(b0, b1, b2));
}

} // namespace furrow::kernel

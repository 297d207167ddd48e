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
// Triangle-Triangle Intersection Tests", INRIA RR-4488, 2002 (the segment test). The fast paths only ever
// skip work whose outcome they have proven: every answer is the one CGAL's own predicates give.
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
    // All of xs strictly on one side of the plane, certainly.
    bool apart(std::initializer_list<const ExactPoint*> xs) const {
        int first = 0;
        for (const ExactPoint* x : xs) {
            const int side = (*this)(*x);
            if (side == 0 || (first != 0 && side != first)) return false;
            first = side;
        }
        return true;
    }

private:
    double px, py, pz, pqx, pqy, pqz, prx, pry, prz, m01, ax, ay, az;
};

// CGAL::do_intersect(Triangle_3(a, b, c), Segment_3(p, q)), answered without CGAL where certified signs
// suffice: p and q strictly on one side of the plane cannot meet the triangle; strictly on opposite sides,
// the segment crosses the plane inside the closed triangle if and only if orientation(p, q, ·, ·) over its
// three edges has no two opposite signs.
[[gnu::always_inline]] inline bool segment_meets_triangle(const ExactPoint& a, const ExactPoint& b, const ExactPoint& c,
                                                          const ExactPoint& p, const ExactPoint& q) {
    const CertainSide plane(a, b, c);
    const int sp = plane(p), sq = plane(q);
    if (sp != 0 && sp == sq) return false;
    if (sp != 0 && sq != 0) {
        const int s1 = CertainSide(p, q, a)(b), s2 = CertainSide(p, q, b)(c), s3 = CertainSide(p, q, c)(a);
        if (s1 != 0 && s2 != 0 && s3 != 0) return s1 == s2 && s2 == s3;
        if ((s1 * s2 < 0) || (s2 * s3 < 0) || (s1 * s3 < 0)) return false;
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
        return CGAL::coplanar(pu, pv, pa, pb) && CGAL::coplanar_orientation(pu, pv, pa, pb) == CGAL::POSITIVE;
    }
    const ExactPoint &a0 = pts[a[0]], &a1 = pts[a[1]], &a2 = pts[a[2]], &b0 = pts[b[0]], &b1 = pts[b[1]], &b2 = pts[b[2]];
    if (shared == 1) {
        // Touching at the shared vertex is adjacency; anything more means the opposite edge of one triangle
        // reaches the other.
        const ExactPoint &oa0 = pts[a[(ia + 1) % 3]], &oa1 = pts[a[(ia + 2) % 3]];
        const ExactPoint &ob0 = pts[b[(ib + 1) % 3]], &ob1 = pts[b[(ib + 2) % 3]];
        return segment_meets_triangle(a0, a1, a2, ob0, ob1) || segment_meets_triangle(b0, b1, b2, oa0, oa1);
    }
    // A triangle wholly on one side of the other's plane cannot meet it.
    if (CertainSide(a0, a1, a2).apart({&b0, &b1, &b2}) || CertainSide(b0, b1, b2).apart({&a0, &a1, &a2})) return false;
    return CGAL::do_intersect(ExactKernel::Triangle_3(a0, a1, a2), ExactKernel::Triangle_3(b0, b1, b2));
}

} // namespace furrow::kernel

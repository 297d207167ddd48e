// The squared distance from a point to a triangle, bit for bit the value of CGAL::squared_distance(Point_3,
// Triangle_3) on CGAL::Simple_cartesian<double> (CGAL 5.5, Distance_3/Point_3_Triangle_3.h and
// Point_3_Segment_3.h): the same operations on the same operands in the same order, without CGAL's
// generic overhead (Segment_3 objects built per edge, the edge tests recomputed per call, no inlining of
// the triangle function): owned_lengths on the Stanford bunny (`furrow -j 1 shells --layers 2 --length 0.004`,
// callgrind) 358.7 M -> 295.3 M instructions; a distance took CGAL about 217 instructions, here about 197
// (86 prepared). The medial-axis clamp (owned_lengths) compares these distances with each other,
// and its answers (which face is nearer, where ownership ends) must be CGAL's; test_point_triangle_distance
// holds the two to the same bits on random, needle, collinear, zero-area, far-from-origin and on-edge
// queries.
//
// Reference: CGAL's algorithm is the classic region test (Eberly, "Distance Between Point and Triangle in
// 3D", Geometric Tools, 1999-2020, the Voronoi regions of a triangle): the point is on the inner side of
// each edge's plane (through the edge, containing the normal) or not; inside all three, the distance is
// the plane's; otherwise the nearer of the (one or two) edges it is outside of. A triangle with a zero
// normal (collinear or repeated corners) is the nearest of its three edges.
//
// PreparedTriangle keeps what does not depend on the point (edges, normal, the edges' outward vectors,
// squared lengths): the bisection of owned_lengths asks the same few triangles about 35 points in a row
// (Stanford bunny, bench length: 92.6 k bisection steps over 2618 clamped vertices).
// Computing them anew gives the same bits (the same operations), so prepared and unprepared agree.
//
// No FMA contraction may merge a product into a sum here (it would change the bits): the library is built
// for baseline x86-64 (no FMA instructions), as CGAL's own code is in the same units.
#pragma once

namespace furrow::shells_detail {

struct PreparedTriangle {
    double t[3][3];   // corners t0, t1, t2
    double e[3][3];   // edge k from t[k] to t[k+1 mod 3]: t1 - t0, t2 - t1, t0 - t2
    double out[3][3]; // cross(e[k], n): the point is on edge k's inner side when dot(out[k], p - t[k]) <= 0
    double n[3];      // cross(t1 - t0, t2 - t0)
    double ee[3];     // dot(e[k], e[k])
    double nn;        // dot(n, n)
    bool flat;        // n == 0 (collinear or repeated corners): the nearest edge
};

namespace ptd {
inline double dot(const double* u, const double* v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; }
// CGAL's wcross(u, v).
inline void cross(double* w, const double* u, const double* v) {
    w[0] = u[1] * v[2] - u[2] * v[1];
    w[1] = u[2] * v[0] - u[0] * v[2];
    w[2] = u[0] * v[1] - u[1] * v[0];
}
inline void sub(double* w, const double* a, const double* b) { w[0] = a[0] - b[0], w[1] = a[1] - b[1], w[2] = a[2] - b[2]; }
// (std::min)(a, b) as CGAL calls it: b if b < a, else a (NaN handling included).
inline double min_of(double a, double b) { return b < a ? b : a; }
} // namespace ptd

inline void prepare_triangle(PreparedTriangle& T, const double* a, const double* b, const double* c) {
    for (int k = 0; k < 3; ++k) T.t[0][k] = a[k], T.t[1][k] = b[k], T.t[2][k] = c[k];
    ptd::sub(T.e[0], b, a);
    ptd::sub(T.e[1], c, b);
    ptd::sub(T.e[2], a, c);
    double oe3[3];
    ptd::sub(oe3, c, a);
    ptd::cross(T.n, T.e[0], oe3);
    T.flat = T.n[0] == 0 && T.n[1] == 0 && T.n[2] == 0;
    for (int k = 0; k < 3; ++k) {
        ptd::cross(T.out[k], T.e[k], T.n);
        T.ee[k] = ptd::dot(T.e[k], T.e[k]);
    }
    T.nn = ptd::dot(T.n, T.n);
}

// CGAL's squared_distance(Point_3, Segment_3) for the edge e = target - source with ee = dot(e, e), given the
// point's offsets from both ends (ds = p - source, dt = p - target; CGAL's target - p has the same squares).
[[gnu::always_inline]] inline double edge_squared_distance(const double* e, double ee, const double* ds, const double* dt) {
    const double d = ptd::dot(ds, e);
    if (d <= 0) return ptd::dot(ds, ds);
    if (d > ee) return ptd::dot(dt, dt);
    double w[3];
    ptd::cross(w, e, ds);
    return ptd::dot(w, w) / ee;
}

// CGAL's choice among the regions (squared_distance_to_triangle), given whether the point is on the inner
// side of edges 0, 1, 2 (in(k)), edge k's distance (edge(k)) and the plane's (plane()). Evaluated as lazily as
// CGAL does; every quantity is a pure function of the triangle and the point, so the order does not matter.
template <class In, class Edge, class Plane>
[[gnu::always_inline]] inline double region_distance(In&& in, Edge&& edge, Plane&& plane) {
    if (!in(0)) {
        if (!in(1)) return ptd::min_of(edge(0), edge(1));
        if (!in(2)) return ptd::min_of(edge(0), edge(2));
        return edge(0);
    }
    if (!in(1)) return !in(2) ? ptd::min_of(edge(1), edge(2)) : edge(1);
    if (!in(2)) return edge(2);
    return plane();
}

inline double squared_distance(const PreparedTriangle& T, const double* p) {
    double d[3][3]; // p - t[k]
    for (int k = 0; k < 3; ++k) ptd::sub(d[k], p, T.t[k]);
    auto edge = [&](int k) __attribute__((always_inline)) { return edge_squared_distance(T.e[k], T.ee[k], d[k], d[(k + 1) % 3]); };
    if (T.flat) return ptd::min_of(ptd::min_of(edge(2), edge(1)), edge(0)); // CGAL: min(min(|t2 t0|, |t1 t2|), |t0 t1|)
    auto in = [&](int k) __attribute__((always_inline)) { return ptd::dot(T.out[k], d[k]) <= 0; };
    auto plane = [&]() __attribute__((always_inline)) {
        const double h = ptd::dot(T.n, d[0]);
        return h * h / T.nn;
    };
    return region_distance(in, edge, plane);
}

// The same for a triangle used once (corners a, b, c), computing only what the point's region needs.
inline double squared_distance(const double* p, const double* a, const double* b, const double* c) {
    const double* t[3] = {a, b, c};
    double e[3][3], oe3[3], n[3];
    ptd::sub(e[0], b, a);
    ptd::sub(e[1], c, b);
    ptd::sub(e[2], a, c);
    ptd::sub(oe3, c, a);
    ptd::cross(n, e[0], oe3);
    double d[3][3];
    for (int k = 0; k < 3; ++k) ptd::sub(d[k], p, t[k]);
    auto edge = [&](int k) __attribute__((always_inline)) { return edge_squared_distance(e[k], ptd::dot(e[k], e[k]), d[k], d[(k + 1) % 3]); };
    if (n[0] == 0 && n[1] == 0 && n[2] == 0) return ptd::min_of(ptd::min_of(edge(2), edge(1)), edge(0));
    auto in = [&](int k) __attribute__((always_inline)) {
        double out[3];
        ptd::cross(out, e[k], n);
        return ptd::dot(out, d[k]) <= 0;
    };
    auto plane = [&]() __attribute__((always_inline)) {
        const double h = ptd::dot(n, d[0]);
        return h * h / ptd::dot(n, n);
    };
    return region_distance(in, edge, plane);
}

// Two triangles at once, one per SSE2 lane (GCC/Clang vector extension): out[i] is squared_distance(p, a[i],
// b[i], c[i]), the same bits. Each lane computes every region's value with the same operations as above and
// takes CGAL's by masks (lane arithmetic is the scalar IEEE arithmetic), so no branch depends on the region.
// For a vertex's own faces at its fur tip, where one distance per face is all that is asked.
inline void squared_distance_pair(double* out, const double* p, const double* const* a, const double* const* b, const double* const* c) {
    typedef double V2 __attribute__((vector_size(16)));
    struct V3 {
        V2 x[3];
    };
    auto load = [](const double* const* q) __attribute__((always_inline)) {
        return V3{{V2{q[0][0], q[1][0]}, V2{q[0][1], q[1][1]}, V2{q[0][2], q[1][2]}}};
    };
    auto sub = [](const V3& u, const V3& v) __attribute__((always_inline)) { return V3{{u.x[0] - v.x[0], u.x[1] - v.x[1], u.x[2] - v.x[2]}}; };
    auto dot = [](const V3& u, const V3& v) __attribute__((always_inline)) { return u.x[0] * v.x[0] + u.x[1] * v.x[1] + u.x[2] * v.x[2]; };
    auto cross = [](const V3& u, const V3& v) __attribute__((always_inline)) {
        return V3{{u.x[1] * v.x[2] - u.x[2] * v.x[1], u.x[2] * v.x[0] - u.x[0] * v.x[2], u.x[0] * v.x[1] - u.x[1] * v.x[0]}};
    };
    auto min_of = [](V2 x, V2 y) __attribute__((always_inline)) { return y < x ? y : x; };
    const V3 A = load(a), B = load(b), C = load(c);
    const V3 P{{V2{p[0], p[0]}, V2{p[1], p[1]}, V2{p[2], p[2]}}};
    const V3 e[3] = {sub(B, A), sub(C, B), sub(A, C)};
    const V3 n = cross(e[0], sub(C, A));
    const V3 d[3] = {sub(P, A), sub(P, B), sub(P, C)};
    V2 edge[3];
    for (int k = 0; k < 3; ++k) { // edge_squared_distance, all three cases computed
        const V3 &ds = d[k], &dt = d[(k + 1) % 3];
        const V2 ee = dot(e[k], e[k]), along = dot(ds, e[k]);
        const V3 w = cross(e[k], ds);
        const V2 line = dot(w, w) / ee;
        edge[k] = along <= 0 ? dot(ds, ds) : (along > ee ? dot(dt, dt) : line);
    }
    const V2 h = dot(n, d[0]);
    const V2 plane = h * h / dot(n, n);
    const auto in0 = dot(cross(e[0], n), d[0]) <= 0, in1 = dot(cross(e[1], n), d[1]) <= 0, in2 = dot(cross(e[2], n), d[2]) <= 0;
    // region_distance's table
    const V2 outside0 = !in1 ? min_of(edge[0], edge[1]) : (!in2 ? min_of(edge[0], edge[2]) : edge[0]);
    const V2 inside0 = !in1 ? (!in2 ? min_of(edge[1], edge[2]) : edge[1]) : (!in2 ? edge[2] : plane);
    const auto flat = (n.x[0] == 0) & (n.x[1] == 0) & (n.x[2] == 0);
    const V2 r = flat ? min_of(min_of(edge[2], edge[1]), edge[0]) : (in0 ? inside0 : outside0);
    out[0] = r[0], out[1] = r[1];
}

} // namespace furrow::shells_detail

// Collider footprints rasterised into the carve layer: lower surfaces of spheres, boxes, capsules and image
// brushes, swept between samples, composited with min (deeper wins).
//
// References: Rise of the Tomb Raider's deformation snow (GDC 2016: deformers write their footprint with an
// atomic min); Blender Dynamic Paint (displace canvas: "deeper value wins", substeps for fast brushes);
// swept sphere = capsule, swept capsule = Minkowski sum of a parallelogram and a ball (C. Ericson,
// "Real-Time Collision Detection", 2005, §4.5 and §5.5). For a texel, the imprint is the lowest point of the
// (swept) solid on the vertical line through the texel centre minus the undeformed ground height there, so
// a rigid body pressed into a slope leaves the right shape, not a copy of a flat-ground print.
//
// Exactness: sphere and capsule sweeps (fixed axis) and box sweeps (fixed heading) are exact envelopes — a
// fast collider leaves a continuous trench however far apart its samples are. A turning box or capsule is
// sub-stepped so that its far corner moves at most half a texel per step and each step is swept with both
// end headings; image brushes are stamped every half texel along the path (they have no closed-form sweep).
#include "deform_internal.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <functional>

namespace furrow::deform_detail {
namespace {

// Lowest w of the capsule {x : dist(x, segment ab) <= r} on the vertical line (qu, qv, ·); +inf if missed.
// (u, v, w) are used as (x, y, z) with w vertical.
double capsule_low(double qu, double qv, const Vec3& a, const Vec3& b, double r) {
    double best = kInf;
    const double r2 = r * r;
    for (const Vec3* e : {&a, &b}) {
        const double du = qu - e->x, dv = qv - e->y;
        const double s = r2 - du * du - dv * dv;
        if (s >= 0) best = std::min(best, e->z - std::sqrt(s));
    }
    const Vec3 d = b - a;
    const double L2 = dot(d, d);
    if (L2 > 1e-24) {
        // Infinite cylinder around the axis: |(X − a) × d|² = r²·|d|² with X − a = e + w·ẑ.
        const Vec3 e{qu - a.x, qv - a.y, -a.z};
        const Vec3 A{-d.y, d.x, 0.0}; // ẑ × d
        const Vec3 B = cross(e, d);
        const double AA = dot(A, A);
        if (AA > 1e-12 * L2) {
            const double AB = dot(A, B), BB = dot(B, B);
            const double disc = AB * AB - AA * (BB - r2 * L2);
            if (disc >= 0) {
                const double w = (-AB - std::sqrt(disc)) / AA;
                const Vec3 xa{e.x, e.y, e.z + w};
                const double t = dot(xa, d) / L2;
                if (t >= 0 && t <= 1) best = std::min(best, w);
            }
        }
    }
    return best;
}

// Lowest w of the parallelogram a0 + α·e1 + β·e2 (α, β in [0,1]) offset by a ball of radius r, from its
// interior face only (the edges are capsules, handled by the caller); +inf if the face's offset plane is not
// what the vertical line meets first.
struct SlabFace {
    bool valid = false;
    Vec3 a0, e1, e2, n;
    double g11 = 0, g12 = 0, g22 = 0, det = 0;
};

SlabFace make_face(const Vec3& a0, const Vec3& e1, const Vec3& e2) {
    SlabFace f;
    Vec3 n = cross(e1, e2);
    const double nn = norm(n);
    if (!(nn > 1e-9 * norm(e1) * norm(e2)) || nn == 0) return f;
    n = n * (1.0 / nn);
    if (n.z < 0) n = n * -1.0;
    if (n.z < 1e-9) return f; // a vertical face: its lowest points are on its edges
    f.valid = true;
    f.a0 = a0, f.e1 = e1, f.e2 = e2, f.n = n;
    f.g11 = dot(e1, e1), f.g12 = dot(e1, e2), f.g22 = dot(e2, e2);
    f.det = f.g11 * f.g22 - f.g12 * f.g12;
    if (!(f.det > 0)) f.valid = false;
    return f;
}

double face_low(const SlabFace& f, double qu, double qv, double r) {
    if (!f.valid) return kInf;
    const double w = f.a0.z + (-r - (qu - f.a0.x) * f.n.x - (qv - f.a0.y) * f.n.y) / f.n.z;
    const Vec3 s = Vec3{qu, qv, w} + f.n * r; // the touching point on the face
    const Vec3 g = s - f.a0;
    const double b1 = dot(g, f.e1), b2 = dot(g, f.e2);
    const double alpha = (f.g22 * b1 - f.g12 * b2) / f.det, beta = (f.g11 * b2 - f.g12 * b1) / f.det;
    const double eps = 1e-12;
    if (alpha < -eps || alpha > 1 + eps || beta < -eps || beta > 1 + eps) return kInf;
    return w;
}

// Convex hull (counter-clockwise, Andrew's monotone chain) of a few points.
std::vector<std::array<double, 2>> convex_hull(std::vector<std::array<double, 2>> p) {
    std::sort(p.begin(), p.end());
    p.erase(std::unique(p.begin(), p.end()), p.end());
    if (p.size() < 3) return p;
    auto turn = [](const std::array<double, 2>& o, const std::array<double, 2>& a, const std::array<double, 2>& b) {
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    };
    std::vector<std::array<double, 2>> h(2 * p.size());
    size_t k = 0;
    for (size_t i = 0; i < p.size(); ++i) {
        while (k >= 2 && turn(h[k - 2], h[k - 1], p[i]) <= 0) --k;
        h[k++] = p[i];
    }
    for (size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
        while (k >= t && turn(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
        h[k++] = p[i - 1];
    }
    h.resize(k - 1);
    return h;
}

// Signed distance to a convex counter-clockwise polygon, from its edges' outward unit normals: exact inside,
// the largest edge distance outside (exact except beyond corners, where it is smaller — harmless for a
// half-texel coverage ramp).
struct EdgeLines {
    std::vector<std::array<double, 3>> lines; // nx, ny, c: distance = nx·x + ny·y − c
};
EdgeLines edge_lines(const std::vector<std::array<double, 2>>& h) {
    EdgeLines e;
    if (h.size() < 3) return e;
    for (size_t i = 0; i < h.size(); ++i) {
        const auto& a = h[i];
        const auto& b = h[(i + 1) % h.size()];
        const double ex = b[0] - a[0], ey = b[1] - a[1], l = std::hypot(ex, ey);
        if (l == 0) continue;
        const double nx = ey / l, ny = -ex / l; // outward for counter-clockwise order
        e.lines.push_back({nx, ny, nx * a[0] + ny * a[1]});
    }
    return e;
}
double signed_distance(const EdgeLines& e, double x, double y) {
    if (e.lines.empty()) return kInf;
    double best = -kInf;
    for (const auto& l : e.lines) best = std::max(best, l[0] * x + l[1] * y - l[2]);
    return best;
}

struct Axes {
    double ex_u, ex_v; // local x (across)
    double ez_u, ez_v; // local z (forward)
};
Axes axes(double heading) {
    const double s = std::sin(heading), c = std::cos(heading);
    return {c, -s, s, c};
}

// Horizontal radius of the shape around its centre (bounding circle).
double shape_radius(const Collider& c) {
    switch (c.shape) {
    case ColliderShape::sphere: return c.radius;
    case ColliderShape::box: return 0.5 * std::hypot(c.size[0], c.size[2]);
    case ColliderShape::capsule: return 0.5 * c.length * std::hypot(c.axis[0], c.axis[2]) + c.radius;
    case ColliderShape::image: return 0.5 * std::hypot(c.size[0], c.size[1]);
    }
    return 0;
}

// Capsule end points for a pose (half axis in local (u, v, w)).
Vec3 capsule_half_axis(const Collider& c, double heading) {
    const Axes ax = axes(heading);
    const double h = 0.5 * c.length;
    return {h * (c.axis[0] * ax.ex_u + c.axis[2] * ax.ez_u), h * (c.axis[0] * ax.ex_v + c.axis[2] * ax.ez_v), h * c.axis[1]};
}

float atomic_min(float* cell, float value) {
    std::atomic_ref<float> a(*cell);
    float cur = a.load(std::memory_order_relaxed);
    while (value < cur && !a.compare_exchange_weak(cur, value, std::memory_order_relaxed)) {
    }
    return cur;
}

// Every texel of a row may be in the shape (rasterise's default row span).
struct WholeRows {
    bool operator()(double, double&, double&) const { return true; }
};

// Evaluates `offset(qu, qv, ground)` (an offset <= 0 to composite, or >= 0 / NaN for none) on every texel of
// the box [u0, u1] × [v0, v1] (metres) and composites it into the carve layer. `span(qv, lo, hi)` may narrow
// a row to the texels within [lo, hi] (metres; a bound, widened here by a texel: the offset decides), or
// return false when no texel of the row is in the shape: the same bytes, fewer texels tested.
template <class Offset, class Span = WholeRows>
void rasterise(const StampTarget& T, double u0, double u1, double v0, double v1, double decay, StampResult& res,
               const Offset& offset, const Span& span = {}) {
    const double t = T.texel;
    const int i0 = clamped_int(std::ceil(u0 / t), 0, T.width), i1 = clamped_int(std::floor(u1 / t), -1, T.width - 1);
    const int j0 = clamped_int(std::ceil(v0 / t), 0, T.height), j1 = clamped_int(std::floor(v1 / t), -1, T.height - 1);
    if (i1 < i0 || j1 < j0) return;
    struct Acc {
        TexelRect rect;
        size_t written = 0;
    };
    auto row_range = [&](int ja, int jb, Acc& acc) {
        for (int j = ja; j < jb; ++j) {
            if (j + 2 < jb) { // the rows are a grid row apart: no hardware prefetcher follows them
                const size_t ahead = size_t(j + 2) * size_t(T.width) + size_t(i0), last = ahead + size_t(i1 - i0);
                for (size_t k = ahead; k <= last; k += 16) __builtin_prefetch(T.ground + k), __builtin_prefetch(T.carve + k, 1);
                __builtin_prefetch(T.ground + last), __builtin_prefetch(T.carve + last, 1);
            }
            const double qv = j * t;
            double lo = u0, hi = u1;
            if (!span(qv, lo, hi)) continue;
            const int ia = std::max(i0, clamped_int(std::ceil(lo / t) - 1, -1, T.width)),
                      ib = std::min(i1, clamped_int(std::floor(hi / t) + 1, -1, T.width));
            for (int i = ia; i <= ib; ++i) {
                const size_t idx = size_t(j) * size_t(T.width) + size_t(i);
                const float g = T.ground[idx];
                if (std::isnan(g)) continue;
                double h = offset(i * t, qv, double(g));
                if (!(h < 0)) continue;
                if (T.snow_depth > 0) h = std::max(h, -T.snow_depth);
                const float hv = float(h * decay);
                if (!(hv < 0)) continue;
                if (atomic_min(&T.carve[idx], hv) > hv) {
                    ++acc.written;
                    acc.rect.unite({i, j, i + 1, j + 1});
                }
            }
        }
    };
    const size_t area = size_t(i1 - i0 + 1) * size_t(j1 - j0 + 1);
    if (area < 16384) {
        Acc acc;
        row_range(j0, j1 + 1, acc);
        res.written += acc.written;
        res.rect.unite(acc.rect);
        return;
    }
    std::vector<Acc> accs(size_t(j1 - j0 + 1));
    tbb::parallel_for(tbb::blocked_range<int>(j0, j1 + 1, 8), [&](const tbb::blocked_range<int>& r) {
        for (int j = r.begin(); j != r.end(); ++j) row_range(j, j + 1, accs[size_t(j - j0)]);
    });
    for (const Acc& a : accs) {
        res.written += a.written;
        res.rect.unite(a.rect);
    }
}

// Whether the convex hull of `pts` (u, v), grown by `grow`, reaches the grid's texel centres [0, U] × [0, V].
// Separating axes: the grid's two and the normal of every pair of points (a superset of the hull's edges).
// Most sweeps of a huge shape turning near a small field miss it, but each would still rasterise its whole
// bounding box: a capsule 2.6e11 m long turning near a 2 x 6 m field took minutes (found by fuzz_stamp).
using UV = std::array<double, 2>;
template <size_t N>
bool hull_reaches_grid(const std::array<UV, N>& pts, double grow, double U, double V) {
    auto separated = [&](double nu, double nv) {
        const double l = std::hypot(nu, nv);
        if (!(l > 0) || !std::isfinite(l)) return false;
        nu /= l, nv /= l;
        double lo = kInf, hi = -kInf;
        for (const auto& p : pts) lo = std::min(lo, p[0] * nu + p[1] * nv), hi = std::max(hi, p[0] * nu + p[1] * nv);
        const double b0 = std::min(0.0, U * nu) + std::min(0.0, V * nv), b1 = std::max(0.0, U * nu) + std::max(0.0, V * nv);
        return lo > b1 + grow || hi < b0 - grow;
    };
    if (separated(1, 0) || separated(0, 1)) return false;
    for (size_t i = 0; i < pts.size(); ++i)
        for (size_t j = i + 1; j < pts.size(); ++j)
            if (separated(pts[i][1] - pts[j][1], pts[j][0] - pts[i][0])) return false;
    return true;
}

// Translation sweep with a fixed heading, p0 → p1.
void sweep_fixed(const StampTarget& T, const Collider& c, const LocalPose& p0, const LocalPose& p1, double heading,
                 double decay, StampResult& res) {
    const double R = shape_radius(c) + T.texel;
    const double u0 = std::min(p0.u, p1.u) - R, u1 = std::max(p0.u, p1.u) + R;
    const double v0 = std::min(p0.v, p1.v) - R, v1 = std::max(p0.v, p1.v) + R;
    const Vec3 c0{p0.u, p0.v, p0.w}, c1{p1.u, p1.v, p1.w};
    const double U = double(T.width - 1) * T.texel, V = double(T.height - 1) * T.texel;
    switch (c.shape) {
    case ColliderShape::sphere: {
        const double r = c.radius;
        if (!hull_reaches_grid(std::array<UV, 2>{UV{c0.x, c0.y}, UV{c1.x, c1.y}}, r + T.texel, U, V)) return;
        rasterise(T, u0, u1, v0, v1, decay, res, [&](double qu, double qv, double g) { return capsule_low(qu, qv, c0, c1, r) - g; });
        break;
    }
    case ColliderShape::capsule: {
        const double r = c.radius;
        const Vec3 h = capsule_half_axis(c, heading);
        const Vec3 a0 = c0 - h, b0 = c0 + h, a1 = c1 - h, b1 = c1 + h;
        if (!hull_reaches_grid(std::array<UV, 4>{UV{a0.x, a0.y}, UV{b0.x, b0.y}, UV{a1.x, a1.y}, UV{b1.x, b1.y}}, r + T.texel, U, V)) return;
        const SlabFace face = make_face(a0, b0 - a0, a1 - a0);
        const bool moving = dot(c1 - c0, c1 - c0) > 0;
        rasterise(T, u0, u1, v0, v1, decay, res, [&](double qu, double qv, double g) {
            double low = capsule_low(qu, qv, a0, b0, r);
            if (moving) {
                low = std::min({low, capsule_low(qu, qv, a1, b1, r), capsule_low(qu, qv, a0, a1, r), capsule_low(qu, qv, b0, b1, r),
                                face_low(face, qu, qv, r)});
            }
            return low - g;
        });
        break;
    }
    case ColliderShape::box: {
        const Axes ax = axes(heading);
        const double hx = 0.5 * c.size[0], hy = 0.5 * c.size[1], hz = 0.5 * c.size[2];
        const double du = p1.u - p0.u, dv = p1.v - p0.v, dw = p1.w - p0.w;
        const double dx = du * ax.ex_u + dv * ax.ex_v, dz = du * ax.ez_u + dv * ax.ez_v;
        // Vertical walls alias into staircases on a grid; the imprint is scaled by the texel's coverage,
        // clamp(1/2 − d/texel, 0, 1) with d the signed distance to the swept outline (a convex polygon).
        const double pad = 0.5 * T.texel;
        const EdgeLines hull = edge_lines(convex_hull({{-hx, -hz}, {hx, -hz}, {hx, hz}, {-hx, hz}, {-hx + dx, -hz + dz}, {hx + dx, -hz + dz},
                                       {hx + dx, hz + dz}, {-hx + dx, hz + dz}}));
        rasterise(T, u0, u1, v0, v1, decay, res, [&](double qu, double qv, double g) {
            const double ru = qu - p0.u, rv = qv - p0.v;
            const double x0 = ru * ax.ex_u + rv * ax.ex_v, z0 = ru * ax.ez_u + rv * ax.ez_v;
            const double sd = signed_distance(hull, x0, z0);
            const double cover = std::clamp(0.5 - sd / T.texel, 0.0, 1.0);
            if (cover <= 0) return kInf;
            double ta = 0, tb = 1;
            // The box (grown by half a texel) covers q at time t when |x0 − t·dx| <= hx and |z0 − t·dz| <= hz.
            auto clip = [&](double x, double dxx, double half) {
                if (std::abs(dxx) < 1e-15) {
                    if (std::abs(x) > half) ta = 1, tb = 0;
                    return;
                }
                double lo = (x - half) / dxx, hi = (x + half) / dxx;
                if (lo > hi) std::swap(lo, hi);
                ta = std::max(ta, lo), tb = std::min(tb, hi);
            };
            clip(x0, dx, hx + pad);
            clip(z0, dz, hz + pad);
            if (ta > tb) return kInf;
            const double depth = p0.w + std::min(ta * dw, tb * dw) - hy - g;
            return depth < 0 ? depth * cover : kInf;
        });
        break;
    }
    case ColliderShape::image: break; // sampled, see stamp_image
    }
}

// The u span (metres) of row rv (from the brush's centre at u = cu) inside the rectangle |lx| <= hx,
// |lz| <= hz of a brush turned to axes `ax`: each bound is a slab in u, or (axis along v) all or nothing.
// Widened by a margin far above the rounding of brush()'s own test, so that it only ever adds texels.
bool brush_row(const Axes& ax, double hx, double hz, double cu, double rv, double texel, double& lo, double& hi) {
    const double margin = texel + 1e-9 * (std::abs(cu) + std::abs(rv) + hx + hz);
    double a = -kInf, b = kInf;
    auto slab = [&](double cu_coef, double cv_coef, double half) {
        const double off = rv * cv_coef;
        if (cu_coef == 0) {
            if (std::abs(off) > half + margin) a = kInf, b = -kInf;
            return;
        }
        double x0 = (-half - off) / cu_coef, x1 = (half - off) / cu_coef;
        if (x0 > x1) std::swap(x0, x1);
        a = std::max(a, x0), b = std::min(b, x1);
    };
    slab(ax.ex_u, ax.ex_v, hx);
    slab(ax.ez_u, ax.ez_v, hz);
    if (!(a <= b)) return false;
    lo = std::max(lo, cu + a - margin), hi = std::min(hi, cu + b + margin);
    return lo <= hi;
}

void stamp_image(const StampTarget& T, const Collider& c, const LocalPose& p, double decay, StampResult& res) {
    if (!(p.penetration > 0) || !c.brush) return;
    const ImageF& im = *c.brush;
    const Axes ax = axes(p.heading);
    const double sx = c.size[0], sz = c.size[1];
    const double R = shape_radius(c) + T.texel;
    const int W = im.width, H = im.height, C = im.channels;
    // A stamp whose rectangle misses the grid writes nothing, but would still rasterise its bounding box: a
    // brush 1e-39 m wide and 1e11 m long turning near the field took 1e6 full-field stamps (found by
    // fuzz_stamp).
    const double hx = 0.5 * sx, hz = 0.5 * sz;
    auto corner = [&](double a, double b) { return UV{p.u + a * ax.ex_u + b * ax.ez_u, p.v + a * ax.ex_v + b * ax.ez_v}; };
    const std::array<UV, 4> corners{corner(-hx, -hz), corner(hx, -hz), corner(hx, hz), corner(-hx, hz)};
    const double U = double(T.width - 1) * T.texel, V = double(T.height - 1) * T.texel;
    if (!hull_reaches_grid(corners, T.texel, U, V)) return;
    // The same in the brush's own frame, from the grid's centre (every texel lies within grid_r of it): exact
    // where the corners lie too far out to place the grid within their rounding. A brush 2.5e38 m long and
    // 6e-30 m wide, turning 1.4e11 m from a 10 x 36 texel grid, rasterised the whole grid two million times
    // (0.66 s, 21 s in the fuzz build; found by fuzz_stamp). The margin (1e-9 of the distance) is far above
    // the rounding of the texels' own test below, so a stamp skipped here writes nothing there either.
    const double du = 0.5 * U - p.u, dv = 0.5 * V - p.v;
    const double grid_r = 0.5 * std::hypot(U, V) + T.texel, margin = 1e-9 * (std::abs(du) + std::abs(dv));
    if (std::abs(du * ax.ex_u + dv * ax.ex_v) > hx + grid_r + margin || std::abs(du * ax.ez_u + dv * ax.ez_v) > hz + grid_r + margin) return;
    auto px = [&](int i, int j) {
        i = std::clamp(i, 0, W - 1), j = std::clamp(j, 0, H - 1);
        return double(im.pixels[(size_t(j) * size_t(W) + size_t(i)) * size_t(C)]);
    };
    auto brush = [&](double qu, double qv, double) {
        const double ru = qu - p.u, rv = qv - p.v;
        const double lx = ru * ax.ex_u + rv * ax.ex_v, lz = ru * ax.ez_u + rv * ax.ez_v;
        if (std::abs(lx) > 0.5 * sx || std::abs(lz) > 0.5 * sz) return 0.0;
        // Seen from above with the heading up the page, local +x is on the left: column 0 is at +x.
        const double xi = (0.5 - lx / sx) * W - 0.5, yj = (0.5 - lz / sz) * H - 0.5;
        const int i0 = clamped_int(std::floor(xi), -1, W), j0 = clamped_int(std::floor(yj), -1, H);
        const double fi = xi - i0, fj = yj - j0;
        const double v = (px(i0, j0) * (1 - fi) + px(i0 + 1, j0) * fi) * (1 - fj) + (px(i0, j0 + 1) * (1 - fi) + px(i0 + 1, j0 + 1) * fi) * fj;
        return -std::clamp(v, 0.0, 1.0) * p.penetration;
    };
    // A turned brush covers a third to a half of its bounding square: each row is cut to the brush's span
    // there (`bench stamp` section 4, where 3 in 4 walkers stamp a brush; figures in deform/README.md).
    auto rows = [&](double qv, double& lo, double& hi) { return brush_row(ax, hx, hz, p.u, qv - p.v, T.texel, lo, hi); };
    if (T.whole_boxes) rasterise(T, p.u - R, p.u + R, p.v - R, p.v + R, decay, res, brush);
    else rasterise(T, p.u - R, p.u + R, p.v - R, p.v + R, decay, res, brush, rows);
}

LocalPose lerp(const LocalPose& a, const LocalPose& b, double t) {
    return {a.u + (b.u - a.u) * t, a.v + (b.v - a.v) * t, a.w + (b.w - a.w) * t, a.heading + (b.heading - a.heading) * t,
            a.penetration + (b.penetration - a.penetration) * t};
}

} // namespace

double collider_bottom_offset(const Collider& c) {
    switch (c.shape) {
    case ColliderShape::sphere: return c.radius;
    case ColliderShape::box: return 0.5 * c.size[1];
    case ColliderShape::capsule: return c.radius + 0.5 * c.length * std::abs(c.axis[1]);
    case ColliderShape::image: return c.depth;
    }
    return 0;
}

double collider_top_offset(const Collider& c) {
    return c.shape == ColliderShape::image ? 0.0 : collider_bottom_offset(c);
}

namespace {

// How many stamps an image brush needs from p0 to p1 (turning by `turn` rad, its far texel R_turn from the
// centre).
//   Stamps every half texel of travel (of the centre or the far corner). Vertical travel only has to give a
//   pressing foot its second stamp; counted up to the grid's size, a print dropped from 1e30 m no longer takes
//   1e6 stamps (found by fuzz_stamp), and nothing smaller changes.
//   Sliding: along each brush axis a step may move the brush by half a texel or by half a brush pixel,
//   whichever is larger. Every texel the rectangle passes over is still covered by a stamp (a step is shorter
//   than the brush), and each texel's sample moves by at most half a brush pixel between stamps. A brush pixel
//   1e24 m wide no longer asks for a stamp every texel; nor does a 1e35 m brush that slides along itself while
//   it turns 3e-12 rad (found by fuzz_stamp). With pixels finer than texels this is the half-texel count.
//   Turning: while the grid stays inside the brush's rectangle, no texel crosses its outline, and a step only
//   has to move each texel's sample by half a brush pixel (or half a texel, whichever is larger). The grid's
//   bounding circle is inside the rectangle at every stamp when the centre's farthest distance from it, at an
//   end of the straight path, plus its radius is within the brush's half width. A brush of 3 pixels 1e25 m
//   wide turning 2 rad near a 2 m field took 1e6 full-field stamps (found by fuzz_stamp). Any other brush
//   still stamps every half texel of travel of its far corner.
double image_stamps_wanted(const StampTarget& T, const Collider& c, const LocalPose& p0, const LocalPose& p1, double turn,
                           double R_turn) {
    const double t = T.texel;
    const double U = double(T.width - 1) * t, V = double(T.height - 1) * t;
    const double vertical = std::min(std::abs(p1.w - p0.w), U + V);
    const double dist = std::hypot(p1.u - p0.u, p1.v - p0.v);
    if (!c.brush || c.brush->width <= 0 || c.brush->height <= 0) return std::max(dist + vertical, turn * R_turn) / (0.5 * t);
    // Sliding, per brush axis.
    const Axes ax = axes(p0.heading);
    const double du = p1.u - p0.u, dv = p1.v - p0.v;
    const double along_x = std::abs(du * ax.ex_u + dv * ax.ex_v), along_z = std::abs(du * ax.ez_u + dv * ax.ez_v);
    const double step_x = 0.5 * std::max(t, c.size[0] / c.brush->width), step_z = 0.5 * std::max(t, c.size[1] / c.brush->height);
    const double slide = std::hypot(along_x * (0.5 * t / step_x), along_z * (0.5 * t / step_z));
    if (p1.heading == p0.heading) return (slide + vertical) / (0.5 * t);
    // Turning.
    double scale = 1;
    const double grid_r = 0.5 * std::hypot(U, V) + t;
    const double reach = std::max(std::hypot(p0.u - 0.5 * U, p0.v - 0.5 * V), std::hypot(p1.u - 0.5 * U, p1.v - 0.5 * V));
    const double pixel = std::min(c.size[0] / c.brush->width, c.size[1] / c.brush->height);
    if (reach + grid_r <= 0.5 * std::min(c.size[0], c.size[1])) scale = t / std::max(t, pixel);
    const bool coarse = step_x > 0.5 * t || step_z > 0.5 * t;
    return std::max((coarse ? slide : dist * scale) + vertical, turn * R_turn * scale) / (0.5 * t);
}

StampResult stamp_sweep_sharp(const StampTarget& T, const Collider& c, const LocalPose& from, const LocalPose& to, double decay,
                              double share) {
    StampResult res;
    res.reach = shape_radius(c);
    const double t = T.texel;
    const double R = shape_radius(c);
    const double U = double(T.width - 1) * t, V = double(T.height - 1) * t; // the grid's far corner (u, v)
    // Only the part of the path from which the shape can reach the grid is stepped: where the centre is within
    // R (plus a texel) of it, an interval of the straight path (Liang–Barsky clipping against the grown grid
    // box). A path from 4e28 m away stepped 1e6 times through empty space first (found by fuzz_stamp).
    // Each end of the clipped part is taken from the nearer end of the path: from 4e28 m away, t = 1 − 1e-28
    // is 1 in double, but the same point is s = 1e-28 measured from the other end.
    if (!(std::isfinite(from.u) && std::isfinite(from.v) && std::isfinite(to.u) && std::isfinite(to.v))) return res;
    const double m = R + t;
    // Slabs the centre must stay within: |(centre − c)·n| <= half, n a unit direction in the (u, v) plane.
    struct Slab {
        double nu, nv, cu, cv, half;
    };
    std::array<Slab, 4> slabs{Slab{1, 0, 0.5 * U, 0.5 * V, 0.5 * U + m}, Slab{0, 1, 0.5 * U, 0.5 * V, 0.5 * V + m}};
    size_t slab_count = 2;
    // An image brush that does not turn is a rectangle sliding along the path: it touches the grid only while
    // the grid's bounding circle overlaps the rectangle, which for a long thin brush is a much shorter part of
    // the path than the bounding circle of the brush gives (a 1e25 x 1e11 m brush slid 1e6 times across a 10 m
    // field, found by fuzz_stamp).
    // A brush that turns by θ over the segment stays within its start heading's slabs grown by D·θ, D the
    // centre's farthest distance from the grid's centre (at an end of the path): a texel's offset from the
    // centre turns by at most θ against the brush's axes. A 1e35 m thin brush turning 3e-12 rad on a path
    // from 1.7e11 m away took 1e6 stamps that missed the field (found by fuzz_stamp). Without a turn this is
    // exactly the sliding brush's rectangle.
    const bool fixed_heading = to.heading == from.heading;
    if (c.shape == ColliderShape::image) {
        const Axes ax = axes(from.heading);
        const double grid_r = 0.5 * std::hypot(U, V) + t;
        const double D = std::max(std::hypot(from.u - 0.5 * U, from.v - 0.5 * V), std::hypot(to.u - 0.5 * U, to.v - 0.5 * V));
        const double slack = fixed_heading ? 0.0 : D * std::abs(to.heading - from.heading);
        if (std::isfinite(slack)) {
            slabs[slab_count++] = {ax.ex_u, ax.ex_v, 0.5 * U, 0.5 * V, 0.5 * c.size[0] + grid_r + slack};
            slabs[slab_count++] = {ax.ez_u, ax.ez_v, 0.5 * U, 0.5 * V, 0.5 * c.size[1] + grid_r + slack};
        }
    }
    auto clip = [&](const LocalPose& a, const LocalPose& b, double& lo, double& hi) { // a + (b − a)·x, x in [lo, hi]
        lo = 0, hi = 1;
        auto side = [&](double p, double q) { // keeps the x with p·x <= q
            if (p == 0) return q >= 0;
            const double r = q / p;
            if (p < 0) lo = std::max(lo, r);
            else hi = std::min(hi, r);
            return lo <= hi;
        };
        for (size_t k = 0; k < slab_count; ++k) {
            const Slab& sl = slabs[k];
            const double d = (b.u - a.u) * sl.nu + (b.v - a.v) * sl.nv, off = (a.u - sl.cu) * sl.nu + (a.v - sl.cv) * sl.nv;
            if (!side(d, sl.half - off) || !side(-d, sl.half + off)) return false;
        }
        return true;
    };
    double ta, tb, sa, sb; // t from `from`, s from `to`: entry at t = ta (s = sb), exit at t = tb (s = sa)
    if (!clip(from, to, ta, tb) || !clip(to, from, sa, sb)) return res;
    const LocalPose p0 = ta <= 0.5 ? lerp(from, to, ta) : lerp(to, from, sb);
    const LocalPose p1 = tb >= 0.5 ? lerp(to, from, sa) : lerp(from, to, tb);
    const double dist = std::hypot(p1.u - p0.u, p1.v - p0.v);
    const double turn = std::abs(p1.heading - p0.heading);
    // Step counts are clamped while still doubles: a path point 1e28 m away or a collider 1e27 m long asks
    // for more steps than an int holds (found by fuzz_colliders); NaN (coordinates that overflow) takes one.
    // 1e6 steps stay the cap they always were.
    // The caps are per path segment: a segment cut into refill sub-steps gives each its `share` of them
    // (10,000 sub-steps each taking the whole cap of a 1e11 m capsule's turn took minutes, found by
    // fuzz_stamp).
    auto capped = [&](double x, double cap) { return clamped_int(std::ceil(x), 1, std::max(1, int(std::ceil(cap * share)))); };
    auto steps = [&](double x) { return capped(x, 1000000); };
    // How far the sub-steps of a turn must resolve the shape: to its far corner, but texels exist only on
    // the grid, and none is farther from the centre than the grid's farthest corner (the distance to a
    // fixed point is largest at an end of the centre's straight path). A 120 m log turning over a 2 m field
    // took 3200 full-field steps (found by fuzz_colliders).
    auto farthest_texel = [&](const LocalPose& p) {
        return std::hypot(std::max(std::abs(p.u), std::abs(p.u - U)), std::max(std::abs(p.v), std::abs(p.v - V)));
    };
    const double R_turn = std::min(R, std::max(farthest_texel(p0), farthest_texel(p1)));
    if (c.shape == ColliderShape::image) {
        const double n_wanted = image_stamps_wanted(T, c, p0, p1, turn, R_turn);
        const int n = n_wanted > 0 ? steps(n_wanted) : 0;
        for (int k = 0; k <= n; ++k) stamp_image(T, c, n ? lerp(p0, p1, double(k) / n) : p0, decay, res);
        return res;
    }
    // Turning: steps in which the far corner moves at most half a texel, each swept with both headings.
    const bool turns = c.shape != ColliderShape::sphere && turn * R_turn > 0.5 * t;
    // Long translations: chunks so that each bounding box stays tight around the trench.
    const double chunk = std::max(4 * R, 32 * t);
    // Sweeps are capped at 1e4 per path segment (each rasterises its bounding box, up to the whole grid): a
    // shape that would need more, whose far texel moves over 5000 texels in one segment, is resolved more
    // coarsely. A 1e26 m box turning 1e-12 rad near a 2 m field asked for 1e6 full-field sweeps (found by
    // fuzz_stamp). Ordinary shapes stay far below the cap: a 1 m box turning a full turn on 1 cm texels
    // takes 900 sweeps.
    auto sweeps = [&](double x) { return capped(x, 10000); };
    int n = sweeps(dist / chunk);
    if (turns) n = std::max(n, sweeps(turn * R_turn / (0.5 * t)));
    for (int k = 0; k < n; ++k) {
        const LocalPose a = lerp(p0, p1, double(k) / n), b = lerp(p0, p1, double(k + 1) / n);
        sweep_fixed(T, c, a, b, a.heading, decay, res);
        if (turns) sweep_fixed(T, c, a, b, b.heading, decay, res);
    }
    return res;
}

// ---- soft brushes (Collider::falloff) ---------------------------------------------------------------------
// The sharp imprint h is rasterised into a private layer over the sweep's box grown by the falloff, then
// dilated with a smooth profile, h_f(q) = min over p of h(p)·w(|q − p| / f) with w(x) = 1 − 3x² + 2x³ on
// texel centres, and min-composited into the carve layer. Inside the solid's footprint h_f <= h (w(0) = 1);
// outside, the edge slopes up to the surface over f (analytic for a box: −D·w(s / f), s the distance to its
// footprint). The profile kernel is cut at kMaxFalloffTexels texels (its cost grows with its area).
constexpr int kMaxFalloffTexels = 64;

StampResult stamp_sweep_soft(const StampTarget& T, const Collider& c, const LocalPose& from, const LocalPose& to, double decay,
                             double share) {
    StampResult res;
    const double t = T.texel;
    const int k = clamped_int(std::ceil(c.falloff / t), 1, kMaxFalloffTexels);
    const double f = std::min(c.falloff, k * t);
    // The sweep's texel box grown by the falloff, clamped to the grid.
    const double R = shape_radius(c) + t + f;
    const int ia = clamped_int(std::floor((std::min(from.u, to.u) - R) / t), 0, T.width);
    const int ib = clamped_int(std::ceil((std::max(from.u, to.u) + R) / t) + 1, 0, T.width);
    const int ja = clamped_int(std::floor((std::min(from.v, to.v) - R) / t), 0, T.height);
    const int jb = clamped_int(std::ceil((std::max(from.v, to.v) + R) / t) + 1, 0, T.height);
    if (ib <= ia || jb <= ja) return res;
    const int W = ib - ia, H = jb - ja;
    std::vector<float> sharp(size_t(W) * size_t(H), 0.0f), ground(size_t(W) * size_t(H));
    for (int j = 0; j < H; ++j)
        std::copy_n(T.ground + size_t(j + ja) * size_t(T.width) + size_t(ia), size_t(W), ground.begin() + long(size_t(j) * size_t(W)));
    StampTarget L = T;
    L.carve = sharp.data(), L.ground = ground.data(), L.width = W, L.height = H;
    auto local = [&](LocalPose p) { return p.u -= ia * t, p.v -= ja * t, p; };
    const StampResult inner = stamp_sweep_sharp(L, c, local(from), local(to), decay, share);
    res.reach = inner.reach + f;
    if (inner.written == 0) return res;
    // The profile on the kernel's offsets.
    struct Tap {
        int di, dj;
        float w;
    };
    std::vector<Tap> taps;
    for (int dj = -k; dj <= k; ++dj)
        for (int di = -k; di <= k; ++di) {
            const double x = t * std::hypot(di, dj) / f;
            if (x < 1) taps.push_back({di, dj, float(1 - x * x * (3 - 2 * x))});
        }
    // Rows near the sharp imprint only: its rectangle grown by k.
    const TexelRect in = inner.rect;
    const int j0 = std::max(0, in.y0 - k), j1 = std::min(H, in.y1 + k), i0 = std::max(0, in.x0 - k), i1 = std::min(W, in.x1 + k);
    std::vector<StampResult> rows(size_t(std::max(0, j1 - j0)));
    tbb::parallel_for(tbb::blocked_range<int>(j0, j1, 4), [&](const tbb::blocked_range<int>& r) {
        for (int j = r.begin(); j != r.end(); ++j) {
            StampResult& row = rows[size_t(j - j0)];
            for (int i = i0; i < i1; ++i) {
                if (std::isnan(ground[size_t(j) * size_t(W) + size_t(i)])) continue;
                float h = 0;
                for (const Tap& tp : taps) {
                    const int si = i + tp.di, sj = j + tp.dj;
                    if (si < in.x0 || si >= in.x1 || sj < in.y0 || sj >= in.y1) continue;
                    h = std::min(h, sharp[size_t(sj) * size_t(W) + size_t(si)] * tp.w);
                }
                if (!(h < 0)) continue;
                const int gi = i + ia, gj = j + ja;
                if (atomic_min(&T.carve[size_t(gj) * size_t(T.width) + size_t(gi)], h) > h) {
                    ++row.written;
                    row.rect.unite({gi, gj, gi + 1, gj + 1});
                }
            }
        }
    });
    for (const StampResult& row : rows) {
        res.written += row.written;
        res.rect.unite(row.rect);
    }
    return res;
}

} // namespace

StampResult stamp_sweep(const StampTarget& T, const Collider& c, const LocalPose& from, const LocalPose& to, double decay,
                        double share) {
    share = std::clamp(share, 0.0, 1.0);
    if (c.falloff > 0 && c.shape != ColliderShape::image) return stamp_sweep_soft(T, c, from, to, decay, share);
    return stamp_sweep_sharp(T, c, from, to, decay, share);
}

} // namespace furrow::deform_detail

// The per-vertex fur frame: where each shell vertex goes, with no cracks and no self-intersection.
//
// References:
//   - J. Lengyel, E. Praun, A. Finkelstein, H. Hoppe, "Real-Time Fur over Arbitrary Surfaces", I3D 2001
//     (shells offset along the normal, height fraction per shell);
//   - G. Thürmer, C. A. Wüthrich, "Computing Vertex Normals from Polygonal Facets", JGT 3(1), 1998, and
//     J. A. Bærentzen, H. Aanæs, "Signed Distance Computation Using the Angle Weighted Pseudonormal",
//     IEEE TVCG 11(3), 2005 (the extrusion direction);
//   - Blender's Solidify modifier (MOD_solidify_extrude.c, "even thickness"): scale each offset by the
//     angle-weighted mean of 1/cos over the incident faces, so that the face planes move by the requested
//     distance: shells stay parallel to the faces at their height over convex and concave corners alike
//     (mitered), instead of thinning over convex ones (a cube's shell sat 0.58 L from its faces when convex
//     vertices moved by L). Measured as the distance of shell faces to the surface (bench shells), the mean
//     error on the corpus fell 2–8× against that, and against the largest 1/cos.
//
// Why each step:
//   - Everything is computed on the position-welded mesh and copied back to every split copy: a direction
//     or length computed per copy (from split normals or a mask sampled on both sides of a UV seam) opens a
//     crack along every seam and hard edge.
//   - The mask is reconciled by the maximum over the copies: a seam then never shortens the furrier side,
//     and a bald region (mask 0 on every copy) stays bald.
//   - Feature clamp: a ray along the direction (and along the bent tip direction when combing or droop
//     bend the strand) measures the free space in front of the vertex; the offset keeps within
//     safe_fraction (< 1/2) of it, so two facing surfaces (a thin gap, a torus hole, a groove) each take
//     less than half of the gap and never meet.
//   - Fold clamp: at concave edges and corners the offsets of neighbouring vertices converge and an offset
//     triangle turns over (the "spikes" and "shells intersecting in concave areas" of existing tools).
//     For each triangle, its signed area along the base normal is a quadratic in a common scale k of its
//     three offsets; the largest k that keeps it >= min_area_ratio × the base area (for every layer when
//     droop makes the path curved) limits its corners. Vertices take the minimum over their triangles;
//     this is repeated until nothing folds (a vertex's reduction changes its neighbours' triangles).
//   - Droop and comb only move the shells along the surface (their normal component is removed): the
//     classic P += g·t³ pushes the tips into the skin wherever gravity points into it. Droop bends the
//     strand instead of shifting its tip (shells_detail::bend_integrals): its length is kept, so the fold clamp
//     has nothing to undo where the surface is smooth (the shifted tips stretched strands up to 4×, and
//     the clamp cut 6861 of the creature's 8066 vertices to a quarter of their length at droop 2). The bend
//     stays short of the tangent plane (70° at droop 4, on a wall): past it the layers of a shell stack
//     would cross, and the sweep clamp shortened 65 % of the creature's fur at droop 4 when it reached 180°.
//
// Determinism: every parallel loop writes only its own entries, every sum runs in a fixed order, the
// iterations are Jacobi-style (a pass reads the previous pass's lengths only).
#include "shells_internal.h"

#include <furrow/shells.h>

#include <furrow_kernel/angle_weighted_normal.h>
#include <furrow_kernel/face_terms.h>
#include <furrow_kernel/welded_ids.h>
#include <furrow_kernel/no_throw.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <memory>
#include <numeric>
#include <set>

namespace furrow {
namespace {

// The sweep of one triangle's shells (layer to layer) stays one-to-one while the Jacobian keeps this fraction
// of its value along the undeformed triangle: positive is what matters, the margin absorbs rounding.
constexpr double kSweepRatio = 0.05;

// The tip's bend at droop 4 (the top of the range) where gravity lies wholly along the surface: 70°. At 80°
// the sweep clamp still cut a third of the creature's fur (8 shells, 4 cm): near the tangent plane, neighbouring
// strands' layers cross; at 70° 97 % of it keeps its full length.
constexpr double kMaxDroopRadians = 70.0 * std::numbers::pi / 180.0;

using V3 = kernel::Vec3;
using kernel::cross;
using kernel::dot;
using kernel::finite;
using kernel::norm;

template <class F>
void parallel(size_t n, size_t grain, F&& f) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, grain), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) f(i);
    });
}

} // namespace

namespace shells_detail {

double first_root_in_unit(double a, double b, double c) {
    double k, hi;
    if (settled_root_in_unit(a, b, c, k, hi)) return k;
    // Bisection: robust for every sign combination, 60 steps reach double resolution.
    double lo = 0;
    for (int i = 0; i < 60; ++i) {
        double mid = 0.5 * (lo + hi);
        (a + b * mid + c * mid * mid >= 0 ? lo : hi) = mid;
    }
    return lo;
}

void first_roots_by_bisection(double* out, const double* a, const double* b, const double* c, const double* hi_in) {
    // Pairs of lanes in SSE2 registers (baseline x86-64): each operation rounds every lane as the scalar one
    // rounds it. Written out, the pairs' chains overlap (GCC 12 spilled a loop over scalar lanes to the stack).
    typedef double V2 __attribute__((vector_size(16)));
    constexpr int N = kBisectionLanes / 2;
    V2 va[N], vb[N], vc[N], lo[N], hi[N];
    for (int j = 0; j < N; ++j) {
        va[j] = V2{a[2 * j], a[2 * j + 1]}, vb[j] = V2{b[2 * j], b[2 * j + 1]}, vc[j] = V2{c[2 * j], c[2 * j + 1]};
        lo[j] = V2{0, 0}, hi[j] = V2{hi_in[2 * j], hi_in[2 * j + 1]};
    }
    const V2 zero = {0, 0}, half = {0.5, 0.5};
    for (int i = 0; i < 60; ++i)
        for (int j = 0; j < N; ++j) {
            const V2 mid = half * (lo[j] + hi[j]);
            const auto keep = va[j] + vb[j] * mid + vc[j] * mid * mid >= zero;
            lo[j] = keep ? mid : lo[j];
            hi[j] = keep ? hi[j] : mid;
        }
    for (int j = 0; j < N; ++j) out[2 * j] = lo[j][0], out[2 * j + 1] = lo[j][1];
}

} // namespace shells_detail

using shells_detail::first_root_in_unit;
using shells_detail::kBisectionLanes;
using shells_detail::settled_root_in_unit;

double shell_height_fraction(int layer, int layers, double spacing_power) {
    if (layers <= 0) return 0;
    double t = double(layer) / double(layers);
    return spacing_power == 1.0 ? t : std::pow(t, spacing_power);
}

Status validate(const ShellOptions& o) {
    auto bad = [](const std::string& m) { return Status::error(StatusCode::invalid_argument, m); };
    if (o.layers < 1 || o.layers > 256) return bad("layers must be in 1..256, got " + std::to_string(o.layers));
    if (!std::isfinite(o.length) || o.length < 0) return bad("length must be a finite number >= 0");
    if (!(o.spacing_power >= 0.1 && o.spacing_power <= 10)) return bad("spacing power must be in 0.1..10");
    if (!(o.droop >= 0 && o.droop <= 4)) return bad("droop must be in 0..4");
    if (!(o.comb_strength >= 0 && o.comb_strength <= 10)) return bad("comb strength must be in 0..10");
    for (double g : o.gravity)
        if (!std::isfinite(g)) return bad("gravity must be finite");
    if (o.lod_levels < 1 || o.lod_levels > 8) return bad("LOD levels must be in 1..8");
    if (!(o.max_even_thickness >= 1 && o.max_even_thickness <= 100)) return bad("max even thickness must be in 1..100");
    if (!(o.safe_fraction > 0 && o.safe_fraction <= 1)) return bad("safe fraction must be in (0, 1]");
    if (!(o.min_area_ratio >= 0 && o.min_area_ratio < 1)) return bad("min area ratio must be in [0, 1)");
    return Status::success();
}

namespace {

// The welded surface the frame is computed on: positions welded exactly (ids in order of first appearance),
// the valid faces with their unit normals and corner angles (a degenerate face, by the kernel's rule, has
// none), and vertex -> faces in ascending face order (a fixed summation order).
struct WeldedSurface {
    std::vector<uint32_t> wid; // vertex -> welded id
    size_t W = 0, T = 0;       // welded vertices, valid faces
    std::vector<V3> P;
    std::vector<double> xyz; // P as packed triples (the batched face terms and the SurfaceIndex read them)
    std::vector<std::array<uint32_t, 3>> tri;
    // Each valid face's unit normal and corner angles, as kernel::face_terms writes them (an array it fills
    // whole, not zeroed first).
    std::unique_ptr<kernel::FaceTerm[]> term;
    std::vector<uint32_t> start, vf; // CSR: faces of welded vertex w are vf[start[w] .. start[w + 1])
    std::vector<uint8_t> vc;         // beside vf: which corner of face vf[i] the vertex is
    V3 fn(size_t f) const { return {term[f].unit[0], term[f].unit[1], term[f].unit[2]}; }
    double angle(size_t f, int corner) const { return term[f].angle[corner]; }
};

WeldedSurface welded_surface(const float* positions, size_t n, const uint32_t* indices, size_t index_count) {
    WeldedSurface s;
    // --- weld by exact position; welded ids in order of first appearance
    std::vector<uint32_t> remap(n);
    weld_positions(remap.data(), positions, n);
    kernel::WeldedIds welded = kernel::welded_ids(remap.data(), n);
    s.wid = std::move(welded.of_vertex);
    const std::vector<uint32_t>& wid = s.wid;
    const std::vector<uint32_t>& rep = welded.first; // welded id -> first vertex
    const size_t W = rep.size();
    std::vector<V3> P(W);
    std::vector<double> xyz(3 * W); // P as packed triples, for the batched face terms
    std::vector<uint8_t> finite(W, 1);
    for (size_t w = 0; w < W; ++w) {
        P[w] = kernel::point_at(positions, rep[w]);
        xyz[3 * w] = P[w].x, xyz[3 * w + 1] = P[w].y, xyz[3 * w + 2] = P[w].z;
        finite[w] = kernel::finite(P[w]);
    }

    // --- valid welded faces, their unit normals and corner angles; a degenerate face (the kernel's rule, the
    // same as compute_vertex_normals') has no normal. The terms come from kernel::face_terms, several faces
    // to a vector register, the same bits as face_term one at a time (face_terms.h): bunny, 69k faces,
    // callgrind: welded_surface 37.9 -> 24.6 M instructions.
    const size_t F = index_count / 3;
    std::vector<std::array<uint32_t, 3>> tri;
    tri.reserve(F);
    for (size_t f = 0; f < F; ++f) {
        std::array<uint32_t, 3> t{wid[indices[3 * f]], wid[indices[3 * f + 1]], wid[indices[3 * f + 2]]};
        if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) continue;
        if (!finite[t[0]] || !finite[t[1]] || !finite[t[2]]) continue;
        tri.push_back(t);
    }
    static_assert(sizeof(std::array<uint32_t, 3>) == 3 * sizeof(uint32_t));
    std::unique_ptr<kernel::FaceTerm[]> term(new kernel::FaceTerm[tri.size()]);
    kernel::face_terms(term.get(), xyz.data(), tri.empty() ? nullptr : tri[0].data(), 0, nullptr, tri.size());
    size_t T = 0; // the valid faces moved to the front, in order
    for (size_t f = 0; f < tri.size(); ++f) {
        if (term[f].angle[0] < 0) continue; // degenerate
        if (T != f) tri[T] = tri[f], term[T] = term[f];
        ++T;
    }
    tri.resize(T);

    // --- vertex -> faces (CSR, faces in ascending order: fixed summation order)
    std::vector<uint32_t> start(W + 1, 0), vf(3 * T);
    std::vector<uint8_t> vc(3 * T);
    for (const auto& t : tri)
        for (uint32_t v : t) ++start[v + 1];
    for (size_t w = 0; w < W; ++w) start[w + 1] += start[w];
    {
        std::vector<uint32_t> fill(start.begin(), start.end() - 1);
        for (size_t f = 0; f < T; ++f)
            for (int c = 0; c < 3; ++c) {
                const uint32_t i = fill[tri[f][c]]++;
                vf[i] = uint32_t(f), vc[i] = uint8_t(c);
            }
    }
    s.W = W, s.T = T;
    s.P = std::move(P), s.xyz = std::move(xyz), s.tri = std::move(tri), s.term = std::move(term);
    s.start = std::move(start), s.vf = std::move(vf), s.vc = std::move(vc);
    return s;
}

// The frame per welded vertex as it is grown and clamped.
struct Growth {
    std::vector<double> m;  // mask (max over copies), 1 without one
    std::vector<V3> combw;  // comb (mean over copies); empty without one
    std::vector<V3> D, lean, sag;
    std::vector<double> H, even_factor;
    std::vector<uint8_t> flags;
    // Where a strand of unit length reaches at height fraction s (comb lean and droop bend included).
    V3 chord(size_t w, double s) const {
        const double d[3] = {D[w].x, D[w].y, D[w].z}, l[3] = {lean[w].x, lean[w].y, lean[w].z}, g3[3] = {sag[w].x, sag[w].y, sag[w].z};
        const auto c = shells_detail::strand_offset(d, l, g3, s);
        return V3{c[0], c[1], c[2]};
    }
};

// The mask (max over the copies of a position: a seam never shortens the furrier side) and the comb (mean
// over the copies) per welded vertex.
void reconcile_mask_and_comb(Growth& gr, const WeldedSurface& s, size_t n, const float* mask, const float* comb) {
    const std::vector<uint32_t>& wid = s.wid;
    const size_t W = s.W;
    std::vector<double>& m = gr.m;
    std::vector<V3>& combw = gr.combw;
    m.assign(W, mask ? 0.0 : 1.0);
    if (mask)
        for (size_t v = 0; v < n; ++v) {
            double x = std::isfinite(mask[v]) ? std::clamp(double(mask[v]), 0.0, 1.0) : 0.0;
            m[wid[v]] = std::max(m[wid[v]], x);
        }
    if (comb) {
        combw.assign(W, V3{});
        std::vector<uint32_t> copies(W, 0);
        for (size_t v = 0; v < n; ++v) {
            V3 c{comb[3 * v], comb[3 * v + 1], comb[3 * v + 2]};
            if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z)) c = {};
            combw[wid[v]] = combw[wid[v]] + c;
            ++copies[wid[v]];
        }
        for (size_t w = 0; w < W; ++w) combw[w] = (1.0 / std::max<uint32_t>(copies[w], 1)) * combw[w];
    }
}

// Direction (angle-weighted pseudo-normal), even-thickness factor, initial length, lean and sag per welded
// vertex, before any clamp.
void initial_growth(Growth& gr, const WeldedSurface& s, const ShellOptions& o) {
    const size_t W = s.W;
    const auto& start = s.start;
    const auto& vf = s.vf;
    const auto& m = gr.m;
    const auto& combw = gr.combw;
    auto& D = gr.D;
    auto& lean = gr.lean;
    auto& sag = gr.sag;
    auto& H = gr.H;
    auto& even_factor = gr.even_factor;
    auto& flags = gr.flags;
    V3 g{o.gravity[0], o.gravity[1], o.gravity[2]};
    if (norm(g) > 0) g = (1.0 / norm(g)) * g;
    D.assign(W, V3{}), lean.assign(W, V3{}), sag.assign(W, V3{});
    H.assign(W, 0.0), even_factor.assign(W, 1.0);
    flags.assign(W, 0);
    const double cos_floor = 1.0 / o.max_even_thickness;
    parallel(W, 1024, [&](size_t w) {
        V3 sum{};
        for (uint32_t i = start[w]; i < start[w + 1]; ++i) {
            size_t f = vf[i];
            sum = sum + s.angle(f, s.vc[i]) * s.fn(f);
        }
        double len = norm(sum);
        if (!(len > 0) || !std::isfinite(len)) {
            flags[w] |= clamp_no_normal;
            return;
        }
        V3 d = (1.0 / len) * sum;
        D[w] = d;
        // Even thickness (Solidify's): the angle-weighted mean of 1/cos between d and the incident faces'
        // normals, so that the faces' planes move by the requested length: at creases and corners, concave
        // and convex alike (a cube's shell is the cube grown by L on every face, its corners mitered: one
        // vertex each, moved by √3·L along the diagonal). A face tilted past the cap (max_even_thickness)
        // counts with the cap, and a vertex whose factor reaches it is flagged.
        double inv_cos = 0, weight = 0;
        for (uint32_t i = start[w]; i < start[w + 1]; ++i) {
            const size_t f = vf[i];
            const double a = s.angle(f, s.vc[i]), c = std::abs(dot(d, s.fn(f)));
            inv_cos += a * (c > cos_floor ? 1.0 / c : o.max_even_thickness);
            weight += a;
        }
        const double nearest = weight > 0 ? weight / inv_cos : 1.0;
        double even = nearest > cos_floor ? 1.0 / nearest : o.max_even_thickness;
        if (even >= o.max_even_thickness * 0.999) flags[w] |= clamp_even_cap;
        even = std::min(even, o.max_even_thickness);
        even_factor[w] = even;
        H[w] = o.length * m[w] * even;
        // Along the surface: off the direction, and (at creases and corners, where the direction is no face's
        // normal) not into any incident face's plane.
        auto along_surface = [&](V3 v) {
            v = v - dot(v, d) * d;
            for (int pass = 0; pass < 2; ++pass)
                for (uint32_t i = start[w]; i < start[w + 1]; ++i) {
                    const V3 n = s.fn(vf[i]);
                    const double into = dot(v, n);
                    if (into < 0) v = v - into * n;
                }
            return v;
        };
        if (!combw.empty()) lean[w] = o.comb_strength * along_surface(combw[w]);
        // Droop: the tip's bend angle θ_tip = droop/4 · 70° × (how much gravity lies along the surface), toward
        // gravity's surface direction (shells_detail::bend_integrals): droop 4 hangs a wall's tips 20° short of
        // straight down. A stack of shells cannot show a strand bent past its surface's tangent plane (the
        // upper layers would pass below the lower ones, and the sweep clamp would cut the fur instead), so
        // the bend stays short of 90°.
        if (o.droop > 0) sag[w] = (o.droop / 4 * kMaxDroopRadians) * along_surface(g);
    });
}

// Feature clamp: rays along the direction, and along the bent tip when comb or droop bend it (free space in
// front), the medial axis (two walls at an inner corner), and the bend limit (a bent tip never nearer to
// the mesh than a straight strand at the same height).
void feature_clamp(Growth& gr, const WeldedSurface& s, const shells_detail::SurfaceIndex& index, const ShellOptions& o) {
    const size_t W = s.W;
    const auto& start = s.start;
    const auto& vf = s.vf;
    const auto& D = gr.D;
    auto& lean = gr.lean;
    auto& sag = gr.sag;
    auto& H = gr.H;
    auto& flags = gr.flags;
    std::vector<uint32_t> qv;
    std::vector<double> qd;
    std::vector<double> qneed; // length of the path per unit H along this ray
    for (size_t w = 0; w < W; ++w) {
        if (!(H[w] > 0)) continue;
        qv.push_back(uint32_t(w));
        qd.insert(qd.end(), {D[w].x, D[w].y, D[w].z});
        qneed.push_back(1.0);
        V3 tip = gr.chord(w, 1.0);
        if (norm(lean[w]) + norm(sag[w]) > 1e-9) {
            double tl = norm(tip);
            qv.push_back(uint32_t(w));
            qd.insert(qd.end(), {tip.x / tl, tip.y / tl, tip.z / tl});
            qneed.push_back(tl);
        }
    }
    // A hit farther than H · need / safe_fraction leaves the length as it is: the rays need not look farther
    // (twice as far, so that a bound rounded either way never decides).
    std::vector<double> reach(qv.size());
    for (size_t q = 0; q < qv.size(); ++q) reach[q] = 2.0 * H[qv[q]] * qneed[q] / o.safe_fraction;
    std::vector<double> dist(qv.size());
    shells_detail::free_distances(dist.data(), index, qv.data(), qd.data(), qv.size(), reach.data());
    for (size_t q = 0; q < qv.size(); ++q) {
        uint32_t w = qv[q];
        double allowed = o.safe_fraction * dist[q] / qneed[q];
        if (allowed < H[w]) {
            H[w] = allowed;
            flags[w] |= clamp_ray;
        }
    }
    // The ray only sees what lies straight ahead. Two walls meeting at an inner corner never cross the
    // other's ray, yet their fur meets on the bisector: keep each offset point nearer to its own
    // vertex's faces than to anything else (the medial axis), with the same safety fraction (x2: the
    // medial axis is already half of the free distance between two facing surfaces).
    qv.clear();
    qd.clear();
    std::vector<double> ql;
    for (size_t w = 0; w < W; ++w) {
        if (!(H[w] > 0)) continue;
        qv.push_back(uint32_t(w));
        qd.insert(qd.end(), {D[w].x, D[w].y, D[w].z});
        ql.push_back(H[w] / (2.0 * o.safe_fraction));
    }
    // 2 % slack: on a curved surface the offset point's nearest point drifts off the 1-ring a little.
    std::vector<double> owned(qv.size());
    shells_detail::owned_lengths(owned.data(), index, start.data(), vf.data(), qv.data(), qd.data(), ql.data(), 0.98, qv.size());
    for (size_t q = 0; q < qv.size(); ++q) {
        uint32_t w = qv[q];
        double allowed = 2.0 * o.safe_fraction * owned[q];
        if (allowed < H[w] * (1 - 1e-12)) {
            H[w] = allowed;
            flags[w] |= clamp_ray;
        }
    }
    // A sideways bend (comb, droop) must not carry a tip toward another part of the surface (a wall's
    // drooping fur into the floor's, a plate's rim into the next plate's): a bent tip may never be nearer
    // to the mesh than a straight strand's point at the same height (its part along D) would be; over a
    // flat or convex surface it keeps or gains clearance. Where it would, the bend (not the length) is
    // scaled down.
    qv.clear();
    std::vector<double> straight, bent;
    for (size_t w = 0; w < W; ++w) {
        if (!(H[w] > 0) || norm(lean[w]) + norm(sag[w]) <= 1e-9) continue;
        qv.push_back(uint32_t(w));
        const V3 b = H[w] * gr.chord(w, 1.0), a = dot(b, D[w]) * D[w];
        straight.insert(straight.end(), {a.x, a.y, a.z});
        bent.insert(bent.end(), {b.x, b.y, b.z});
    }
    std::vector<double> sigma(qv.size());
    shells_detail::bend_limits(sigma.data(), index, start.data(), vf.data(), qv.data(), straight.data(), bent.data(), 0.995, qv.size());
    for (size_t q = 0; q < qv.size(); ++q)
        if (sigma[q] < 1.0) {
            const uint32_t w = qv[q];
            lean[w] = (0.9 * sigma[q]) * lean[w];
            sag[w] = (0.9 * sigma[q]) * sag[w];
            flags[w] |= clamp_ray;
        }
}

// Fold clamp (Jacobi iterations of per-triangle limits): at concave edges and corners the offsets of
// neighbouring vertices converge and an offset triangle turns over, or the sweep of its shells stops being
// one-to-one; the largest common scale of its corners' offsets that avoids it limits them.
class FoldClamp {
public:
    FoldClamp(Growth& gr, const WeldedSurface& s, const ShellOptions& o) : gr(gr), s(s), o(o), limit(s.T, 1.0), listed(s.T, 0), marked(s.W, 0) {
        // ts: layer fractions t = i/N_k of every LOD level the shells will be made for
        const bool curved = o.droop > 0;
        if (curved) {
            std::set<std::pair<int, int>> seen; // reduced fractions, so that 1/2 and 2/4 count once
            for (int k = 0; k < o.lod_levels; ++k) {
                int nk = std::max(1, o.layers >> k);
                for (int i = 1; i <= nk; ++i) {
                    const int d = std::gcd(i, nk);
                    if (seen.insert({i / d, nk / d}).second) ts.push_back(double(i) / double(nk));
                }
            }
            std::sort(ts.begin(), ts.end());
        } else {
            ts.push_back(1.0); // straight paths: scaling the tip offset by k sweeps every layer
        }
    }
    // Where the layer at t sits (relative to the base point), and the direction in which it moves as t grows.
    V3 path(size_t w, double t) const;
    V3 velocity(size_t w, double t) const;
    // One clamp pass. `seed`: only triangles around these vertices can have changed (null: all of them).
    // Each pass evaluates only the listed triangles (ascending): after the first pass they are the few around
    // the vertices it shortened, and a pass over all T triangles and W vertices would cost more than they do.
    void pass(const std::vector<uint8_t>* seed);

private:
    // Roots that need first_root_in_unit's bisection, gathered to run kBisectionLanes side by side, with the
    // triangle each one limits.
    struct Bisections {
        double a[kBisectionLanes], b[kBisectionLanes], c[kBisectionLanes], hi[kBisectionLanes];
        uint32_t face[kBisectionLanes];
        int n = 0;
    };
    // Triangle f's limit takes a root k: a factor just under 1 is rounding, accepted rather than iterated on
    // forever. The minimum over f's roots is taken in any order: k -> 0.999·k rounds monotonically, so the
    // limit is the same as from the smallest root alone.
    void take(uint32_t f, double k) {
        if (k < 1.0 - 1e-9) limit[f] = std::min(limit[f], k * 0.999);
    }
    void flush(Bisections& pending);
    // The scales k (first roots in (0, 1], 1 for none) that fold triangle f at one layer fraction or turn its
    // sweep, from its corners' paths u and velocities v there, into take() (the bisections: into `pending`).
    void face_roots(uint32_t f, const V3 u[3], const V3 v[3], Bisections& pending);
    // The limits of the listed triangles into `limit`: with the paths and velocities of every vertex worked out
    // once per layer fraction (`every`: a long list), or each triangle's corners on their own (a short one).
    void limits(const std::vector<uint32_t>& faces, bool every);

    Growth& gr;
    const WeldedSurface& s;
    const ShellOptions& o;
    std::vector<double> ts, limit;
    std::vector<uint8_t> listed; // pass's scratch: all 0 between passes
    std::vector<V3> u_, v_;      // limits' scratch: every vertex's path and velocity at one layer fraction
    bool cached_ = false;        // u_ and v_ hold them at the only fraction, for the current lengths
    std::vector<uint8_t> marked; // pass's scratch: all 0 between passes
};

V3 FoldClamp::path(size_t w, double t) const {
    return gr.H[w] * gr.chord(w, o.spacing_power == 1.0 ? t : std::pow(t, o.spacing_power));
}
// Direction in which the layer at t moves as t grows (d path / dt): the sweep from shell to shell,
// along the strand's tangent (D turned toward ĝ by θ_tip·s²) plus the lean.
V3 FoldClamp::velocity(size_t w, double t) const {
    const auto& D = gr.D;
    const auto& lean = gr.lean;
    const auto& sag = gr.sag;
    const auto& H = gr.H;
    const double s = o.spacing_power == 1.0 ? t : std::pow(t, o.spacing_power);
    const double ds = o.spacing_power == 1.0 ? 1.0 : o.spacing_power * std::pow(t, o.spacing_power - 1);
    const double theta = norm(sag[w]), th = theta * s * s;
    const V3 tangent = theta > 0 ? std::cos(th) * D[w] + (std::sin(th) / theta) * sag[w] : D[w];
    return (H[w] * ds) * (tangent + lean[w]);
    }

void FoldClamp::flush(Bisections& p) {
    for (int j = p.n; j < kBisectionLanes; ++j) p.a[j] = 1, p.b[j] = p.c[j] = 0, p.hi[j] = 1; // idle lanes
    double k[kBisectionLanes];
    shells_detail::first_roots_by_bisection(k, p.a, p.b, p.c, p.hi);
    for (int j = 0; j < p.n; ++j) take(p.face[j], k[j]);
    p.n = 0;
}

void FoldClamp::face_roots(uint32_t f, const V3 u[3], const V3 v[3], Bisections& pending) {
    auto root = [&](double a, double b, double c) {
        double k, hi;
        if (settled_root_in_unit(a, b, c, k, hi)) return take(f, k);
        const int j = pending.n++;
        pending.a[j] = a, pending.b[j] = b, pending.c[j] = c, pending.hi[j] = hi, pending.face[j] = f;
        if (pending.n == kBisectionLanes) flush(pending);
    };
    const auto& t = s.tri[f];
    const auto& P = s.P;
    const double r = o.min_area_ratio;
    const V3 e1 = P[t[1]] - P[t[0]], e2 = P[t[2]] - P[t[0]], e12 = cross(e1, e2);
    const V3 n0 = s.fn(f);
    const double a = dot(e12, n0);
    const V3 d1 = u[1] - u[0], d2 = u[2] - u[0];
    const V3 nb = cross(e1, d2) + cross(d1, e2), nc = cross(d1, d2);
    root(a - r * a, dot(nb, n0), dot(nc, n0));
    // Shells of one triangle must not cross each other either: the sweep from layer to layer is one-to-one
    // while every corner keeps moving to the front side of the scaled triangle (the Jacobian of
    // (barycentrics, t) -> point is linear in the barycentrics).
    for (int j = 0; j < 3; ++j) {
        const double a0 = dot(e12, v[j]);
        if (a0 > 0) root(a0 - kSweepRatio * a0, dot(nb, v[j]), dot(nc, v[j]));
    }
}

void FoldClamp::limits(const std::vector<uint32_t>& faces, bool every) {
    const auto& tri = s.tri;
    const auto& H = gr.H;
    for (uint32_t f : faces) limit[f] = 1.0;
    // roots(f, pending) for every listed triangle whose corners move; each block of triangles runs its own
    // bisections (it alone writes its triangles' limits).
    auto each_face = [&](auto&& roots) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, faces.size(), 256), [&](const tbb::blocked_range<size_t>& range) {
            Bisections pending;
            for (size_t q = range.begin(); q != range.end(); ++q) {
                const uint32_t f = faces[q];
                const auto& t = tri[f];
                if (H[t[0]] > 0 || H[t[1]] > 0 || H[t[2]] > 0) roots(f, pending);
            }
            if (pending.n) flush(pending);
        });
    };
    if (every || cached_) {
        // A vertex's path and velocity, worked out once for its ~6 triangles rather than in each (the same
        // bits: the same function of the same values), and kept while only a few vertices change.
        u_.resize(s.W), v_.resize(s.W);
        for (double tt : ts) {
            if (!cached_) parallel(s.W, 1024, [&](size_t w) { u_[w] = path(w, tt), v_[w] = velocity(w, tt); });
            each_face([&](uint32_t f, Bisections& pending) {
                const auto& t = tri[f];
                const V3 u[3] = {u_[t[0]], u_[t[1]], u_[t[2]]}, v[3] = {v_[t[0]], v_[t[1]], v_[t[2]]};
                face_roots(f, u, v, pending);
            });
        }
        cached_ = ts.size() == 1;
        return;
    }
    each_face([&](uint32_t f, Bisections& pending) {
        const auto& t = tri[f];
        for (double tt : ts) {
            const V3 u[3] = {path(t[0], tt), path(t[1], tt), path(t[2], tt)};
            const V3 v[3] = {velocity(t[0], tt), velocity(t[1], tt), velocity(t[2], tt)};
            face_roots(f, u, v, pending);
        }
    });
}

// The ids in `list` (each marked once in `mark`) in ascending order, their marks cleared: a long list is
// read back from the marks in one sweep, a short one sorted (bunny, the fold clamp's first pass: sorting its
// 16k triangles and 5k vertices took 1.6 ms).
void sort_marked(std::vector<uint32_t>& list, std::vector<uint8_t>& mark) {
    if (32 * list.size() < mark.size()) {
        for (uint32_t i : list) mark[i] = 0;
        std::sort(list.begin(), list.end());
        return;
    }
    list.clear();
    for (size_t i = 0; i < mark.size(); ++i)
        if (mark[i]) list.push_back(uint32_t(i)), mark[i] = 0;
}

void FoldClamp::pass(const std::vector<uint8_t>* seed) {
    const size_t T = s.T, W = s.W;
    const auto& start = s.start;
    const auto& vf = s.vf;
    const auto& tri = s.tri;
    auto& H = gr.H;
    auto& flags = gr.flags;
    std::vector<uint32_t> faces, verts;
    auto add_faces_of = [&](size_t w) {
        for (uint32_t i = start[w]; i < start[w + 1]; ++i)
            if (!listed[vf[i]]) listed[vf[i]] = 1, faces.push_back(vf[i]);
    };
    if (!seed) {
        faces.resize(T);
        std::iota(faces.begin(), faces.end(), 0u);
    } else {
        for (size_t w = 0; w < W; ++w)
            if ((*seed)[w]) add_faces_of(w);
        sort_marked(faces, listed);
    }
    cached_ = false; // the lengths may have changed since the last pass
    std::vector<double> scale;
    for (int iteration = 0; iteration < 200 && !faces.empty(); ++iteration) {
        limits(faces, 4 * faces.size() >= T);
        // The corners of limited triangles scale by the smallest limit around them (an unlisted
        // triangle's limit is 1).
        verts.clear();
        for (uint32_t f : faces)
            if (limit[f] < 1.0)
                for (uint32_t w : tri[f])
                    if (!marked[w]) marked[w] = 1, verts.push_back(w);
        if (verts.empty()) break;
        sort_marked(verts, marked);
        scale.assign(verts.size(), 1.0);
        parallel(verts.size(), 1024, [&](size_t q) {
            const uint32_t w = verts[q];
            for (uint32_t i = start[w]; i < start[w + 1]; ++i) scale[q] = std::min(scale[q], limit[vf[i]]);
        });
        for (uint32_t f : faces) limit[f] = 1.0;
        // After many passes a stubborn configuration is resolved the blunt way: no fur there.
        const bool last_resort = iteration >= 100;
        faces.clear();
        for (size_t q = 0; q < verts.size(); ++q) {
            const uint32_t w = verts[q];
            H[w] = last_resort ? 0.0 : H[w] * scale[q];
            flags[w] |= clamp_fold;
            add_faces_of(w);
            if (cached_) u_[w] = path(w, ts[0]), v_[w] = velocity(w, ts[0]);
        }
        sort_marked(faces, listed);
    }
}

// Verification: the local limits of the fold clamp do not see two distant parts of one shell meeting (both
// sides of a thin ear, fur across a crevice). The outermost shell is intersected with itself and with the base
// (exact predicates); the fur at every vertex of an offending shell triangle is shortened, and the fold clamp
// runs again around what changed, for up to 8 rounds.
// How much to shorten: each crossing pair is first re-tested alone with its blamed corners' fur halved 1, 2, ...
// 6 times, and a corner takes the most halvings its pairs need (at least one: a pair cleared by one halving
// is shortened exactly as a plain halving round would), and no fur once 6 are not enough. A crossing that
// no scale clears (at a non-manifold edge shared by four walls, the walls' shells meet however short the fur)
// thus goes bald in one round, where halving once per round re-ran the whole intersection test 7 times to
// get there (21 of the 23 s of the 48k-quad lattice's set-up).
void verify_crossings(Growth& gr, const WeldedSurface& s, const shells_detail::SurfaceIndex& index, FoldClamp& fold) {
    const size_t W = s.W;
    const auto& P = s.P;
    auto& H = gr.H;
    auto& flags = gr.flags;
    std::vector<double> top(3 * W);
    shells_detail::CrossingTest crossing(index, s.start.data(), s.vf.data());
    std::vector<double> last_h(H);
    std::vector<uint8_t> changed, need(W), halved(W, 0), moving(W), hit(W);
    constexpr int kMaxHalvings = 6;
    for (int round = 0; round < 8; ++round) {
        // The outermost shell: every point in the first round, then those whose length the last one changed.
        for (size_t w = 0; w < W; ++w) {
            if (round && !changed[w]) continue;
            const V3 q = P[w] + fold.path(w, 1.0);
            top[3 * w] = q.x, top[3 * w + 1] = q.y, top[3 * w + 2] = q.z;
            moving[w] = H[w] > 0;
        }
        std::fill(hit.begin(), hit.end(), uint8_t(0));
        std::fill(need.begin(), need.end(), uint8_t(0));
        if (crossing.run(hit.data(), top, moving, round ? &changed : nullptr, need.data(), kMaxHalvings) == 0) break;
        for (size_t w = 0; w < W; ++w)
            if (hit[w] && H[w] > 0) {
                const int k = std::max<int>(need[w], 1);
                halved[w] = uint8_t(std::min(int(halved[w]) + k, 255));
                H[w] = round < kMaxHalvings && halved[w] <= kMaxHalvings ? std::ldexp(H[w], -k) : 0.0;
                flags[w] |= clamp_fold;
            }
        changed.assign(W, 0);
        for (size_t w = 0; w < W; ++w) changed[w] = H[w] != last_h[w];
        fold.pass(&changed);
        for (size_t w = 0; w < W; ++w) changed[w] = H[w] != last_h[w];
        last_h = H;
    }
}

// The welded frame copied back to every split copy of a position, with the clamp counts.
void copy_back(ShellFrame& out, const WeldedSurface& s, Growth& gr, const ShellOptions& o, size_t n) {
    const size_t W = s.W;
    const auto& wid = s.wid;
    const auto& D = gr.D;
    const auto& lean = gr.lean;
    const auto& sag = gr.sag;
    const auto& m = gr.m;
    auto& H = gr.H;
    auto& flags = gr.flags;
    for (size_t w = 0; w < W; ++w) {
        if (!(H[w] > 0) || !std::isfinite(H[w])) H[w] = 0;
        if (flags[w] & (clamp_ray | clamp_fold | clamp_even_cap)) {
            ++out.clamped_vertices;
            if (flags[w] & clamp_ray) ++out.clamped_by_ray;
            if (flags[w] & clamp_fold) ++out.clamped_by_fold;
            if (flags[w] & clamp_even_cap) ++out.clamped_by_even_cap;
        }
        if (H[w] == 0) ++out.bald_vertices;
    }
    for (size_t v = 0; v < n; ++v) {
        const uint32_t w = wid[v];
        out.direction[3 * v] = float(D[w].x), out.direction[3 * v + 1] = float(D[w].y), out.direction[3 * v + 2] = float(D[w].z);
        out.lean[3 * v] = float(lean[w].x), out.lean[3 * v + 1] = float(lean[w].y), out.lean[3 * v + 2] = float(lean[w].z);
        out.sag[3 * v] = float(sag[w].x), out.sag[3 * v + 1] = float(sag[w].y), out.sag[3 * v + 2] = float(sag[w].z);
        out.length[v] = float(H[w]);
        out.requested[v] = float(o.length * m[w]);
        out.flags[v] = flags[w];
    }
}

} // namespace

Status compute_shell_frame(ShellFrame& out, const float* positions, size_t vertex_count, const uint32_t* indices,
                           size_t index_count, const float* mask, const float* comb, const ShellOptions& o) {
    return kernel::no_throw("computing the shell frame", [&]() -> Status {
        out = ShellFrame{};
        if (Status s = validate(o); !s.ok()) return s;
        if (index_count % 3 != 0) return Status::error(StatusCode::invalid_argument, "index count is not a multiple of 3");
        if (vertex_count > 0 && !positions) return Status::error(StatusCode::invalid_argument, "no positions");
        for (size_t i = 0; i < index_count; ++i)
            if (indices[i] >= vertex_count)
                return Status::error(StatusCode::invalid_argument, "index " + std::to_string(indices[i]) + " out of range");
        const size_t n = vertex_count;
        out.direction.assign(3 * n, 0.0f);
        out.length.assign(n, 0.0f);
        out.requested.assign(n, 0.0f);
        out.lean.assign(3 * n, 0.0f);
        out.sag.assign(3 * n, 0.0f);
        out.flags.assign(n, 0);
        if (n == 0) return Status::success();


        const WeldedSurface s = welded_surface(positions, n, indices, index_count);
        out.welded_vertices = s.W;
        Growth gr;
        reconcile_mask_and_comb(gr, s, n, mask, comb);
        initial_growth(gr, s, o);
        if (s.T > 0) {
            // One hierarchy over the welded triangles, built once, serves every clamp query and the final
            // intersection test: building one per query kind cost as much as the queries on small meshes.
            const shells_detail::SurfaceIndex index(s.xyz, s.tri);
            if (o.feature_clamp) feature_clamp(gr, s, index, o);
            FoldClamp fold(gr, s, o);
            fold.pass(nullptr);
            verify_crossings(gr, s, index, fold);
        }
        copy_back(out, s, gr, o, n);
        return Status::success();
    });
}

void shell_positions(float* out, const ShellFrame& frame, const float* positions, size_t vertex_count, int layer, int layers,
                     double spacing_power) {
    instanced_shell_positions(out, positions, frame.direction.data(), frame.length.data(), frame.lean.data(), frame.sag.data(),
                              vertex_count, layer, layers, spacing_power);
}

namespace {

// instanced_shell_positions' blocks (vertices): a straight one copies its lengths to the stack.
constexpr size_t kShellBlock = 1024;

// Component j of a straight strand's shell point: root + h·(s·direction + 0·sag + s·lean), in double (see
// instanced_shell_positions), for n components with their lengths h3 (lean, sag null = zero). One loop over
// the components with no dependence between them, compiled for AVX-512 and AVX2 as well (GCC's target clones,
// an ifunc resolved at load; not under AddressSanitizer, whose runtime may not be up when the resolver runs,
// nor with Clang, which builds the fuzzers with it): each lane does one component's operations in the same
// order, without fusing (-ffp-contract=off), so the same bits at every width. One loop for each of lean and
// sag null or not: one loop reading a zero array for a null one took 3.1-3.2 ms against 2.6-2.8 for the
// bunny's 32 shells (a timer around the calls, three interleaved runs).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_ADDRESS__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void straight_positions(float* __restrict out, const float* __restrict roots, const float* __restrict direction, const float* __restrict h3,
                        const float* __restrict lean, const float* __restrict sag, size_t n, double s) {
    if (lean && sag) {
        for (size_t j = 0; j < n; ++j)
            out[j] = float(double(roots[j]) + double(h3[j]) * (s * double(direction[j]) + 0.0 * double(sag[j]) + s * double(lean[j])));
    } else if (lean) {
        for (size_t j = 0; j < n; ++j)
            out[j] = float(double(roots[j]) + double(h3[j]) * (s * double(direction[j]) + 0.0 * 0.0 + s * double(lean[j])));
    } else if (sag) {
        for (size_t j = 0; j < n; ++j)
            out[j] = float(double(roots[j]) + double(h3[j]) * (s * double(direction[j]) + 0.0 * double(sag[j]) + s * 0.0));
    } else {
        for (size_t j = 0; j < n; ++j) out[j] = float(double(roots[j]) + double(h3[j]) * (s * double(direction[j]) + 0.0 * 0.0 + s * 0.0));
    }
}

} // namespace

void instanced_shell_positions(float* out, const float* roots, const float* direction, const float* length, const float* lean,
                               const float* sag, size_t vertex_count, int layer, int layers, double spacing_power) {
    const double s = shell_height_fraction(layer, layers, spacing_power);
    static constexpr float zero[3] = {0, 0, 0};
    // In double, from per-copy inputs that are bit-identical: every copy lands on the same float.
    auto bent = [&](size_t v) {
        const double h = length[v];
        const auto o = shells_detail::strand_offset(&direction[3 * v], lean ? &lean[3 * v] : zero, sag ? &sag[3 * v] : zero, s);
        for (size_t k = 0; k < 3; ++k) out[3 * v + k] = float(double(roots[3 * v + k]) + h * o[k]);
    };
    // A run of vertices without droop (every sag component 0, so θ = 0): strand_offset's arithmetic with its
    // bend integrals at θ = 0 (A = s, B/θ taken as 0) written out, the same operations in the same order (the
    // 0·sag term kept: it decides the sign of a zero), so the same bits, in a loop without calls or branches.
    // The viewer layout's 32 shells of the Stanford bunny (`bench shells`, -j 1, a timer around this call):
    // 7.9-8.3 -> 5.7-6.2 ms; 2.1-2.3 ms once fur_scene passed no lean and no sag where they are all +0.
    auto straight = [&](size_t v0, size_t v1) {
        float h3[3 * kShellBlock]; // each vertex's length thrice: then one loop over the components
        for (size_t v = v0; v < v1; ++v) h3[3 * (v - v0)] = h3[3 * (v - v0) + 1] = h3[3 * (v - v0) + 2] = length[v];
        const size_t j0 = 3 * v0, n = 3 * (v1 - v0);
        straight_positions(out + j0, roots + j0, direction + j0, h3, lean ? lean + j0 : nullptr, sag ? sag + j0 : nullptr, n, s);
    };
    // Blocks of at most kShellBlock (a task's range may be longer: the partitioner only bounds it from below).
    tbb::parallel_for(tbb::blocked_range<size_t>(0, vertex_count, kShellBlock), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t v0 = r.begin(); v0 < r.end(); v0 += kShellBlock) {
            const size_t v1 = std::min(r.end(), v0 + kShellBlock);
            bool any_bent = false;
            if (sag)
                for (size_t j = 3 * v0; j < 3 * v1; ++j) any_bent |= sag[j] != 0; // (NaN too: bent's path)
            if (!any_bent) {
                straight(v0, v1);
                continue;
            }
            for (size_t v = v0; v != v1; ++v) bent(v);
        }
    });
}

} // namespace furrow

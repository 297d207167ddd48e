// Internal pieces shared by the shells sources (not installed).
#pragma once

#include <furrow/mesh.h>
#include <furrow/shells.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace furrow::shells_detail {

// f(i) for i in [0, n), in parallel chunks of at least `grain`: for loops whose iterations each write their own
// slots (so the result does not depend on the thread count).
template <class F>
void parallel(size_t n, size_t grain, F&& f) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, grain), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) f(i);
    });
}

// ---- refine_starved_faces.cpp: bisects the triangles of p whose corners the clamps starve (see the file),
// recomputing `frame` with `regrow` after each round. At the first split p becomes a copy of `base`; p then
// gains the new vertices (every attribute at the mean of an edge's ends), `tris` the new triangles, never more
// than `max_triangles` of them in all, until two rounds in a row change the share of the fur kept by less than
// `tolerance`. p is left as it was when no face is split (faces_split 0).
using RegrowFrame = std::function<Status(const Primitive&, const std::vector<uint32_t>&, ShellFrame&)>;
struct Refinement {
    size_t faces_split = 0; // triangles bisected
    size_t rounds = 0;      // rounds, each one call of `regrow`
};
Status refine_starved_faces(const Primitive& base, Primitive& p, std::vector<uint32_t>& tris, ShellFrame& frame, double length,
                            const RegrowFrame& regrow, size_t max_triangles, double tolerance, Refinement& out);

// Droop as a bent strand that keeps its length: at arc fraction u its direction has turned from the extrusion
// direction D toward ĝ (gravity along the surface) by θ(u) = θ_tip·u², curving more toward the tip, as a
// strand weighed down by its own length does. The point at arc fraction s is then
// H·(A(s)·D + B(s)·ĝ) with A = ∫₀ˢ cos θ(u) du and B = ∫₀ˢ sin θ(u) du, whatever θ_tip: every shell point
// lies on a curve of length H·s (the t³ sag it replaces moved tips sideways by up to 4 H, stretching strands
// until the fold clamp cut them to a quarter). Simpson's rule with 16 intervals: error < 1e-7 for θ_tip <= π.
inline void bend_integrals(double theta_tip, double s, double& a, double& b) {
    if (!(theta_tip > 0)) {
        a = s, b = 0;
        return;
    }
    constexpr int n = 16;
    const double h = s / n;
    double sa = 0, sb = 0;
    for (int i = 0; i <= n; ++i) {
        const double u = h * i, th = theta_tip * u * u, w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
        sa += w * std::cos(th);
        sb += w * std::sin(th);
    }
    a = sa * h / 3, b = sb * h / 3;
}

// The offset of a strand point at height fraction s, per unit of fur length: A(s)·D + B(s)·ĝ + s·lean, where
// sag = θ_tip·ĝ (ShellFrame::sag). Written for float and double triples alike.
template <class T>
inline std::array<double, 3> strand_offset(const T* dir, const T* lean, const T* sag, double s) {
    const double theta = std::sqrt(double(sag[0]) * sag[0] + double(sag[1]) * sag[1] + double(sag[2]) * sag[2]);
    double a, b;
    bend_integrals(theta, s, a, b);
    const double g = theta > 0 ? b / theta : 0.0; // B·ĝ = (B/θ)·sag
    return {a * dir[0] + g * sag[0] + s * lean[0], a * dir[1] + g * sag[1] + s * lean[1], a * dir[2] + g * sag[2] + s * lean[2]};
}

// ---- shell_frame.cpp: the fold clamp's roots. The smallest k in (0, 1] with a + b·k + c·k² = 0 where the
// quadratic falls below 0 (it starts at a > 0); 1 if it stays >= 0 on [0, 1]; 0 if a <= 0. Bisection (60 steps)
// where no shortcut settles it.
double first_root_in_unit(double a, double b, double c);
// first_root_in_unit's shortcuts: true with its answer in k, or false with the end of the bracket (0, hi) its
// bisection starts from. Inline: the fold clamp asks it four times a triangle.
inline bool settled_root_in_unit(double a, double b, double c, double& k, double& hi) {
    if (a <= 0) return k = 0, true;
    auto q = [&](double x) { return a + b * x + c * x * x; };
    if (q(1) >= 0) {
        // Still possible to dip in between: a minimum inside (0,1) with a negative value.
        if (c > 0) {
            double km = -b / (2 * c);
            if (!(km > 0 && km < 1 && q(km) < 0)) return k = 1, true;
        } else {
            return k = 1, true;
        }
    }
    hi = 1;
    if (q(1) >= 0) hi = -b / (2 * c); // the dip: the root lies before the minimum
    return false;
}
// first_root_in_unit's bisection for kBisectionLanes quadratics side by side, out[j] for (a[j], b[j], c[j]) from
// the bracket (0, hi[j]): each lane takes the same steps as the one-at-a-time loop (the same bits), and the
// lanes' independent chains overlap where one 60-step chain of dependent operations waits on each step.
inline constexpr int kBisectionLanes = 8;
void first_roots_by_bisection(double* out, const double* a, const double* b, const double* c, const double* hi);

// feature_distance.cpp: the welded triangles (`points` xyz, `triangles` with no repeated corner) with a
// bounding-volume hierarchy (triangle_bvh.h) and their CGAL triangles, built once per frame and shared by
// every query below. Keeps references to both arrays: they must outlive it.
class SurfaceIndex {
public:
    SurfaceIndex(const std::vector<double>& points, const std::vector<std::array<uint32_t, 3>>& triangles);
    ~SurfaceIndex();
    SurfaceIndex(const SurfaceIndex&) = delete;
    SurfaceIndex& operator=(const SurfaceIndex&) = delete;
    struct Impl;
    const Impl& impl() const { return *impl_; }

private:
    std::unique_ptr<Impl> impl_;
};

// For each query, the distance along the unit direction dirs[3q..3q+2] from points[query_vertex[q]] to the
// first triangle that does not contain that vertex; +infinity if the ray leaves the mesh. With `reach`
// (optional), a query only looks as far as reach[q]: a first hit within reach[q] (give or take 1e-6 of it) is
// answered as without it, anything else is +infinity. A clamp that cannot be
// affected by a far hit thus never walks the hierarchy across the whole mesh.
void free_distances(double* out, const SurfaceIndex& index, const uint32_t* query_vertex, const double* dirs,
                    size_t query_count, const double* reach = nullptr);

// The medial-axis limit. For each query vertex v with unit direction d and length H, the largest t <= H such
// that the point q = p + t·d is still "owned" by v: its distance to the whole mesh is at least `ratio` × its
// distance to v's own faces (ring_start/ring_faces: CSR vertex -> incident triangles). Past that point q is
// nearer to another part of the surface than to v's own faces: the fur of two surface parts (the walls of an
// inner corner, the sides of a gap) would cross there.
void owned_lengths(double* out, const SurfaceIndex& index, const uint32_t* ring_start, const uint32_t* ring_faces,
                   const uint32_t* query_vertex, const double* dirs, const double* lengths, double ratio, size_t query_count);

// How much of a sideways bend (comb, droop) each tip can take. For query q, with straight tip offset a (3
// values) and bent tip offset b, the largest sigma in [0, 1] such that the tip t = p + a + sigma·(b − a) (1) is
// reached from p + a without crossing the mesh, (2) is at least `clearance` × as far from the mesh as p + a,
// and (3) is still owned by v: its distance to the mesh is at least 0.98 × its distance to the faces within a
// few rings of v (enough rings to cover the bend).
void bend_limits(double* out, const SurfaceIndex& index, const uint32_t* ring_start, const uint32_t* ring_faces,
                 const uint32_t* query_vertex, const double* straight, const double* bent, double clearance, size_t query_count);

// The crossing test's shortcut for one candidate pair (triangles a and b: ids into points, xyz each): whether
// the two planes alone rule a crossing out; *crosses (if given) receives the full pair test's answer, which
// must then be false. Exposed for the test that holds the shortcut to the full test.
bool planes_rule_out(const std::vector<double>& points, const std::array<uint32_t, 3>& a, const std::array<uint32_t, 3>& b,
                     bool* crosses = nullptr);

// The crossing test's neighbour shortcut: whether the triangles (centre, spokes[i][0], spokes[i][1]) (ids into
// points, xyz each; each written in one winding) close into a fan that is certainly embedded, so that no two of
// them cross. Exposed for the test that holds it to the full pair test.
bool fan_rules_out(const std::vector<double>& points, uint32_t centre, const std::vector<std::array<uint32_t, 2>>& spokes);

// Its topological half: do the spokes (a_i, b_i) around `centre` close into a fan (3 to 32 spokes, no corner
// is the centre, the a_i distinct, the b_i distinct, each a_i some b_j)? next[i] receives the spoke j whose
// a_j is b_i when they do. Exposed for the test that holds it to that definition.
bool spokes_close_into_fan(uint32_t centre, const std::vector<std::array<uint32_t, 2>>& spokes, std::vector<uint8_t>& next);

// owned_lengths' bisection test for one point x (xyz): is the witness face (an index into triangles) nearer
// to x than `ratio` × x's distance to the faces `own`, with distances as CGAL's Simple_cartesian computes
// them? *hint: where in `own` to start (updated). Exposed for the test that holds it to that definition.
bool witness_takes(const std::vector<double>& points, const std::vector<std::array<uint32_t, 3>>& triangles, const double* x,
                   uint32_t witness, const std::vector<uint32_t>& own, double ratio, uint32_t* hint);

// Intersections of an offset shell with itself and with its base (the index's points and triangles), for
// the repair rounds of compute_shell_frame. run(): `shell` holds one xyz point per welded vertex,
// `moving[v]` says whether the shell point differs from the base point (a vertex that does not move is
// shared by both). Every vertex of a shell triangle that properly intersects another shell triangle or a
// base triangle (adjacent triangles: only when they fold onto each other) gets hit[v] = 1. Returns the
// number of such pairs. Exact predicates (Epick). `changed` (after the first run): the vertices whose shell
// point changed since the previous run; only pairs with a shell triangle around them are tested (after a
// repair, nothing else can have started to intersect), and only their triangles are rebuilt. `halvings`
// (optional, per vertex, zeroed by the caller): for the blamed corners of every crossing pair, the most, over
// their pairs, of the halvings of those corners' offsets (1..max_halvings, max_halvings + 1 for none) that clear
// the pair when it is tested alone.
class CrossingTest {
public:
    // ring_start/ring_faces: CSR vertex -> incident triangles (as owned_lengths takes), read by run().
    CrossingTest(const SurfaceIndex& index, const uint32_t* ring_start, const uint32_t* ring_faces);
    ~CrossingTest();
    CrossingTest(const CrossingTest&) = delete;
    CrossingTest& operator=(const CrossingTest&) = delete;
    size_t run(uint8_t* hit, const std::vector<double>& shell, const std::vector<uint8_t>& moving,
               const std::vector<uint8_t>* changed = nullptr, uint8_t* halvings = nullptr, int max_halvings = 6);

private:
    struct State;
    std::unique_ptr<State> state_;
};

// strand_texture.cpp: the PNG bytes of make_strand_texture (fin = false) or make_fin_texture (fin = true) for
// these options, encoded once per process and option set (a small, thread-safe cache).
std::shared_ptr<const std::vector<uint8_t>> strand_texture_png(const StrandTextureOptions& options, bool fin);

// texture_sampling.cpp: bilinear sample of channel c at glTF uv (v = 0 on the top row), texel centres at
// (x + 0.5) / width; wrap: 10497 REPEAT, 33648 MIRRORED_REPEAT, 33071 CLAMP_TO_EDGE.
float sample_bilinear(const ImageF& image, int channel, float u, float v, int wrap_s = 10497, int wrap_t = 10497);

// simplify_lod.cpp: the base triangles of LOD level k >= 1 simplified (meshopt_simplify) toward 1/4^k of them
// within the relative error error·2^(k−1) (FurOptions::lod_simplify_error), checked on the sampled distance
// between the surfaces (original vertices to the simplified faces, simplified face centroids and edge
// midpoints to the original); indices into the same vertices.
// error 0 or level 0: the triangles unchanged, errors 0.
struct SimplifiedBase {
    std::vector<uint32_t> tris;
    double relative_error = 0; // meshopt's result error: fraction of the mesh extent (meshopt_simplifyScale)
    double absolute_error = 0; // the same in object units
    double distance = 0;       // sampled two-sided distance between the surfaces, relative to the extent: <= the bound
};
SimplifiedBase simplify_base(const Primitive& base, const std::vector<uint32_t>& tris, int level, double error);

} // namespace furrow::shells_detail

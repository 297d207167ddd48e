// Coarse meshes at concave corners: a face whose corners are all clamped (every shelf vertex of a printed
// bookshelf sits where the shelf meets a wall) interpolates their zero length over its whole area, though fur
// could grow in its middle. Such faces are refined before any shell is emitted, in rounds:
//   1. mark: a triangle is *starved* when its corners grow less than 0.8 of the fur asked there, or *uneven*
//      when the fractions of it they keep differ by more than half (the clamp varies strongly across the
//      face; a fur mask's own variation does not count), and its
//      longest edge is longer than twice the fur (finer than the fur buys nothing: the clamp's own reach);
//   2. split: the longest edge of every marked triangle is bisected in every triangle that has it (longest-
//      edge bisection: M.-C. Rivara, "Mesh refinement processes based on the generalized bisection of
//      simplices", SIAM J. Numer. Anal. 21(3), 1984), so the mesh stays conforming (no crack between the
//      shells of neighbours) and the angles of the new triangles stay bounded. Edges are matched by welded
//      position, so both sides of a UV seam split at the same point. Two marked edges of one triangle are
//      both split in the round (the second in the child that holds it);
//   3. the frame is recomputed on the refined triangles: a whole compute_shell_frame, most of a coarse
//      mesh's set-up. A second marked edge of an already split triangle used to wait for the next round, one
//      more frame: Suzanne took 10 rounds and 11 frames, now 6 and 7 (`furrow -j 1 bench shells --layers 32`,
//      set-up 96-99 -> 59-62 ms; over Suzanne, spot_control_mesh, 73342.stl, 70375.stl, Duck, the Fox and
//      bunny.off 423-448 -> 314-340 ms in three interleaved runs, 17621 -> 17540 base triangles, the share of
//      the area furred to 0.8 of the length the same or higher except 70375.stl's, 0.991 -> 0.977 on 284
//      triangles instead of 380);
//   4. converged: the rounds stop once two in a row have changed the share of the fur asked that grows over
//      the furred area (fur_share) by less than FurOptions::refine_tolerance (0.001). 73342.stl used all 16
//      rounds, and its last eight won back 0.00007 of it together: now 10 rounds, 1646 triangles instead of
//      1802, the same furred area. A change either way counts: a round can lose fur (the regrown frame's
//      crossing test and fold clamp shorten other points) and the next win more back (spot_control_mesh at
//      half the bench's length: -0.004, +0.00003, +0.005).
// A split of a starved triangle is a probe: when its new vertex grows no more fur than the ends of its edge
// (a crevice where nothing fits), its starved children are not split again, so the cost is bounded by what
// the fur gains, and by a budget (FurOptions::refine_budget: 8 × the input's triangles + 4096 by default,
// less where the shells' triangle limit leaves less room). Uneven triangles (a transition from
// clamped to free fur) are split until their edges are as short as twice the fur. The new vertex carries every attribute
// at the mean of its edge's ends: linear interpolation is reproduced exactly, so the base surface and its
// shading do not change (skin weights are merged and renormalised over the 4 largest).
#include "shells_internal.h"

#include <furrow_kernel/vec3.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <numeric>
#include <unordered_map>

namespace furrow::shells_detail {
namespace {

constexpr int kMaxRounds = 16;

// Welded-position key of an undirected edge.
struct EdgeKey {
    std::array<uint32_t, 6> bits;
    bool operator<(const EdgeKey& o) const { return bits < o.bits; }
};
EdgeKey edge_key(const Primitive& p, uint32_t a, uint32_t b) {
    std::array<float, 3> pa, pb;
    for (int k = 0; k < 3; ++k) pa[size_t(k)] = p.positions[3 * size_t(a) + size_t(k)] + 0.0f, pb[size_t(k)] = p.positions[3 * size_t(b) + size_t(k)] + 0.0f;
    if (pb < pa) std::swap(pa, pb);
    EdgeKey key;
    std::memcpy(key.bits.data(), pa.data(), 12);
    std::memcpy(key.bits.data() + 3, pb.data(), 12);
    return key;
}

void mean_of(std::vector<float>& v, size_t per, uint32_t a, uint32_t b) {
    if (v.empty()) return;
    for (size_t k = 0; k < per; ++k) v.push_back(float(0.5 * (double(v[per * a + k]) + double(v[per * b + k]))));
}

void normalise_last(std::vector<float>& v, size_t per) {
    if (v.empty()) return;
    float* x = &v[v.size() - per];
    const double l = std::sqrt(double(x[0]) * x[0] + double(x[1]) * x[1] + double(x[2]) * x[2]);
    if (l > 0) x[0] = float(x[0] / l), x[1] = float(x[1] / l), x[2] = float(x[2] / l);
}

// Appends the midpoint of vertex a and b with every attribute of p; returns its index.
uint32_t append_midpoint(Primitive& p, uint32_t a, uint32_t b) {
    const uint32_t m = uint32_t(p.vertex_count());
    mean_of(p.positions, 3, a, b);
    mean_of(p.normals, 3, a, b);
    normalise_last(p.normals, 3);
    if (!p.tangents.empty()) {
        mean_of(p.tangents, 4, a, b);
        normalise_last(p.tangents, 4);
        p.tangents.back() = p.tangents[4 * size_t(a) + 3];
    }
    mean_of(p.uv0, 2, a, b);
    mean_of(p.uv1, 2, a, b);
    mean_of(p.colors, 4, a, b);
    for (CustomAttribute& c : p.custom) mean_of(c.values, size_t(c.components), a, b);
    for (MorphTarget& t : p.targets) {
        mean_of(t.position_deltas, 3, a, b);
        mean_of(t.normal_deltas, 3, a, b);
        mean_of(t.tangent_deltas, 3, a, b);
    }
    if (!p.joints.empty() && !p.weights.empty()) {
        std::map<uint16_t, double> w;
        for (uint32_t v : {a, b})
            for (size_t k = 0; k < 4; ++k) w[p.joints[4 * v + k]] += 0.5 * double(p.weights[4 * v + k]);
        std::vector<std::pair<double, uint16_t>> order;
        for (const auto& [j, x] : w) order.push_back({-x, j}); // heaviest first, then the lowest joint
        std::sort(order.begin(), order.end());
        order.resize(4, {0.0, 0});
        double sum = 0;
        for (const auto& o : order) sum += -o.first;
        for (const auto& o : order) {
            p.joints.push_back(o.second);
            p.weights.push_back(sum > 0 ? float(-o.first / sum) : 0.0f);
        }
    }
    return m;
}

// Which triangles to refine this round: starved or uneven, long enough, and not below a split that did not
// help. Returns, per triangle, the corner that starts its longest edge (or -1).
std::vector<int> mark(const Primitive& p, const std::vector<uint32_t>& tris, const ShellFrame& frame, const std::vector<uint8_t>& blocked,
                      double length) {
    const size_t T = tris.size() / 3;
    std::vector<int> split(T, -1);
    for (size_t t = 0; t < T; ++t) {
        const uint32_t* c = &tris[3 * t];
        // What the clamps left of the fur asked at each corner (a mask's own variation is not a clamp: a
        // triangle across a mask edge is neither starved nor uneven). Bald corners (mask 0) do not count.
        double asked = 0, lo = INFINITY, hi = 0;
        for (int k = 0; k < 3; ++k) {
            const double want = frame.requested[c[k]];
            if (!(want > 0)) continue;
            asked = std::max(asked, want);
            const double kept = std::min(1.0, double(frame.length[c[k]]) / want);
            lo = std::min(lo, kept);
            hi = std::max(hi, kept);
        }
        const bool uneven = hi - lo > 0.5, starved = hi < 0.8;
        // A starved triangle is a probe: below a probe that found no room (blocked), it is left alone. An
        // uneven one holds a transition, refined until it is as narrow as the fur.
        if (!(asked > 0) || !(uneven || (starved && !blocked[t]))) continue;
        int longest = -1;
        double best = 0;
        for (int k = 0; k < 3; ++k) {
            const float* a = &p.positions[3 * size_t(c[k])];
            const float* b = &p.positions[3 * size_t(c[(k + 1) % 3])];
            const double l = std::hypot(double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]);
            if (l > best) best = l, longest = k;
        }
        if (best > 2 * std::max(asked, 1e-12 * length)) split[t] = longest;
    }
    return split;
}

// A round's splits so far: the triangles split or made (touched), the midpoints made (midpoint, edge ends),
// and each bisected edge's midpoint by its (lower, higher) vertex index.
struct Round {
    std::vector<uint8_t> touched;
    std::vector<std::array<uint32_t, 3>> made;
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoint;
};
using EdgeSet = std::map<EdgeKey, std::vector<size_t>>; // welded edges, each with the triangles that have it

// One pass of a round, in key order (deterministic): an edge none of whose triangles this pass has split yet is
// bisected in every triangle that has it. Returns the others: each lies in one child of a triangle split
// before it, and is bisected there by the next pass (two marked edges of one triangle are both split in one
// round: they used to wait a round each, and every round regrows the whole frame). `fresh`: the triangles
// whose edges are not in `edges`' lists yet (all of them in a round's first pass; then the ones the last pass
// split, the only ones that changed); on return, the ones this pass split.
EdgeSet bisect_pass(Primitive& p, std::vector<uint32_t>& tris, EdgeSet edges, std::vector<size_t>& fresh, Round& r,
                    std::vector<uint8_t>& blocked, size_t& faces_split) {
    for (size_t t : fresh)
        for (int k = 0; k < 3; ++k) {
            auto it = edges.find(edge_key(p, tris[3 * t + size_t(k)], tris[3 * t + size_t((k + 1) % 3)]));
            if (it != edges.end()) it->second.push_back(t);
        }
    for (auto& [key, around] : edges) std::sort(around.begin(), around.end()); // split in index order
    fresh.clear();
    std::vector<uint8_t> busy(tris.size() / 3, 0); // split in this pass
    EdgeSet waiting;
    for (const auto& [key, around] : edges) {
        bool free = true;
        for (size_t t : around) free = free && !busy[t];
        if (!free) {
            waiting[key] = around;
            continue;
        }
        for (size_t t : around) {
            busy[t] = r.touched[t] = 1;
            int k = 0;
            while (edge_key(p, tris[3 * t + size_t(k)], tris[3 * t + size_t((k + 1) % 3)]) < key ||
                   key < edge_key(p, tris[3 * t + size_t(k)], tris[3 * t + size_t((k + 1) % 3)]))
                ++k;
            const uint32_t a = tris[3 * t + size_t(k)], b = tris[3 * t + size_t((k + 1) % 3)], c = tris[3 * t + size_t((k + 2) % 3)];
            auto [it, made] = r.midpoint.try_emplace({std::min(a, b), std::max(a, b)}, 0u);
            if (made) {
                it->second = append_midpoint(p, a, b);
                r.made.push_back({it->second, a, b});
            }
            const uint32_t m = it->second;
            tris[3 * t] = a, tris[3 * t + 1] = m, tris[3 * t + 2] = c; // (a, m, c) in place
            tris.insert(tris.end(), {m, b, c});                      // (m, b, c) appended
            fresh.push_back(t);
            fresh.push_back(tris.size() / 3 - 1);
            busy.push_back(1);
            r.touched.push_back(1);
            blocked.push_back(0);
            ++faces_split;
        }
    }
    // A waiting edge's triangles that this pass left whole still have it; the split ones' children hold it
    // now, and the next pass finds them among `fresh`.
    for (auto& [key, around] : waiting) std::erase_if(around, [&](size_t t) { return busy[t] != 0; });
    return waiting;
}

// The share of the fur asked that the frame grows, over the area of the triangles where fur is asked: each
// triangle's area times the mean of its corners' kept fractions (min(1, length / requested); bald corners do
// not count), which integrates the fractions interpolated over it. What a round of refinement wins back.
double fur_share(const Primitive& p, const std::vector<uint32_t>& tris, const ShellFrame& frame) {
    double fur = 0, area = 0;
    for (size_t t = 0; t + 2 < tris.size(); t += 3) {
        const uint32_t* c = &tris[t];
        double kept = 0;
        int asked = 0;
        for (int k = 0; k < 3; ++k)
            if (frame.requested[c[k]] > 0) kept += std::min(1.0, double(frame.length[c[k]]) / frame.requested[c[k]]), ++asked;
        if (asked == 0) continue;
        const kernel::Vec3 a = kernel::point_at(p.positions.data(), c[0]), b = kernel::point_at(p.positions.data(), c[1]),
                           d = kernel::point_at(p.positions.data(), c[2]);
        const double A = 0.5 * kernel::norm(kernel::cross(b - a, d - a));
        if (!std::isfinite(A)) continue;
        fur += A * kept / asked, area += A;
    }
    return area > 0 ? fur / area : 0.0;
}

} // namespace

Status refine_starved_faces(const Primitive& base, Primitive& p, std::vector<uint32_t>& tris, ShellFrame& frame, double length,
                            const RegrowFrame& regrow, size_t budget, double tolerance, Refinement& out) {
    out = Refinement{};
    // Read from base until the first split copies it into p (most meshes need no split: the Stanford bunny's
    // every attribute and index was copied for nothing).
    const Primitive* cur = &base;
    std::vector<uint8_t> blocked(tris.size() / 3, 0);
    double fur = 0; // fur_share of the last frame (measured once a round splits something)
    int idle = 0; // rounds in a row that changed the share of the fur kept by less than `tolerance`
    for (int round = 0; round < kMaxRounds && idle < 2; ++round) {
        const std::vector<int> split = mark(*cur, tris, frame, blocked, length);
        EdgeSet edges;
        for (size_t t = 0; t < split.size(); ++t)
            if (split[t] >= 0) edges[edge_key(*cur, tris[3 * t + size_t(split[t])], tris[3 * t + size_t((split[t] + 1) % 3)])];
        if (edges.empty() || tris.size() / 3 + 2 * edges.size() > budget) break;
        if (round == 0) fur = fur_share(*cur, tris, frame); // (not for the meshes nothing is split in)
        if (cur == &base) p = base, cur = &p;
        Round r;
        r.touched.assign(tris.size() / 3, 0);
        std::vector<size_t> fresh(tris.size() / 3);
        std::iota(fresh.begin(), fresh.end(), size_t(0));
        while (!edges.empty()) edges = bisect_pass(p, tris, std::move(edges), fresh, r, blocked, out.faces_split);
        ++out.rounds;
        Status s = regrow(p, tris, frame);
        if (!s.ok()) return s;
        // A split that grew no more fur than its edge's ends: its triangles are not split further.
        std::vector<uint8_t> unhelpful(p.vertex_count(), 0);
        for (const auto& [m, a, b] : r.made)
            unhelpful[m] = frame.length[m] <= std::max(frame.length[a], frame.length[b]) + 0.1 * frame.requested[m];
        for (size_t t = 0; t < tris.size() / 3; ++t)
            for (int k = 0; k < 3; ++k) blocked[t] = blocked[t] || (unhelpful[tris[3 * t + size_t(k)]] && r.touched[t]);
        const double now = fur_share(p, tris, frame);
        idle = std::abs(now - fur) < tolerance ? idle + 1 : 0;
        fur = now;
    }
    return Status::success();
}

} // namespace furrow::shells_detail

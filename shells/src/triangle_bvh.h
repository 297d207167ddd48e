// A bounding-volume hierarchy over axis-aligned boxes (one per triangle), in double, for the queries of
// feature_distance.cpp: boxes overlapping a box, boxes along a ray (nearest first), boxes within a distance
// of a point (nearest first). Only the traversal lives here; what a leaf does (CGAL constructions and
// predicates) is the caller's, so the geometric decisions stay those of CGAL.
//
// Reference: C. Ericson, "Real-Time Collision Detection", Morgan Kaufmann 2005, chapter 6 (top-down
// construction, stack-based descent, descending two hierarchies together) and section 5.3.3 (ray against
// box by slabs). The split is along the longest axis of the box centres, where the binned surface area
// heuristic puts it (I. Wald, "On fast construction of SAH-based bounding volume hierarchies", IEEE RT 2007),
// down to depth kSahDepth, and at the median below (which bounds the depth, hence the traversal stacks): O(n
// log n) and fully determined by the input, whatever the thread count (large subtrees are built in parallel
// and numbered as one thread numbers them).
//
// Why not CGAL's AABB_tree: its ray query constructs an intersection with every primitive of every leaf it
// reaches (the do_intersect filter is commented out in AABB_ray_intersection.h), its distance query needs a
// kd-tree of sample points to start, and neither can answer "is anything nearer than r?" with an early exit
// (the medial-axis test only needs that). Measured on the 69k-triangle Stanford bunny, the three trees and
// their queries took 1.0 s of a 2.3 s add_fur_shells.
//
// Slabs (add_slabs, for_near only): the medial-axis clamp asks whether any face comes within a ball that sits
// just above the surface and nearly touches it; the axis-aligned boxes of a tilted patch reach up into such a
// ball though its faces do not, and the search descended into them. A node of roughly coplanar faces also keeps
// the slab between two planes that holds them; a node whose slab is out of reach is skipped (on the bunny,
// `bench shells` set-up about 20 ms less, for the same instruction count: the skipped nodes were cache misses).
//
// Wide nodes (widen; for_near and for_ray): the ball queries of the medial-axis clamp wait on the nodes they read
// (36 binary nodes a query on the bunny). Collapsed to 4 children a node, with the four boxes and slabs side by
// side and tested two lanes at a time, a query reads about a third as many nodes: on the 69k-triangle Stanford
// bunny (`furrow -j 1 shells --layers 32`, stage timer) owned_lengths 87-94 -> 70-71 ms, widen ~2 ms. Embree 3's
// rtcPointQuery in their place lost (README "Where the shells' set-up goes, and why not Embree"). Oblique rays
// descend them too (for_ray_wide): bunny free_distances 142.1 -> 112.6 M instructions (callgrind).
//
// Leaf blocks (widen): a wide node's leaf keeps its boxes side by side too, tested four at once, the slots
// within reach taken from a bit mask in slot order (the same primitives met in the same order). On the bunny
// (callgrind --branch-sim=yes, `furrow -j 1 -q shells --layers 2 --length 0.004`), owned_lengths 300.2 ->
// 288.7 M instructions, 2.96 -> 2.34 M mispredicted branches (callgrind's model). The wide nodes' own
// "child within reach" and slab tests as masks too (the slabs of all four children computed) came out at
// 169.8 M instructions in for_near_wide against 154.4 M, for 0.53 M fewer mispredictions, and no faster.
//
// Packets (for_near_packet): the first test of owned_lengths asks, for every vertex, whether any face comes
// within a ball just above it, and the balls of neighbouring vertices (consecutive in the queries' leaf order)
// descend through the same nodes. Eight balls go down together, each node's four boxes and slabs tested for
// all of them at once on AVX-512 (or AVX2) lanes, each ball keeping the tests it would make alone, bit for bit
// (so each meets the same faces and gets the same answer). Bunny (`furrow -j 1 bench shells --layers 32`,
// owned_lengths' stage timer, medians of 4 interleaved runs): 68.6 ms one ball at a time, 60.9 on AVX-512
// lanes, 66.8 on AVX2 lanes, 71.7 ball by ball without lanes (so that case keeps the one-at-a-time searches).
//
// Robustness: every box is grown by a margin (1e-9 of the larger of the extent and the largest coordinate)
// so that rounding in the slab and box-distance tests can only let an extra box through, never drop one;
// the leaf test decides.
#pragma once

#include <algorithm>
#if defined(__x86_64__)
#include <immintrin.h>
#endif
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace furrow::shells_detail {

struct Box3 {
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL};
    double hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    void add(const double* p) {
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    }
    void add(const Box3& b) {
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], b.lo[k]), hi[k] = std::max(hi[k], b.hi[k]);
    }
    // Closed boxes: touching counts (as CGAL::box_intersection_d's default topology).
    bool overlaps(const Box3& b) const {
        return lo[0] <= b.hi[0] && b.lo[0] <= hi[0] && lo[1] <= b.hi[1] && b.lo[1] <= hi[1] && lo[2] <= b.hi[2] && b.lo[2] <= hi[2];
    }
    double squared_distance(const double* p) const {
        // Branch-free (max instead of comparisons): the traversals call this for every child they look at,
        // and which side of a box the point lies on is unpredictable.
        const double dx = std::max(std::max(lo[0] - p[0], p[0] - hi[0]), 0.0);
        const double dy = std::max(std::max(lo[1] - p[1], p[1] - hi[1]), 0.0);
        const double dz = std::max(std::max(lo[2] - p[2], p[2] - hi[2]), 0.0);
        return dx * dx + dy * dy + dz * dz;
    }
    // Entry parameter of the ray o + t·d (t in [0, t_max]) into the box, or +infinity if it misses.
    double ray_entry(const double* o, const double* inv_d, const double* d, double t_max) const {
        double t0 = 0, t1 = t_max;
        for (int k = 0; k < 3; ++k) {
            if (d[k] == 0) {
                if (o[k] < lo[k] || o[k] > hi[k]) return HUGE_VAL;
                continue;
            }
            double ta = (lo[k] - o[k]) * inv_d[k], tb = (hi[k] - o[k]) * inv_d[k];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta); // a NaN (0 · inf) leaves the bound as it was: conservative
            t1 = std::min(t1, tb);
            if (t0 > t1) return HUGE_VAL;
        }
        return t0;
    }
    // ray_entry for a ray with no zero component of d, without branches: the swap of (ta, tb) where ta > tb is
    // the pair (std::min(ta, tb), std::max(tb, ta)), NaN included, and the test for an empty interval waits for
    // the last axis (t0 only rises and t1 only falls, a NaN leaving either as it was): the same parameter, bit
    // for bit. Which face of a box the ray enters by, and on which axis it leaves the interval empty, were
    // branches taken at random: Stanford bunny's ray casts (callgrind with --branch-sim=yes, `furrow -j 1 -q
    // shells --layers 2 --length 0.003`), free_distances 151.6 -> 141.0 M instructions, 27.0 -> 10.4 M
    // conditional branches, 1.88 -> 1.32 M of them mispredicted (callgrind's model).
    double ray_entry_oblique(const double* o, const double* inv_d, double t_max) const {
        const double xa = (lo[0] - o[0]) * inv_d[0], xb = (hi[0] - o[0]) * inv_d[0];
        const double ya = (lo[1] - o[1]) * inv_d[1], yb = (hi[1] - o[1]) * inv_d[1];
        const double za = (lo[2] - o[2]) * inv_d[2], zb = (hi[2] - o[2]) * inv_d[2];
        const double t0 = std::max(std::max(std::max(0.0, std::min(xa, xb)), std::min(ya, yb)), std::min(za, zb));
        const double t1 = std::min(std::min(std::min(t_max, std::max(xb, xa)), std::max(yb, ya)), std::max(zb, za));
        return t0 > t1 ? HUGE_VAL : t0;
    }
};

class BoxBvh {
public:
    // Primitive i has box boxes[i] (an empty box leaves it out).
    void build(std::vector<Box3> boxes);

    // This tree's shape over other boxes of the same primitives (a shell triangle's box for its base face):
    // only the boxes are recomputed, bottom-up, in O(n). Primitives with an empty box take no part.
    void refit(const BoxBvh& shape, const std::vector<Box3>& boxes) {
        take_shape(shape);
        refit(boxes);
    }
    // Shape's nodes and primitives, with no boxes until refit(boxes) (nothing to query before).
    void take_shape(const BoxBvh& shape) {
        nodes_ = shape.nodes_;
        prims_ = shape.prims_;
        boxes_.clear();
        slabs_.clear();
        wide_.clear();
        leaf_boxes_.clear();
        leaf_first_.clear();
        pair_blocks_.clear();
    }
    // The same, keeping this tree's own shape (boxes[i] for primitive i, as at the build).
    void refit(const std::vector<Box3>& boxes) {
        slabs_.clear(); // they held the old primitives
        wide_.clear();
        leaf_boxes_.clear();
        leaf_first_.clear();
        boxes_.resize(prims_.size());
        double reach = 0;
        for (size_t j = 0; j < prims_.size(); ++j) {
            boxes_[j] = boxes[prims_[j]];
            if (boxes_[j].lo[0] <= boxes_[j].hi[0])
                for (int k = 0; k < 3; ++k)
                    reach = std::max({reach, boxes_[j].hi[k] - boxes_[j].lo[k], std::abs(boxes_[j].lo[k]), std::abs(boxes_[j].hi[k])});
        }
        const double margin = 1e-9 * reach + 1e-300;
        for (Box3& b : boxes_)
            for (int k = 0; k < 3; ++k) b.lo[k] -= margin, b.hi[k] += margin; // an empty box stays empty
        // Children always come after their parent (build_node allocates them later): one backward pass.
        // Each leaf's boxes also go side by side into a block, for the paired descent's leaf pairs.
        pair_blocks_.clear();
        pair_blocks_.reserve(nodes_.size() / 2 + 1); // a binary tree of L leaves has 2L - 1 nodes
        block_of_node_.assign(nodes_.size(), 0);
        for (size_t i = nodes_.size(); i-- > 0;) {
            Node& n = nodes_[i];
            n.box = Box3{};
            if (n.count > 0) {
                for (uint32_t j = n.first; j < n.first + n.count; ++j) n.box.add(boxes_[j]);
                block_of_node_[i] = uint32_t(pair_blocks_.size());
                pair_blocks_.push_back(pair_block(n));
            } else {
                n.box.add(nodes_[n.first].box), n.box.add(nodes_[n.first + 1].box);
            }
        }
    }

    // Slabs for for_near (triangles only): for each node of at most max_prims primitives whose faces roughly
    // agree on a normal n (the area-weighted sum at least half the area), the slab lo <= n·x <= hi that holds
    // all their corners, widened by the boxes' margin. corners(prim, out) writes a primitive's 3 corners (9
    // doubles). A box that comes within reach can still lie wholly outside reach of a flat patch it holds
    // (a query point above a surface, whose boxes reach up toward it): for_near then skips the node.
    template <class Corners>
    void add_slabs(Corners&& corners, uint32_t max_prims) {
        std::vector<double> c(9 * prims_.size());
        for (size_t j = 0; j < prims_.size(); ++j) corners(prims_[j], &c[9 * j]);
        add_slabs_gathered(c.data(), max_prims);
    }
    // The same from the corners already gathered in leaf order (c: 9 doubles per position in leaf_order()), for a
    // caller that reads them for more than the slabs.
    void add_slabs_gathered(const double* c, uint32_t max_prims) {
        const size_t N = nodes_.size();
        slabs_.assign(N, Slab{{0, 0, 0}, -HUGE_VAL, HUGE_VAL});
        std::vector<std::pair<uint32_t, uint32_t>> range(N);
        for (size_t i = N; i-- > 0;) {
            const Node& n = nodes_[i];
            range[i] = n.count > 0 ? std::make_pair(n.first, n.first + n.count) : std::make_pair(range[n.first].first, range[n.first + 1].second);
        }
        std::vector<double> sum(4 * N, 0.0); // area-weighted normal (twice the area) and twice the area
        for (size_t i = N; i-- > 0;) {
            const Node& n = nodes_[i];
            double* si = &sum[4 * i];
            if (n.count > 0) {
                for (uint32_t j = n.first; j < n.first + n.count; ++j) {
                    const double* t = &c[9 * size_t(j)];
                    const double e1[3] = {t[3] - t[0], t[4] - t[1], t[5] - t[2]}, e2[3] = {t[6] - t[0], t[7] - t[1], t[8] - t[2]};
                    const double m[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
                    for (int k = 0; k < 3; ++k) si[k] += m[k];
                    si[3] += std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
                }
            } else {
                for (int k = 0; k < 4; ++k) si[k] = sum[4 * size_t(n.first) + size_t(k)] + sum[4 * size_t(n.first + 1) + size_t(k)];
            }
            const auto [begin, end] = range[i];
            const double len = std::sqrt(si[0] * si[0] + si[1] * si[1] + si[2] * si[2]);
            if (end - begin > max_prims || !(len >= 0.5 * si[3]) || !(len > 0) || !std::isfinite(len)) continue;
            Slab& sl = slabs_[i];
            for (int k = 0; k < 3; ++k) sl.n[k] = si[k] / len;
            // A primitive's three corners into three pairs of bounds, merged after: one pair waited on its own
            // last minimum and maximum at every corner. (A minimum does not depend on the order it is taken in;
            // which of +0 and -0 it keeps does, and the margin's subtraction makes both the same.)
            double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
            for (size_t q = 9 * size_t(begin); q < 9 * size_t(end); q += 9)
                for (int k = 0; k < 3; ++k) {
                    const double* x = &c[q + 3 * size_t(k)];
                    const double d = sl.n[0] * x[0] + sl.n[1] * x[1] + sl.n[2] * x[2];
                    lo[k] = std::min(lo[k], d), hi[k] = std::max(hi[k], d);
                }
            sl.lo = std::min({lo[0], lo[1], lo[2]}) - margin_, sl.hi = std::max({hi[0], hi[1], hi[2]}) + margin_;
        }
    }

    bool empty() const { return prims_.empty(); }
    // The same nodes (boxes bit for bit, children, leaves), primitives and leaf boxes (a test's check).
    bool same_tree(const BoxBvh& o) const {
        auto same_box = [](const Box3& a, const Box3& b) { return std::memcmp(&a, &b, sizeof(Box3)) == 0; };
        if (nodes_.size() != o.nodes_.size() || prims_ != o.prims_ || boxes_.size() != o.boxes_.size()) return false;
        for (size_t i = 0; i < nodes_.size(); ++i)
            if (!same_box(nodes_[i].box, o.nodes_[i].box) || nodes_[i].first != o.nodes_[i].first || nodes_[i].count != o.nodes_[i].count)
                return false;
        for (size_t j = 0; j < boxes_.size(); ++j)
            if (!same_box(boxes_[j], o.boxes_[j])) return false;
        return true;
    }
    // The primitives in leaf order (left to right): neighbours in it are neighbours in space.
    const std::vector<uint32_t>& leaf_order() const { return prims_; }

    // f(prim) for every primitive whose (grown) box overlaps q.
    template <class F>
    void for_overlapping(const Box3& q, F&& f) const {
        if (nodes_.empty()) return;
        uint32_t stack[kStack];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& n = nodes_[stack[--top]];
            if (!n.box.overlaps(q)) continue;
            if (n.count > 0) {
                for (uint32_t j = n.first; j < n.first + n.count; ++j)
                    if (boxes_[j].overlaps(q)) f(prims_[j]);
            } else {
                stack[top++] = n.first;
                stack[top++] = n.first + 1;
            }
        }
    }

    // The number of binary levels (a leaf at the root: 1); every descent's stack holds 3 × depth + 1 entries.
    int depth() const {
        if (nodes_.empty()) return 0;
        std::vector<std::pair<uint32_t, int>> stack{{0, 1}};
        int deepest = 0;
        while (!stack.empty()) {
            const auto [node, level] = stack.back();
            stack.pop_back();
            deepest = std::max(deepest, level);
            if (nodes_[node].count == 0) stack.emplace_back(nodes_[node].first, level + 1), stack.emplace_back(nodes_[node].first + 1, level + 1);
        }
        return deepest;
    }
    static constexpr int kMaxDepth = 55;

    // Every pair (a primitive of this tree, one of `other`) whose boxes overlap, found by descending both
    // trees together (Ericson, chapter 6): the upper levels are visited once for all pairs instead of once per
    // query box. With other == this, each unordered pair of distinct primitives comes once. Each pair goes to
    // emit(a, b, i, j, list) (i, j: a's and b's positions in leaf_order(), for data the caller keeps in that
    // order), which appends to `list` what the caller keeps of it (the caller's filter runs in the
    // tasks, and only what it keeps is stored and copied); the lists are appended to `out`. Parallel: the
    // node pairs are expanded breadth-first into independent tasks in a fixed order, each task fills its own
    // list, and the lists are joined in task order, so the result is the same for any thread count.
    template <class T, class Emit>
    void overlapping_pairs(const BoxBvh& other, Emit&& emit, std::vector<T>& out) const {
        using Pair = std::pair<uint32_t, uint32_t>;
        if (nodes_.empty() || other.nodes_.empty()) return;
        const bool self = &other == this;
        std::vector<Pair> frontier{{0, 0}}, next;
        for (int depth = 0; depth < 12 && frontier.size() < 256; ++depth) {
            next.clear();
            bool split = false;
            for (const Pair& xy : frontier) split |= expand(other, self, xy, next);
            frontier.swap(next);
            if (!split) break;
        }
        std::vector<std::vector<T>> lists(frontier.size());
        tbb::parallel_for(tbb::blocked_range<size_t>(0, frontier.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t k = r.begin(); k != r.end(); ++k) {
                auto leaf = [&](uint32_t a, uint32_t b, uint32_t i, uint32_t j) { emit(a, b, i, j, lists[k]); };
                descend(other, self, frontier[k], leaf);
            }
        });
        size_t total = out.size();
        for (const auto& l : lists) total += l.size();
        out.reserve(total);
        for (const auto& l : lists) out.insert(out.end(), l.begin(), l.end());
    }

    // Primitives whose box the ray o + t·d (t in [0, t_max]) enters, nearer boxes first; f(prim, t_max) may
    // lower t_max (the nearest hit so far), which prunes everything that starts beyond it.
    // After widen(), a ray with no zero direction component descends the 4-wide nodes (for_ray_wide).
    template <class F>
    void for_ray(const double* o, const double* d, double& t_max, F&& f) const {
        if (nodes_.empty()) return;
        double inv[3];
        for (int k = 0; k < 3; ++k) inv[k] = d[k] != 0 ? 1.0 / d[k] : 0.0;
        const bool oblique = d[0] != 0 && d[1] != 0 && d[2] != 0;
        if (oblique && !wide_.empty()) return for_ray_wide(o, inv, t_max, f);
        auto ray_entry = [&](const Box3& b) { return oblique ? b.ray_entry_oblique(o, inv, t_max) : b.ray_entry(o, inv, d, t_max); };
        uint32_t stack[kStack];
        double entry[kStack];
        int top = 0;
        const double root = ray_entry(nodes_[0].box);
        if (root == HUGE_VAL) return;
        stack[top] = 0, entry[top++] = root;
        while (top > 0) {
            --top;
            if (entry[top] > t_max) continue;
            const Node& n = nodes_[stack[top]];
            if (n.count > 0) {
                for (uint32_t j = n.first; j < n.first + n.count; ++j)
                    if (ray_entry(boxes_[j]) != HUGE_VAL) f(prims_[j], t_max);
                continue;
            }
            const double ta = ray_entry(nodes_[n.first].box);
            const double tb = ray_entry(nodes_[n.first + 1].box);
            // Push the farther child first so that the nearer one is visited first.
            const bool a_first = ta <= tb;
            const uint32_t near_id = a_first ? n.first : n.first + 1, far_id = a_first ? n.first + 1 : n.first;
            const double near_t = a_first ? ta : tb, far_t = a_first ? tb : ta;
            if (far_t != HUGE_VAL) stack[top] = far_id, entry[top++] = far_t;
            if (near_t != HUGE_VAL) stack[top] = near_id, entry[top++] = near_t;
        }
    }

    // for_ray on the 4-wide nodes (oblique rays: inv_d holds 1 / d, no component zero): the same primitives
    // met (every one whose box the ray enters before t_max, as it stands when the box's node is popped), nearer
    // boxes first, in a different order where the binary descent would have finished one subtree before a
    // nearer box of the next. Each child's entry parameter is Box3::ray_entry_oblique's, bit for bit, two
    // children at a time (std::min / std::max written out as the same comparisons, NaN included). A box
    // inside another is entered no earlier and left no later (the rounding is monotone), so dropping the
    // binary levels collapsed away drops no primitive. Why: Stanford bunny, 34.8 k rays (bounded by their
    // reach) popped 25 binary nodes each to meet 6 primitives, nearly all the faces around the origin.
    template <class F>
    void for_ray_wide(const double* o, const double* inv_d, double& t_max, F& f) const {
        const double root = nodes_[0].box.ray_entry_oblique(o, inv_d, t_max);
        if (root == HUGE_VAL) return;
        // A node pops one entry and pushes at most four, at most once per level: 3 × depth + 1 entries.
        uint32_t stack[kStack], count[kStack];
        double entry[kStack];
        int top = 0;
        stack[top] = 0, count[top] = 0, entry[top++] = root;
        auto vmin = [](V2 a, V2 b) { return b < a ? b : a; }; // std::min(a, b), lane by lane
        auto vmax = [](V2 a, V2 b) { return a < b ? b : a; }; // std::max(a, b)
        while (top > 0) {
            --top;
            if (entry[top] > t_max) continue;
            if (count[top] > 0) { // a leaf block: its primitives start at leaf_first_
                const uint32_t first = leaf_first_[stack[top]];
                for (uint32_t j = first; j < first + count[top]; ++j)
                    if (boxes_[j].ray_entry_oblique(o, inv_d, t_max) != HUGE_VAL) f(prims_[j], t_max);
                continue;
            }
            const Wide& w = wide_[stack[top]];
            double t0[4], t1[4];
            for (int h = 0; h < 4; h += 2) {
                V2 lo[3], hi[3];
                for (int k = 0; k < 3; ++k) std::memcpy(&lo[k], &w.lo[k][h], sizeof(V2)), std::memcpy(&hi[k], &w.hi[k][h], sizeof(V2));
                V2 a[3], b[3];
                for (int k = 0; k < 3; ++k) a[k] = (lo[k] - o[k]) * inv_d[k], b[k] = (hi[k] - o[k]) * inv_d[k];
                const V2 near = vmax(vmax(vmax(V2{0, 0}, vmin(a[0], b[0])), vmin(a[1], b[1])), vmin(a[2], b[2]));
                const V2 far = vmin(vmin(vmin(V2{t_max, t_max}, vmax(b[0], a[0])), vmax(b[1], a[1])), vmax(b[2], a[2]));
                std::memcpy(&t0[h], &near, sizeof near), std::memcpy(&t1[h], &far, sizeof far);
            }
            // The children entered (an unused slot, an empty box, never is).
            push_nearest_last(w, t0, [&](int i) { return !(t0[i] > t1[i]) && w.lo[0][i] <= w.hi[0][i]; }, stack, count, entry, top);
        }
    }

    // Primitives whose box lies within squared distance r2 of p, nearer boxes first; f(prim, r2) may lower
    // r2 (a nearest-point search) and returns true to stop the search (an emptiness test that found
    // something). Returns whether f stopped it. An f taking a third argument is also given the primitive's position
    // in leaf_order(), for data the caller keeps in that order.
    template <class F>
    bool for_near(const double* p, double& r2, F&& f) const {
        return wide_.empty() ? for_near_binary(p, r2, f) : for_near_wide(p, r2, f);
    }

    // for_near on the binary nodes (what it does before widen()): the reference the 4-wide descent is tested
    // against.
    template <class F>
    bool for_near_binary(const double* p, double& r2, F&& f) const {
        if (nodes_.empty()) return false;
        uint32_t stack[kStack];
        double dist[kStack];
        int top = 0;
        stack[top] = 0, dist[top++] = nodes_[0].box.squared_distance(p);
        // A node whose slab lies out of reach holds nothing within reach: skipped, the other visits in the same
        // order.
        auto slab_out_of_reach = [&](uint32_t node) {
            return !slabs_.empty() && out_of_reach(slabs_[node].n, slabs_[node].lo, slabs_[node].hi, p, r2);
        };
        while (top > 0) {
            --top;
            if (!(dist[top] < r2) || slab_out_of_reach(stack[top])) continue;
            const Node& n = nodes_[stack[top]];
            if (n.count > 0) {
                if (near_in_leaf(n.first, n.count, p, r2, f)) return true;
                continue;
            }
            const double da = nodes_[n.first].box.squared_distance(p), db = nodes_[n.first + 1].box.squared_distance(p);
            const bool a_first = da <= db;
            // A child already out of reach stays out (r2 only shrinks): not pushed, the same visits.
            const double d_far = a_first ? db : da, d_near = a_first ? da : db;
            if (d_far < r2) stack[top] = a_first ? n.first + 1 : n.first, dist[top++] = d_far;
            if (d_near < r2) stack[top] = a_first ? n.first : n.first + 1, dist[top++] = d_near;
        }
        return false;
    }

    // The hierarchy collapsed to 4 children a node (for for_near and for_ray; call it after add_slabs, and again after
    // a refit): each binary node's two children are replaced by their children, the larger box first, until
    // four (Wald, Benthin, Boulos, "Getting Rid of Packets", IEEE RT 2008, section 3; Embree's BVH4). The
    // boxes and slabs of a node's four children sit side by side, one array per coordinate, so one node
    // tests all four at once and the descent reads a third as many nodes.
    void widen() {
        wide_.clear();
        leaf_boxes_.clear();
        leaf_first_.clear();
        if (nodes_.empty()) return;
        size_t leaves = 0;
        for (const Node& n : nodes_) leaves += n.count > 0;
        wide_.reserve(leaves); // at most one a binary inner node: grown in place (no copies of the 384-byte nodes)
        leaf_boxes_.reserve(leaves);
        leaf_first_.reserve(leaves);
        wide_.emplace_back();
        if (nodes_[0].count > 0) {
            set_slot(0, 0, 0, 0);
            wide_[0].child[0] = add_leaf_block(nodes_[0]), wide_[0].count[0] = nodes_[0].count;
            return;
        }
        widen_node(0, 0);
    }

    // for_near on the 4-wide nodes: the same primitives met (every one whose box lies within reach and whose
    // binary ancestors' slabs do not put it out of reach), nearer boxes first, in a different order where the
    // binary descent would have finished one subtree before a nearer box of the next.
    template <class F>
    bool for_near_wide(const double* p, double& r2, F&& f) const {
        if (wide_.empty()) return false;
        // A node pops one entry and pushes at most four, at most once per level: 3 × depth + 1 entries.
        uint32_t stack[kStack], count[kStack];
        double dist[kStack];
        int top = 0;
        stack[top] = 0, count[top] = 0, dist[top++] = nodes_[0].box.squared_distance(p);
        if (!slabs_.empty() && out_of_reach(slabs_[0].n, slabs_[0].lo, slabs_[0].hi, p, r2)) return false;
        const double err = slab_error(p);
        while (top > 0) {
            --top;
            if (!(dist[top] < r2)) continue;
            if (count[top] > 0) {
                if (near_in_block(stack[top], p, r2, f)) return true;
                continue;
            }
            const Wide& w = wide_[stack[top]];
            double d[4];
            lanes_within(w.lo, w.hi, p, r2, d);
            // The children within reach.
            push_nearest_last(w, d, [&](int i) {
                if (!(d[i] < r2)) return false;
                const double sn[3] = {w.sn[0][i], w.sn[1][i], w.sn[2][i]};
                return !out_of_reach(sn, w.slo[i], w.shi[i], p, err, r2);
            }, stack, count, dist, top);
        }
        return false;
    }

    // for_near_wide for a packet of up to kPacket balls at once (centre p[k], squared reach r2[k], ball k taking
    // part where bit k of `balls` is set): each ball meets exactly the primitives for_near_wide meets for it (the
    // same box and slab tests, bit for bit), in another order, and a node is read once for the whole packet,
    // its tests made for all the balls at once (AVX-512 or AVX2 lanes, chosen at run time; else ball by ball).
    // f(k, prim, j) for ball k and the primitive at leaf-order position j; true settles ball k (it meets no
    // more). Returns the settled balls as bits: with a yes-or-no f, ball k is settled exactly when
    // for_near_wide(p[k], r2[k], f_k) returns true. `lanes`: 8 (AVX-512), 4 (AVX2) or 1 (ball by ball), at most
    // what the processor runs (packet_lanes()); tests compare them (the same answers).
    static constexpr int kPacket = 8;
    // The widest lanes for_near_packet runs here: 8 with AVX-512, 4 with AVX2, else 1.
    static int packet_width() { return packet_lanes(); }
    template <class F>
    unsigned for_near_packet(const double (*p)[3], const double* r2, unsigned balls, F&& f, int lanes = packet_lanes()) const {
        if (wide_.empty()) return 0;
        PacketBalls P;
        unsigned live = 0;
        for (unsigned m = balls; m != 0; m &= m - 1) {
            const int k = __builtin_ctz(m);
            if (!(nodes_[0].box.squared_distance(p[k]) < r2[k])) continue;
            if (!slabs_.empty() && out_of_reach(slabs_[0].n, slabs_[0].lo, slabs_[0].hi, p[k], r2[k])) continue;
            P.x[k] = p[k][0], P.y[k] = p[k][1], P.z[k] = p[k][2], P.r2[k] = r2[k], P.err[k] = slab_error(p[k]);
            live |= 1u << k;
        }
        if (live == 0) return 0;
        lanes = std::min(lanes, packet_lanes());
        auto within_of = [&](const double (&lo)[3][4], const double (&hi)[3][4], unsigned m, unsigned* within) {
            lanes >= 8 ? packet_within8(lo, hi, P, m, within) : lanes >= 4 ? packet_within4(lo, hi, P, m, within) : packet_within(lo, hi, P, m, within);
        };
        auto out_of = [&](const Wide& w, int i, unsigned m) {
            return lanes >= 8 ? packet_out_of_reach8(w, i, P, m) : lanes >= 4 ? packet_out_of_reach4(w, i, P, m) : packet_out_of_reach(w, i, P, m);
        };
        uint32_t stack[kStack], count[kStack];
        unsigned mask[kStack];
        int top = 0;
        stack[top] = 0, count[top] = 0, mask[top++] = live;
        unsigned settled = 0;
        while (top > 0) {
            --top;
            const unsigned m = mask[top] & ~settled;
            if (m == 0) continue;
            unsigned within[4];
            if (count[top] > 0) {
                const LeafBoxes& b = leaf_boxes_[stack[top]];
                const uint32_t first = leaf_first_[stack[top]];
                within_of(b.lo, b.hi, m, within);
                for (int i = 0; i < 4; ++i)
                    for (unsigned mm = within[i] & ~settled; mm != 0; mm &= mm - 1) {
                        const int k = __builtin_ctz(mm);
                        if (f(k, prims_[first + uint32_t(i)], first + uint32_t(i))) settled |= 1u << k;
                    }
                continue;
            }
            const Wide& w = wide_[stack[top]];
            within_of(w.lo, w.hi, m, within);
            for (int i = 0; i < 4; ++i) {
                if (within[i] == 0) continue;
                const unsigned child = within[i] & ~out_of(w, i, within[i]);
                if (child != 0) stack[top] = w.child[i], count[top] = w.count[i], mask[top++] = child;
            }
        }
        return settled;
    }

private:
    static constexpr uint32_t kLeaf = 4;
    // Depth <= kSahDepth + log2(2^32 / kLeaf) + 1 = kMaxDepth (each split below kSahDepth halves the count):
    // the wide descents' 3 x depth + 1 entries fit.
    static constexpr int kStack = 192;
    static_assert(3 * kMaxDepth + 1 <= kStack);
    struct Node {
        Box3 box;
        uint32_t first = 0; // leaf: first index into prims_/boxes_; inner: left child (right = first + 1)
        uint32_t count = 0; // leaf: number of primitives; inner: 0
    };

    // One step of the breadth-first split into tasks: the child pairs of node pair xy go to `next` (two
    // leaves: the pair itself). Returns whether xy was split; a pair that does not overlap is dropped.
    bool expand(const BoxBvh& other, bool self, std::pair<uint32_t, uint32_t> xy, std::vector<std::pair<uint32_t, uint32_t>>& next) const {
        const auto [x, y] = xy;
        const Node &a = nodes_[x], &b = other.nodes_[y];
        if (!a.box.overlaps(b.box)) return false;
        const bool same = self && x == y;
        if (a.count > 0 && b.count > 0) {
            next.push_back(xy);
            return false;
        }
        if (same) { // (l, l), (l, r), (r, r): the pair (r, l) is (l, r) again
            next.emplace_back(a.first, a.first);
            next.emplace_back(a.first, a.first + 1);
            next.emplace_back(a.first + 1, a.first + 1);
        } else if (a.count > 0) {
            next.emplace_back(x, b.first);
            next.emplace_back(x, b.first + 1);
        } else if (b.count > 0) {
            next.emplace_back(a.first, y);
            next.emplace_back(a.first + 1, y);
        } else {
            for (uint32_t i = 0; i < 2; ++i)
                for (uint32_t j = 0; j < 2; ++j) next.emplace_back(a.first + i, b.first + j);
        }
        return true;
    }

    // The paired descent below node pair xy: every primitive pair whose boxes overlap to leaf(a, b, i, j) (i, j:
    // their positions in the leaf order); two leaves that both have blocks (refit) go to leaf_pair. A child pair
    // is tested before it is stacked, so the stack (on the frame: a step replaces one pair by at most four and
    // goes one level down in at least one tree, so 3 x (both depths) + 1 entries suffice) holds only
    // overlapping pairs. Stanford bunny's crossing test (callgrind, `furrow -j 1 -q shells --layers 2
    // --length 0.003`): 394 k node pairs were stacked and popped, 235 k of them overlapping; verify_crossings
    // 312.6 -> 298.5 M instructions.
    template <class Leaf>
    void descend(const BoxBvh& other, bool self, std::pair<uint32_t, uint32_t> xy, Leaf& leaf) const {
        std::pair<uint32_t, uint32_t> stack[6 * kStack + 1];
        int top = 0;
        const bool blocks = !pair_blocks_.empty() && !other.pair_blocks_.empty();
        auto push = [&](uint32_t x, uint32_t y) {
            if (nodes_[x].box.overlaps(other.nodes_[y].box)) stack[top++] = {x, y};
        };
        push(xy.first, xy.second);
        while (top > 0) {
            const auto [x, y] = stack[--top];
            const Node &a = nodes_[x], &b = other.nodes_[y];
            const bool same = self && x == y;
            if (a.count > 0 && b.count > 0) {
                if (blocks) {
                    leaf_pair(pair_blocks_[block_of_node_[x]], a, other.pair_blocks_[other.block_of_node_[y]], b, other, same, leaf);
                    continue;
                }
                for (uint32_t i = a.first; i < a.first + a.count; ++i)
                    for (uint32_t j = same ? i + 1 : b.first; j < b.first + b.count; ++j)
                        if (boxes_[i].overlaps(other.boxes_[j])) leaf(prims_[i], other.prims_[j], i, j);
            } else if (same) { // (l, l), (l, r), (r, r): the pair (r, l) is (l, r) again
                push(a.first, a.first), push(a.first, a.first + 1), push(a.first + 1, a.first + 1);
            } else if (a.count > 0) {
                push(x, b.first), push(x, b.first + 1);
            } else if (b.count > 0) {
                push(a.first, y), push(a.first + 1, y);
            } else {
                for (uint32_t i = 0; i < 2; ++i)
                    for (uint32_t j = 0; j < 2; ++j) push(a.first + i, b.first + j);
            }
        }
    }

    // A primitive's box in float and its id, moved with it by the split: the binning and the partition read
    // their keys in order. The float box only guides the split (the node boxes are the double boxes' unions,
    // below); it is the double box rounded to nearest, clamped to +-1e37 (so that lo + hi, twice the centre,
    // stays finite; a NaN goes to -1e37). The keys used to hold the centre in double, and every level gathered
    // each primitive's double box by id, a cache miss once the partitions had shuffled them; the bins' boxes
    // and the centres' box were scalar minima and maxima through memory, each waiting on the last store; the
    // partition computed each bin again; and every node measured its centres, which its parent's bins know.
    // Build alone on the 69k-triangle Stanford bunny (a micro-benchmark, best of 30): 18.1-18.9 -> 14.2-14.7
    // ms; `bench shells` set-up (bunny, 32 layers, -j 1, four interleaved rounds, medians of 5) 151.1-160.7 ->
    // 146.4-158.6 ms. The tree changes with the keys' rounding: of the md5 check set (bunny,
    // creature, spot, fox, suzanne, alligator) only suzanne's bytes moved (1913 of 109604 positions, by at
    // most 3.9e-6 of a 0.01 length).
    // nth_element's and partition's moves depend only on their comparisons: the tree depends on nothing but the
    // input.
    struct Keyed {
        float lo[3];
        uint32_t id;
        float hi[3];
        uint32_t bin; // sah_split's, for its partition
        static float key(double d) { return d >= -1e37 ? (d <= 1e37 ? float(d) : 1e37f) : -1e37f; }
        static Keyed of(const Box3& b, uint32_t id) {
            return {{key(b.lo[0]), key(b.lo[1]), key(b.lo[2])}, id, {key(b.hi[0]), key(b.hi[1]), key(b.hi[2])}, 0};
        }
        float centre2(int axis) const { return lo[axis] + hi[axis]; } // twice the centre
    };
    // A box of keys (bins, centres), in float, three lanes of four (the fourth is not read): GCC/Clang vector
    // extension, one SSE operation for the three axes.
    typedef float V4 __attribute__((vector_size(16)));
    struct KeyBox {
        V4 lo = {HUGE_VALF, HUGE_VALF, HUGE_VALF, HUGE_VALF};
        V4 hi = {-HUGE_VALF, -HUGE_VALF, -HUGE_VALF, -HUGE_VALF};
        void add(V4 l, V4 h) {
            lo = l < lo ? l : lo;
            hi = h > hi ? h : hi;
        }
        double half_area() const { // the extents in double (float products could overflow)
            const V4 e = hi - lo; // (float differences: the costs only rank the splits)
            return double(e[0]) * e[1] + double(e[1]) * e[2] + double(e[2]) * e[0];
        }
    };
    // A key's lo and hi as vectors, the fourth lane (the id's or the bin's bits) cleared: as a float it is
    // mostly a denormal, and arithmetic on denormals is slow (a microcode assist an operation on x86).
    static V4 three_lanes(const float* x) {
        typedef uint32_t U4 __attribute__((vector_size(16)));
        U4 v;
        std::memcpy(&v, x, sizeof v);
        v &= U4{~0u, ~0u, ~0u, 0u};
        V4 f;
        std::memcpy(&f, &v, sizeof f);
        return f;
    }
    static V4 lo_of(const Keyed& k) { return three_lanes(k.lo); }
    static V4 hi_of(const Keyed& k) { return three_lanes(k.hi); }
    static constexpr int kBins = 16;
    static constexpr int kSahDepth = 24;
    static_assert(kMaxDepth >= kSahDepth + 31, "below kSahDepth, median splits of at most 2^32 primitives into leaves of kLeaf");
    // The split of keyed[begin, end) along the longest axis of the centres' box (centres, of twice the centres)
    // that the surface area heuristic prefers: the centres binned in kBins slabs, each bin boundary costed as
    // left area × left count + right area × right count, and the primitives partitioned at the cheapest (in
    // place; mid its end). False when all centres share one bin (then the median split). Tighter boxes than the
    // median's where the triangles are uneven: Stanford bunny (`bench shells`, -j 1, stage timers, three
    // interleaved runs) the medial-axis queries 57.4-62.1 -> 51.1-56.0 ms, the rays 19.8-21.5 -> 18.8-20.1, the
    // crossing test 38.0-41.1 -> 35.4-38.5 (binning on the three axes instead: 10 ms slower to build).
    bool sah_split(uint32_t begin, uint32_t end, int axis, const KeyBox& centres, std::vector<Keyed>& keyed, uint32_t& mid,
                   KeyBox& left_centres, KeyBox& right_centres) const;
    // The centres' box of keyed[begin, end) (of twice the centres).
    static KeyBox centres_of(const std::vector<Keyed>& keyed, uint32_t begin, uint32_t end);
    // The split of inner node keyed[begin, end) (more than kLeaf keys), whose centres' box is `centres`: keyed
    // partitioned at mid, and the centres' boxes of the two sides.
    void split(uint32_t begin, uint32_t end, std::vector<Keyed>& keyed, const KeyBox& centres, int depth, uint32_t& mid,
               KeyBox& left_centres, KeyBox& right_centres) const;
    // Node `node` of `nodes` over keyed[begin, end), whose centres' box is `centres` (its parent's split found
    // it). Its children are allocated as a pair when it splits, then the left subtree is built, then the right:
    // that order numbers the nodes.
    void build_node(std::vector<Node>& nodes, uint32_t node, uint32_t begin, uint32_t end, const std::vector<Box3>& boxes,
                    std::vector<Keyed>& keyed, const KeyBox& centres, int depth = 0) const;
    // An inner node's box, bottom-up: the union of its children's (min and max are exact, so it is the box of
    // the primitives below, as a pass over them would give).
    static void join_boxes(Node& n, const Node& left, const Node& right) {
        Box3 box;
        box.add(left.box);
        box.add(right.box);
        n.box = box;
    }

    // The build on more than one thread: the same tree, node for node (test box_bvh.BuildOnTwoThreadsIsTheOneThreadTree).
    // A node of more than kTaskKeys keys is split on its own and its two subtrees built in parallel, each in a
    // part of its own (the keys of the two are disjoint ranges of keyed: the splits are those one thread
    // makes); a smaller one is built whole by build_node into its part's nodes. place() then numbers every
    // node as one thread does. Stanford bunny (69k boxes, a harness building its tree 15 times, three
    // interleaved runs): best 16.9-18.0 -> 11.5-12.7 ms on 2 threads; the root's split, over every key, stays
    // on one. One thread takes build_node straight into nodes_ (the parts would only add their copies).
    static constexpr uint32_t kTaskKeys = 4096;
    struct Part {
        std::vector<Node> nodes;       // small: its subtree (root first); large: its node alone, box unset
        std::unique_ptr<Part> kid[2];  // large: its children's parts
    };
    void build_part(Part& part, uint32_t begin, uint32_t end, const std::vector<Box3>& boxes, std::vector<Keyed>& keyed,
                    const KeyBox& centres, int depth) const;
    // Node i of `part` into nodes_[at], and the nodes below it after the nodes already placed: children as a
    // pair, the left subtree first, as build_node numbers them.
    void place(const Part& part, uint32_t i, uint32_t at);

    // for_near's leaf: f for each of slots [first, first + count) whose box lies within reach; whether f stopped
    // the search. A caller that keeps per-primitive data in leaf order (leaf_order()) is also told the position.
    template <class F>
    bool near_in_leaf(uint32_t first, uint32_t count, const double* p, double& r2, F& f) const {
        for (uint32_t j = first; j < first + count; ++j) {
            if (!(boxes_[j].squared_distance(p) < r2)) continue;
            if constexpr (std::is_invocable_v<F&, uint32_t, double&, uint32_t>) {
                if (f(prims_[j], r2, j)) return true;
            } else if (f(prims_[j], r2)) {
                return true;
            }
        }
        return false;
    }

    // Is the slab lo <= n·x <= hi out of reach of p (squared reach r2)? The slab distance |n·p − lo or hi| is
    // rounded by at most 4e-16 Σ|n_k p_k| (|n| = 1 within 1e-15), and what is skipped is at least that much
    // farther than reach by a factor 1 + 5e-7. No slab (n = 0, lo = −inf, hi = +inf) is never out of reach.
    static bool out_of_reach(const double* n, double lo, double hi, const double* p, double r2) {
        const double err = 4e-16 * (std::abs(n[0] * p[0]) + std::abs(n[1] * p[1]) + std::abs(n[2] * p[2]));
        return out_of_reach(n, lo, hi, p, err, r2);
    }
    // The same with the rounding allowance err given, at least the one above.
    static bool out_of_reach(const double* n, double lo, double hi, const double* p, double err, double r2) {
        const double d = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
        const double gap = std::max(d - hi, lo - d) - err;
        return gap > 0 && gap * gap * (1 - 1e-6) >= r2;
    }
    // An allowance for every slab at once (for_near_wide, once a query): 4e-16 Σ|n_k p_k| <= 4e-16 (1 + 1e-6)
    // Σ|p_k| for a unit n (|n_k| <= 1 + 1e-15): it skips no node the exact allowance would keep, and a node
    // skipped or kept leaves the others' order as it was, so the primitives met within reach are the same, in
    // the same order (a node kept in excess holds none). Bunny callgrind (`furrow -j 1 -q shells --layers 2
    // --length 0.004`): owned_lengths 288.7 -> 280.1 M instructions.
    static double slab_error(const double* p) { return 4e-16 * (1 + 1e-6) * (std::abs(p[0]) + std::abs(p[1]) + std::abs(p[2])); }

    // A 4-wide node: per child slot its box and slab (structure of arrays), and what it is: a wide node
    // (count 0, child its index) or a leaf of count primitives (child its index in leaf_boxes_ and
    // leaf_first_). An unused slot has an empty box (lo +inf, hi −inf): its distance is +inf, never within reach.
    struct alignas(64) Wide {
        double lo[3][4] = {{HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL}, {HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL}, {HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL}};
        double hi[3][4] = {{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL}};
        double sn[3][4] = {};
        double slo[4] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        double shi[4] = {HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL};
        uint32_t child[4] = {0, 0, 0, 0};
        uint32_t count[4] = {0, 0, 0, 0};
    };
    // The children i of wide node w that `enter` accepts, pushed with their keys (entry parameter or box
    // distance) farther first, ties the later slot first, so that the nearest is popped next: both wide
    // descents' order.
    template <class Enter>
    static void push_nearest_last(const Wide& w, const double* key, Enter&& enter, uint32_t* stack, uint32_t* count, double* keys,
                                  int& top) {
        int order[4], n = 0;
        for (int i = 0; i < 4; ++i) {
            if (!enter(i)) continue;
            int k = n++;
            for (; k > 0 && key[order[k - 1]] < key[i]; --k) order[k] = order[k - 1];
            order[k] = i;
        }
        for (int k = 0; k < n; ++k) {
            const int i = order[k];
            stack[top] = w.child[i], count[top] = w.count[i], keys[top++] = key[i];
        }
    }
    // A leaf's boxes (boxes_[first, first + count)) side by side, as a wide node's: the slots past count are
    // empty boxes, never within reach.
    struct alignas(64) LeafBoxes {
        double lo[3][4] = {{HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL}, {HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL}, {HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL}};
        double hi[3][4] = {{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL}};
    };
    static_assert(kLeaf <= 4, "a leaf's boxes fill one LeafBoxes");
    // Binary leaf node c's boxes side by side.
    LeafBoxes leaf_block(const Node& c) const {
        LeafBoxes b;
        for (uint32_t i = 0; i < c.count; ++i)
            for (int k = 0; k < 3; ++k) b.lo[k][i] = boxes_[c.first + i].lo[k], b.hi[k][i] = boxes_[c.first + i].hi[k];
        return b;
    }
    // Binary leaf node c's boxes as a new leaf block of the wide nodes; its index.
    uint32_t add_leaf_block(const Node& c) {
        leaf_boxes_.push_back(leaf_block(c));
        leaf_first_.push_back(c.first);
        return uint32_t(leaf_boxes_.size() - 1);
    }
    // Slot i of wide node w takes binary node b's box and slab.
    void set_slot(uint32_t w, int i, uint32_t b, uint32_t slab) {
        Wide& x = wide_[w];
        for (int k = 0; k < 3; ++k) x.lo[k][i] = nodes_[b].box.lo[k], x.hi[k][i] = nodes_[b].box.hi[k];
        if (slabs_.empty()) return;
        const Slab& sl = slabs_[slab];
        for (int k = 0; k < 3; ++k) x.sn[k][i] = sl.n[k];
        x.slo[i] = sl.lo, x.shi[i] = sl.hi;
    }
    // Fills wide node w from inner binary node b (its descendants down to four). A slot without a slab of its
    // own takes that of the binary node it was split from (which holds its faces too), so the descent skips
    // no less than the binary one did at the nodes collapsed away.
    void widen_node(uint32_t w, uint32_t b) {
        uint32_t slot[4] = {nodes_[b].first, nodes_[b].first + 1, 0, 0};
        uint32_t slab[4] = {slot[0], slot[1], 0, 0};
        auto has_slab = [&](uint32_t node) { return !slabs_.empty() && slabs_[node].lo != -HUGE_VAL; };
        int n = 2;
        while (n < 4) {
            int pick = -1;
            double best = -1;
            for (int i = 0; i < n; ++i) {
                const Node& c = nodes_[slot[i]];
                if (c.count > 0) continue;
                const double e[3] = {c.box.hi[0] - c.box.lo[0], c.box.hi[1] - c.box.lo[1], c.box.hi[2] - c.box.lo[2]};
                const double area = e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
                if (area > best) best = area, pick = i;
            }
            if (pick < 0) break;
            const uint32_t first = nodes_[slot[pick]].first, from = slab[pick];
            for (int i = n; i > pick + 1; --i) slot[i] = slot[i - 1], slab[i] = slab[i - 1];
            slot[pick] = first, slot[pick + 1] = first + 1;
            slab[pick] = has_slab(first) ? first : from, slab[pick + 1] = has_slab(first + 1) ? first + 1 : from;
            ++n;
        }
        for (int i = 0; i < n; ++i) {
            set_slot(w, i, slot[i], slab[i]);
            const Node& c = nodes_[slot[i]];
            if (c.count > 0) {
                wide_[w].child[i] = add_leaf_block(c), wide_[w].count[i] = c.count;
                continue;
            }
            const uint32_t child = uint32_t(wide_.size());
            wide_.emplace_back();
            wide_[w].child[i] = child, wide_[w].count[i] = 0;
            widen_node(child, slot[i]);
        }
    }

    // for_near_wide's leaf: near_in_leaf over leaf block `block` (its boxes side by side, leaf_boxes_), the same
    // slots met in the same order: the four distances are Box3::squared_distance's, bit for bit, when not NaN
    // (a NaN one lets f decide, where near_in_leaf skips the slot). They are computed at once and the slots
    // within reach taken from a bit mask, instead of a branch per slot and per axis (Box3::squared_distance's
    // clamps to 0 compiled as branches); a slot is tested against r2 again in case f lowered it.
    template <class F>
    bool near_in_block(uint32_t block, const double* p, double& r2, F& f) const {
        const LeafBoxes& b = leaf_boxes_[block];
        double d[4];
        const uint32_t first = leaf_first_[block];
        for (unsigned m = lanes_within(b.lo, b.hi, p, r2, d); m != 0; m &= m - 1) {
            const uint32_t i = uint32_t(__builtin_ctz(m));
            if (!(d[i] < r2)) continue; // r2 lowered by f since the mask was taken
            const uint32_t j = first + i;
            if constexpr (std::is_invocable_v<F&, uint32_t, double&, uint32_t>) {
                if (f(prims_[j], r2, j)) return true;
            } else if (f(prims_[j], r2)) {
                return true;
            }
        }
        return false;
    }

    // A packet's balls side by side (for_near_packet): centres, squared reaches, slab allowances.
    struct alignas(64) PacketBalls {
        double x[kPacket] = {}, y[kPacket] = {}, z[kPacket] = {}, r2[kPacket] = {}, err[kPacket] = {};
    };
    // within[i]: the balls of m (bits) whose squared distance to box i of four side by side is below their
    // reach, as lanes_within decides it for each ball.
    static void packet_within(const double (&lo)[3][4], const double (&hi)[3][4], const PacketBalls& P, unsigned m, unsigned* within) {
        within[0] = within[1] = within[2] = within[3] = 0;
        for (; m != 0; m &= m - 1) {
            const int k = __builtin_ctz(m);
            const double p[3] = {P.x[k], P.y[k], P.z[k]};
            double d[4];
            for (unsigned s = lanes_within(lo, hi, p, P.r2[k], d); s != 0; s &= s - 1) within[__builtin_ctz(s)] |= 1u << k;
        }
    }
    // The balls of m that slot i's slab of w puts out of reach (out_of_reach with each ball's allowance).
    static unsigned packet_out_of_reach(const Wide& w, int i, const PacketBalls& P, unsigned m) {
        const double sn[3] = {w.sn[0][i], w.sn[1][i], w.sn[2][i]};
        unsigned out = 0;
        for (; m != 0; m &= m - 1) {
            const int k = __builtin_ctz(m);
            const double p[3] = {P.x[k], P.y[k], P.z[k]};
            if (out_of_reach(sn, w.slo[i], w.shi[i], p, P.err[k], P.r2[k])) out |= 1u << k;
        }
        return out;
    }
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    static int packet_lanes() {
        static const int lanes = __builtin_cpu_supports("avx512f") ? 8 : __builtin_cpu_supports("avx2") ? 4 : 1;
        return lanes;
    }
    // packet_within, all eight balls in one AVX-512 register a coordinate: lanes_within's operations in each
    // lane, in the same order (no fused multiply-add: -ffp-contract=off), so the same bits.
    __attribute__((target("avx512f"))) static void packet_within8(const double (&lo)[3][4], const double (&hi)[3][4], const PacketBalls& P,
                                                                  unsigned m, unsigned* within) {
        within[0] = within[1] = within[2] = within[3] = 0;
        const __m512d zero = _mm512_setzero_pd();
        for (int g = 0; g < kPacket; g += 8) {
            if (((m >> g) & 0xffu) == 0) continue;
            const __m512d p[3] = {_mm512_load_pd(P.x + g), _mm512_load_pd(P.y + g), _mm512_load_pd(P.z + g)};
            const __m512d r2 = _mm512_load_pd(P.r2 + g);
            for (int i = 0; i < 4; ++i) {
                __m512d dv = zero;
                for (int k = 0; k < 3; ++k) {
                    const __m512d a = _mm512_sub_pd(_mm512_set1_pd(lo[k][i]), p[k]), b = _mm512_sub_pd(p[k], _mm512_set1_pd(hi[k][i]));
                    __m512d e = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(a, b, _CMP_GT_OQ), b, a); // a > b ? a : b
                    e = _mm512_maskz_mov_pd(_mm512_cmp_pd_mask(e, zero, _CMP_GT_OQ), e);        // e > 0 ? e : 0
                    dv = _mm512_add_pd(dv, _mm512_mul_pd(e, e));
                }
                within[i] |= (unsigned(_mm512_cmp_pd_mask(dv, r2, _CMP_LT_OQ)) << g) & m;
            }
        }
    }
    // packet_out_of_reach in AVX-512 lanes: out_of_reach's operations in each lane, in the same order.
    __attribute__((target("avx512f"))) static unsigned packet_out_of_reach8(const Wide& w, int i, const PacketBalls& P, unsigned m) {
        unsigned out = 0;
        for (int g = 0; g < kPacket; g += 8) {
            if (((m >> g) & 0xffu) == 0) continue;
            const __m512d d = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(_mm512_set1_pd(w.sn[0][i]), _mm512_load_pd(P.x + g)),
                                                          _mm512_mul_pd(_mm512_set1_pd(w.sn[1][i]), _mm512_load_pd(P.y + g))),
                                            _mm512_mul_pd(_mm512_set1_pd(w.sn[2][i]), _mm512_load_pd(P.z + g)));
            const __m512d above = _mm512_sub_pd(d, _mm512_set1_pd(w.shi[i])), below = _mm512_sub_pd(_mm512_set1_pd(w.slo[i]), d);
            __m512d gap = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(above, below, _CMP_LT_OQ), above, below); // std::max(above, below)
            gap = _mm512_sub_pd(gap, _mm512_load_pd(P.err + g));
            const __m512d far = _mm512_mul_pd(_mm512_mul_pd(gap, gap), _mm512_set1_pd(1 - 1e-6));
            out |= unsigned(_mm512_cmp_pd_mask(gap, _mm512_setzero_pd(), _CMP_GT_OQ) & _mm512_cmp_pd_mask(far, _mm512_load_pd(P.r2 + g), _CMP_GE_OQ)) << g;
        }
        return out & m;
    }
    // The same two tests on AVX2, four balls a register (two registers a packet): the same operations per lane.
    __attribute__((target("avx2"))) static void packet_within4(const double (&lo)[3][4], const double (&hi)[3][4], const PacketBalls& P,
                                                               unsigned m, unsigned* within) {
        within[0] = within[1] = within[2] = within[3] = 0;
        const __m256d zero = _mm256_setzero_pd();
        for (int g = 0; g < kPacket; g += 4) {
            if (((m >> g) & 0xfu) == 0) continue;
            const __m256d p[3] = {_mm256_load_pd(P.x + g), _mm256_load_pd(P.y + g), _mm256_load_pd(P.z + g)};
            const __m256d r2 = _mm256_load_pd(P.r2 + g);
            for (int i = 0; i < 4; ++i) {
                __m256d dv = zero;
                for (int k = 0; k < 3; ++k) {
                    const __m256d a = _mm256_sub_pd(_mm256_set1_pd(lo[k][i]), p[k]), b = _mm256_sub_pd(p[k], _mm256_set1_pd(hi[k][i]));
                    __m256d e = _mm256_blendv_pd(b, a, _mm256_cmp_pd(a, b, _CMP_GT_OQ)); // a > b ? a : b
                    e = _mm256_and_pd(e, _mm256_cmp_pd(e, zero, _CMP_GT_OQ));          // e > 0 ? e : 0
                    dv = _mm256_add_pd(dv, _mm256_mul_pd(e, e));
                }
                within[i] |= (unsigned(_mm256_movemask_pd(_mm256_cmp_pd(dv, r2, _CMP_LT_OQ))) << g) & m;
            }
        }
    }
    __attribute__((target("avx2"))) static unsigned packet_out_of_reach4(const Wide& w, int i, const PacketBalls& P, unsigned m) {
        unsigned out = 0;
        for (int g = 0; g < kPacket; g += 4) {
            if (((m >> g) & 0xfu) == 0) continue;
            const __m256d d = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(w.sn[0][i]), _mm256_load_pd(P.x + g)),
                                                          _mm256_mul_pd(_mm256_set1_pd(w.sn[1][i]), _mm256_load_pd(P.y + g))),
                                            _mm256_mul_pd(_mm256_set1_pd(w.sn[2][i]), _mm256_load_pd(P.z + g)));
            const __m256d above = _mm256_sub_pd(d, _mm256_set1_pd(w.shi[i])), below = _mm256_sub_pd(_mm256_set1_pd(w.slo[i]), d);
            __m256d gap = _mm256_blendv_pd(above, below, _mm256_cmp_pd(above, below, _CMP_LT_OQ)); // std::max(above, below)
            gap = _mm256_sub_pd(gap, _mm256_load_pd(P.err + g));
            const __m256d far = _mm256_mul_pd(_mm256_mul_pd(gap, gap), _mm256_set1_pd(1 - 1e-6));
            const __m256d hit = _mm256_and_pd(_mm256_cmp_pd(gap, _mm256_setzero_pd(), _CMP_GT_OQ), _mm256_cmp_pd(far, _mm256_load_pd(P.r2 + g), _CMP_GE_OQ));
            out |= unsigned(_mm256_movemask_pd(hit)) << g;
        }
        return out & m;
    }
#else
    static int packet_lanes() { return 1; }
    static void packet_within8(const double (&lo)[3][4], const double (&hi)[3][4], const PacketBalls& P, unsigned m, unsigned* within) {
        packet_within(lo, hi, P, m, within);
    }
    static unsigned packet_out_of_reach8(const Wide& w, int i, const PacketBalls& P, unsigned m) { return packet_out_of_reach(w, i, P, m); }
    static void packet_within4(const double (&lo)[3][4], const double (&hi)[3][4], const PacketBalls& P, unsigned m, unsigned* within) {
        packet_within(lo, hi, P, m, within);
    }
    static unsigned packet_out_of_reach4(const Wide& w, int i, const PacketBalls& P, unsigned m) { return packet_out_of_reach(w, i, P, m); }
#endif

    typedef double V2 __attribute__((vector_size(16)));
    // Bits h and h + 1 set where the two-lane comparison c (all ones where true) holds.
    template <class M>
    static unsigned lane_bits(M c, int h) {
#if defined(__SSE2__)
        return unsigned(__builtin_ia32_movmskpd((V2)c)) << h;
#else
        return unsigned(c[0] & 1) << h | unsigned(c[1] & 1) << (h + 1);
#endif
    }
    // Four boxes side by side (lo[k][i], hi[k][i] for box i): d[i] their squared distances to p, two lanes at a
    // time (GCC/Clang vector extension: one SSE2 operation for two boxes), and bit i set where d[i] < r2. A
    // NaN distance counts as 0 (within reach): the caller's exact test decides. The same operations as
    // Box3::squared_distance otherwise (a sign of zero aside, which squaring drops).
    static unsigned lanes_within(const double (&lo)[3][4], const double (&hi)[3][4], const double* p, double r2, double* d) {
        unsigned m = 0;
        for (int h = 0; h < 4; h += 2) {
            V2 dv = {0, 0};
            for (int k = 0; k < 3; ++k) {
                V2 l, u;
                std::memcpy(&l, &lo[k][h], sizeof l);
                std::memcpy(&u, &hi[k][h], sizeof u);
                const V2 a = l - p[k], b = p[k] - u;
                V2 e = a > b ? a : b;
                e = e > 0.0 ? e : V2{0, 0};
                dv += e * e;
            }
            std::memcpy(&d[h], &dv, sizeof dv);
            m |= lane_bits(dv < r2, h);
        }
        return m;
    }
    // A leaf's boxes side by side for the paired descent, in float: four boxes in 96 bytes (two cache lines
    // where the double blocks took three), each box of a leaf tested against another leaf's four in one 4-lane
    // comparison per side. Rounding to nearest is monotone, so lo <= hi in double gives lo <= hi in float: no
    // overlapping pair is lost (a NaN stays NaN and overlaps nothing); a pair that misses by less than the
    // rounding may be met too, and the caller's exact tests reject it (the same output bytes). Bunny (`bench
    // shells`, -j 1, stage timers, three interleaved runs): the crossing test's self-descent 11.7-12.1 -> 9.9-10.6
    // ms, refit 3.0-3.2 -> 2.4-2.5 ms (half the bytes to write).
    struct alignas(32) PairBlock {
        float lo[3][4] = {{HUGE_VALF, HUGE_VALF, HUGE_VALF, HUGE_VALF}, {HUGE_VALF, HUGE_VALF, HUGE_VALF, HUGE_VALF}, {HUGE_VALF, HUGE_VALF, HUGE_VALF, HUGE_VALF}};
        float hi[3][4] = {{-HUGE_VALF, -HUGE_VALF, -HUGE_VALF, -HUGE_VALF}, {-HUGE_VALF, -HUGE_VALF, -HUGE_VALF, -HUGE_VALF}, {-HUGE_VALF, -HUGE_VALF, -HUGE_VALF, -HUGE_VALF}};
    };
    // Binary leaf node c's boxes as a pair block.
    PairBlock pair_block(const Node& c) const {
        PairBlock b;
        for (uint32_t i = 0; i < c.count; ++i)
            for (int k = 0; k < 3; ++k) b.lo[k][i] = float(boxes_[c.first + i].lo[k]), b.hi[k][i] = float(boxes_[c.first + i].hi[k]);
        return b;
    }
    // A pair of leaves a (this tree's, boxes in block A) and b (other's, block B): leaf(...) for each pair of their
    // primitives whose boxes overlap, in the scalar loop's order (i, then j; j > i within one leaf), each box of
    // a tested against b's four at once: every pair whose double boxes overlap, and those that miss by less
    // than the float rounding (PairBlock), which the caller's exact tests reject.
    // Bunny (`bench shells`, -j 1): the crossing test's self-descent tests 1.34 M box pairs in 123 k leaf pairs,
    // whose branches the scalar loop mispredicted; `furrow -j 1 shells --length 0.005`, stage timers, three
    // interleaved runs: self-descent 19.8-20.9 -> 16.6-17.4 ms, for 0.7-1.1 ms more in refit (the blocks).
    template <class Leaf>
    void leaf_pair(const PairBlock& A, const Node& a, const PairBlock& B, const Node& b, const BoxBvh& other, bool same, Leaf& leaf) const {
        for (uint32_t i = 0; i < a.count; ++i) {
            unsigned m = overlap_mask(A, int(i), B);
            if (same) m &= ~((2u << i) - 1); // j > i
            for (; m != 0; m &= m - 1) {
                const uint32_t j = uint32_t(__builtin_ctz(m));
                leaf(prims_[a.first + i], other.prims_[b.first + j], a.first + i, b.first + j);
            }
        }
    }
    // Bit j set where box i of block A overlaps box j of block B (the four at once).
    static unsigned overlap_mask(const PairBlock& A, int i, const PairBlock& B) {
        V4 lo[3], hi[3];
        for (int k = 0; k < 3; ++k) std::memcpy(&lo[k], B.lo[k], sizeof(V4)), std::memcpy(&hi[k], B.hi[k], sizeof(V4));
        const auto c = (A.lo[0][i] <= hi[0]) & (lo[0] <= A.hi[0][i]) & (A.lo[1][i] <= hi[1]) & (lo[1] <= A.hi[1][i]) &
                       (A.lo[2][i] <= hi[2]) & (lo[2] <= A.hi[2][i]);
#if defined(__SSE2__)
        return unsigned(__builtin_ia32_movmskps((V4)c));
#else
        return unsigned(c[0] & 1) | unsigned(c[1] & 1) << 1 | unsigned(c[2] & 1) << 2 | unsigned(c[3] & 1) << 3;
#endif
    }

    struct Slab {
        double n[3], lo, hi;
    };
    std::vector<Node> nodes_;
    std::vector<Slab> slabs_;     // per node, or none (add_slabs)
    std::vector<Wide> wide_;      // the 4-wide nodes, or none (widen)
    std::vector<LeafBoxes> leaf_boxes_; // the wide nodes' leaves: their boxes (widen)
    std::vector<uint32_t> leaf_first_;  // and where their primitives start in prims_/boxes_
    std::vector<PairBlock> pair_blocks_; // every leaf's boxes side by side, in float (refit; the paired descent)
    std::vector<uint32_t> block_of_node_; // a leaf node's block in pair_blocks_
    double margin_ = 0;           // the boxes' growth at the build
    std::vector<uint32_t> prims_; // primitive ids in leaf order
    std::vector<Box3> boxes_;     // their grown boxes, same order
};

} // namespace furrow::shells_detail

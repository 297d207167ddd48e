// BoxBvh's build (triangle_bvh.h): binned SAH splits down to kSahDepth, median splits below, subtrees over
// kTaskKeys boxes built in parallel and numbered as one thread numbers them. Out of the header so that the
// translation units that include the hierarchy for its (templated) descents do not carry the build: in
// feature_distance.cpp the build's code had pushed GCC's inliner past its unit-growth limit, and the point-
// triangle distance stopped being inlined into witness_takes (callgrind, bunny: +3.5 M instructions).
#include "triangle_bvh.h"

#include <furrow_kernel/threads.h>

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>

namespace furrow::shells_detail {

void BoxBvh::build(std::vector<Box3> boxes) {
    nodes_.clear();
    prims_.clear();
    double reach = 0;
    Box3 all;
    for (size_t i = 0; i < boxes.size(); ++i) {
        if (!(boxes[i].lo[0] <= boxes[i].hi[0])) continue; // empty, or NaN corners
        prims_.push_back(uint32_t(i));
        all.add(boxes[i]);
    }
    if (prims_.empty()) {
        boxes_.clear();
        return;
    }
    for (int k = 0; k < 3; ++k) reach = std::max({reach, all.hi[k] - all.lo[k], std::abs(all.lo[k]), std::abs(all.hi[k])});
    const double margin = 1e-9 * reach + 1e-300;
    margin_ = margin;
    slabs_.clear();
    wide_.clear();
    leaf_boxes_.clear();
    leaf_first_.clear();
    pair_blocks_.clear();
    // Boxes in leaf order, grown by the margin, so that a leaf reads them contiguously.
    std::vector<Keyed> keyed(prims_.size());
    for (size_t j = 0; j < prims_.size(); ++j) keyed[j] = Keyed::of(boxes[prims_[j]], prims_[j]);
    nodes_.reserve(2 * (prims_.size() / kLeaf + 1));
    nodes_.emplace_back();
    const KeyBox all_centres = centres_of(keyed, 0, uint32_t(keyed.size()));
    if (prims_.size() > kTaskKeys && !kernel::one_thread()) {
        Part whole;
        build_part(whole, 0, uint32_t(keyed.size()), boxes, keyed, all_centres, 0);
        place(whole, 0, 0);
    } else {
        build_node(nodes_, 0, 0, uint32_t(prims_.size()), boxes, keyed, all_centres);
    }
    for (size_t j = 0; j < prims_.size(); ++j) prims_[j] = keyed[j].id;
    boxes_.resize(prims_.size());
    for (size_t j = 0; j < prims_.size(); ++j) {
        boxes_[j] = boxes[prims_[j]];
        for (int k = 0; k < 3; ++k) boxes_[j].lo[k] -= margin, boxes_[j].hi[k] += margin;
    }
    for (Node& n : nodes_)
        for (int k = 0; k < 3; ++k) n.box.lo[k] -= margin, n.box.hi[k] += margin;
}

bool BoxBvh::sah_split(uint32_t begin, uint32_t end, int axis, const KeyBox& centres, std::vector<Keyed>& keyed, uint32_t& mid,
                       KeyBox& left_centres, KeyBox& right_centres) const {
    const float lo = centres.lo[axis], extent = centres.hi[axis] - lo;
    const float scale = kBins / extent;
    if (!(extent > 0) || !std::isfinite(scale)) return false;
    KeyBox bin_box[kBins], bin_centres[kBins];
    uint32_t bin_n[kBins] = {};
    for (uint32_t j = begin; j < end; ++j) {
        Keyed& k = keyed[j];
        const V4 l = lo_of(k), h = hi_of(k), c = l + h;
        // c[axis] >= lo (lo is the least of them), so f >= 0; f may round to kBins at the far end.
        const int b = std::min(int((c[axis] - lo) * scale), kBins - 1);
        k.bin = uint32_t(b);
        ++bin_n[b];
        bin_box[b].add(l, h);
        bin_centres[b].add(c, c);
    }
    double right_area[kBins];
    uint32_t right_n[kBins];
    KeyBox acc;
    uint32_t n = 0;
    for (int b = kBins - 1; b > 0; --b) {
        acc.add(bin_box[b].lo, bin_box[b].hi), n += bin_n[b];
        right_area[b] = n ? acc.half_area() : 0, right_n[b] = n;
    }
    double best = HUGE_VAL;
    int best_bin = -1;
    acc = KeyBox{}, n = 0;
    for (int b = 0; b + 1 < kBins; ++b) {
        acc.add(bin_box[b].lo, bin_box[b].hi), n += bin_n[b];
        if (n == 0 || right_n[b + 1] == 0) continue;
        const double cost = acc.half_area() * n + right_area[b + 1] * right_n[b + 1];
        if (cost < best) best = cost, best_bin = b;
    }
    if (best_bin < 0) return false; // one bin holds them all, or costs that overflow
    for (int b = 0; b < kBins; ++b) (b <= best_bin ? left_centres : right_centres).add(bin_centres[b].lo, bin_centres[b].hi);
    mid = uint32_t(std::partition(keyed.begin() + begin, keyed.begin() + end, [&](const Keyed& k) { return k.bin <= uint32_t(best_bin); }) -
                   keyed.begin());
    return true;
}

BoxBvh::KeyBox BoxBvh::centres_of(const std::vector<Keyed>& keyed, uint32_t begin, uint32_t end) {
    KeyBox centres;
    for (uint32_t j = begin; j < end; ++j) {
        const V4 c = lo_of(keyed[j]) + hi_of(keyed[j]); // (the fourth lane: not read)
        centres.add(c, c);
    }
    return centres;
}

void BoxBvh::split(uint32_t begin, uint32_t end, std::vector<Keyed>& keyed, const KeyBox& centres, int depth, uint32_t& mid,
                   KeyBox& left_centres, KeyBox& right_centres) const {
    int axis = 0;
    for (int k = 1; k < 3; ++k)
        if (centres.hi[k] - centres.lo[k] > centres.hi[axis] - centres.lo[axis]) axis = k;
    if (!(depth < kSahDepth && sah_split(begin, end, axis, centres, keyed, mid, left_centres, right_centres))) {
        mid = begin + (end - begin) / 2;
        // Ties broken by primitive index: the split, hence the tree, depends on nothing but the input.
        std::nth_element(keyed.begin() + begin, keyed.begin() + mid, keyed.begin() + end, [axis](const Keyed& a, const Keyed& b) {
            const float ca = a.centre2(axis), cb = b.centre2(axis);
            return ca < cb || (ca == cb && a.id < b.id);
        });
        left_centres = centres_of(keyed, begin, mid);
        right_centres = centres_of(keyed, mid, end);
    }
}

void BoxBvh::build_node(std::vector<Node>& nodes, uint32_t node, uint32_t begin, uint32_t end, const std::vector<Box3>& boxes,
                        std::vector<Keyed>& keyed, const KeyBox& centres, int depth) const {
    if (end - begin <= kLeaf) {
        Box3 box;
        for (uint32_t j = begin; j < end; ++j) box.add(boxes[keyed[j].id]);
        nodes[node].box = box;
        nodes[node].first = begin;
        nodes[node].count = end - begin;
        return;
    }
    uint32_t mid = 0;
    KeyBox left_centres, right_centres;
    split(begin, end, keyed, centres, depth, mid, left_centres, right_centres);
    const uint32_t left = uint32_t(nodes.size());
    nodes.emplace_back();
    nodes.emplace_back();
    nodes[node].first = left;
    nodes[node].count = 0;
    build_node(nodes, left, begin, mid, boxes, keyed, left_centres, depth + 1);
    build_node(nodes, left + 1, mid, end, boxes, keyed, right_centres, depth + 1);
    join_boxes(nodes[node], nodes[left], nodes[left + 1]);
}

void BoxBvh::build_part(Part& part, uint32_t begin, uint32_t end, const std::vector<Box3>& boxes, std::vector<Keyed>& keyed,
                        const KeyBox& centres, int depth) const {
    part.nodes.emplace_back();
    if (end - begin <= kTaskKeys) {
        part.nodes.reserve(2 * ((end - begin) / kLeaf + 1));
        build_node(part.nodes, 0, begin, end, boxes, keyed, centres, depth);
        return;
    }
    uint32_t mid = 0;
    KeyBox left_centres, right_centres;
    split(begin, end, keyed, centres, depth, mid, left_centres, right_centres);
    part.kid[0] = std::make_unique<Part>(), part.kid[1] = std::make_unique<Part>();
    tbb::parallel_invoke([&] { build_part(*part.kid[0], begin, mid, boxes, keyed, left_centres, depth + 1); },
                         [&] { build_part(*part.kid[1], mid, end, boxes, keyed, right_centres, depth + 1); });
}

void BoxBvh::place(const Part& part, uint32_t i, uint32_t at) {
    const Node& n = part.nodes[i];
    if (!part.kid[0] && n.count > 0) {
        nodes_[at] = n;
        return;
    }
    const uint32_t left = uint32_t(nodes_.size());
    nodes_.emplace_back();
    nodes_.emplace_back();
    if (part.kid[0]) place(*part.kid[0], 0, left), place(*part.kid[1], 0, left + 1);
    else place(part, n.first, left), place(part, n.first + 1, left + 1);
    nodes_[at].first = left;
    nodes_[at].count = 0;
    join_boxes(nodes_[at], nodes_[left], nodes_[left + 1]);
}

} // namespace furrow::shells_detail

// Polygon triangulation for every path that turns n-gons into triangles (glTF output, the rasterizer, shells,
// stamping): ear clipping in the polygon's best-fit plane that never creates an edge the mesh already has.
//
// References:
//   D. Eberly, "Triangulation by Ear Clipping" (Geometric Tools, 2002–2015): an ear is a convex corner whose
//     triangle holds no other corner of the polygon; every simple polygon has two (G. Meisters, "Polygons
//     have ears", 1975), so clipping ears one at a time triangulates it.
//   M. Newell's normal (Sutherland, Sproull, Schumacker, 1974): the area vector of a non-planar polygon, the
//     normal of its best-fit plane, robust where three corners would pick a bad plane.
//
// Why each step:
//   - a fan from corner 0 is only right for convex, planar polygons: on a non-convex one it makes triangles
//     outside the polygon, folded over its neighbours;
//   - a diagonal that is already an edge of the mesh (two faces sharing two corners that are not neighbours
//     in one of them) becomes an edge with three or more faces: the non-manifold edges a fan made of
//     beast.obj. Edges are compared by welded position, because split copies of one position (UV seams) are
//     one edge in space;
//   - the scan starts at corner 1 and resumes after each clipped ear, so a convex polygon with no conflicting
//     diagonal gets exactly the fan it always got (outputs that were right stay byte-identical);
//   - when no corner passes every test (a self-overlapping, degenerate or non-simple polygon), the tests are
//     relaxed one at a time, the edge test last: the result is always s − 2 triangles over the corners;
//   - ear clipping costs O(s²) per polygon; a polygon of more than kMaxEarClipCorners corners (a fuzzer's, not
//     a modeller's) is fanned, so the cost stays bounded.
#include <furrow/mesh.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <bit>
#include <vector>

namespace furrow {
namespace {

constexpr uint32_t kMaxEarClipCorners = 1024;

using P2 = std::array<double, 2>;

double cross2(const P2& a, const P2& b, const P2& c) {
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

// p inside the triangle abc (counter-clockwise) or on its boundary.
bool in_triangle(const P2& p, const P2& a, const P2& b, const P2& c) {
    return cross2(a, b, p) >= 0 && cross2(b, c, p) >= 0 && cross2(c, a, p) >= 0;
}

uint64_t edge_key(uint32_t a, uint32_t b) {
    if (a > b) std::swap(a, b);
    return (uint64_t(a) << 32) | b;
}

// The welded edges made so far, in one open-addressed table (linear probing, Fibonacci hashing): a node per
// edge in std::unordered_set made triangulation a quarter of a `furrow convert` of a quad mesh.
class EdgeSet {
public:
    explicit EdgeSet(size_t expected = 0) {
        size_t capacity = 16;
        while (capacity < 2 * expected) capacity *= 2;
        slots_.assign(capacity, kEmpty);
        shift_ = 64 - std::countr_zero(capacity);
    }
    bool contains(uint64_t key) const {
        for (size_t i = slot(key);; i = (i + 1) & (slots_.size() - 1)) {
            if (slots_[i] == key) return true;
            if (slots_[i] == kEmpty) return false;
        }
    }
    void insert(uint64_t key) {
        if (2 * (count_ + 1) > slots_.size()) grow();
        size_t i = slot(key);
        for (; slots_[i] != kEmpty; i = (i + 1) & (slots_.size() - 1))
            if (slots_[i] == key) return;
        slots_[i] = key;
        ++count_;
    }

private:
    static constexpr uint64_t kEmpty = ~uint64_t(0); // no edge: welded ids are below 2^32 − 1
    size_t slot(uint64_t key) const { return size_t((key * 0x9E3779B97F4A7C15ull) >> shift_); }
    void grow() {
        std::vector<uint64_t> old = std::move(slots_);
        slots_.assign(2 * old.size(), kEmpty);
        --shift_;
        count_ = 0;
        for (uint64_t k : old)
            if (k != kEmpty) insert(k);
    }
    std::vector<uint64_t> slots_;
    int shift_ = 60;
    size_t count_ = 0;
};

struct Context {
    const float* positions;
    std::vector<uint32_t> weld; // vertex -> first vertex at the same position
    EdgeSet edges;              // every polygon edge and every diagonal made so far, welded
    std::vector<uint32_t> prev, next; // clip_ears' corner lists, kept from polygon to polygon
};

// The polygon's corners in its best-fit plane (Newell's normal); false when the polygon has no area.
bool project(std::vector<P2>& out, const Context& cx, const uint32_t* corners, uint32_t s) {
    double n[3] = {0, 0, 0};
    for (uint32_t i = 0; i < s; ++i) {
        const float* a = &cx.positions[3 * size_t(corners[i])];
        const float* b = &cx.positions[3 * size_t(corners[(i + 1) % s])];
        n[0] += (double(a[1]) - b[1]) * (double(a[2]) + b[2]);
        n[1] += (double(a[2]) - b[2]) * (double(a[0]) + b[0]);
        n[2] += (double(a[0]) - b[0]) * (double(a[1]) + b[1]);
    }
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0) || !std::isfinite(len)) return false;
    for (double& c : n) c /= len;
    // u ⟂ n from the axis least aligned with n; v = n × u, so (u, v, n) is right-handed and a counter-clockwise
    // polygon (seen from n) stays counter-clockwise in (u, v).
    const int k = std::abs(n[0]) < std::abs(n[1]) ? (std::abs(n[0]) < std::abs(n[2]) ? 0 : 2) : (std::abs(n[1]) < std::abs(n[2]) ? 1 : 2);
    double axis[3] = {0, 0, 0};
    axis[k] = 1;
    double u[3] = {axis[1] * n[2] - axis[2] * n[1], axis[2] * n[0] - axis[0] * n[2], axis[0] * n[1] - axis[1] * n[0]};
    const double ul = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (double& c : u) c /= ul;
    const double v[3] = {n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]};
    out.resize(s);
    for (uint32_t i = 0; i < s; ++i) {
        const float* p = &cx.positions[3 * size_t(corners[i])];
        out[i] = {u[0] * p[0] + u[1] * p[1] + u[2] * p[2], v[0] * p[0] + v[1] * p[1] + v[2] * p[2]};
    }
    return true;
}

// Ear clipping of one polygon (s >= 4) into out; level 0 asks convexity, emptiness and a new diagonal,
// level 1 drops emptiness, level 2 drops convexity, level 3 takes any corner.
void clip_ears(std::vector<uint32_t>& out, Context& cx, const uint32_t* corners, uint32_t s, const std::vector<P2>& p) {
    std::vector<uint32_t>&prev = cx.prev, &next = cx.next;
    prev.resize(s), next.resize(s);
    for (uint32_t i = 0; i < s; ++i) prev[i] = (i + s - 1) % s, next[i] = (i + 1) % s;
    auto welded = [&](uint32_t i) { return cx.weld[corners[i]]; };
    auto is_ear = [&](uint32_t i, int level) {
        const uint32_t a = prev[i], c = next[i];
        if (level < 3 && cx.edges.contains(edge_key(welded(a), welded(c)))) return false;
        if (level < 3 && welded(a) == welded(c)) return false;
        if (level < 2 && !(cross2(p[a], p[i], p[c]) > 0)) return false;
        if (level < 1)
            for (uint32_t j = next[c]; j != a; j = next[j])
                if (p[j] != p[a] && p[j] != p[i] && p[j] != p[c] && in_triangle(p[j], p[a], p[i], p[c])) return false;
        return true;
    };
    uint32_t at = 1 % s, left = s;
    while (left > 3) {
        uint32_t ear = UINT32_MAX;
        for (int level = 0; level < 4 && ear == UINT32_MAX; ++level) {
            uint32_t i = at;
            for (uint32_t tried = 0; tried < left; ++tried, i = next[i])
                if (is_ear(i, level)) {
                    ear = i;
                    break;
                }
        }
        const uint32_t a = prev[ear], c = next[ear];
        out.insert(out.end(), {corners[a], corners[ear], corners[c]});
        cx.edges.insert(edge_key(welded(a), welded(c)));
        next[a] = c, prev[c] = a;
        at = c;
        --left;
    }
    const uint32_t a = prev[at], c = next[at];
    out.insert(out.end(), {corners[a], corners[at], corners[c]});
}

void fan(std::vector<uint32_t>& out, const uint32_t* corners, uint32_t s) {
    for (uint32_t k = 1; k + 1 < s; ++k) out.insert(out.end(), {corners[0], corners[k], corners[k + 1]});
}

} // namespace

size_t triangulate_polygons(std::vector<uint32_t>& out, const uint32_t* indices, size_t index_count,
                            const uint32_t* face_sizes, size_t face_count, const float* positions, size_t vertex_count) {
    out.clear();
    Context cx{positions, std::vector<uint32_t>(vertex_count), EdgeSet(), {}, {}};
    bool polygons = false;
    for (size_t f = 0; f < face_count; ++f) polygons |= face_sizes[f] > 3;
    if (polygons) {
        cx.edges = EdgeSet(index_count / 2 + face_count); // a closed mesh's edges and a diagonal a face (it grows)
        weld_positions(cx.weld.data(), positions, vertex_count);
        size_t at = 0;
        for (size_t f = 0; f < face_count && face_sizes[f] <= index_count - at; at += face_sizes[f], ++f)
            for (uint32_t k = 0; k < face_sizes[f]; ++k) {
                const uint32_t a = indices[at + k], b = indices[at + (k + 1) % face_sizes[f]];
                if (a < vertex_count && b < vertex_count) cx.edges.insert(edge_key(cx.weld[a], cx.weld[b]));
            }
    }
    std::vector<P2> projected;
    size_t at = 0;
    for (size_t f = 0; f < face_count; ++f) {
        const uint32_t s = face_sizes[f];
        if (s > index_count - at) break; // face_sizes claims more corners than there are: stop, never overread
        const uint32_t* corners = indices + at;
        at += s;
        if (s < 3) continue; // no area
        bool in_range = true;
        for (uint32_t k = 0; k < s; ++k) in_range &= corners[k] < vertex_count;
        if (s == 3 || s > kMaxEarClipCorners || !in_range || !project(projected, cx, corners, s))
            fan(out, corners, s);
        else
            clip_ears(out, cx, corners, s, projected);
    }
    return out.size() / 3;
}

void triangulate(Primitive& p) {
    if (p.face_sizes.empty() || p.mode != PrimitiveMode::triangles) return;
    std::vector<uint32_t> tris;
    triangulate_polygons(tris, p.indices.data(), p.indices.size(), p.face_sizes.data(), p.face_sizes.size(),
                         p.positions.data(), p.vertex_count());
    p.indices = std::move(tris);
    p.face_sizes.clear();
}

} // namespace furrow

// Welding vertices by position.
//
// Exact mode maps every vertex to the lowest index with the same position bits (-0 folded into +0). It
// hashes first: vertices visited in index order, each looked up in an open-addressed table (linear probing,
// load <= 1/2) of the first index of every position seen, with a 32-bit fingerprint of the bits beside it so
// that a probe reads the positions only when the fingerprints agree. The result does not depend on the hash
// (the first index of a position is the first one visited), only the time does; input crafted to collide in
// the fixed hash is caught by a probe budget (16 a vertex), and then the sort below runs instead, O(n)
// whatever the input. On a 628 x 628 grid (394k distinct points, one thread, warm): 8.2-8.5 ms sorting,
// 4.8 ms hashing, 4.3-4.6 ms with each slot fetched 16 vertices ahead; a first call pays the page faults
// of its table (6.5-8.4 ms), as the sort pays its arrays' (11.7-12.0 ms).
// The sort: (bit patterns of the coordinates, index) records, so identical positions become neighbours
// and every group maps to its lowest index. It is an LSD radix sort (Knuth, TAOCP vol. 3, §5.2.5) on the
// 96-bit key: stable, and the records start in index order, so it gives the (key, index) order of a
// comparison sort in O(n), in nine passes of 11 bits (a pass whose digit is the same in every record is
// skipped). It replaced tbb::parallel_sort: on a 473k-vertex grid (both versions in one program, same remap)
// 43 ms against 61 ms on two threads and 88 ms on one.
//
// Tolerance mode follows the usual uniform-grid approach (cells of side `tolerance`, neighbours searched in
// the 3×3×3 block around a point's cell; see e.g. Ericson, "Real-Time Collision Detection", 2005, §7.1).
// Vertices are visited in index order and join the lowest-index representative within the tolerance, which
// makes the result deterministic even though "within tolerance" is not transitive. A cell of side t holds
// only a bounded number of representatives that are pairwise farther apart than t, so each lookup is O(1)
// after the O(n log n) sort that numbers the cells.
//
// meshoptimizer's meshopt_generateVertexRemap, considered in this one's place, welds by hashing each
// vertex's bytes: it has no tolerance mode and keeps -0 and +0 apart, so it serves neither mode here. furrow
// uses meshoptimizer where its result is the one wanted: vertex cache and fetch order, simplification, the
// codec.
#include <furrow/mesh.h>

#include "weld_exact.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <numeric>
#include <utility>

#include <tbb/parallel_for.h>

namespace furrow {
namespace {

// -0 and +0 compare equal but have different bits; fold them so that mirrored modelling does not split.
uint32_t position_bits(float f) {
    if (f == 0.0f) f = 0.0f;
    uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return u;
}

// A position's bits and its index: sorted by key, in index order within equal keys.
struct Keyed {
    std::array<uint32_t, 3> key; // key[0] most significant
    uint32_t v;
};

// Stable LSD radix sort of `order` by key, 11 bits a pass from the least significant.
void radix_sort_by_key(std::vector<Keyed>& order) {
    constexpr int kBits = 11, kPasses = (96 + kBits - 1) / kBits;
    constexpr size_t kBuckets = size_t(1) << kBits;
    auto digit = [](const Keyed& r, int pass) -> size_t {
        const uint64_t lo = (uint64_t(r.key[1]) << 32) | r.key[2], hi = r.key[0];
        const int b = pass * kBits;
        const uint64_t bits = b >= 64 ? hi >> (b - 64) : b + kBits <= 64 ? lo >> b : (lo >> b) | (hi << (64 - b));
        return size_t(bits & (kBuckets - 1));
    };
    const size_t n = order.size();
    std::vector<uint32_t> count(size_t(kPasses) * kBuckets, 0); // every pass's histogram, from one read
    for (const Keyed& r : order)
        for (int pass = 0; pass < kPasses; ++pass) ++count[size_t(pass) * kBuckets + digit(r, pass)];
    std::vector<Keyed> other(n);
    for (int pass = 0; pass < kPasses; ++pass) {
        uint32_t* c = &count[size_t(pass) * kBuckets];
        if (std::find(c, c + kBuckets, uint32_t(n)) != c + kBuckets) continue; // one digit everywhere
        uint32_t start = 0;
        for (size_t d = 0; d < kBuckets; ++d) start += std::exchange(c[d], start);
        for (const Keyed& r : order) other[c[digit(r, pass)]++] = r;
        order.swap(other);
    }
}

using Cell = std::array<int64_t, 3>;

int64_t cell_coordinate(double x, double tolerance) {
    // Clamped so that neighbour offsets (±1) never overflow; clamped points merely share a crowded cell.
    constexpr double limit = 4611686018427387904.0; // 2^62
    double q = std::floor(x / tolerance);
    q = std::clamp(q, -limit, limit);
    return int64_t(q);
}

} // namespace

namespace mesh_detail {

bool weld_exact_hashed(uint32_t* remap, size_t& unique, const float* positions, size_t vertex_count, size_t stride_floats,
                       size_t probe_budget) {
    using Key = std::array<uint32_t, 3>;
    auto key_of = [&](size_t v) {
        const float* p = positions + v * stride_floats;
        return Key{position_bits(p[0]), position_bits(p[1]), position_bits(p[2])};
    };
    auto hash_of = [](const Key& k) { // 64-bit multiply-xorshift mix of the 96 bits
        uint64_t h = ((uint64_t(k[0]) << 32) | k[1]) * 0x9E3779B97F4A7C15ull ^ uint64_t(k[2]) * 0xC2B2AE3D27D4EB4Full;
        h ^= h >> 29, h *= 0xBF58476D1CE4E5B9ull, h ^= h >> 32;
        return h;
    };
    constexpr uint64_t kEmpty = ~uint64_t(0);
    const size_t slots = std::max<size_t>(16, std::bit_ceil(2 * vertex_count)), mask = slots - 1;
    std::vector<uint64_t> table(slots, kEmpty); // (fingerprint << 32) | first index
    size_t probes = 0;
    unique = 0;
    constexpr size_t kAhead = 16; // the slot of the vertex this far ahead is fetched early: each is a cache miss
    for (size_t v = 0; v < vertex_count; ++v) {
        if (v + kAhead < vertex_count) __builtin_prefetch(&table[size_t(hash_of(key_of(v + kAhead))) & mask]);
        const Key k = key_of(v);
        const uint64_t h = hash_of(k), print = h >> 32;
        for (size_t at = size_t(h) & mask;; at = (at + 1) & mask) {
            const uint64_t e = table[at];
            if (e == kEmpty) {
                table[at] = (print << 32) | v;
                remap[v] = uint32_t(v);
                ++unique;
                break;
            }
            if (e >> 32 == print && key_of(uint32_t(e)) == k) {
                remap[v] = uint32_t(e);
                break;
            }
            if (++probes > probe_budget) return false;
        }
    }
    return true;
}

size_t weld_exact_sorted(uint32_t* remap, const float* positions, size_t vertex_count, size_t stride_floats) {
    auto p = [&](size_t v) { return positions + v * stride_floats; };
    std::vector<Keyed> order(vertex_count);
    tbb::parallel_for(size_t(0), vertex_count, [&](size_t v) {
        order[v] = {{position_bits(p(v)[0]), position_bits(p(v)[1]), position_bits(p(v)[2])}, uint32_t(v)};
    });
    radix_sort_by_key(order);
    size_t unique = 0;
    for (size_t i = 0; i < vertex_count; ++i) {
        const uint32_t v = order[i].v;
        if (i == 0 || order[i].key != order[i - 1].key) {
            remap[v] = v; // lowest index of its group, thanks to the index tie-break
            ++unique;
        } else {
            remap[v] = remap[order[i - 1].v];
        }
    }
    return unique;
}

} // namespace mesh_detail

size_t weld_positions(uint32_t* remap, const float* positions, size_t vertex_count, size_t stride_floats,
                      double tolerance) {
    if (vertex_count == 0 || !remap || !positions) return 0;
    if (stride_floats < 3) stride_floats = 3;
    auto p = [&](size_t v) { return positions + v * stride_floats; };
    size_t unique = 0;
    if (vertex_count > UINT32_MAX ||
        !mesh_detail::weld_exact_hashed(remap, unique, positions, vertex_count, stride_floats, 16 * vertex_count))
        unique = mesh_detail::weld_exact_sorted(remap, positions, vertex_count, stride_floats);
    if (!(tolerance > 0.0) || !std::isfinite(tolerance)) return unique;

    // Tolerance pass over the exact representatives only: duplicates of one position need no search.
    // Non-finite positions have no distance to anything; they stay welded by bits only.
    std::vector<uint32_t> reps;
    reps.reserve(unique);
    for (uint32_t v = 0; v < vertex_count; ++v)
        if (remap[v] == v && std::isfinite(p(v)[0]) && std::isfinite(p(v)[1]) && std::isfinite(p(v)[2]))
            reps.push_back(v);

    std::vector<Cell> cell_of(reps.size());
    for (size_t i = 0; i < reps.size(); ++i)
        for (int k = 0; k < 3; ++k) cell_of[i][k] = cell_coordinate(double(p(reps[i])[k]), tolerance);
    std::vector<Cell> cells(cell_of);
    std::sort(cells.begin(), cells.end());
    cells.erase(std::unique(cells.begin(), cells.end()), cells.end());

    // Representatives found so far per cell; `reps` is in index order, so each list is too.
    std::vector<std::vector<uint32_t>> in_cell(cells.size());
    std::vector<uint32_t> target(vertex_count);
    std::iota(target.begin(), target.end(), 0u);
    const double tolerance2 = tolerance * tolerance;
    for (size_t i = 0; i < reps.size(); ++i) {
        const uint32_t v = reps[i];
        const float* pv = p(v);
        uint32_t best = v;
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                    Cell c{cell_of[i][0] + dx, cell_of[i][1] + dy, cell_of[i][2] + dz};
                    auto it = std::lower_bound(cells.begin(), cells.end(), c);
                    if (it == cells.end() || *it != c) continue;
                    for (uint32_t r : in_cell[size_t(it - cells.begin())]) {
                        if (r >= best) break;
                        const float* pr = p(r);
                        double d2 = 0;
                        for (int k = 0; k < 3; ++k) {
                            double d = double(pv[k]) - double(pr[k]);
                            d2 += d * d;
                        }
                        if (d2 <= tolerance2) best = r;
                    }
                }
        if (best == v) {
            auto it = std::lower_bound(cells.begin(), cells.end(), cell_of[i]);
            in_cell[size_t(it - cells.begin())].push_back(v);
        } else {
            target[v] = best;
            --unique;
        }
    }
    for (size_t v = 0; v < vertex_count; ++v) remap[v] = target[remap[v]];
    return unique;
}

} // namespace furrow

// Welding vertices by position.
//
// Exact mode sorts (bit patterns of the coordinates, index) records (a radix-free comparison sort, O(n log n),
// in parallel), so identical positions become neighbours and every group maps to its lowest index. Hashing
// would be O(n) on average but its worst case depends on the data, and sorting keeps the result independent
// of any hash seed or container order.
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

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

namespace furrow {
namespace {

// -0 and +0 compare equal but have different bits; fold them so that mirrored modelling does not split.
uint32_t position_bits(float f) {
    if (f == 0.0f) f = 0.0f;
    uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return u;
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

size_t weld_positions(uint32_t* remap, const float* positions, size_t vertex_count, size_t stride_floats,
                      double tolerance) {
    if (vertex_count == 0 || !remap || !positions) return 0;
    if (stride_floats < 3) stride_floats = 3;
    auto p = [&](size_t v) { return positions + v * stride_floats; };

    // (bits, index) records sorted in place: each comparison reads one contiguous record, and the order is
    // total (index tie-break), so the parallel sort gives the same sequence as a serial one.
    struct Keyed {
        std::array<uint32_t, 3> key;
        uint32_t v;
        bool operator<(const Keyed& o) const { return key != o.key ? key < o.key : v < o.v; }
    };
    std::vector<Keyed> order(vertex_count);
    tbb::parallel_for(size_t(0), vertex_count, [&](size_t v) {
        order[v] = {{position_bits(p(v)[0]), position_bits(p(v)[1]), position_bits(p(v)[2])}, uint32_t(v)};
    });
    tbb::parallel_sort(order.begin(), order.end());
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

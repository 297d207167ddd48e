// The exact weld's two ways (weld_positions.cpp), private to mesh and its tests: a hash table over the
// positions' bits, with the sort as its fallback. Both give weld_positions' remap (each position's lowest index).
#pragma once

#include <cstddef>
#include <cstdint>

namespace furrow::mesh_detail {

// Hashing, visiting vertices in index order; gives up (returns false, remap partly written) once the probes
// exceed `probe_budget` (crafted input that collides in the fixed hash). Writes `unique` on success.
bool weld_exact_hashed(uint32_t* remap, size_t& unique, const float* positions, size_t vertex_count, size_t stride_floats,
                       size_t probe_budget);
// Sorting (an LSD radix sort of the bits): O(n) whatever the input. Returns the unique count.
size_t weld_exact_sorted(uint32_t* remap, const float* positions, size_t vertex_count, size_t stride_floats);

} // namespace furrow::mesh_detail

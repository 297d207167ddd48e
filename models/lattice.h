// A generated non-manifold lattice of any size: every wall of a cells × cells × cells grid of unit cubes, one
// quad per wall, the quads sharing the grid's vertices. Inside the block every edge is shared by four quads
// (a non-manifold edge) and every quad faces walls on all four of its edges, 1 unit away: for fur, the
// intersection-heavy case (each wall's fur runs into its neighbours' at every edge, and the medial-axis,
// fold and crossing clamps all work everywhere). cells = 25 gives 3 × 26 × 25² = 48750 quads. Used by
// `furrow bench shells --lattice` and tests/shells (the shell set-up on a small lattice).
//
// Deterministic and exact: every coordinate is an integer; every quad faces +axis (its corners counter-clockwise
// seen from +axis).
#pragma once

#include <furrow/mesh.h>

#include <cstdint>

namespace furrow::models {

// Number of quads of the lattice with `cells` cells along each axis.
inline size_t lattice_quad_count(int cells) { return cells > 0 ? 3 * size_t(cells + 1) * size_t(cells) * size_t(cells) : 0; }

inline Primitive lattice_primitive(int cells) {
    Primitive p;
    if (cells <= 0) return p;
    const uint32_t n = uint32_t(cells) + 1; // grid points per axis
    p.positions.reserve(3 * size_t(n) * n * n);
    for (uint32_t k = 0; k < n; ++k)
        for (uint32_t j = 0; j < n; ++j)
            for (uint32_t i = 0; i < n; ++i) p.positions.insert(p.positions.end(), {float(i), float(j), float(k)});
    auto id = [n](uint32_t x[3]) { return x[0] + n * (x[1] + n * x[2]); };
    p.indices.reserve(4 * lattice_quad_count(cells));
    // A wall with normal along axis a at plane c, spanning cell (u, v) along the two other axes (b, d) with
    // (a, b, d) cyclic: corners (u, v), (u+1, v), (u+1, v+1), (u, v+1) turn counter-clockwise around +a.
    for (int a = 0; a < 3; ++a) {
        const int b = (a + 1) % 3, d = (a + 2) % 3;
        for (uint32_t c = 0; c < n; ++c)
            for (uint32_t v = 0; v + 1 < n; ++v)
                for (uint32_t u = 0; u + 1 < n; ++u) {
                    const uint32_t du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
                    for (int corner = 0; corner < 4; ++corner) {
                        uint32_t x[3];
                        x[a] = c, x[b] = u + du[corner], x[d] = v + dv[corner];
                        p.indices.push_back(id(x));
                    }
                    p.face_sizes.push_back(4);
                }
    }
    p.material = -1;
    return p;
}

} // namespace furrow::models

// furrow's private geometry kernel: disjoint sets (union-find) over 0..n-1, in one place. Shared because mesh
// (check_primitive: fans, components, boundary loops) and tessellate (prepare_mesh: fans, points, normal
// sectors) both classify corners by unions in index order, and both rely on the same determinism rule below.
// Not installed and not part of any public header (see affine.h).
//
// Path halving in find (R. E. Tarjan, J. van Leeuwen, "Worst-case analysis of set union algorithms",
// JACM 31(2), 1984); no union by rank: the smaller root always wins, so every root is the lowest element of
// its class whatever the order of the unions, and any numbering derived from roots depends on the input only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

namespace furrow::kernel {

struct DisjointSets {
    std::vector<uint32_t> parent;

    explicit DisjointSets(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }

    uint32_t find(uint32_t x) {
        while (parent[x] != x) {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        return x;
    }

    // Joins the classes of a and b; the smaller root becomes the root of both.
    void unite(uint32_t a, uint32_t b) {
        a = find(a);
        b = find(b);
        if (a < b) parent[b] = a;
        else if (b < a) parent[a] = b;
    }
};

} // namespace furrow::kernel

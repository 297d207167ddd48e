// furrow's private geometry kernel: welded positions numbered 0..k-1, in one place. Shared because shells
// (shell_frame), tessellate (prepare_mesh) and deform (displaced_ground) all work on the position-welded mesh
// and copy the result back to every split copy of a position; they must number the welded points the same
// way, in order of first appearance, so that every sum over them runs in the same, input-given order.
// Not installed and not part of any public header (see affine.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace furrow::kernel {

struct WeldedIds {
    std::vector<uint32_t> of_vertex; // vertex -> welded id, 0..k-1
    std::vector<uint32_t> first;     // welded id -> its first vertex (the weld's representative); k entries
};

// welded_ids' numbering in place, when the caller needs only the ids and their count: remap (as
// weld_positions writes it: remap[v] is the first vertex with v's position, so remap[v] <= v and
// remap[remap[v]] == remap[v]) becomes vertex -> welded id. A representative (remap[v] == v) takes the next
// id; any other vertex takes its representative's, already renumbered (it comes first). Returns the count.
inline size_t number_welded_in_place(uint32_t* remap, size_t vertex_count) {
    uint32_t next = 0;
    for (size_t v = 0; v < vertex_count; ++v) remap[v] = remap[v] == v ? next++ : remap[remap[v]];
    return next;
}

// Dense ids for such a remap, in order of first appearance, and each id's representative.
inline WeldedIds welded_ids(const uint32_t* remap, size_t vertex_count) {
    WeldedIds w;
    for (size_t v = 0; v < vertex_count; ++v)
        if (remap[v] == v) w.first.push_back(uint32_t(v));
    w.of_vertex.assign(remap, remap + vertex_count);
    number_welded_in_place(w.of_vertex.data(), vertex_count);
    return w;
}

} // namespace furrow::kernel

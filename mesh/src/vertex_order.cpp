// Vertex order of a triangle primitive for the GPU and for compression (meshoptimizer, Kapoulkine):
//   1. meshopt_optimizeVertexCache reorders the triangles so that the post-transform cache hits more often
//      (Forsyth's algorithm, as meshoptimizer tunes it); it only permutes triangles, nothing is dropped.
//      For EXT_meshopt_compression output, meshopt_optimizeVertexCacheStrip instead (gltfpack -cc's choice):
//      it favours triangles that continue a strip, which the index codec encodes in fewer bits and which
//      keeps consecutive vertices closer for the vertex codec's deltas (with the index codec's version 1,
//      the demo fur's --compress file went from 4331644 to 3804144 bytes in bench io).
//   2. meshopt_optimizeVertexFetchRemap numbers the vertices in the order the new triangles first use them,
//      so vertex fetch walks memory forward; this is also what makes EXT_meshopt_compression's delta coding
//      of neighbouring vertices effective. Unreferenced vertices, which meshoptimizer would drop, keep their
//      data and go after the referenced ones in their old order, so the vertex count never changes.
//   3. The remap is applied to every per-vertex array (positions, normals, tangents, UVs, colours, joints,
//      weights, morph deltas, custom attributes) and to the indices.
// Both meshoptimizer steps are single-threaded and depend only on the indices: the same input gives the same
// bytes at any thread count.
#include "encoding.h"

#include <meshoptimizer.h>

#include <algorithm>

namespace furrow {

namespace {

// Step 2 with step 2's note on unreferenced vertices: a permutation of [0, n).
std::vector<uint32_t> fetch_order(const std::vector<uint32_t>& indices, size_t n) {
    std::vector<uint32_t> remap(n);
    const size_t used = meshopt_optimizeVertexFetchRemap(remap.data(), indices.data(), indices.size(), n);
    uint32_t next = uint32_t(used);
    for (size_t i = 0; i < n; ++i)
        if (remap[i] == ~0u) remap[i] = next++;
    return remap;
}

template <class T>
void remap_array(std::vector<T>& v, const std::vector<uint32_t>& remap, size_t per_vertex) {
    v = mesh_detail::remapped(v, remap, per_vertex);
}

} // namespace

namespace mesh_detail {

std::vector<uint32_t> optimized_vertex_remap(std::vector<uint32_t>& out, const uint32_t* indices, size_t count, size_t n,
                                             bool strip) {
    if (n == 0 || count < 3 || count % 3 != 0) return {};
    for (size_t k = 0; k < count; ++k)
        if (indices[k] >= n) return {}; // the writer reports it
    std::vector<uint32_t> reordered(count);
    if (strip) meshopt_optimizeVertexCacheStrip(reordered.data(), indices, count, n);
    else meshopt_optimizeVertexCache(reordered.data(), indices, count, n);
    std::vector<uint32_t> remap = fetch_order(reordered, n);
    for (uint32_t& i : reordered) i = remap[i];
    out.swap(reordered);
    return remap;
}

std::vector<uint32_t> optimized_vertex_remap(std::vector<uint32_t>& indices, size_t n, bool strip) {
    return optimized_vertex_remap(indices, indices.data(), indices.size(), n, strip);
}

} // namespace mesh_detail

void optimize_vertex_order(Primitive& p, Encoding encoding) {
    if (p.mode != PrimitiveMode::triangles || !p.face_sizes.empty()) return;
    const std::vector<uint32_t> remap =
        mesh_detail::optimized_vertex_remap(p.indices, p.vertex_count(), encoding == Encoding::compress);
    if (remap.empty()) return;
    remap_array(p.positions, remap, 3);
    remap_array(p.normals, remap, 3);
    remap_array(p.tangents, remap, 4);
    remap_array(p.uv0, remap, 2);
    remap_array(p.uv1, remap, 2);
    remap_array(p.colors, remap, 4);
    remap_array(p.joints, remap, 4);
    remap_array(p.weights, remap, 4);
    for (MorphTarget& t : p.targets) {
        remap_array(t.position_deltas, remap, 3);
        remap_array(t.normal_deltas, remap, 3);
        remap_array(t.tangent_deltas, remap, 3);
    }
    for (CustomAttribute& c : p.custom) remap_array(c.values, remap, size_t(std::max(c.components, 0)));
}

} // namespace furrow

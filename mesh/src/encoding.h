// Internal: the byte-level encodings of the glTF writer and loader (meshoptimizer stays behind these
// functions; no meshoptimizer or tinygltf type reaches furrow/mesh.h).
#pragma once

#include <furrow/mesh.h>

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace tinygltf { class Model; }

namespace furrow::mesh_detail {

// mesh_quantize.cpp: the integer grid of one mesh's positions (KHR_mesh_quantization): position =
// offset + scale × q, q an integer in [0, 2^bits − 1] per axis. offset = the mesh's bounding-box minimum
// (double, so a far-from-origin mesh keeps its precision), scale = its largest extent / (2^bits − 1), as the
// shortest decimal of that float (what a reader reads).
struct PositionGrid {
    bool quantized = false; // false: positions stay float (skinned or morphed meshes, empty meshes)
    std::array<double, 3> offset{0, 0, 0};
    double scale = 1.0;
};
PositionGrid position_grid(const Mesh& mesh, int bits);
// A float as the double of its shortest decimal (0.9f as 0.9, not 0.8999999761581421): the JSON is shorter
// and a reader's float is the same float.
double decimal(float f);
// Integer positions on `grid`, 4 uint16 per vertex (the 4th is 0: vertex attributes are 4-byte aligned).
std::vector<uint16_t> quantize_positions(const std::vector<float>& positions, const PositionGrid& grid);
// Unit vectors (3 or 4 components in `stride`) as normalized int8, 4 bytes per vertex (w = the tangent's sign
// for stride 4, else 0). `octahedral` (--compress): each x, y, z is the decoded 8-bit octahedral code of the
// float vector (meshopt_encodeFilterOct then meshopt_decodeFilterOct), so the codec's OCTAHEDRAL filter
// re-encodes it without a second rounding.
std::vector<int8_t> quantize_unit_vectors(const std::vector<float>& v, size_t stride, bool octahedral = false);
// Values in [0, 1] as normalized uint16 / uint8; false when one is outside (the caller keeps floats).
bool quantize_unorm16(std::vector<uint16_t>& out, const std::vector<float>& v);
bool quantize_unorm8(std::vector<uint8_t>& out, const std::vector<float>& v);

// texture_transform.cpp: a texture-coordinate set stored as normalized uint16 on its bounding box,
// uv = offset + scale · q (KHR_texture_transform on the references that sample it). `used` is false where the
// set stays float or fits [0, 1] as it is.
struct UvGrid {
    bool used = false;
    std::array<double, 2> offset{0, 0}, scale{1, 1};
};
// q = round(65535 · (uv − offset) / scale), clamped to [0, 65535].
std::vector<uint16_t> quantize_uv(const std::vector<float>& uv, const UvGrid& grid);

// vertex_order.cpp: steps 1 and 2 of optimize_vertex_order on a triangle list of n vertices. Reorders and
// renumbers `indices` in place and returns the old → new vertex index; empty (indices untouched) when the
// list is not eligible (not a whole number of triangles, an index out of range). `strip`: step 1 uses
// meshopt_optimizeVertexCacheStrip (the order for EXT_meshopt_compression).
std::vector<uint32_t> optimized_vertex_remap(std::vector<uint32_t>& indices, size_t n, bool strip = false);
// The same from `count` indices that stay as they are, into `out` (untouched when not eligible): the writer's
// form, which never holds a third copy of a large index list.
std::vector<uint32_t> optimized_vertex_remap(std::vector<uint32_t>& out, const uint32_t* indices, size_t count, size_t n,
                                             bool strip = false);
// Step 3 for one per-vertex array of `per_vertex` values: out[remap[i]] = v[i]. v unchanged when remap is
// empty or v's size does not match.
template <class T>
std::vector<T> remapped(const std::vector<T>& v, const std::vector<uint32_t>& remap, size_t per_vertex) {
    if (remap.empty() || v.empty() || per_vertex == 0 || v.size() != remap.size() * per_vertex) return v;
    std::vector<T> out(v.size());
    for (size_t i = 0; i < remap.size(); ++i)
        for (size_t c = 0; c < per_vertex; ++c) out[size_t(remap[i]) * per_vertex + c] = v[i * per_vertex + c];
    return out;
}

// meshopt_codec.cpp: EXT_meshopt_compression.
// Writer: every vertex and index buffer view of `bin` (described by the glTF JSON `j`) is encoded with
// meshopt_encodeVertexBuffer / meshopt_encodeIndexBuffer / meshopt_encodeIndexSequence into a new binary
// chunk; the views point into a fallback buffer without data, so the extension is required.
struct CompressedBin {
    std::vector<uint8_t> bin;  // buffer 0: compressed views and the untouched ones (images, animation)
    size_t fallback_bytes = 0; // byteLength of buffer 1, the data-less fallback
};
void compress_buffer_views(CompressedBin& out, nlohmann::json& document, const std::vector<uint8_t>& bin);
// Loader: decodes every buffer view that has the extension into a buffer of its own, checking every count,
// stride and length first. `max_decoded_bytes` bounds the decoded data of the whole file.
Status decode_meshopt_views(tinygltf::Model& model, size_t max_decoded_bytes);

} // namespace furrow::mesh_detail

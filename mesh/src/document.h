// Internal: the part of a glTF document that furrow carries through untouched (animations, cameras, extras,
// extensions, the asset block). Only mesh/ sees tinygltf types.
#pragma once

#include "encoding.h"

#include <furrow/mesh.h>
#include <tiny_gltf.h>

#include <map>

namespace furrow::mesh_detail {

struct Document {
    tinygltf::Model model; // as loaded (buffers kept: animation samplers are re-encoded from them on save)
};

// Reads accessor `index` as floats (normalized integers mapped to [0,1]/[-1,1], plain integers converted,
// sparse substitution applied), `components` per element. Bounds-checked against buffers.
Status read_accessor_floats(std::vector<float>& out, const tinygltf::Model& model, int index, int& components);
// Reads an index or joint accessor (unsigned integer types) as uint32.
Status read_accessor_uints(std::vector<uint32_t>& out, const tinygltf::Model& model, int index, int& components);

// texture_transform.cpp. Loader: KHR_texture_transform applied to the texture coordinates it transforms and
// removed from the material's references, where every reference of the material to a set agrees (the
// extension is no longer declared when none is left). Writer (--quantize, --compress): per material of `m`
// (already written) and set 0/1, the grid of a set outside [0, 1] that a texture samples, and the transform
// that dequantizes it on those references (declared used and required).
void bake_texture_transforms(Scene& scene, tinygltf::Model& model);
// Which texture-coordinate sets (0, 1) the textures of a material sample; both when its own extensions sample
// textures (their references are not inspected).
std::array<bool, 2> sampled_uv_sets(const tinygltf::Material& material);
std::vector<std::array<UvGrid, 2>> texture_uv_grids(tinygltf::Model& m, const Scene& scene);

} // namespace furrow::mesh_detail

namespace furrow::mesh_detail {

// gltf_resources.cpp: the document tinygltf is given, with every external resource it may read decided and
// read beforehand (see the file's opening comment). tinygltf itself never touches the file system: its file
// callbacks serve only `files`.
struct PreparedGltf {
    std::vector<uint8_t> bytes;                           // the rewritten .gltf/.glb; empty = use the input as is
    std::map<std::string, std::vector<uint8_t>> files;    // token (the uri tinygltf sees) -> the resource's bytes
    std::vector<std::string> image_uris, buffer_uris;     // per image/buffer of the rewritten file: the uri as
                                                          // written where a token replaced it, else ""
};
Status prepare_gltf(PreparedGltf& out, const uint8_t* data, size_t size, const ResourceResolver& resolver,
                    const LoadOptions& options);
// The node and primitive limits of LoadOptions, with the message that names the flag raising them.
Status check_scene_counts(size_t nodes, size_t primitives, const LoadOptions& options);
// A URI shown in a one-line message: bytes outside printable ASCII as %XX, at most 80 characters.
std::string printable_uri(const std::string& uri);

// image_io.cpp: width and height from a PNG or JPEG header (false if neither can be read); the JPEG Huffman
// check of decode_image runs first, as stb_image parses tables while it looks for the frame header.
bool image_dimensions(const uint8_t* data, size_t size, int& width, int& height);

} // namespace furrow::mesh_detail

namespace furrow::mesh_detail {

// What a polygon reader (obj_load.cpp, and OpenMesh's PLY/OFF readers in openmesh_load.cpp) reports: its
// vertices, and its faces as lists of reader vertices. reader_mesh_to_scene turns it into a primitive.
struct ReaderMesh {
    std::vector<double> points;        // xyz per reader vertex, in double
    std::vector<float> normals;        // xyz per reader vertex (sized when any_normal)
    std::vector<float> colors;         // rgba per reader vertex (sized when any_color)
    std::vector<float> vertex_uv;      // uv per reader vertex (sized when any_vertex_uv)
    std::vector<uint32_t> face_start;  // offset into corners
    std::vector<uint32_t> corners;     // reader vertex indices (>= the vertex count: the face is refused)
    std::vector<float> corner_uv;      // uv per corner, parallel to corners (sized when any_corner_uv)
    bool any_normal = false, any_color = false, any_vertex_uv = false, any_corner_uv = false;
    size_t dropped_faces = 0; // faces the reader dropped for having fewer than 3 distinct corners
    size_t vertex_count() const { return points.size() / 3; }
};
// One glTF vertex per distinct (reader vertex, corner uv) pair, so that UV seams split; positions recentred
// in double; v flipped (OBJ/PLY put v = 0 at the image bottom, glTF at the top).
Status reader_mesh_to_scene(Scene& out, ReaderMesh& mesh, const LoadOptions& options);

} // namespace furrow::mesh_detail

namespace furrow {
// Format loaders behind load_scene (gltf_load.cpp, obj_load.cpp, off_load.cpp, ply_load.cpp, stl_load.cpp,
// openmesh_load.cpp). `resolver` reads external resources; empty = none are resolved. load_openmesh_bytes is
// the former reader of ".ply" (ASCII and binary) and ".off" (a validation pass, then OpenMesh's), called by
// no loader: kept as the oracle of tests/mesh/test_ply_load.cpp and tests/mesh/test_off_load.cpp.
Status load_gltf_bytes(Scene& out, const uint8_t* data, size_t size, const ResourceResolver& resolver,
                       const LoadOptions& options);
Status load_stl_bytes(Scene& out, const char* data, size_t size, const LoadOptions& options);
Status load_openmesh_bytes(Scene& out, const std::string& bytes, const std::string& ext, const LoadOptions& options);
Status load_obj_bytes(Scene& out, const char* text, size_t size, const LoadOptions& options);
Status load_off_bytes(Scene& out, const char* text, size_t size, const LoadOptions& options);
// PLY, ASCII and binary (little and big endian), in one pass (ply_load.cpp).
Status load_ply_bytes(Scene& out, const char* text, size_t size, const LoadOptions& options);
} // namespace furrow

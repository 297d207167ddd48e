// Internal: the part of a glTF document that furrow carries through untouched (animations, cameras, extras,
// extensions, the asset block). Only mesh/ sees tinygltf types.
#pragma once

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

namespace furrow {
// Format loaders behind load_scene (gltf_load.cpp, openmesh_load.cpp). `resolver` reads external resources;
// empty = none are resolved.
Status load_gltf_bytes(Scene& out, const uint8_t* data, size_t size, const ResourceResolver& resolver,
                       const LoadOptions& options);
Status load_stl_bytes(Scene& out, const std::string& bytes, const LoadOptions& options);
Status load_openmesh_bytes(Scene& out, const std::string& bytes, const std::string& ext, const LoadOptions& options);
} // namespace furrow

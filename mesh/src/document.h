// Internal: the part of a glTF document that furrow carries through untouched (animations, cameras, extras,
// extensions, the asset block). Only mesh/ sees tinygltf types.
#pragma once

#include <furrow/mesh.h>
#include <tiny_gltf.h>

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

namespace furrow {
// Format loaders behind load_scene (gltf_load.cpp, openmesh_load.cpp).
Status load_gltf_bytes(Scene& out, const uint8_t* data, size_t size, const std::string& base_dir,
                       const LoadOptions& options);
Status load_stl_bytes(Scene& out, const std::string& bytes, const LoadOptions& options);
Status load_openmesh_bytes(Scene& out, const std::string& bytes, const std::string& ext, const LoadOptions& options);
} // namespace furrow

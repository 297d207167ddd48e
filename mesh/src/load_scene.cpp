// load_scene: reads the file once (with a size guard) and dispatches on the extension. A glTF file's external
// resources are read through LoadOptions::resolver, by default confined_file_resolver under the resource root
// (LoadOptions::resource_root, or the input's own folder): see gltf_resources.cpp.
#include "document.h"
#include <furrow_kernel/huge_pages.h>
#include <furrow_kernel/no_throw.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>

namespace furrow {

namespace {
std::string lower_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

Status dispatch(Scene& out, const uint8_t* data, size_t size, const std::string& ext, const ResourceResolver& resolver,
                const LoadOptions& options) {
    // A .glb must be a GLB container. Without this check a .glb with a wrong magic was parsed as JSON and
    // reported as a JSON syntax error at column 1, which does not say what is wrong with the file.
    if (ext == ".glb" && size > 0 && (size < 4 || std::memcmp(data, "glTF", 4) != 0))
        return Status::error(StatusCode::invalid_input, "invalid GLB: the file does not start with the GLB magic 'glTF'");
    if (ext == ".gltf" || ext == ".glb") return load_gltf_bytes(out, data, size, resolver, options);
    if (ext == ".stl") return load_stl_bytes(out, reinterpret_cast<const char*>(data), size, options);
    if (ext == ".obj") return load_obj_bytes(out, reinterpret_cast<const char*>(data), size, options);
    if (ext == ".off") return load_off_bytes(out, reinterpret_cast<const char*>(data), size, options);
    if (ext == ".ply") return load_ply_bytes(out, reinterpret_cast<const char*>(data), size, options);
    return Status::error(StatusCode::unsupported,
                         "unsupported file type '" + ext + "' (expected .gltf, .glb, .obj, .ply, .off or .stl)");
}
} // namespace

namespace {
Status load_scene_unguarded(Scene& out, const std::string& path, const LoadOptions& options) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!fs::exists(path, ec)) return Status::error(StatusCode::io_error, "file not found");
    if (fs::is_directory(path, ec)) return Status::error(StatusCode::io_error, "is a directory, not a mesh file");
    const std::string ext = lower_extension(path);
    if (ext != ".gltf" && ext != ".glb" && ext != ".obj" && ext != ".ply" && ext != ".off" && ext != ".stl")
        return dispatch(out, nullptr, 0, ext, {}, options);
    std::ifstream in(path, std::ios::binary);
    if (!in) return Status::error(StatusCode::io_error, std::string("cannot open: ") + std::strerror(errno));
    in.seekg(0, std::ios::end);
    const auto end = in.tellg();
    if (end < 0) return Status::error(StatusCode::io_error, "cannot read");
    const size_t size = size_t(end);
    if (size > options.max_file_bytes)
        return Status::error(StatusCode::out_of_memory, "file is " + std::to_string(size) + " bytes, above the limit of " +
                                                            std::to_string(options.max_file_bytes));
    in.seekg(0);
    // Not zero-filled first: a 100 MB OBJ spent a tenth of its load in that memset and its page faults; huge
    // pages for the rest of those faults.
    const kernel::HugeBytes bytes = kernel::allocate_huge_bytes(size);
    if (!bytes) return Status::error(StatusCode::out_of_memory, "cannot allocate " + std::to_string(size) + " bytes to read it");
    if (size && !in.read(reinterpret_cast<char*>(bytes.get()), std::streamsize(size)))
        return Status::error(StatusCode::io_error, "read failed");
    const std::string base_dir = fs::absolute(fs::path(path), ec).parent_path().string();
    if (ec) return Status::error(StatusCode::io_error, "cannot resolve its folder: " + ec.message());
    if (!options.resolver && !options.resource_root.empty() && !fs::is_directory(options.resource_root, ec))
        return Status::error(StatusCode::io_error, "the resource root " + options.resource_root + " is not a folder");
    const ResourceResolver resolver =
        options.resolver ? options.resolver
                         : confined_file_resolver(options.resource_root.empty() ? base_dir : options.resource_root, base_dir);
    return dispatch(out, bytes.get(), size, ext, resolver, options);
}
} // namespace

Status load_scene(Scene& out, const std::string& path, const LoadOptions& options) {
    return kernel::no_throw("loading the scene", [&] { return load_scene_unguarded(out, path, options); });
}

namespace {
Status load_scene_from_memory_unguarded(Scene& out, const uint8_t* data, size_t size, const std::string& extension,
                              const LoadOptions& options) {
    std::string ext = extension;
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (!ext.empty() && ext[0] != '.') ext = "." + ext;
    if (size > options.max_file_bytes) return Status::error(StatusCode::out_of_memory, "input above the size limit");
    return dispatch(out, data, size, ext, options.resolver, options);
}
} // namespace

Status load_scene_from_memory(Scene& out, const uint8_t* data, size_t size, const std::string& extension,
                              const LoadOptions& options) {
    return kernel::no_throw("loading the scene", [&] { return load_scene_from_memory_unguarded(out, data, size, extension, options); });
}

} // namespace furrow

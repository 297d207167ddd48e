// Internal: write-to-temporary-then-rename, so that a failed write never leaves a half-written output and
// a reader never sees one.
#pragma once

#include <furrow/mesh.h>

namespace furrow::detail {

// Writes bytes to `path` atomically (temporary file in the same folder, then rename).
Status atomic_write(const std::string& path, const void* data, size_t size);
// Writes two files (a .gltf's .bin, then the .gltf) both or neither: both are staged as temporaries first,
// so a second output that cannot be written no longer leaves the first one behind.
Status atomic_write_pair(const std::string& first, const void* first_data, size_t first_size, const std::string& second,
                         const void* second_data, size_t second_size);
// A unique temporary path beside `path` (same folder, so rename is atomic).
std::string temp_path_beside(const std::string& path);

} // namespace furrow::detail

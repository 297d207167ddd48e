#include <furrow/mesh.h>

namespace furrow {

size_t Primitive::triangle_count() const {
    if (mode != PrimitiveMode::triangles) return 0;
    if (face_sizes.empty()) return indices.size() / 3;
    size_t n = 0;
    for (uint32_t s : face_sizes) n += s >= 3 ? s - 2 : 0;
    return n;
}

} // namespace furrow

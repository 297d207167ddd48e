#include <furrow/mesh.h>

namespace furrow {

size_t Primitive::triangle_count() const {
    if (mode != PrimitiveMode::triangles) return 0;
    if (face_sizes.empty()) return indices.size() / 3;
    size_t n = 0;
    for (uint32_t s : face_sizes) n += s >= 3 ? s - 2 : 0;
    return n;
}

void triangulate(Primitive& p) {
    if (p.face_sizes.empty() || p.mode != PrimitiveMode::triangles) return;
    std::vector<uint32_t> tris;
    tris.reserve(p.triangle_count() * 3);
    size_t at = 0;
    for (uint32_t s : p.face_sizes) {
        if (s > p.indices.size() - at) break; // face_sizes claims more corners than there are: stop, never overread
        // A fan keeps the polygon's winding; faces with fewer than 3 corners carry no area and are dropped.
        for (uint32_t k = 1; k + 1 < s; ++k) {
            tris.push_back(p.indices[at]);
            tris.push_back(p.indices[at + k]);
            tris.push_back(p.indices[at + k + 1]);
        }
        at += s;
    }
    p.indices = std::move(tris);
    p.face_sizes.clear();
}

} // namespace furrow

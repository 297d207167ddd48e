// A polygon reader's output (ReaderMesh: reader vertices, faces as lists of them, a uv per corner) as one
// glTF primitive. Stages:
//  - corners become glTF vertices: one per distinct (reader vertex, corner uv) pair, numbered in the order
//    the kept faces first use them, so that a UV seam splits a vertex and nothing else does (glTF has one uv
//    per vertex). The pairs of one reader vertex are a short chain, searched linearly: no map, no hashing.
//  - faces naming a vertex that does not exist refuse the file (counted, one message).
//  - positions relative to the bbox centre, computed in double: recentre() only sees floats, and a model
//    1e5 m from the origin would lose its millimetres in float.
//  - v flipped: OBJ and PLY put v = 0 at the image bottom, glTF at the top.
#include "document.h"
#include <furrow_kernel/huge_pages.h>

#include <algorithm>
#include <cmath>

namespace furrow::mesh_detail {
namespace {

// Corner -> glTF vertex. Without corner uvs the reader vertices are the glTF vertices, all of them.
struct CornerSplit {
    std::vector<uint32_t> reader_vertex; // glTF vertex -> reader vertex
    std::vector<float> uvs;              // uv per glTF vertex (corner uvs only)
    std::vector<uint32_t> head;          // reader vertex -> its first glTF vertex + 1 (0: none yet)
    std::vector<uint32_t> next;          // glTF vertex -> the next one of the same reader vertex + 1

    uint32_t vertex_for(const ReaderMesh& m, size_t corner) {
        const uint32_t v = m.corners[corner];
        if (!m.any_corner_uv) return v;
        const float u = m.corner_uv[corner * 2], w = m.corner_uv[corner * 2 + 1];
        uint32_t* link = &head[v];
        while (*link) {
            const uint32_t g = *link - 1;
            if (uvs[g * 2] == u && uvs[g * 2 + 1] == w) return g; // -0 == +0, as the map did
            link = &next[g];
        }
        const uint32_t g = uint32_t(reader_vertex.size());
        *link = g + 1;
        reader_vertex.push_back(v);
        next.push_back(0);
        uvs.insert(uvs.end(), {u, w});
        return g;
    }
};

// The bbox centre to subtract (zero unless LoadOptions asks and the mesh is far from the origin).
Status centre_of(const ReaderMesh& m, const LoadOptions& options, double centre[3]) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    bool finite = true;
    for (size_t i = 0; i < m.points.size(); i += 3)
        for (size_t k = 0; k < 3; ++k) {
            const double x = m.points[i + k];
            if (!std::isfinite(x)) { finite = false; continue; }
            lo[k] = std::min(lo[k], x);
            hi[k] = std::max(hi[k], x);
        }
    if (!finite && !options.allow_non_finite)
        return Status::error(StatusCode::invalid_input, "vertex positions contain NaN or infinite values");
    centre[0] = centre[1] = centre[2] = 0;
    if (options.recentre && lo[0] <= hi[0]) {
        const double diag = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                      (hi[2] - lo[2]) * (hi[2] - lo[2]));
        const double c[3] = {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
        const double dist = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        if (dist > options.recentre_threshold * std::max(diag, 1e-300) || dist > 1e4)
            for (int k = 0; k < 3; ++k) centre[k] = c[k];
    }
    return Status::success();
}

// Per glTF vertex, the reader vertex's values (`width` floats each).
std::vector<float> gather(const std::vector<float>& per_reader_vertex, const std::vector<uint32_t>& reader_vertex, size_t width) {
    std::vector<float> out;
    kernel::assign_huge(out, reader_vertex.size() * width);
    for (size_t i = 0; i < reader_vertex.size(); ++i)
        std::copy_n(per_reader_vertex.begin() + std::ptrdiff_t(size_t(reader_vertex[i]) * width), width,
                    out.begin() + std::ptrdiff_t(i * width));
    return out;
}

} // namespace

Status reader_mesh_to_scene(Scene& out, ReaderMesh& m, const LoadOptions& options) {
    const size_t nv = m.vertex_count();
    if (nv == 0) return Status::error(StatusCode::invalid_input, "contains no vertices");
    Primitive p;
    CornerSplit split;
    if (m.any_corner_uv) {
        kernel::assign_huge(split.head, nv, 0u);
        kernel::reserve_huge(split.reader_vertex, nv);
        kernel::reserve_huge(split.next, nv);
        kernel::reserve_huge(split.uvs, nv * 2);
    }
    size_t dropped = m.dropped_faces, out_of_range = 0;
    kernel::reserve_huge(p.indices, m.corners.size());
    kernel::reserve_huge(p.face_sizes, m.face_start.size());
    for (size_t f = 0; f < m.face_start.size(); ++f) {
        const size_t b = m.face_start[f], e = f + 1 < m.face_start.size() ? m.face_start[f + 1] : m.corners.size();
        if (e - b < 3) { ++dropped; continue; }
        bool bad = false;
        for (size_t c = b; c < e; ++c) bad |= m.corners[c] >= nv;
        if (bad) { ++out_of_range; continue; }
        if (out_of_range) continue; // the file is refused: only count
        for (size_t c = b; c < e; ++c) p.indices.push_back(split.vertex_for(m, c));
        p.face_sizes.push_back(uint32_t(e - b));
    }
    if (out_of_range)
        return Status::error(StatusCode::invalid_input, std::to_string(out_of_range) + " faces reference vertices that do not exist");
    if (!m.any_corner_uv) {
        kernel::assign_huge(split.reader_vertex, nv, 0u);
        for (size_t i = 0; i < nv; ++i) split.reader_vertex[i] = uint32_t(i);
        if (m.any_vertex_uv) split.uvs = std::move(m.vertex_uv);
    }
    double centre[3] = {0, 0, 0};
    if (Status s = centre_of(m, options, centre); !s.ok()) return s;
    const std::vector<uint32_t>& reader_vertex = split.reader_vertex;
    const size_t n = reader_vertex.size();
    kernel::assign_huge(p.positions, n * 3, 0.0f);
    for (size_t i = 0; i < n; ++i)
        for (size_t k = 0; k < 3; ++k) p.positions[i * 3 + k] = float(m.points[size_t(reader_vertex[i]) * 3 + k] - centre[k]);
    if (m.any_normal) p.normals = gather(m.normals, reader_vertex, 3);
    if (m.any_color) p.colors = gather(m.colors, reader_vertex, 4);
    if (!split.uvs.empty()) {
        for (size_t i = 1; i < split.uvs.size(); i += 2) split.uvs[i] = 1.0f - split.uvs[i];
        p.uv0 = std::move(split.uvs);
    }
    if (std::all_of(p.face_sizes.begin(), p.face_sizes.end(), [](uint32_t s) { return s == 3; })) std::vector<uint32_t>().swap(p.face_sizes);
    Scene scene = make_scene(std::move(p), "mesh");
    scene.nodes[0].translation = {centre[0], centre[1], centre[2]};
    if (dropped) scene.warnings.push_back(std::to_string(dropped) + " faces with fewer than 3 distinct corners were dropped by the reader");
    out = std::move(scene);
    return Status::success();
}

} // namespace furrow::mesh_detail

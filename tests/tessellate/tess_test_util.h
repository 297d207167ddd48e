// Helpers for the tessellate tests: a Primitive as TessellateInput and back, topology counts of the output.
#pragma once

#include <furrow/mesh.h>
#include <furrow/tessellate.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

namespace furrow::test {

// Welds a primitive by exact position (OpenSubdiv's Far reference needs the welded topology); a
// primitive without face sizes gets triangles.
inline Primitive welded(const Primitive& p) {
    std::vector<uint32_t> remap(p.vertex_count());
    weld_positions(remap.data(), p.positions.data(), p.vertex_count());
    Primitive w;
    std::vector<uint32_t> id(p.vertex_count(), 0xffffffffu);
    for (size_t v = 0; v < p.vertex_count(); ++v)
        if (remap[v] == v) {
            id[v] = uint32_t(w.positions.size() / 3);
            w.positions.insert(w.positions.end(), &p.positions[v * 3], &p.positions[v * 3 + 3]);
        }
    for (uint32_t i : p.indices) w.indices.push_back(id[remap[i]]);
    w.face_sizes = p.face_sizes;
    if (w.face_sizes.empty()) w.face_sizes.assign(p.indices.size() / 3, 3);
    return w;
}

// Plain-array view of a primitive (the primitive must outlive it).
inline TessellateInput input_of(const Primitive& p) {
    TessellateInput in;
    in.positions = p.positions.data();
    in.vertex_count = p.vertex_count();
    in.indices = p.indices.data();
    in.index_count = p.indices.size();
    if (!p.face_sizes.empty()) {
        in.face_sizes = p.face_sizes.data();
        in.face_count = p.face_sizes.size();
    }
    // The plain-array API cannot see array lengths: a short uv0 would be read past its end.
    EXPECT_TRUE(p.uv0.empty() || p.uv0.size() == 2 * p.vertex_count()) << "uv0 does not match the positions";
    if (!p.uv0.empty()) in.uvs = p.uv0.data();
    return in;
}

inline Primitive primitive_of(const TessellateOutput& t) {
    Primitive p;
    p.positions = t.positions;
    p.normals = t.normals;
    p.uv0 = t.uvs;
    p.indices = t.indices;
    return p;
}

inline TessellateOutput run_tessellate(const Primitive& p, const TessellateOptions& o) {
    TessellateOutput out;
    Status s = tessellate(out, input_of(p), o);
    EXPECT_TRUE(s.ok()) << s.message;
    return out;
}

inline TessellateOptions uniform_options(SubdivisionScheme scheme, int rate) {
    TessellateOptions o;
    o.surface.scheme = scheme;
    o.rates.uniform = rate;
    o.rates.max_rate = std::max(rate, 1);
    return o;
}

// A closed torus of nu x nv quads (every vertex of valence 4: all patches regular for Catmull-Clark).
inline Primitive quad_torus(int nu, int nv, float R = 2.0f, float r = 0.7f) {
    Primitive p;
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            double a = 2 * M_PI * i / nu, b = 2 * M_PI * j / nv;
            p.positions.push_back(float((R + r * std::cos(b)) * std::cos(a)));
            p.positions.push_back(float(r * std::sin(b)));
            p.positions.push_back(float((R + r * std::cos(b)) * std::sin(a)));
        }
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            auto id = [&](int x, int y) { return uint32_t(((y + nv) % nv) * nu + (x + nu) % nu); };
            // Counter-clockwise seen from outside.
            p.indices.insert(p.indices.end(), {id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j)});
            p.face_sizes.push_back(4);
        }
    return p;
}

// Exact-position welded triangle mesh: counts of triangles whose geometric normal opposes the vertex normals.
inline size_t flipped_triangles(const TessellateOutput& t) {
    size_t flipped = 0;
    for (size_t i = 0; i + 2 < t.indices.size(); i += 3) {
        const float* a = &t.positions[t.indices[i] * 3];
        const float* b = &t.positions[t.indices[i + 1] * 3];
        const float* c = &t.positions[t.indices[i + 2] * 3];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
        double s = 0;
        for (int k = 0; k < 3; ++k)
            for (int j = 0; j < 3; ++j) s += n[j] * t.normals[t.indices[i + size_t(k)] * 3 + size_t(j)];
        if (s < 0) ++flipped;
    }
    return flipped;
}

} // namespace furrow::test

// Grounds and colliders shared by the furrow::deform tests.
#pragma once

#include <furrow/deform.h>
#include <furrow/mesh.h>
#include <furrow/shapes.h>

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace furrow::test {

inline Collider sphere(double r, std::vector<std::array<double, 3>> path) {
    Collider c;
    c.shape = ColliderShape::sphere;
    c.radius = r;
    c.path = std::move(path);
    c.name = "sphere";
    return c;
}

inline Collider box(std::array<double, 3> size, double heading, std::vector<std::array<double, 3>> path) {
    Collider c;
    c.shape = ColliderShape::box;
    c.size = size;
    c.heading = {heading};
    c.path = std::move(path);
    c.name = "box";
    return c;
}

inline Collider capsule(double r, double length, std::vector<std::array<double, 3>> path) {
    Collider c;
    c.shape = ColliderShape::capsule;
    c.radius = r;
    c.length = length;
    c.path = std::move(path);
    c.name = "capsule";
    return c;
}

// An image collider with a procedural brush (w × h grey values from f(column, row)).
template <class F>
Collider image(int w, int h, double sx, double sz, double depth, double heading, std::array<double, 3> centre, F f) {
    auto im = std::make_shared<ImageF>();
    im->width = w, im->height = h, im->channels = 1;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) im->pixels.push_back(float(f(i, j)));
    Collider c;
    c.shape = ColliderShape::image;
    c.brush = im;
    c.size = {sx, sz, 0};
    c.depth = depth;
    c.heading = {heading};
    c.path = {centre};
    c.name = "image";
    return c;
}

// Flat ground (y = 0) of size × size metres, cells × cells quads.
inline Primitive flat_ground(float size, int cells) { return shapes::grid(size, size, cells, cells); }

// A smooth hill: y = height · exp(−(x² + z²) / (2 σ²)).
inline double hill_height(double x, double z, double height = 1.0, double sigma = 1.5) {
    return height * std::exp(-(x * x + z * z) / (2 * sigma * sigma));
}
inline Primitive hill_ground(float size, int cells) {
    Primitive g = shapes::grid(size, size, cells, cells);
    for (size_t v = 0; v < g.vertex_count(); ++v) g.positions[3 * v + 1] = float(hill_height(g.positions[3 * v], g.positions[3 * v + 2]));
    g.normals.clear();
    g.normals.resize(g.positions.size());
    compute_vertex_normals(g.normals.data(), g.positions.data(), g.vertex_count(), g.indices.data(), g.indices.size());
    return g;
}

// A flat grid whose middle column of vertices is split into two copies (a UV seam: the left half's copy keeps
// u, the right half's copy gets u + 0.5), bit-identical positions.
inline Primitive seam_ground(float size, int cells) {
    Primitive g = shapes::grid(size, size, cells, cells);
    const int n = cells + 1, mid = cells / 2;
    std::vector<uint32_t> copy_of(g.vertex_count(), UINT32_MAX);
    for (int j = 0; j < n; ++j) {
        const uint32_t v = uint32_t(j * n + mid);
        copy_of[v] = uint32_t(g.vertex_count());
        for (int d = 0; d < 3; ++d) g.positions.push_back(g.positions[3 * v + size_t(d)]);
        for (int d = 0; d < 3; ++d) g.normals.push_back(g.normals[3 * v + size_t(d)]);
        g.uv0.push_back(g.uv0[2 * v] + 0.5f);
        g.uv0.push_back(g.uv0[2 * v + 1]);
    }
    // Triangles right of the seam use the copies.
    for (size_t t = 0; t < g.indices.size() / 3; ++t) {
        double cx = 0;
        for (int c = 0; c < 3; ++c) cx += g.positions[3 * size_t(g.indices[3 * t + size_t(c)])];
        if (cx / 3 <= 0) continue;
        for (int c = 0; c < 3; ++c) {
            uint32_t& v = g.indices[3 * t + size_t(c)];
            if (copy_of[v] != UINT32_MAX) v = copy_of[v];
        }
    }
    return g;
}

inline SnowField make_field(const Primitive& ground, const SnowOptions& o) {
    SnowField f;
    Status s = f.create(ground.positions.data(), ground.vertex_count(), ground.indices.data(), ground.indices.size(), o);
    EXPECT_TRUE(s.ok()) << s.message;
    return f;
}

// Heightmap value at the texel nearest to world (x, z) (y-up frames).
inline float texel_at(const Heightmap& h, double x, double z) {
    const double p[3] = {x, 0, z};
    auto t = h.frame.to_texel(p);
    return h.at(int(std::lround(t[0])), int(std::lround(t[1])));
}

// World (x, z) of texel (i, j) for y-up frames.
inline std::array<double, 2> texel_xz(const HeightmapFrame& f, int i, int j) {
    return {f.origin[0] + i * f.texel * f.axis_u[0] + j * f.texel * f.axis_v[0], f.origin[2] + i * f.texel * f.axis_u[2] + j * f.texel * f.axis_v[2]};
}

// Analytic imprint of a sphere of radius r pressed p into flat ground at horizontal distance rho.
inline double sphere_imprint(double r, double p, double rho) {
    const double contact = std::sqrt(std::max(0.0, 2 * r * p - p * p));
    if (rho >= contact) return 0.0;
    return -(p - r + std::sqrt(r * r - rho * rho));
}

} // namespace furrow::test

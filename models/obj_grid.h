// A generated OBJ of any size: an n × n grid of vertices, a `vt` per vertex, one `vn`, two triangles per
// cell with v/t/n corners. Every number is a multiple of a power of two written in full, so that the values a
// reader must produce are known exactly (obj_grid_position, obj_grid_uv). Used by `furrow bench io` (its
// ~100 MB row) and by tests/mesh/test_obj_large.cpp, which checks that such a file loads exactly.
#pragma once

#include <array>
#include <cstdio>
#include <string>

namespace furrow::models {

// Vertex (i, j), 0-based: x = i/8, y = j/8, z a small bumpy height in eighths.
inline std::array<double, 3> obj_grid_position(int i, int j) { return {i / 8.0, j / 8.0, double((i * 7 + j * 13) % 17) / 8.0}; }
// Its texture coordinate as written (OBJ: v up), in 1024ths: n must be at most 1025.
inline std::array<double, 2> obj_grid_uv(int i, int j) { return {i / 1024.0, j / 1024.0}; }
// The side n of the grid whose file is about `bytes` long (each vertex writes ~145 bytes).
inline int obj_grid_side_for_bytes(double bytes) {
    int n = 2;
    while (n < 1025 && double(n + 1) * (n + 1) * 145.0 < bytes) ++n;
    return n;
}

// Writes the grid to `path`; false if the file cannot be written.
inline bool write_obj_grid(const std::string& path, int n) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return false;
    std::string buf;
    buf.reserve(1 << 20);
    char line[160];
    auto put = [&](int len) {
        buf.append(line, size_t(len));
        if (buf.size() > (1u << 20) - 160) std::fwrite(buf.data(), 1, buf.size(), f), buf.clear();
    };
    put(std::snprintf(line, sizeof line, "# furrow OBJ grid %d x %d\no grid\n", n, n));
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const auto p = obj_grid_position(i, j);
            put(std::snprintf(line, sizeof line, "v %.3f %.3f %.3f\n", p[0], p[1], p[2]));
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const auto t = obj_grid_uv(i, j);
            put(std::snprintf(line, sizeof line, "vt %.10g %.10g\n", t[0], t[1]));
        }
    put(std::snprintf(line, sizeof line, "vn 0 0 1\ns 1\n"));
    for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
            const long a = long(j) * n + i + 1, b = a + 1, c = a + n, d = c + 1;
            put(std::snprintf(line, sizeof line, "f %ld/%ld/1 %ld/%ld/1 %ld/%ld/1\nf %ld/%ld/1 %ld/%ld/1 %ld/%ld/1\n", a, a, b, b, d, d,
                              a, a, d, d, c, c));
        }
    std::fwrite(buf.data(), 1, buf.size(), f);
    const bool written = !std::ferror(f);
    return std::fclose(f) == 0 && written;
}

} // namespace furrow::models

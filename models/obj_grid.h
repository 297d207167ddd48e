// A generated OBJ of any size: an n × n grid of vertices, a `vt` per vertex, one `vn`, two triangles per
// cell with v/t/n corners (and the same grid as OFF, ASCII PLY and ASCII STL: write_text_grid; binary PLY:
// write_binary_ply_grid). Every number is a multiple of a power of two written in full, so that the values a
// reader must produce are known exactly (obj_grid_position, obj_grid_uv). Used by `furrow bench io` (its
// ~100 MB row) and by tests/mesh/test_obj_large.cpp, which checks that such a file loads exactly.
#pragma once

#include <array>
#include <cstdint>
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

// Buffered text output of the generators below (1 MiB at a time).
class GridWriter {
public:
    explicit GridWriter(const std::string& path) : f_(std::fopen(path.c_str(), "wb")) { buf_.reserve(1 << 20); }
    ~GridWriter() { if (f_) std::fclose(f_); }
    GridWriter(const GridWriter&) = delete;
    GridWriter& operator=(const GridWriter&) = delete;
    bool open() const { return f_ != nullptr; }
    template <class... A> void put(const char* format, A... args) {
        char line[160];
        const int len = std::snprintf(line, sizeof line, format, args...);
        buf_.append(line, size_t(len));
        if (buf_.size() > (1u << 20) - 160) std::fwrite(buf_.data(), 1, buf_.size(), f_), buf_.clear();
    }
    void bytes(const void* data, size_t size) { // raw bytes (the binary PLY grid)
        buf_.append(static_cast<const char*>(data), size);
        if (buf_.size() > (1u << 20) - 160) std::fwrite(buf_.data(), 1, buf_.size(), f_), buf_.clear();
    }
    bool close() { // false if anything failed
        std::fwrite(buf_.data(), 1, buf_.size(), f_);
        const bool written = !std::ferror(f_);
        const bool closed = std::fclose(f_) == 0;
        f_ = nullptr;
        return written && closed;
    }

private:
    std::FILE* f_;
    std::string buf_;
};

// Writes the grid to `path`; false if the file cannot be written.
inline bool write_obj_grid(const std::string& path, int n) {
    GridWriter w(path);
    if (!w.open()) return false;
    w.put("# furrow OBJ grid %d x %d\no grid\n", n, n);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const auto p = obj_grid_position(i, j);
            w.put("v %.3f %.3f %.3f\n", p[0], p[1], p[2]);
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const auto t = obj_grid_uv(i, j);
            w.put("vt %.10g %.10g\n", t[0], t[1]);
        }
    w.put("vn 0 0 1\ns 1\n");
    for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
            const long a = long(j) * n + i + 1, b = a + 1, c = a + n, d = c + 1;
            w.put("f %ld/%ld/1 %ld/%ld/1 %ld/%ld/1\nf %ld/%ld/1 %ld/%ld/1 %ld/%ld/1\n", a, a, b, b, d, d, a, a, d, d, c, c);
        }
    return w.close();
}

// The same grid (positions and triangles, no texture coordinates) in the other text formats furrow reads,
// for `furrow bench io`'s MB/s per format: OFF, ASCII PLY (float x y z, a uchar/int vertex_indices list) and
// ASCII STL (one facet per triangle, its three positions written out). `format`: "off", "ply" or "stl".
// The side n of such a file of about `bytes` (per vertex: a position line and two triangles; "ply binary":
// write_binary_ply_grid's 12 + 2 x 13 bytes).
inline int text_grid_side_for_bytes(const std::string& format, double bytes) {
    const double per_vertex = format == "stl" ? 293.0 : format == "ply binary" ? 38.0 : 57.0;
    int n = 2;
    while (n < 20000 && double(n + 1) * (n + 1) * per_vertex < bytes) ++n;
    return n;
}
inline bool write_text_grid(const std::string& path, int n, const std::string& format) {
    if (format != "off" && format != "ply" && format != "stl") return false;
    GridWriter w(path);
    if (!w.open()) return false;
    const long cells = long(n - 1) * (n - 1);
    if (format == "off") w.put("OFF\n%ld %ld 0\n", long(n) * n, 2 * cells);
    if (format == "ply")
        w.put("ply\nformat ascii 1.0\ncomment furrow grid %d x %d\nelement vertex %ld\n", n, n, long(n) * n),
            w.put("property float x\nproperty float y\nproperty float z\nelement face %ld\n", 2 * cells),
            w.put("property list uchar int vertex_indices\nend_header\n");
    if (format == "stl") {
        w.put("solid grid\n");
        auto vertex = [&](int i, int j) {
            const auto p = obj_grid_position(i, j);
            w.put("      vertex %.3f %.3f %.3f\n", p[0], p[1], p[2]);
        };
        for (int j = 0; j + 1 < n; ++j)
            for (int i = 0; i + 1 < n; ++i)
                for (int t = 0; t < 2; ++t) {
                    w.put("  facet normal 0 0 1\n    outer loop\n");
                    vertex(i, j);
                    t == 0 ? vertex(i + 1, j) : vertex(i + 1, j + 1);
                    t == 0 ? vertex(i + 1, j + 1) : vertex(i, j + 1);
                    w.put("    endloop\n  endfacet\n");
                }
        w.put("endsolid grid\n");
        return w.close();
    }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const auto p = obj_grid_position(i, j);
            w.put("%.3f %.3f %.3f\n", p[0], p[1], p[2]);
        }
    for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
            const long a = long(j) * n + i, b = a + 1, c = a + n, d = c + 1;
            w.put("3 %ld %ld %ld\n3 %ld %ld %ld\n", a, b, d, a, d, c);
        }
    return w.close();
}

// The same grid as binary little-endian PLY (float x y z; a uchar count and three int indices per triangle):
// the MB/s of the binary PLY reader. Written with this machine's byte order, which must be little-endian.
inline bool write_binary_ply_grid(const std::string& path, int n) {
    GridWriter w(path);
    if (!w.open()) return false;
    const long cells = long(n - 1) * (n - 1);
    w.put("ply\nformat binary_little_endian 1.0\ncomment furrow grid %d x %d\nelement vertex %ld\n", n, n, long(n) * n);
    w.put("property float x\nproperty float y\nproperty float z\nelement face %ld\n", 2 * cells);
    w.put("property list uchar int vertex_indices\nend_header\n");
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const auto p = obj_grid_position(i, j);
            const float xyz[3] = {float(p[0]), float(p[1]), float(p[2])};
            w.bytes(xyz, sizeof xyz);
        }
    for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
            const int32_t a = j * n + i, b = a + 1, c = a + n, d = c + 1;
            const int32_t triangles[2][3] = {{a, b, d}, {a, d, c}};
            for (const auto& t : triangles) {
                const uint8_t three = 3;
                w.bytes(&three, 1);
                w.bytes(t, sizeof t);
            }
        }
    return w.close();
}

} // namespace furrow::models

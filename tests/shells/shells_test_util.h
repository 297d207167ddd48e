// Helpers of the shells tests: hard concave solids, naive vs. furrow extrusion, merged intersection counts,
// crack checks.
#pragma once

#include <furrow/mesh.h>
#include <furrow/shapes.h>
#include <furrow/shells.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <set>
#include <vector>

namespace furrow::test {

// The boundary surface of a set of unit voxels (cell size `cell`): one quad (two triangles) per face between
// a filled and an empty cell, counter-clockwise seen from outside. Shared corners are bit-identical, so the
// welded surface is closed; inner corners, slots and gaps come out exactly as drawn.
inline Primitive voxel_surface(int nx, int ny, int nz, float cell, const std::function<bool(int, int, int)>& filled) {
    auto in = [&](int x, int y, int z) {
        return x >= 0 && y >= 0 && z >= 0 && x < nx && y < ny && z < nz && filled(x, y, z);
    };
    Primitive p;
    std::map<std::array<int, 3>, uint32_t> ids;
    auto vid = [&](int x, int y, int z) {
        auto [it, fresh] = ids.emplace(std::array<int, 3>{x, y, z}, uint32_t(p.positions.size() / 3));
        if (fresh) p.positions.insert(p.positions.end(), {x * cell, y * cell, z * cell});
        return it->second;
    };
    for (int x = 0; x < nx; ++x)
        for (int y = 0; y < ny; ++y)
            for (int z = 0; z < nz; ++z) {
                if (!in(x, y, z)) continue;
                for (int axis = 0; axis < 3; ++axis)
                    for (int side = 0; side < 2; ++side) {
                        int d[3] = {0, 0, 0};
                        d[axis] = side ? 1 : -1;
                        if (in(x + d[0], y + d[1], z + d[2])) continue;
                        // Corners of the face, ordered counter-clockwise around the outward normal.
                        int u = (axis + 1) % 3, w = (axis + 2) % 3;
                        int base[3] = {x, y, z};
                        base[axis] += side;
                        std::array<std::array<int, 3>, 4> c;
                        for (int k = 0; k < 4; ++k) {
                            c[size_t(k)] = {base[0], base[1], base[2]};
                            int du = (k == 1 || k == 2), dw = (k >= 2);
                            c[size_t(k)][size_t(u)] += du;
                            c[size_t(k)][size_t(w)] += dw;
                        }
                        uint32_t q[4];
                        for (int k = 0; k < 4; ++k) q[k] = vid(c[size_t(k)][0], c[size_t(k)][1], c[size_t(k)][2]);
                        if (side) p.indices.insert(p.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
                        else p.indices.insert(p.indices.end(), {q[0], q[2], q[1], q[0], q[3], q[2]});
                    }
            }
    return p;
}

// Base + shells 1..layers of a frame as one primitive (triangles whose corners are all bald left out, as
// add_fur_shells does), for CGAL's self-intersection count.
inline Primitive merged_shells(const Primitive& base, const ShellFrame& frame, int layers, double spacing_power = 1.0) {
    Primitive m;
    m.positions = base.positions;
    m.indices = base.indices;
    const size_t n = base.vertex_count();
    std::vector<float> shell(3 * n);
    for (int i = 1; i <= layers; ++i) {
        shell_positions(shell.data(), frame, base.positions.data(), n, i, layers, spacing_power);
        const uint32_t offset = uint32_t(m.positions.size() / 3);
        m.positions.insert(m.positions.end(), shell.begin(), shell.end());
        for (size_t t = 0; t + 3 <= base.indices.size(); t += 3) {
            const uint32_t a = base.indices[t], b = base.indices[t + 1], c = base.indices[t + 2];
            if (!(frame.length[a] > 0 || frame.length[b] > 0 || frame.length[c] > 0)) continue;
            m.indices.insert(m.indices.end(), {offset + a, offset + b, offset + c});
        }
    }
    return m;
}

// The naive extrusion of the classic tutorials: every vertex along its own (welded, normalised) normal by
// the full length, no clamp of any kind.
inline Primitive naive_shells(const Primitive& base, double length, int layers) {
    const size_t n = base.vertex_count();
    std::vector<float> normals(3 * n);
    compute_vertex_normals(normals.data(), base.positions.data(), n, base.indices.data(), base.indices.size());
    ShellFrame f;
    f.direction = normals;
    f.length.assign(n, float(length));
    f.lean.assign(3 * n, 0.0f);
    f.sag.assign(3 * n, 0.0f);
    return merged_shells(base, f, layers);
}

inline long long intersecting_pairs(const Primitive& p) {
    CheckOptions o;
    o.self_intersections = true;
    return check_primitive(p, o).self_intersections;
}

// Crack check on plain arrays: in every shell, all split copies of one welded base position have
// bit-identical positions. Returns the number of (shell, position) pairs that disagree.
inline size_t cracked_positions(const Primitive& base, const ShellFrame& frame, int layers, double spacing_power = 1.0) {
    const size_t n = base.vertex_count();
    std::vector<uint32_t> remap(n);
    weld_positions(remap.data(), base.positions.data(), n);
    std::vector<float> shell(3 * n);
    size_t bad = 0;
    for (int i = 1; i <= layers; ++i) {
        shell_positions(shell.data(), frame, base.positions.data(), n, i, layers, spacing_power);
        for (size_t v = 0; v < n; ++v)
            if (std::memcmp(&shell[3 * v], &shell[3 * size_t(remap[v])], 3 * sizeof(float)) != 0) ++bad;
    }
    return bad;
}

// Welds a primitive's triangles by exact position and counts the distinct positions its faces use.
inline size_t used_positions(const Primitive& p) {
    std::set<std::array<float, 3>> s;
    for (uint32_t i : p.indices) s.insert({p.positions[3 * i], p.positions[3 * i + 1], p.positions[3 * i + 2]});
    return s.size();
}

} // namespace furrow::test

namespace furrow::test {

// A 16-bit greyscale PNG written by hand (stored deflate blocks): save_png only writes 8-bit.
inline std::vector<uint8_t> png_grey16(int w, int h, const std::function<double(int, int)>& value) {
    auto crc32 = [](const uint8_t* d, size_t n, uint32_t c = 0xFFFFFFFFu) {
        for (size_t i = 0; i < n; ++i) {
            c ^= d[i];
            for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
        }
        return c;
    };
    std::vector<uint8_t> raw;
    for (int y = 0; y < h; ++y) {
        raw.push_back(0); // filter: none
        for (int x = 0; x < w; ++x) {
            double v = std::min(1.0, std::max(0.0, value(x, y)));
            uint16_t q = uint16_t(std::lround(v * 65535.0));
            raw.push_back(uint8_t(q >> 8));
            raw.push_back(uint8_t(q & 0xFF));
        }
    }
    std::vector<uint8_t> z{0x78, 0x01};
    for (size_t at = 0; at < raw.size() || at == 0;) {
        size_t len = std::min<size_t>(65535, raw.size() - at);
        bool last = at + len >= raw.size();
        z.push_back(last ? 1 : 0);
        z.push_back(uint8_t(len & 0xFF));
        z.push_back(uint8_t(len >> 8));
        z.push_back(uint8_t(~len & 0xFF));
        z.push_back(uint8_t((~len >> 8) & 0xFF));
        z.insert(z.end(), raw.begin() + long(at), raw.begin() + long(at + len));
        at += len;
        if (last) break;
    }
    uint32_t a = 1, b = 0;
    for (uint8_t c : raw) a = (a + c) % 65521, b = (b + a) % 65521;
    uint32_t adler = (b << 16) | a;
    for (int k = 3; k >= 0; --k) z.push_back(uint8_t(adler >> (8 * k)));
    std::vector<uint8_t> png{0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
    auto chunk = [&](const char* type, const std::vector<uint8_t>& data) {
        uint32_t n = uint32_t(data.size());
        for (int k = 3; k >= 0; --k) png.push_back(uint8_t(n >> (8 * k)));
        std::vector<uint8_t> td(type, type + 4);
        td.insert(td.end(), data.begin(), data.end());
        png.insert(png.end(), td.begin(), td.end());
        uint32_t c = ~crc32(td.data(), td.size());
        for (int k = 3; k >= 0; --k) png.push_back(uint8_t(c >> (8 * k)));
    };
    std::vector<uint8_t> ihdr;
    for (uint32_t v : {uint32_t(w), uint32_t(h)})
        for (int k = 3; k >= 0; --k) ihdr.push_back(uint8_t(v >> (8 * k)));
    ihdr.insert(ihdr.end(), {16, 0, 0, 0, 0}); // 16-bit, greyscale, deflate, adaptive filter, no interlace
    chunk("IHDR", ihdr);
    chunk("IDAT", z);
    chunk("IEND", {});
    return png;
}

} // namespace furrow::test

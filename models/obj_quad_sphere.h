// A generated closed quad mesh of any size for the Catmull-Clark benchmarks: a cube whose six faces are each
// an n x n grid of quads, projected onto a bumpy sphere ("cube sphere"). Every vertex has valence 4 except
// the eight cube corners (valence 3, extraordinary), so Bfr builds both regular and irregular patches, as
// on a scanned or sculpted quad model. n = 73 gives 6 * 73^2 = 31,974 quads, the 32k-quad setting of the
// tessellation issue (uniform rate 4 / 8 against Blender's Subdivision Surface levels 2 / 3). Written as
// plain `v` and `f` lines (no UVs, no normals), vertices shared, so every reader builds the same topology.
// Used by `furrow bench tessellate` (its Blender comparison).
#pragma once

#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace furrow::models {

// Radius of the bumpy sphere in direction d (unit): 1 plus a smooth product of sines (amplitude 0.08).
inline double quad_sphere_radius(const std::array<double, 3>& d) {
    return 1.0 + 0.08 * std::sin(5.0 * d[0]) * std::sin(4.0 * d[1] + 1.0) * std::sin(3.0 * d[2] + 2.0);
}

// Writes the cube sphere with n quads along each cube edge to `path`; false if it cannot be written.
inline bool write_obj_quad_sphere(const std::string& path, int n) {
    if (n < 1) return false;
    // Lattice points (i, j, k) in [0, n]^3 on the cube's surface get one vertex each, numbered in scan order.
    const int s = n + 1;
    std::vector<long> index(size_t(s) * size_t(s) * size_t(s), 0);
    auto at = [&](int i, int j, int k) -> long& { return index[(size_t(k) * size_t(s) + size_t(j)) * size_t(s) + size_t(i)]; };
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return false;
    std::fprintf(f, "# furrow cube sphere, %d quads per cube edge, %d quads\no quad_sphere\n", n, 6 * n * n);
    long count = 0;
    for (int k = 0; k <= n; ++k)
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i) {
                if (i != 0 && i != n && j != 0 && j != n && k != 0 && k != n) continue;
                const std::array<double, 3> c{2.0 * i / n - 1.0, 2.0 * j / n - 1.0, 2.0 * k / n - 1.0};
                const double l = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
                const std::array<double, 3> d{c[0] / l, c[1] / l, c[2] / l};
                const double r = quad_sphere_radius(d);
                std::fprintf(f, "v %.6f %.6f %.6f\n", d[0] * r, d[1] * r, d[2] * r);
                at(i, j, k) = ++count; // OBJ indices are 1-based
            }
    // Cube face (axis a, side 0 or n): quads in the plane of the axes b = a+1, c = a+2 (cyclic), whose corner
    // order (b, c), (b+1, c), (b+1, c+1), (b, c+1) turns around +a: reversed on the side at 0 (outward = -a).
    for (int a = 0; a < 3; ++a)
        for (int side : {0, n}) {
            for (int v = 0; v < n; ++v)
                for (int u = 0; u < n; ++u) {
                    long q[4];
                    const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
                    for (int t = 0; t < 4; ++t) {
                        int p[3];
                        p[a] = side;
                        p[(a + 1) % 3] = u + du[t];
                        p[(a + 2) % 3] = v + dv[t];
                        q[t] = at(p[0], p[1], p[2]);
                    }
                    if (side == 0) std::fprintf(f, "f %ld %ld %ld %ld\n", q[3], q[2], q[1], q[0]);
                    else std::fprintf(f, "f %ld %ld %ld %ld\n", q[0], q[1], q[2], q[3]);
                }
        }
    const bool written = !std::ferror(f);
    return std::fclose(f) == 0 && written;
}

} // namespace furrow::models

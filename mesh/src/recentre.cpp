// Far-from-origin meshes: float32 has 24 bits of mantissa, so at 1e5 m a position is only good to ~8 mm.
// Storing positions relative to the bounding-box centre and the centre in the node's double translation
// keeps every bit the source had.
#include <furrow/mesh.h>

#include <cmath>

namespace furrow {

size_t recentre(Scene& scene, double threshold) {
    size_t moved = 0;
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
        bool skinned = false, used = false;
        for (const Node& n : scene.nodes)
            if (n.mesh == int(mi)) {
                used = true;
                skinned |= n.skin >= 0;
            }
        if (!used || skinned) continue; // a skinned mesh's vertices live in the skeleton's space
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (const Primitive& p : scene.meshes[mi].primitives)
            for (size_t i = 0; i + 2 < p.positions.size(); i += 3)
                for (int k = 0; k < 3; ++k) {
                    double x = p.positions[i + size_t(k)];
                    if (!std::isfinite(x)) continue;
                    lo[k] = std::min(lo[k], x);
                    hi[k] = std::max(hi[k], x);
                }
        if (!(lo[0] <= hi[0])) continue;
        double c[3], diag2 = 0;
        for (int k = 0; k < 3; ++k) {
            c[k] = 0.5 * (lo[k] + hi[k]);
            diag2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
        }
        double dist = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        if (!(dist > threshold * std::sqrt(diag2) || dist > 1e4)) continue;
        for (Primitive& p : scene.meshes[mi].primitives)
            for (size_t i = 0; i + 2 < p.positions.size(); i += 3)
                for (int k = 0; k < 3; ++k) p.positions[i + size_t(k)] = float(double(p.positions[i + size_t(k)]) - c[k]);
        for (Node& n : scene.nodes) {
            if (n.mesh != int(mi)) continue;
            // local' = local · T(c): the translation gains the node's linear part applied to c.
            std::array<double, 16> m = n.local_matrix();
            double d[3];
            for (int r = 0; r < 3; ++r) d[r] = m[0 * 4 + r] * c[0] + m[1 * 4 + r] * c[1] + m[2 * 4 + r] * c[2];
            if (n.has_matrix)
                for (int r = 0; r < 3; ++r) n.matrix[12 + size_t(r)] += d[r];
            else
                for (int r = 0; r < 3; ++r) n.translation[size_t(r)] += d[r];
        }
        ++moved;
    }
    return moved;
}

} // namespace furrow

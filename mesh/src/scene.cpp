#include <furrow/mesh.h>

#include <cmath>

namespace furrow {

namespace {
using Mat4 = std::array<double, 16>; // column-major

Mat4 multiply(const Mat4& a, const Mat4& b) {
    Mat4 r{};
    for (int c = 0; c < 4; ++c)
        for (int rI = 0; rI < 4; ++rI) {
            double s = 0;
            for (int k = 0; k < 4; ++k) s += a[k * 4 + rI] * b[c * 4 + k];
            r[c * 4 + rI] = s;
        }
    return r;
}
} // namespace

std::array<double, 16> Node::local_matrix() const {
    if (has_matrix) return matrix;
    // glTF: M = T * R * S; the quaternion is normalised because exporters write slightly-off unit quaternions.
    double x = rotation[0], y = rotation[1], z = rotation[2], w = rotation[3];
    double n = std::sqrt(x * x + y * y + z * z + w * w);
    if (n > 0) x /= n, y /= n, z /= n, w /= n;
    else x = y = z = 0, w = 1;
    Mat4 m{};
    m[0] = (1 - 2 * (y * y + z * z)) * scale[0];
    m[1] = (2 * (x * y + z * w)) * scale[0];
    m[2] = (2 * (x * z - y * w)) * scale[0];
    m[4] = (2 * (x * y - z * w)) * scale[1];
    m[5] = (1 - 2 * (x * x + z * z)) * scale[1];
    m[6] = (2 * (y * z + x * w)) * scale[1];
    m[8] = (2 * (x * z + y * w)) * scale[2];
    m[9] = (2 * (y * z - x * w)) * scale[2];
    m[10] = (1 - 2 * (x * x + y * y)) * scale[2];
    m[12] = translation[0];
    m[13] = translation[1];
    m[14] = translation[2];
    m[15] = 1;
    return m;
}

std::vector<std::array<double, 16>> Scene::world_matrices() const {
    const Mat4 identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    std::vector<Mat4> world(nodes.size(), identity);
    std::vector<char> seen(nodes.size(), 0);
    // Iterative DFS: a malformed cycle or a node reachable twice is visited once (the loader rejects
    // cycles; this guard keeps hand-built scenes safe too).
    std::vector<std::pair<int, Mat4>> stack;
    for (int r : roots)
        if (r >= 0 && size_t(r) < nodes.size()) stack.push_back({r, identity});
    while (!stack.empty()) {
        auto [n, parent] = stack.back();
        stack.pop_back();
        if (seen[size_t(n)]) continue;
        seen[size_t(n)] = 1;
        world[size_t(n)] = multiply(parent, nodes[size_t(n)].local_matrix());
        for (int c : nodes[size_t(n)].children)
            if (c >= 0 && size_t(c) < nodes.size()) stack.push_back({c, world[size_t(n)]});
    }
    return world;
}

Scene make_scene(Primitive primitive, const std::string& name) {
    Scene s;
    Mesh m;
    m.name = name;
    m.primitives.push_back(std::move(primitive));
    s.meshes.push_back(std::move(m));
    Node n;
    n.name = name;
    n.mesh = 0;
    s.nodes.push_back(std::move(n));
    s.roots.push_back(0);
    return s;
}

} // namespace furrow

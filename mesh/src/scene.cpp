#include <furrow/mesh.h>
#include <furrow_kernel/affine.h>

#include <cmath>
#include <cstdint>

namespace furrow {

using kernel::Mat4;
using kernel::multiply;

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

std::vector<int> Scene::drawn_nodes() const {
    std::vector<int> start = roots;
    if (start.empty()) {
        std::vector<uint8_t> has_parent(nodes.size(), 0);
        for (const Node& n : nodes)
            for (int c : n.children)
                if (c >= 0 && size_t(c) < nodes.size()) has_parent[size_t(c)] = 1;
        for (size_t i = 0; i < nodes.size(); ++i)
            if (!has_parent[i]) start.push_back(int(i));
    }
    // Iterative DFS: a malformed cycle or a node reachable twice is visited once (the loader rejects cycles;
    // this guard keeps hand-built scenes safe too).
    std::vector<int> order;
    std::vector<uint8_t> seen(nodes.size(), 0);
    std::vector<int> stack(start.rbegin(), start.rend());
    while (!stack.empty()) {
        const int n = stack.back();
        stack.pop_back();
        if (n < 0 || size_t(n) >= nodes.size() || seen[size_t(n)]) continue;
        seen[size_t(n)] = 1;
        order.push_back(n);
        const auto& ch = nodes[size_t(n)].children;
        stack.insert(stack.end(), ch.rbegin(), ch.rend());
    }
    return order;
}

std::vector<std::array<double, 16>> Scene::world_matrices() const {
    const Mat4 identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    std::vector<Mat4> world(nodes.size(), identity);
    std::vector<int> parent(nodes.size(), -1);
    const std::vector<int> order = drawn_nodes();
    // In DFS order a node's parent (the node it was first reached from) comes before it.
    for (int n : order)
        for (int c : nodes[size_t(n)].children)
            if (c >= 0 && size_t(c) < nodes.size() && parent[size_t(c)] < 0 && c != n) parent[size_t(c)] = n;
    std::vector<uint8_t> done(nodes.size(), 0);
    for (int n : order) {
        const int p = parent[size_t(n)];
        world[size_t(n)] = p >= 0 && done[size_t(p)] ? multiply(world[size_t(p)], nodes[size_t(n)].local_matrix()) : nodes[size_t(n)].local_matrix();
        done[size_t(n)] = 1;
    }
    return world;
}

std::array<double, 16> Scene::mesh_placement(int n, const std::vector<std::array<double, 16>>& world) const {
    const Mat4 identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    if (n < 0 || size_t(n) >= nodes.size()) return identity;
    const Mat4 own = size_t(n) < world.size() ? world[size_t(n)] : identity;
    const Node& node = nodes[size_t(n)];
    if (node.skin < 0 || size_t(node.skin) >= skins.size() || node.mesh < 0 || size_t(node.mesh) >= meshes.size()) return own;
    const Skin& skin = skins[size_t(node.skin)];
    // Total weight per joint over the mesh's vertices.
    std::vector<double> weight(skin.joints.size(), 0.0);
    for (const Primitive& p : meshes[size_t(node.mesh)].primitives) {
        const size_t V = std::min(p.joints.size(), p.weights.size()) / 4;
        for (size_t k = 0; k < 4 * V; ++k)
            if (p.joints[k] < weight.size() && std::isfinite(p.weights[k])) weight[p.joints[k]] += double(p.weights[k]);
    }
    size_t best = SIZE_MAX;
    for (size_t j = 0; j < weight.size(); ++j)
        if (weight[j] > 0 && (best == SIZE_MAX || weight[j] > weight[best])) best = j;
    if (best == SIZE_MAX) return own;
    const int joint = skin.joints[best];
    if (joint < 0 || size_t(joint) >= world.size()) return own;
    Mat4 ibm = identity;
    if (skin.inverse_bind_matrices.size() >= 16 * (best + 1))
        for (size_t k = 0; k < 16; ++k) ibm[k] = double(skin.inverse_bind_matrices[16 * best + k]);
    return multiply(world[size_t(joint)], ibm);
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

// One scene rule for every module (Scene::drawn_nodes, Scene::world_matrices, Scene::mesh_placement): a scene
// with a skinned mesh (whose node's own transform glTF says to ignore), a mirrored bind pose and an instanced,
// negatively scaled mesh is placed exactly as its unskinned twin (the same meshes drawn by nodes holding the
// bind placement) by render, shells, tessellate and stamp. Once each module had its own rule: stamp drew
// a skinned ground at its node's transform, tessellate took joints[0] whether it weighed anything or not,
// and render culled a mirrored skinned mesh's front faces.
#include "test_support.h"

#include <furrow/deform.h>
#include <furrow/render.h>
#include <furrow/shapes.h>
#include <furrow/shells.h>
#include <furrow/tessellate.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

using namespace furrow;

namespace {

using Mat4 = std::array<double, 16>;

Mat4 multiply(const Mat4& a, const Mat4& b) {
    Mat4 r{};
    for (size_t c = 0; c < 4; ++c)
        for (size_t row = 0; row < 4; ++row)
            for (size_t k = 0; k < 4; ++k) r[c * 4 + row] += a[k * 4 + row] * b[c * 4 + k];
    return r;
}

// Inverse of a rigid-times-scale affine matrix by Gauss-Jordan on the 4×4 (test-side, independent of furrow).
Mat4 inverse(const Mat4& m) {
    double a[4][8] = {};
    for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) a[r][c] = m[size_t(c * 4 + r)];
        a[r][4 + r] = 1;
    }
    for (int c = 0; c < 4; ++c) {
        int p = c;
        for (int r = c + 1; r < 4; ++r)
            if (std::abs(a[r][c]) > std::abs(a[p][c])) p = r;
        std::swap(a[c], a[p]);
        const double d = a[c][c];
        for (double& x : a[c]) x /= d;
        for (int r = 0; r < 4; ++r)
            if (r != c) {
                const double f = a[r][c];
                for (int k = 0; k < 8; ++k) a[r][k] -= f * a[c][k];
            }
    }
    Mat4 out{};
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out[size_t(c * 4 + r)] = a[r][4 + c];
    return out;
}

Node trs(std::string name, std::array<double, 3> t, double yaw_degrees, std::array<double, 3> s) {
    Node n;
    n.name = std::move(name);
    const double h = yaw_degrees * std::numbers::pi / 360;
    n.translation = t;
    n.rotation = {0, std::sin(h), 0, std::cos(h)};
    n.scale = s;
    return n;
}

// The bind placement: turned, moved and mirrored (det < 0).
Mat4 bind_placement() { return trs("", {1, 0.5, -2}, 30, {-1.5, 1.5, 1.5}).local_matrix(); }

Primitive ground() {
    Primitive g = shapes::grid(2, 2, 8, 8);
    for (size_t v = 0; v < g.vertex_count(); ++v) g.positions[3 * v + 1] = 0.1f * std::sin(3.0f * g.positions[3 * v]);
    g.normals.assign(g.positions.size(), 0.0f);
    compute_vertex_normals(g.normals.data(), g.positions.data(), g.vertex_count(), g.indices.data(), g.indices.size());
    g.material = 0;
    return g;
}

// skinned = true: mesh 0 skinned to two joints in their bind pose, drawn by a node whose own transform (far
// away, scaled 3×) must be ignored. false: its twin, mesh 0 drawn by a node holding the bind placement.
// Both: mesh 1 drawn twice, once under a moved parent and once mirrored.
Scene placement_scene(bool skinned) {
    Scene s;
    Material m;
    m.name = "single-sided";
    s.materials.push_back(m);
    Mesh a;
    a.name = "ground";
    a.primitives.push_back(ground());
    Mesh b;
    b.name = "instanced";
    b.primitives.push_back(ground());
    s.meshes = {a, b};
    if (skinned) {
        Primitive& p = s.meshes[0].primitives[0];
        for (size_t v = 0; v < p.vertex_count(); ++v) {
            const float w = 0.5f + 0.4f * p.positions[3 * v] / 1.0f; // joint 1 weighs more on +x
            p.joints.insert(p.joints.end(), {0, 1, 0, 0});
            p.weights.insert(p.weights.end(), {1 - w, w, 0, 0});
        }
        s.nodes.push_back(trs("skinned", {50, 0, 0}, 0, {3, 3, 3}));
        s.nodes[0].mesh = 0;
        s.nodes[0].skin = 0;
        s.nodes.push_back(trs("joint0", {3, 1, 0}, 40, {1, 1, 1}));
        s.nodes.push_back(trs("joint1", {0, 2, 0}, -70, {2, 2, 2}));
        s.nodes[1].children = {2};
        Skin skin;
        skin.joints = {1, 2};
        const auto world = [&] {
            Scene tmp = s;
            tmp.roots = {0, 1};
            return tmp.world_matrices();
        }();
        for (int j : skin.joints) {
            const Mat4 ibm = multiply(inverse(world[size_t(j)]), bind_placement());
            for (double x : ibm) skin.inverse_bind_matrices.push_back(float(x));
        }
        s.skins.push_back(skin);
        s.roots = {0, 1};
    } else {
        Node n;
        n.name = "twin";
        n.mesh = 0;
        n.has_matrix = true;
        n.matrix = bind_placement();
        s.nodes.push_back(n);
        s.roots = {0};
    }
    // The instances: a parent moved along z with one child, and a mirrored root.
    const int parent = int(s.nodes.size());
    s.nodes.push_back(trs("parent", {0, 0, 5}, 15, {1, 1, 1}));
    s.nodes.push_back(trs("instance", {-2, 0, 0}, 0, {1, 1, 1}));
    s.nodes.push_back(trs("mirrored", {4, 0, 3}, 0, {-1, 1, 1}));
    s.nodes[size_t(parent)].children = {parent + 1};
    s.nodes[size_t(parent + 1)].mesh = 1;
    s.nodes[size_t(parent + 2)].mesh = 1;
    s.roots.push_back(parent);
    s.roots.push_back(parent + 2);
    return s;
}

std::vector<std::array<float, 3>> sorted_points(const std::vector<float>& p) {
    std::vector<std::array<float, 3>> out;
    for (size_t i = 0; i + 2 < p.size(); i += 3) out.push_back({p[i], p[i + 1], p[i + 2]});
    std::sort(out.begin(), out.end());
    return out;
}

} // namespace

TEST(ScenePlacement, SkinnedMeshIsPlacedByItsBindPose) {
    const Scene s = placement_scene(true);
    // The bind-pose fixture itself (matrices through float inverse binds: 1e-5).
    const auto world = s.world_matrices();
    const Mat4 placed = s.mesh_placement(0, world), want = bind_placement();
    for (size_t k = 0; k < 16; ++k) EXPECT_NEAR(placed[k], want[k], 1e-5) << k;
    EXPECT_EQ(s.drawn_nodes(), (std::vector<int>{0, 1, 2, 3, 4, 5}));
}

TEST(ScenePlacement, RenderDrawsTheSkinnedSceneAsItsTwin) {
    RenderOptions o;
    o.width = 160, o.height = 120;
    o.camera.eye = std::array<double, 3>{3, 9, 12};
    o.camera.target = std::array<double, 3>{1, 0, 1};
    RenderResult a, b;
    ASSERT_TRUE(render_scene(a, placement_scene(true), o).ok());
    ASSERT_TRUE(render_scene(b, placement_scene(false), o).ok());
    size_t covered = 0, differ = 0;
    for (size_t i = 0; i < a.depth.pixels.size(); ++i) {
        const bool ca = std::isfinite(a.depth.pixels[i]), cb = std::isfinite(b.depth.pixels[i]);
        covered += ca;
        differ += ca != cb || (ca && std::abs(a.depth.pixels[i] - b.depth.pixels[i]) > 1e-3f);
    }
    EXPECT_GT(covered, 1000u);
    EXPECT_LE(differ, covered / 500) << "pixels whose coverage or depth differ";
    EXPECT_EQ(a.culled, b.culled) << "a mirrored bind pose culls the same faces as its twin";
}

TEST(ScenePlacement, StampSeesTheSkinnedSceneAsItsTwin) {
    std::vector<float> pa, pb;
    std::vector<uint32_t> ia, ib;
    scene_triangles(pa, ia, placement_scene(true));
    scene_triangles(pb, ib, placement_scene(false));
    ASSERT_EQ(pa.size(), pb.size());
    const auto A = sorted_points(pa), B = sorted_points(pb);
    double worst = 0;
    for (size_t i = 0; i < A.size(); ++i)
        for (int d = 0; d < 3; ++d) worst = std::max(worst, double(std::abs(A[i][size_t(d)] - B[i][size_t(d)])));
    EXPECT_LT(worst, 1e-4) << "world positions of the skinned ground";
}

TEST(ScenePlacement, ShellsMeasureTheSkinnedMeshAsItsTwin) {
    FurOptions o;
    o.shells.layers = 4;
    o.shells.length = 0.1;
    o.keep_frames = true;
    FurReport ra, rb;
    Scene a = placement_scene(true), b = placement_scene(false);
    ASSERT_TRUE(add_fur_shells(a, o, &ra).ok());
    ASSERT_TRUE(add_fur_shells(b, o, &rb).ok());
    ASSERT_EQ(ra.frames.size(), rb.frames.size());
    for (size_t f = 0; f < ra.frames.size(); ++f) {
        EXPECT_NEAR(ra.frames[f].length, rb.frames[f].length, 1e-6) << "frame " << f;
        EXPECT_NEAR(ra.frames[f].length, f == 0 ? 0.1 / 1.5 : 0.1, 1e-6) << "world length in object units";
    }
    EXPECT_EQ(ra.shell_triangles, rb.shell_triangles);
}

TEST(ScenePlacement, TessellationRatesSeeTheSkinnedMeshAsItsTwin) {
    TessellateOptions o;
    o.rates.camera = TessellationCamera{};
    o.rates.camera->eye = {3, 9, 12};
    o.rates.pixel_error = 4;
    o.rates.max_rate = 32;
    Scene a = placement_scene(true), b = placement_scene(false);
    SceneTessellateReport ra, rb;
    ASSERT_TRUE(tessellate_scene(a, o, &ra).ok());
    ASSERT_TRUE(tessellate_scene(b, o, &rb).ok());
    EXPECT_EQ(a.meshes[0].primitives[0].triangle_count(), b.meshes[0].primitives[0].triangle_count());
    EXPECT_EQ(a.meshes[1].primitives[0].triangle_count(), b.meshes[1].primitives[0].triangle_count());
    EXPECT_GT(a.meshes[0].primitives[0].triangle_count(), 128u) << "the camera asks for more than the input's 128";
}

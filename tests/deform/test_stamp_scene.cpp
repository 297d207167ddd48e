// stamp_scene / stamp_files: tessellation where the heightmap has detail, displacement without cracks, the
// scene kept, the analytic oracle, no-contact and overhang reports.
#include "deform_test_util.h"
#include "test_support.h"

#include <map>
#include <set>

using namespace furrow;
using namespace furrow::test;

namespace {

Scene ground_scene(Primitive g) {
    g.material = 0;
    Scene s = make_scene(std::move(g), "ground");
    Material m;
    m.name = "snow";
    m.metallic = 0;
    s.materials.push_back(m);
    return s;
}

ColliderSet set_of(std::vector<Collider> cs) {
    ColliderSet set;
    set.colliders = std::move(cs);
    return set;
}

// Vertical deviation of the mesh from a surface y = f(x, z), sampled at the corners, edge midpoints and
// centroid of every triangle.
template <class F>
std::pair<double, double> deviation(const Primitive& p, F f) {
    double worst = 0, sum = 0;
    size_t n = 0;
    auto P = [&](uint32_t v, int d) { return double(p.positions[3 * size_t(v) + size_t(d)]); };
    const double w[7][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5, 0.5, 0}, {0, 0.5, 0.5}, {0.5, 0, 0.5}, {1 / 3., 1 / 3., 1 / 3.}};
    for (size_t t = 0; t + 3 <= p.indices.size(); t += 3)
        for (const auto& b : w) {
            double q[3] = {0, 0, 0};
            for (int c = 0; c < 3; ++c)
                for (int d = 0; d < 3; ++d) q[d] += b[c] * P(p.indices[t + size_t(c)], d);
            const double e = std::abs(q[1] - f(q[0], q[2]));
            worst = std::max(worst, e);
            sum += e;
            ++n;
        }
    return {worst, n ? sum / double(n) : 0.0};
}

void expect_watertight_sheet(const Primitive& p) {
    CheckReport r = check_primitive(p);
    EXPECT_EQ(r.boundary_loops, 1u) << "a crack opens a second boundary loop";
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.nan_values, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
}

} // namespace

TEST(StampScene, SphereOnFlatGroundFollowsTheAnalyticSurface) {
    const double r = 0.35, p = 0.12, cx = 0.05, cz = -0.03;
    Scene scene = ground_scene(flat_ground(2, 4));
    StampOptions o;
    o.snow.texel = 0.005;
    o.max_error = 0.0005;
    StampReport rep;
    Status s = stamp_scene(scene, set_of({sphere(r, {{cx, r - p, cz}})}), o, &rep);
    ASSERT_TRUE(s.ok()) << s.message;
    EXPECT_TRUE(rep.changed);
    EXPECT_EQ(rep.stats.contacts, 1u);
    const Primitive& out = scene.meshes[0].primitives[0];
    auto [worst, mean] = deviation(out, [&](double x, double z) { return sphere_imprint(r, p, std::hypot(x - cx, z - cz)); });
    // The mesh interpolates the bilinear heightmap within max_error; the heightmap itself is exact at texel
    // centres; the largest error sits at the imprint's edge, where the surface has a kink.
    EXPECT_LT(worst, 0.004);
    EXPECT_LT(mean, 0.0002);
    expect_watertight_sheet(out);
    // Untouched snow stays coarse: beyond the input cells around the imprint (whose shared edges carry the
    // fine rates one ring out) there are a few thousand triangles where a grid at the texel size has 180 000.
    EXPECT_LT(rep.triangles_out, size_t(2 * 400 * 400) / 3);
    EXPECT_GT(rep.triangles_out, rep.triangles_in);
    size_t far = 0;
    for (size_t t = 0; t < out.indices.size(); t += 3) {
        double x = 0, z = 0;
        for (int c = 0; c < 3; ++c) x += out.positions[3 * size_t(out.indices[t + size_t(c)])] / 3, z += out.positions[3 * size_t(out.indices[t + size_t(c)]) + 2] / 3;
        far += std::hypot(x - cx, z - cz) > 0.75;
    }
    EXPECT_LT(far, 2000u);
}

TEST(StampScene, ACameraCoarsensFarImprints) {
    // Two identical balls, 1.8 m and 13 m from the eye: with a camera (1 px error) the far one is coarser.
    auto count = [](const Primitive& p, double cx) {
        size_t n = 0;
        for (size_t t = 0; t < p.indices.size(); t += 3) {
            double x = 0;
            for (int c = 0; c < 3; ++c) x += p.positions[3 * size_t(p.indices[t + size_t(c)])] / 3;
            n += std::abs(x - cx) < 1.0;
        }
        return n;
    };
    ColliderSet set = set_of({sphere(0.3, {{-6, 0.22, 0}}), sphere(0.3, {{6, 0.22, 0}})});
    StampOptions o;
    o.snow.texel = 0.01;
    o.max_error = 0.0005;
    Scene plain = ground_scene(flat_ground(16, 16)), viewed = plain;
    ASSERT_TRUE(stamp_scene(plain, set, o).ok());
    o.camera = StampCamera{{-7, 1.5, 0}, 45.0, 1080, 1.0};
    ASSERT_TRUE(stamp_scene(viewed, set, o).ok());
    const Primitive &a = plain.meshes[0].primitives[0], &b = viewed.meshes[0].primitives[0];
    EXPECT_GT(count(b, -6), 2 * count(b, 6)); // the near imprint finer than the far one
    EXPECT_LT(count(b, 6), count(a, 6) / 2);  // the far one coarser than without a camera
    expect_watertight_sheet(b);
}

TEST(StampScene, BoxLeavesAFlatRectangle) {
    Scene scene = ground_scene(flat_ground(2, 2));
    StampOptions o;
    o.snow.texel = 0.01;
    StampReport rep;
    ASSERT_TRUE(stamp_scene(scene, set_of({box({0.5, 0.3, 0.7}, 0, {{0, 0.15 - 0.06, 0}})}), o, &rep).ok());
    const Primitive& out = scene.meshes[0].primitives[0];
    size_t floor = 0;
    for (size_t v = 0; v < out.vertex_count(); ++v) {
        const double x = out.positions[3 * v], z = out.positions[3 * v + 2], y = out.positions[3 * v + 1];
        if (std::abs(x) < 0.25 - 0.015 && std::abs(z) < 0.35 - 0.015) {
            EXPECT_NEAR(y, -0.06, 1e-6);
            ++floor;
        } else if (std::abs(x) > 0.25 + 0.015 || std::abs(z) > 0.35 + 0.015) {
            EXPECT_NEAR(y, 0.0, 1e-6);
        }
    }
    EXPECT_GT(floor, 4u);
    expect_watertight_sheet(out);
}

TEST(StampScene, HillGroundHasNoCracksAndIsValid) {
    Scene scene = ground_scene(hill_ground(6, 24));
    std::vector<Collider> cs;
    // A ball rolling over the hill's top and a box on its flank, placed on the analytic hill.
    std::vector<std::array<double, 3>> path;
    for (int k = 0; k <= 8; ++k) {
        const double x = -2 + 0.5 * k, z = 0.3 * std::sin(k * 0.7);
        path.push_back({x, hill_height(x, z) + 0.25 - 0.08, z});
    }
    cs.push_back(sphere(0.25, path));
    cs.push_back(box({0.4, 0.3, 0.4}, 25, {{0.8, hill_height(0.8, 1.2) + 0.15 - 0.05, 1.2}}));
    StampOptions o;
    o.snow.texel = 0.01;
    o.snow.rim_width = 0.1;
    o.snow.conserve_volume = true;
    StampReport rep;
    ASSERT_TRUE(stamp_scene(scene, set_of(cs), o, &rep).ok());
    EXPECT_EQ(rep.stats.contacts, 10u);
    EXPECT_EQ(rep.overhang_triangles, 0u);
    EXPECT_NEAR(rep.raised_volume, 0.7 * rep.removed_volume, 0.01 * rep.removed_volume);
    const Primitive& out = scene.meshes[0].primitives[0];
    expect_watertight_sheet(out);
    for (size_t k = 0; k < out.normals.size(); k += 3)
        ASSERT_NEAR(std::hypot(out.normals[k], out.normals[k + 1], out.normals[k + 2]), 1.0, 1e-5);
    const auto file = temp_dir() / "hill.glb";
    ASSERT_TRUE(save_scene(scene, file.string()).ok());
    EXPECT_VALID_GLTF(file);
}

TEST(StampScene, UvSeamGroundHasNoCracks) {
    Scene scene = ground_scene(seam_ground(4, 16));
    // A trail straight along the seam (x = 0) and a footprint-like image across it.
    Collider img = image(16, 32, 0.3, 0.5, 0.05, 90, {0, 0, 1.2}, [](int i, int j) { return ((i / 2 + j / 3) % 2) ? 1.0 : 0.6; });
    StampReport rep;
    StampOptions o;
    o.snow.texel = 0.01;
    ASSERT_TRUE(stamp_scene(scene, set_of({sphere(0.3, {{0, 0.22, -1.5}, {0, 0.22, 0.5}}), img}), o, &rep).ok());
    const Primitive& out = scene.meshes[0].primitives[0];
    ASSERT_EQ(out.uv0.size() / 2, out.vertex_count());
    expect_watertight_sheet(out);
    // The seam is still there (split UVs), and its copies share positions and normals bit for bit.
    std::map<std::array<float, 3>, std::vector<size_t>> at;
    for (size_t v = 0; v < out.vertex_count(); ++v)
        at[{out.positions[3 * v], out.positions[3 * v + 1], out.positions[3 * v + 2]}].push_back(v);
    size_t split = 0;
    for (const auto& [pos, vs] : at) {
        if (vs.size() < 2) continue;
        ++split;
        for (size_t v : vs)
            for (int d = 0; d < 3; ++d) EXPECT_EQ(out.normals[3 * v + size_t(d)], out.normals[3 * vs[0] + size_t(d)]);
    }
    EXPECT_GT(split, 17u); // more seam points than the input's column: the seam was tessellated too
    const auto file = temp_dir() / "seam.gltf";
    ASSERT_TRUE(save_scene(scene, file.string()).ok());
    EXPECT_VALID_GLTF(file);
}

TEST(StampScene, NoContactLeavesTheSceneUnchanged) {
    Scene scene = ground_scene(hill_ground(4, 16));
    const Scene before = scene;
    StampReport rep;
    Heightmap h;
    ASSERT_TRUE(stamp_scene(scene, set_of({sphere(0.2, {{0, 3, 0}, {1, 3, 0}})}), StampOptions{}, &rep, &h).ok());
    EXPECT_FALSE(rep.changed);
    EXPECT_EQ(rep.stats.contacts, 0u);
    EXPECT_EQ(rep.stats.samples, 2u);
    EXPECT_EQ(scene.meshes[0].primitives[0].positions, before.meshes[0].primitives[0].positions);
    EXPECT_EQ(scene.meshes[0].primitives[0].indices, before.meshes[0].primitives[0].indices);
    EXPECT_EQ(scene.meshes[0].primitives[0].normals, before.meshes[0].primitives[0].normals);
    for (float v : h.values) ASSERT_EQ(v, 0.0f);
}

// scene_triangles reads an index out of range as a degenerate corner, but the ground is written back with its
// own indices: an ok stamp used to return a scene with the bad index still in it (found by fuzz_stamp).
TEST(StampScene, IndexOutOfRangeIsAnError) {
    Scene scene = ground_scene(flat_ground(2, 4));
    scene.meshes[0].primitives[0].indices[4] = 1000;
    Status s = stamp_scene(scene, set_of({sphere(0.3, {{0, 0.2, 0}})}), StampOptions{});
    EXPECT_EQ(s.code, StatusCode::invalid_input);
    EXPECT_NE(s.message.find("index 1000"), std::string::npos) << s.message;
}

TEST(StampScene, WarnsAboutOverhangs) {
    Primitive g = flat_ground(4, 8);
    const uint32_t b = uint32_t(g.vertex_count());
    g.positions.insert(g.positions.end(), {1, 1, -1, -1, 1, -1, -1, 1, 1});
    g.normals.insert(g.normals.end(), {0, -1, 0, 0, -1, 0, 0, -1, 0});
    g.uv0.insert(g.uv0.end(), {0, 0, 0, 0, 0, 0});
    g.indices.insert(g.indices.end(), {b, b + 2, b + 1}); // facing down
    Scene scene = ground_scene(g);
    StampReport rep;
    ASSERT_TRUE(stamp_scene(scene, set_of({sphere(0.3, {{1.5, 0.25, 1.5}})}), StampOptions{}, &rep).ok());
    EXPECT_EQ(rep.overhang_triangles, 1u);
    bool warned = false;
    for (const auto& w : rep.warnings) warned = warned || w.find("overhang") != std::string::npos;
    EXPECT_TRUE(warned);
    EXPECT_TRUE(rep.changed);
}

TEST(StampScene, KeepsTheSceneAndTransformsToWorldSpace) {
    // The ground drawn by a scaled, translated node; colliders are in world space.
    Scene scene = ground_scene(flat_ground(2, 4));
    scene.nodes[0].translation = {10, 1, 0};
    scene.nodes[0].scale = {2, 1, 2};
    StampReport rep;
    StampOptions o;
    o.snow.texel = 0.01;
    ASSERT_TRUE(stamp_scene(scene, set_of({sphere(0.3, {{10.5, 1.2, 0.5}})}), o, &rep).ok());
    EXPECT_TRUE(rep.changed);
    ASSERT_EQ(scene.meshes.size(), 1u);
    ASSERT_EQ(scene.materials.size(), 1u);
    EXPECT_EQ(scene.meshes[0].primitives[0].material, 0);
    EXPECT_EQ(scene.nodes[0].translation, (std::array<double, 3>{10, 1, 0}));
    // The imprint's bottom in object space: world (10.5, 1.2 − 0.3, 0.5) -> object (0.25, −0.1, 0.25).
    float lowest = 1;
    std::array<float, 3> at{};
    const auto& P = scene.meshes[0].primitives[0].positions;
    for (size_t k = 0; k < P.size(); k += 3)
        if (P[k + 1] < lowest) lowest = P[k + 1], at = {P[k], P[k + 1], P[k + 2]};
    EXPECT_NEAR(lowest, -0.1f, 1e-3);
    EXPECT_NEAR(at[0], 0.25f, 0.01);
    EXPECT_NEAR(at[2], 0.25f, 0.01);
}

TEST(StampScene, AMeshDrawnTwiceGetsACopyPerNode) {
    Scene scene = ground_scene(flat_ground(2, 4));
    Node second = scene.nodes[0];
    second.name = "ground2";
    second.translation = {5, 0, 0};
    scene.nodes.push_back(second);
    scene.roots.push_back(1);
    StampReport rep;
    ASSERT_TRUE(stamp_scene(scene, set_of({sphere(0.3, {{0.2, 0.2, 0}})}), StampOptions{}, &rep).ok());
    ASSERT_EQ(scene.meshes.size(), 2u);
    EXPECT_EQ(scene.nodes[1].mesh, 1);
    // Only the first copy (under the sphere) is pressed.
    auto lowest = [](const Mesh& m) {
        float lo = 1;
        for (size_t k = 1; k < m.primitives[0].positions.size(); k += 3) lo = std::min(lo, m.primitives[0].positions[k]);
        return lo;
    };
    EXPECT_LT(lowest(scene.meshes[0]), -0.05f);
    EXPECT_EQ(lowest(scene.meshes[1]), 0.0f);
}

TEST(StampScene, MemoryGuardIsAnError) {
    Scene scene = ground_scene(flat_ground(20, 1));
    StampOptions o;
    o.snow.texel = 0.001;
    o.snow.max_bytes = size_t(64) << 20;
    Status s = stamp_scene(scene, set_of({sphere(0.3, {{0, 0.2, 0}})}), o);
    EXPECT_EQ(s.code, StatusCode::out_of_memory);
}

TEST(StampFiles, StampsTheBundledSnowField) {
    Scene scene;
    StampReport rep;
    StampOptions o;
    o.snow.rim_width = 0.08;
    Status s = stamp_files(scene, (models_dir() / "ground.glb").string(), (models_dir() / "colliders.json").string(), o, &rep);
    ASSERT_TRUE(s.ok()) << s.message;
    EXPECT_EQ(rep.stats.contacts, rep.stats.samples); // every collider was placed on the ground
    EXPECT_EQ(rep.stats.samples, 20u + 17u + 1u + 7u);
    EXPECT_GT(rep.max_depth, 0.05);
    EXPECT_EQ(scene.materials.size(), 1u);
    EXPECT_EQ(scene.materials[0].name, "snow");
    EXPECT_EQ(scene.nodes[0].name, "ground");
    ASSERT_FALSE(scene.meshes[0].primitives[0].uv0.empty());
    expect_watertight_sheet(scene.meshes[0].primitives[0]);
    const auto file = temp_dir() / "snow.glb";
    ASSERT_TRUE(save_scene(scene, file.string()).ok());
    EXPECT_VALID_GLTF(file);
}

namespace {

// A 40 m ground turned 10° about up and drawn at `offset` (the node holds the offset in double, as a recentred
// load leaves it), stamped by a sphere 0.15 m deep at (3, ·, −2) from the ground's centre.
struct FarStamp {
    Scene before, after;
    StampReport rep;
    std::array<double, 16> M{};
};
FarStamp stamp_far(std::array<double, 3> offset) {
    FarStamp f;
    f.before = ground_scene(flat_ground(40, 80));
    const double a = 10 * 3.14159265358979323846 / 180;
    f.before.nodes[0].rotation = {0, std::sin(a / 2), 0, std::cos(a / 2)};
    f.before.nodes[0].translation = offset;
    f.after = f.before;
    StampOptions o;
    o.snow.resolution = 512;
    const double r = 0.5, p = 0.15;
    Status s = stamp_scene(f.after, set_of({sphere(r, {{offset[0] + 3, offset[1] + r - p, offset[2] - 2}})}), o, &f.rep);
    EXPECT_TRUE(s.ok()) << s.message;
    f.M = f.after.world_matrices()[0];
    return f;
}

std::array<double, 3> world_of(const std::array<double, 16>& M, const float* p) {
    return {M[0] * p[0] + M[4] * p[1] + M[8] * p[2] + M[12], M[1] * p[0] + M[5] * p[1] + M[9] * p[2] + M[13],
            M[2] * p[0] + M[6] * p[1] + M[10] * p[2] + M[14]};
}

// Worst and mean vertical deviation from the analytic imprint, in double, relative to the ground's centre.
std::pair<double, double> far_imprint_deviation(const FarStamp& f, std::array<double, 3> offset) {
    const Primitive& g = f.after.meshes[0].primitives[0];
    double worst = 0, sum = 0;
    for (size_t v = 0; v < g.vertex_count(); ++v) {
        const auto w = world_of(f.M, &g.positions[3 * v]);
        const double x = w[0] - offset[0], y = w[1] - offset[1], z = w[2] - offset[2];
        const double e = std::abs(y - sphere_imprint(0.5, 0.15, std::hypot(x - 3, z + 2)));
        worst = std::max(worst, e);
        sum += e;
    }
    return {worst, sum / double(g.vertex_count())};
}

} // namespace

// Far from the origin (1e5 m, and UTM-like 5e5 / −5.4e6 m) every ground point no print touches is bit-identical
// in world space, and the imprint is as exact as at the origin: world positions were once built in float32
// (steps of 8 mm at 1e5 m, 0.5 m at 5e6 m), which moved every vertex by millimetres to decimetres.
TEST(StampScene, FarFromOriginUntouchedPointsAreBitIdentical) {
    const FarStamp home = stamp_far({0, 0, 0});
    const auto [home_worst, home_mean] = far_imprint_deviation(home, {0, 0, 0});
    EXPECT_LT(home_worst, 0.03); // texels of 9 cm (512 over the turned 40 m ground); the worst sits at the kink
    for (const std::array<double, 3> offset : {std::array<double, 3>{1e5, 12, 1e5}, std::array<double, 3>{5e5, 300, -5.4e6}}) {
        SCOPED_TRACE("offset " + std::to_string(offset[0]) + ", " + std::to_string(offset[2]));
        const FarStamp f = stamp_far(offset);
        ASSERT_TRUE(f.rep.changed);
        // The ground's frame is reported in world space.
        EXPECT_NEAR(f.rep.frame.origin[0], home.rep.frame.origin[0] + offset[0], 1e-6);
        EXPECT_NEAR(f.rep.frame.origin[2], home.rep.frame.origin[2] + offset[2], 1e-6);
        std::set<std::array<double, 3>> out;
        const Primitive& g = f.after.meshes[0].primitives[0];
        for (size_t v = 0; v < g.vertex_count(); ++v) out.insert(world_of(f.M, &g.positions[3 * v]));
        const Primitive& in = f.before.meshes[0].primitives[0];
        const auto M0 = f.before.world_matrices()[0];
        size_t untouched = 0, kept = 0;
        std::vector<double> moves; // of the points not kept: distance to the nearest output point
        for (size_t v = 0; v < in.vertex_count(); ++v) {
            const auto w = world_of(M0, &in.positions[3 * v]);
            if (std::hypot(w[0] - offset[0] - 3, w[2] - offset[2] + 2) < 1.0) continue; // the print and a ring
            ++untouched;
            if (out.count(w)) {
                ++kept;
                continue;
            }
            double nearest = INFINITY;
            for (const auto& q : out) nearest = std::min(nearest, std::hypot(q[0] - w[0], q[1] - w[1], q[2] - w[2]));
            moves.push_back(nearest);
        }
        EXPECT_GT(untouched, 6000u);
        std::sort(moves.begin(), moves.end());
        EXPECT_EQ(kept, untouched) << "untouched points moved: median " << (moves.empty() ? 0 : moves[moves.size() / 2]) << " m, max "
                                   << (moves.empty() ? 0 : moves.back()) << " m";
        // Touched points: the imprint as exact as at the origin, within 1e-6 of the ground's size.
        const auto [worst, mean] = far_imprint_deviation(f, offset);
        EXPECT_NEAR(worst, home_worst, 1e-6 * 40);
        EXPECT_NEAR(mean, home_mean, 1e-6 * 40);
        EXPECT_EQ(g.vertex_count(), home.after.meshes[0].primitives[0].vertex_count());
    }
}

// Authored normals are kept where the displacement did not change the surface: a ground with a hard edge
// (split normals along its middle column) stamped away from the edge keeps the edge, and keeps every normal
// away from the print; inside the print the normals are those of the displaced surface. (Once every normal
// was recomputed on welded points: the split vanished and a stamped box looked pillow-shaded.)
TEST(StampScene, KeepsAuthoredHardNormalsAwayFromThePrint) {
    Primitive g = seam_ground(4, 16);
    const float tilt[3] = {0.6f, 0.8f, 0.0f}, up[3] = {0, 1, 0};
    const size_t first_copy = size_t(17 * 17);
    for (size_t v = 0; v < g.vertex_count(); ++v) {
        const bool right = v >= first_copy || g.positions[3 * v] > 0;
        std::copy_n(right ? tilt : up, 3, &g.normals[3 * v]);
    }
    Scene scene = ground_scene(g);
    StampOptions o;
    o.snow.texel = 0.01;
    const double cx = -1.2, cz = 0.8;
    ASSERT_TRUE(stamp_scene(scene, set_of({sphere(0.3, {{cx, 0.2, cz}})}), o).ok());
    const Primitive& out = scene.meshes[0].primitives[0];
    ASSERT_EQ(out.normals.size(), out.positions.size());
    size_t far = 0, kept = 0, seam_up = 0, seam_tilt = 0, bent = 0;
    for (size_t v = 0; v < out.vertex_count(); ++v) {
        const float* p = &out.positions[3 * v];
        const float* n = &out.normals[3 * v];
        auto is = [&](const float* want) { return std::abs(n[0] - want[0]) < 1e-6f && std::abs(n[1] - want[1]) < 1e-6f && std::abs(n[2] - want[2]) < 1e-6f; };
        const double rho = std::hypot(p[0] - cx, p[2] - cz);
        if (rho > 0.08 && rho < 0.2) bent += n[1] < 0.995f; // the print's wall leans towards its centre
        if (rho < 0.6) continue;
        ++far;
        if (p[0] == 0) {
            seam_up += is(up);
            seam_tilt += is(tilt);
            kept += is(up) || is(tilt);
        } else {
            kept += is(p[0] > 0 ? tilt : up);
        }
    }
    EXPECT_GT(far, 250u);
    EXPECT_EQ(kept, far);
    EXPECT_GE(seam_up, 17u);
    EXPECT_EQ(seam_tilt, seam_up) << "each seam point keeps both of its normals";
    EXPECT_GT(bent, 0u) << "inside the print the normals follow the displaced surface";
}

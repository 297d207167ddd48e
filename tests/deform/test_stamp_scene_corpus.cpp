// stamp_scene on the corpus terrain (irregular triangulation, open boundary, slivers, textured).
#include "deform_test_util.h"
#include "test_support.h"

using namespace furrow;
using namespace furrow::test;

TEST(StampSceneCorpus, TerrainTrailHasNoCracksAndIsValid) {
    Scene scene;
    ASSERT_TRUE(load_scene(scene, corpus("terrain/terrain.glb").string()).ok());
    const CheckReport before = check_primitive(scene.meshes[0].primitives[0]);
    // Place a rolling ball and a line of boxes on the terrain with the field's own contact rays.
    std::vector<float> P;
    std::vector<uint32_t> I;
    scene_triangles(P, I, scene);
    SnowOptions so;
    so.texel = 0.02;
    SnowField probe = make_field([&] {
        Primitive g;
        g.positions = P;
        g.indices = I;
        return g;
    }(), so);
    ColliderSet set;
    Collider ball = sphere(0.25, {});
    // (The terrain covers only part of its square: a diagonal edge cuts a corner off.)
    for (int k = 0; k <= 12; ++k) {
        const double x = -4 + 0.4 * k, z = 2 + 1.5 * std::sin(0.5 * k);
        double h = 0;
        probe.cast_down(&h, std::array<double, 3>{x, 10, z}.data(), 1);
        ASSERT_FALSE(std::isnan(h)) << x << " " << z;
        ball.path.push_back({x, h + 0.25 - 0.06, z});
    }
    set.colliders.push_back(ball);
    for (int k = 0; k < 4; ++k) {
        const double x = -3.5 + 1.5 * k, z = 3.5;
        double h = 0;
        probe.cast_down(&h, std::array<double, 3>{x, 10, z}.data(), 1);
        ASSERT_FALSE(std::isnan(h)) << x << " " << z;
        set.colliders.push_back(box({0.4, 0.3, 0.4}, 20.0 * k, {{x, h + 0.15 - 0.04, z}}));
    }
    StampOptions o;
    o.snow.texel = 0.02;
    o.snow.rim_width = 0.1;
    o.snow.conserve_volume = true;
    StampReport rep;
    Status s = stamp_scene(scene, set, o, &rep);
    ASSERT_TRUE(s.ok()) << s.message;
    EXPECT_EQ(rep.stats.contacts, rep.stats.samples);
    EXPECT_NEAR(rep.raised_volume, 0.7 * rep.removed_volume, 0.01 * rep.removed_volume);
    const CheckReport after = check_primitive(scene.meshes[0].primitives[0]);
    EXPECT_EQ(after.boundary_loops, before.boundary_loops);
    EXPECT_EQ(after.non_manifold_edges, 0u);
    EXPECT_EQ(after.components, before.components);
    EXPECT_GT(after.triangles, before.triangles);
    const auto file = temp_dir() / "terrain_snow.glb";
    ASSERT_TRUE(save_scene(scene, file.string()).ok());
    EXPECT_VALID_GLTF(file);
}

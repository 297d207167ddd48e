// `furrow demo`: the main job runs on the bundled scene and writes valid glTF and non-empty previews.
#include "test_support.h"

#include <furrow/render.h>

#include <nlohmann/json.hpp>

#include <cmath>

using namespace furrow;
using namespace furrow::test;

TEST(demo_cli, WritesValidGltfAndPreviews) {
    const auto dir = temp_dir() / "out";
    RunResult r = run_furrow({"demo", "-o", dir.string(), "--ssaa", "1"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("furrow demo wrote"), std::string::npos);
    for (const char* glb : {"creature.glb", "creature_fur.glb", "ground.glb", "snow.glb", "terrain.glb", "scene.glb"}) {
        ASSERT_TRUE(std::filesystem::exists(dir / glb)) << glb;
        EXPECT_VALID_GLTF(dir / glb);
    }
    for (const char* png : {"creature_shaded.png", "creature_wireframe.png", "creature_fur_shaded.png", "ground_shaded.png",
                            "ground_wireframe.png", "snow_shaded.png", "snow_wireframe.png",
                            "terrain_shaded.png", "terrain_wireframe.png", "scene_shaded.png"}) {
        ImageF img;
        ASSERT_TRUE(load_png(img, (dir / png).string()).ok()) << png;
        EXPECT_EQ(img.channels, 4);
        // The previews have an opaque background (the top-left pixel); the model covers a real part of the
        // frame, but not all of it.
        size_t differs = 0, n = size_t(img.width) * size_t(img.height);
        for (size_t i = 0; i < n; ++i) {
            float d = 0;
            for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(img.pixels[i * 4 + size_t(c)] - img.pixels[size_t(c)]));
            differs += d > 0.05f;
            ASSERT_EQ(img.pixels[i * 4 + 3], 1.0f);
        }
        EXPECT_GT(double(differs) / double(n), 0.05) << png;
        EXPECT_LT(double(differs) / double(n), 0.95) << png;
    }
}

// The demo terrain is tessellated for its camera (models/scene.json: eye at (-9, 3, 9), 2 px, rate <= 8):
// one piece with one boundary loop, finer near the eye than far from it, far below the uniform rate-8 count.
TEST(demo_cli, TerrainIsAdaptiveAndCrackFree) {
    const auto dir = temp_dir() / "out";
    RunResult r = run_furrow({"demo", "-o", dir.string(), "--ssaa", "1"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    Scene s;
    ASSERT_TRUE(load_scene(s, (dir / "terrain.glb").string()).ok());
    ASSERT_EQ(s.meshes.size(), 1u);
    const Primitive& p = s.meshes[0].primitives[0];
    CheckReport c = check_primitive(p);
    EXPECT_EQ(c.non_manifold_edges, 0u);
    EXPECT_EQ(c.boundary_loops, 1u);
    EXPECT_EQ(c.nan_values, 0u);
    const size_t base = 8192, uniform8 = base * 64;
    EXPECT_GT(c.triangles, base * 4) << "the near side should be refined";
    EXPECT_LT(c.triangles, uniform8 / 2) << "the far side should stay coarse";
    // Mean edge length of triangles within 6 m of the eye vs beyond 18 m (ground is 20 x 20 m).
    const double eye[3] = {-9, 3, 9};
    double near_sum = 0, far_sum = 0;
    size_t near_n = 0, far_n = 0;
    auto at = [&](uint32_t v, int d) { return double(p.positions[size_t(v) * 3 + size_t(d)]); };
    for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
        const uint32_t a = p.indices[t], b = p.indices[t + 1];
        double dist = 0, len = 0;
        for (int d = 0; d < 3; ++d) {
            dist += (at(a, d) - eye[d]) * (at(a, d) - eye[d]);
            len += (at(a, d) - at(b, d)) * (at(a, d) - at(b, d));
        }
        dist = std::sqrt(dist);
        len = std::sqrt(len);
        if (dist < 6) near_sum += len, ++near_n;
        if (dist > 18) far_sum += len, ++far_n;
    }
    ASSERT_GT(near_n, 0u);
    ASSERT_GT(far_n, 0u);
    EXPECT_LT(near_sum / double(near_n), 0.5 * far_sum / double(far_n));
}

TEST(demo_cli, MissingSceneDescriptionIsAnError) {
    const auto dir = temp_dir();
    RunResult r = run_furrow({"demo", "--models", dir.string(), "-o", (dir / "out").string()});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.err.rfind("Error: ", 0), 0u) << r.err;
}

// The combined scene (models/scene.json "scene"): the furred creature stands where the scene puts it, turned
// to its heading, its paws in the snow, and every print of its trail is pressed into the ground as deep as
// the scene asks (the bottom of each paw ball, within a centimetre).
TEST(demo_cli, CombinedSceneHasTheFurredCreatureInItsOwnTrail) {
    const auto dir = temp_dir() / "out";
    RunResult r = run_furrow({"demo", "-o", dir.string(), "--ssaa", "1", "-q"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    Scene s;
    ASSERT_TRUE(load_scene(s, (dir / "scene.glb").string()).ok());
    const auto desc = nlohmann::json::parse(read_text(models_dir() / "scene.json"));
    const auto& d = desc["scene"];
    // The creature's subtree and the rest (the snow).
    int place = -1;
    for (size_t n = 0; n < s.nodes.size(); ++n)
        if (s.nodes[n].name == "creature_in_snow") place = int(n);
    ASSERT_GE(place, 0);
    const auto position = d["position"].get<std::array<double, 3>>();
    EXPECT_EQ(s.nodes[size_t(place)].translation, position);
    std::vector<uint8_t> in_creature(s.nodes.size(), 0);
    std::vector<int> stack{place};
    while (!stack.empty()) {
        const int n = stack.back();
        stack.pop_back();
        in_creature[size_t(n)] = 1;
        for (int c : s.nodes[size_t(n)].children) stack.push_back(c);
    }
    size_t shells = 0;
    for (const Material& m : s.materials) shells += m.alpha_mode == AlphaMode::mask;
    EXPECT_GE(shells, 32u) << "the creature keeps its fur";
    std::vector<std::array<double, 3>> snow;
    const auto world = s.world_matrices();
    double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
    for (int n : s.drawn_nodes()) {
        if (s.nodes[size_t(n)].mesh < 0) continue;
        const auto M = s.mesh_placement(n, world);
        for (const Primitive& p : s.meshes[size_t(s.nodes[size_t(n)].mesh)].primitives)
            for (size_t v = 0; v < p.vertex_count(); ++v) {
                const float* q = &p.positions[3 * v];
                const std::array<double, 3> w{M[0] * q[0] + M[4] * q[1] + M[8] * q[2] + M[12], M[1] * q[0] + M[5] * q[1] + M[9] * q[2] + M[13],
                                              M[2] * q[0] + M[6] * q[1] + M[10] * q[2] + M[14]};
                if (!in_creature[size_t(n)]) {
                    snow.push_back(w);
                    continue;
                }
                for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], w[size_t(k)]), hi[k] = std::max(hi[k], w[size_t(k)]);
            }
    }
    const auto P = d["position"].get<std::array<double, 3>>();
    EXPECT_NEAR(0.5 * (lo[0] + hi[0]), P[0], 0.1);
    EXPECT_NEAR(0.5 * (lo[2] + hi[2]), P[2], 0.1);
    EXPECT_NEAR(lo[1], P[1], 0.03) << "the soles at the placed height";
    // Heading 90°: the creature is longer along x (nose to tail) than across.
    EXPECT_GT(hi[0] - lo[0], hi[2] - lo[2]);
    size_t prints = 0;
    for (const auto& c : d["trail"]["colliders"]) {
        const auto centre = c["path"][0].get<std::array<double, 3>>();
        const double bottom = centre[1] - c["radius"].get<double>();
        double lowest = 1e9;
        for (const auto& w : snow)
            if (std::hypot(w[0] - centre[0], w[2] - centre[2]) < 0.03) lowest = std::min(lowest, w[1]);
        EXPECT_NEAR(lowest, bottom, 0.01) << "print at " << centre[0] << ", " << centre[2];
        ++prints;
    }
    EXPECT_EQ(prints, 24u);
}

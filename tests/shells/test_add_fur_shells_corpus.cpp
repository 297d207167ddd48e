// add_fur_shells on the shared corpus and the bundled creature: cracks at real seams and hard edges, no new
// intersections, validator-clean output including the skinned, animated Fox.
#include "shells_test_util.h"
#include "test_support.h"

#include <furrow/shells.h>
#include <gtest/gtest.h>

namespace furrow {
namespace {

namespace fs = std::filesystem;

Scene load(const fs::path& file) {
    Scene s;
    Status st = load_scene(s, file.string());
    EXPECT_TRUE(st.ok()) << file << ": " << st.message;
    return s;
}

double diagonal(const Primitive& p) { return check_primitive(p).diagonal; }

// Convex hard edges (BoxTextured: a unit cube, split faces): every vertex of shell i, its corners included,
// lies on the cube grown by that shell's height, so every shell face is parallel to its base face at its
// height (±5 %). Before, the corners moved by L along the diagonal and the top shell's faces sat 0.58 L out.
TEST(add_fur_shells_corpus, CubeShellsAreAtTheirHeightOverHardEdges) {
    Scene s = load(test::corpus("box_textured/BoxTextured.gltf"));
    ASSERT_EQ(s.meshes.size(), 1u);
    FurOptions o;
    o.shells.layers = 8;
    o.shells.length = 0.05;
    FurReport rep;
    o.keep_frames = true;
    ASSERT_TRUE(add_fur_shells(s, o, &rep).ok());
    const double L = rep.frames[0].length; // object units
    const auto& prims = s.meshes[0].primitives;
    ASSERT_EQ(prims.size(), 1u + 8u);
    for (int i = 1; i <= 8; ++i) {
        const double want = L * shell_height_fraction(i, 8, 1.0);
        const Primitive& shell = prims[size_t(i)];
        for (size_t v = 0; v < shell.vertex_count(); ++v) {
            const float* p = &shell.positions[3 * v];
            const double out = std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2])}) - 0.5;
            ASSERT_NEAR(out, want, 0.05 * want) << "shell " << i << " vertex " << v;
        }
    }
}

TEST(add_fur_shells_corpus, NoCracksAtSeamsAndHardEdges) {
    for (const char* file : {"box_textured/BoxTextured.gltf", "duck/Duck.glb", "spot/spot_triangulated.obj", "fox/Fox.glb"}) {
        Scene s = load(test::corpus(file));
        ASSERT_FALSE(s.meshes.empty()) << file;
        const Primitive base = s.meshes[0].primitives[0];
        const CheckReport b = check_primitive(base);
        ASSERT_LT(b.welded_vertices, base.vertex_count()) << file << ": the case must have split copies";
        FurOptions o;
        o.shells.layers = 8;
        o.shells.length = 1.0; // converted to object units below
        o.keep_frames = true;
        FurReport probe;
        {
            Scene t = s;
            ASSERT_TRUE(add_fur_shells(t, o, &probe).ok()) << file;
        }
        // 3 % of the object-space diagonal, in world units.
        o.shells.length = 0.03 * diagonal(base) / probe.frames[0].length;
        FurReport r;
        ASSERT_TRUE(add_fur_shells(s, o, &r).ok()) << file;
        ASSERT_FALSE(r.frames.empty());
        const FurFrame& f = r.frames[0];
        // The base the shells grew from: the input, or its refinement where clamps starved coarse faces
        // (r.refined_faces; the Fox's paws).
        const Primitive grown_base = s.meshes[0].primitives[0];
        EXPECT_EQ(test::cracked_positions(grown_base, f.frame, 8), 0u) << file;
        // The shells as written: welded, each has the positions of the base triangles it keeps (those with
        // some fur; a self-intersecting input like the Duck gets bald spots) and the same border.
        Primitive kept = grown_base;
        triangulate(kept);
        kept.indices.clear();
        for (size_t t = 0; t + 3 <= f.triangles.size(); t += 3)
            if (f.frame.length[f.triangles[t]] > 0 || f.frame.length[f.triangles[t + 1]] > 0 || f.frame.length[f.triangles[t + 2]] > 0)
                kept.indices.insert(kept.indices.end(), {f.triangles[t], f.triangles[t + 1], f.triangles[t + 2]});
        if (r.bald_vertices == 0) {
            EXPECT_EQ(kept.indices.size(), f.triangles.size()) << file;
        }
        const size_t kept_border = check_primitive(kept).boundary_edges;
        for (size_t i = 1; i < s.meshes[0].primitives.size(); ++i) {
            const Primitive& shell = s.meshes[0].primitives[i];
            EXPECT_EQ(test::used_positions(shell), test::used_positions(kept)) << file << " shell " << i;
            EXPECT_EQ(check_primitive(shell).boundary_edges, kept_border) << file << " shell " << i;
        }
    }
}

TEST(add_fur_shells_corpus, ShellsAddNoIntersection) {
    struct Item {
        const char* file;
        double relative_length;
        bool t_junctions = false;
    };
    // 70375 is a 1 mm plate (any inward offset above 0.5 mm crosses it); bunny_closed has valence-16 fans.
    for (Item it : {Item{"thingi10k_70375/70375.stl", 0.05, true}, Item{"spot/spot_triangulated.obj", 0.05},
                    Item{"bunny_closed/bunny.off", 0.08}, Item{"duck/Duck.glb", 0.05}}) {
        Scene s = load(test::corpus(it.file));
        Primitive base = s.meshes[0].primitives[0];
        triangulate(base);
        ShellOptions o;
        o.layers = 4;
        o.length = it.relative_length * diagonal(base);
        ShellFrame f;
        ASSERT_TRUE(compute_shell_frame(f, base.positions.data(), base.vertex_count(), base.indices.data(), base.indices.size(),
                                        nullptr, nullptr, o)
                        .ok());
        const long long own = test::intersecting_pairs(base);
        // 70375's own contacts are T-junctions (a vertex lying on another face). The shells' bald corners sit
        // on them, so each of the 4 layers touches the same points, and nothing else: fur grows beside them
        // (once it was cut to nothing around every such point, which left printed shelves bald).
        const long long expected = it.t_junctions ? own * (1 + 4) : own;
        EXPECT_EQ(test::intersecting_pairs(test::merged_shells(base, f, 4)), expected) << it.file;
    }
}

TEST(add_fur_shells_corpus, FoxKeepsItsSkinAndValidates) {
    Scene s = load(test::corpus("fox/Fox.glb"));
    const size_t nodes = s.nodes.size();
    FurOptions o;
    o.shells.layers = 8;
    o.shells.length = 3; // the Fox is in centimetres
    o.shells.droop = 0.5;
    o.fins = true;
    o.shells.lod_levels = 2;
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, o, &r).ok());
    int skinned = -1;
    for (size_t i = 0; i < nodes; ++i)
        if (s.nodes[i].mesh >= 0) skinned = int(i);
    ASSERT_GE(skinned, 0);
    EXPECT_GE(s.nodes[size_t(skinned)].skin, 0);
    for (const Primitive& p : s.meshes[size_t(s.nodes[size_t(skinned)].mesh)].primitives) EXPECT_EQ(p.joints.size(), 4 * p.vertex_count());
    fs::path out = test::temp_dir() / "fox_fur.glb";
    ASSERT_TRUE(save_scene(s, out.string()).ok());
    EXPECT_VALID_GLTF(out);
    auto j = test::gltf_json(out);
    EXPECT_EQ(j["animations"].size(), 3u); // animations kept
}

TEST(add_fur_shells_corpus, CreatureWithItsMaskValidates) {
    Scene s = load(test::models_dir() / "creature.glb");
    FurOptions o;
    o.shells.layers = 16;
    o.shells.length = 0.04;
    ASSERT_TRUE(load_png(o.mask, (test::models_dir() / "creature_fur_mask.png").string()).ok());
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, o, &r).ok());
    EXPECT_GT(r.bald_vertices, 0u);        // nose and eyes
    EXPECT_GT(r.dropped_triangles, 0u);
    fs::path out = test::temp_dir() / "creature_fur.glb";
    ASSERT_TRUE(save_scene(s, out.string()).ok());
    EXPECT_VALID_GLTF(out);
}

} // namespace
} // namespace furrow

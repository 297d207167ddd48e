// add_fur_shells: layouts, materials, masks, fins, LOD, skins and morph targets, rendering, validity.
#include "shells_test_util.h"
#include "test_support.h"

#include <furrow/render.h>
#include <furrow/shapes.h>
#include <furrow/shells.h>
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <cmath>
#include <map>
#include <set>

namespace furrow {
namespace {

namespace fs = std::filesystem;

Scene sphere_scene(float radius = 0.5f) {
    Scene s = make_scene(shapes::uv_sphere(radius, 32, 16), "sphere");
    Material m;
    m.name = "skin";
    m.base_color = {0.8f, 0.4f, 0.2f, 1.0f};
    m.metallic = 0;
    s.materials.push_back(m);
    s.meshes[0].primitives[0].material = 0;
    return s;
}

FurOptions fur(int layers, double length) {
    FurOptions o;
    o.shells.layers = layers;
    o.shells.length = length;
    return o;
}

fs::path save_valid(const Scene& s, const std::string& name) {
    fs::path file = test::temp_dir() / name;
    Status st = save_scene(s, file.string());
    EXPECT_TRUE(st.ok()) << st.message;
    EXPECT_VALID_GLTF(file);
    return file;
}

TEST(add_fur_shells, ViewerLayoutHasOneMaskMaterialPerShellWithRisingCutoff) {
    Scene s = sphere_scene();
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, fur(4, 0.05), &r).ok());
    const Mesh& mesh = s.meshes[0];
    ASSERT_EQ(mesh.primitives.size(), 5u); // the skin + 4 shells
    EXPECT_EQ(mesh.primitives[0].material, 0); // the skin is untouched
    float previous = 0;
    for (int i = 1; i <= 4; ++i) {
        const Primitive& p = mesh.primitives[size_t(i)];
        const Material& m = s.materials[size_t(p.material)];
        EXPECT_EQ(m.alpha_mode, AlphaMode::mask);
        EXPECT_NEAR(m.alpha_cutoff, (i - 0.5f) / 4.0f, 1e-6); // mid-slab
        EXPECT_GT(m.alpha_cutoff, previous);
        previous = m.alpha_cutoff;
        EXPECT_EQ(m.base_color_texture.texcoord, 1);
        EXPECT_EQ(m.metallic, 0.0f);
        EXPECT_EQ(p.uv1.size(), 2 * p.vertex_count());
        ASSERT_EQ(p.colors.size(), 4 * p.vertex_count());
        // Albedo × root shade: darker toward the roots, the material's colour at the tips.
        const float shade = float(0.45 + 0.55 * (i / 4.0));
        EXPECT_NEAR(p.colors[0], 0.8f * shade, 1e-5);
        EXPECT_NEAR(p.colors[1], 0.4f * shade, 1e-5);
        EXPECT_EQ(p.joints.size(), 0u);
    }
    EXPECT_EQ(r.shell_primitives, 4u);
    EXPECT_EQ(r.shell_triangles, 4 * mesh.primitives[0].triangle_count());
    EXPECT_EQ(r.dropped_triangles, 0u);
    save_valid(s, "viewer.glb");
}

TEST(add_fur_shells, ShellsOfAClosedMeshAreClosedWhenWelded) {
    // The output-side crack check: a crack would show up as boundary edges of the welded shell.
    Scene s = make_scene(shapes::torus(1.0f, 0.4f, 32, 16));
    ASSERT_TRUE(add_fur_shells(s, fur(6, 0.1)).ok());
    const CheckReport base = check_primitive(s.meshes[0].primitives[0]);
    ASSERT_TRUE(base.closed);
    for (size_t i = 1; i < s.meshes[0].primitives.size(); ++i) {
        CheckReport c = check_primitive(s.meshes[0].primitives[i]);
        EXPECT_EQ(c.boundary_edges, 0u) << "shell " << i;
        EXPECT_EQ(c.welded_vertices, base.welded_vertices) << "shell " << i;
    }
}

TEST(add_fur_shells, EngineLayoutCarriesFurAttributes) {
    Scene s = sphere_scene();
    FurOptions o = fur(6, 0.05);
    o.layout = ShellLayout::engine;
    ASSERT_TRUE(add_fur_shells(s, o).ok());
    ASSERT_EQ(s.meshes[0].primitives.size(), 2u);
    const Primitive& p = s.meshes[0].primitives[1];
    const size_t m = s.meshes[0].primitives[0].vertex_count();
    ASSERT_EQ(p.vertex_count(), 6 * m);
    ASSERT_EQ(p.custom.size(), 3u);
    EXPECT_EQ(p.custom[0].name, "_FUR_LAYER");
    EXPECT_EQ(p.custom[1].name, "_FUR_LENGTH");
    EXPECT_EQ(p.custom[2].name, "_FUR_DIRECTION");
    EXPECT_EQ(p.custom[2].components, 3);
    EXPECT_FLOAT_EQ(p.custom[0].values[0], 1.0f / 6.0f);
    EXPECT_FLOAT_EQ(p.custom[0].values[6 * m - 1], 1.0f);
    // Position = base + layer × length × direction: back on the sphere (no clamp, no comb, no droop).
    for (size_t j = 2 * m; j < 3 * m; ++j) { // shell 3 of 6
        double r2 = 0;
        for (int k = 0; k < 3; ++k) {
            double x = p.positions[3 * j + k] - 0.5 * p.custom[1].values[j] * p.custom[2].values[3 * j + k];
            r2 += x * x;
        }
        EXPECT_NEAR(std::sqrt(r2), 0.5, 1e-4) << j;
        EXPECT_NEAR(p.custom[1].values[j], 0.05f, 2e-3);
    }
    save_valid(s, "engine.glb");
}

TEST(add_fur_shells, FinsStandOnEveryManifoldEdge) {
    Scene s = sphere_scene();
    FurOptions o = fur(4, 0.05);
    o.fins = true;
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, o, &r).ok());
    const CheckReport base = check_primitive(s.meshes[0].primitives[0]);
    const size_t edges = 3 * base.welded_vertices - 6; // closed genus 0: E = 3V − 6
    EXPECT_EQ(r.fin_quads, edges);
    const Primitive& fins = s.meshes[0].primitives.back();
    ASSERT_EQ(fins.vertex_count(), 4 * edges);
    ASSERT_EQ(fins.custom.size(), 1u);
    EXPECT_EQ(fins.custom[0].name, "_FUR_FIN_NORMAL");
    const Material& m = s.materials[size_t(fins.material)];
    EXPECT_TRUE(m.double_sided);
    EXPECT_EQ(m.alpha_mode, AlphaMode::mask);
    save_valid(s, "fins.glb");
}

TEST(add_fur_shells, LodLevelsHaveFewerShellsAndThickerCutoffs) {
    Scene s = sphere_scene();
    FurOptions o = fur(8, 0.05);
    o.shells.lod_levels = 3;
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, o, &r).ok());
    ASSERT_EQ(s.meshes.size(), 3u);
    EXPECT_EQ(s.meshes[0].primitives.size(), 9u);
    EXPECT_EQ(s.meshes[1].primitives.size(), 5u);
    EXPECT_EQ(s.meshes[2].primitives.size(), 3u);
    ASSERT_EQ(r.lod_nodes.size(), 2u);
    for (int n : r.lod_nodes)
        for (int root : s.roots) EXPECT_NE(n, root); // outside the default scene
    // Level 2's shell 1 sits at height 1/2 but shows the strands from 1/16 up, like level 0's first shell:
    // thicker strands for the thicker slab.
    const Primitive& lod2_first = s.meshes[2].primitives[1];
    EXPECT_NEAR(s.materials[size_t(lod2_first.material)].alpha_cutoff, 1.0f / 16.0f, 1e-6);
    const Primitive& lod2_last = s.meshes[2].primitives[2];
    EXPECT_NEAR(s.materials[size_t(lod2_last.material)].alpha_cutoff, 9.0f / 16.0f, 1e-6);
    EXPECT_LT(s.materials[size_t(lod2_last.material)].alpha_cutoff,
              s.materials[size_t(s.meshes[0].primitives[8].material)].alpha_cutoff);
    // A far level's shells sit at heights of level 0's shells, over the same base: the file writes their
    // positions, colours, texture coordinates and triangles once (save_scene shares equal accessors).
    const nlohmann::json j = test::gltf_json(save_valid(s, "lod.glb"));
    std::set<int> positions, others;
    for (size_t m = 0; m < 3; ++m)
        for (const auto& p : j["meshes"][m]["primitives"]) {
            positions.insert(p["attributes"]["POSITION"].get<int>());
            if (m > 0) others.insert(p["attributes"]["POSITION"].get<int>());
        }
    EXPECT_EQ(positions.size(), 9u); // the base and level 0's 8 shells
    for (const auto& p : j["meshes"][0]["primitives"]) others.erase(p["attributes"]["POSITION"].get<int>());
    EXPECT_TRUE(others.empty()); // every far level's positions are level 0's
}

TEST(add_fur_shells, SkinsAndMorphTargetsAreCarried) {
    Primitive p = shapes::box(1, 1, 1, true);
    const size_t n = p.vertex_count();
    p.joints.resize(4 * n);
    p.weights.resize(4 * n);
    MorphTarget t;
    for (size_t v = 0; v < n; ++v) {
        p.joints[4 * v] = 0, p.joints[4 * v + 1] = 1;
        float w = p.positions[3 * v + 1] > 0 ? 0.8f : 0.2f;
        p.weights[4 * v] = w, p.weights[4 * v + 1] = 1 - w;
        t.position_deltas.insert(t.position_deltas.end(), {0, 0.1f * p.positions[3 * v + 1], 0});
        t.normal_deltas.insert(t.normal_deltas.end(), {0, 0, 0});
    }
    p.targets.push_back(t);
    Scene s = make_scene(p, "skinned");
    s.meshes[0].weights = {0.5f};
    Node j0, j1;
    j0.name = "root_joint";
    j0.children = {2};
    j1.name = "child_joint";
    j1.translation = {0, 0.5, 0};
    s.nodes.push_back(j0);
    s.nodes.push_back(j1);
    s.roots.push_back(1);
    Skin skin;
    skin.joints = {1, 2};
    skin.inverse_bind_matrices = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -0.5f, 0, 1};
    s.skins.push_back(skin);
    s.nodes[0].skin = 0;
    FurOptions o = fur(4, 0.05);
    o.fins = true;
    o.shells.lod_levels = 2;
    ASSERT_TRUE(add_fur_shells(s, o).ok());
    for (const Mesh& m : s.meshes)
        for (const Primitive& q : m.primitives) {
            EXPECT_EQ(q.joints.size(), 4 * q.vertex_count());
            EXPECT_EQ(q.weights.size(), 4 * q.vertex_count());
            ASSERT_EQ(q.targets.size(), 1u);
            EXPECT_EQ(q.targets[0].position_deltas.size(), 3 * q.vertex_count());
        }
    EXPECT_EQ(s.nodes[0].skin, 0);
    EXPECT_EQ(s.nodes.back().skin, 0); // the LOD node is skinned too
    save_valid(s, "skinned.glb");
}

TEST(add_fur_shells, ZeroMaskGrowsNothingThere) {
    Scene s = make_scene(shapes::grid(1, 1, 32, 32));
    FurOptions o = fur(4, 0.05);
    o.mask.width = 64, o.mask.height = 1, o.mask.channels = 1;
    // Bald on the left half; the last column is 0 too so that REPEAT does not wrap fur onto u = 0.
    for (int x = 0; x < 64; ++x) o.mask.pixels.push_back(x < 32 || x == 63 ? 0.0f : 1.0f);
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, o, &r).ok());
    EXPECT_GT(r.dropped_triangles, 0u);
    EXPECT_EQ(r.dropped_triangles % 4, 0u);
    for (size_t i = 1; i < s.meshes[0].primitives.size(); ++i) {
        const Primitive& p = s.meshes[0].primitives[i];
        for (uint32_t v : p.indices) EXPECT_GE(p.positions[3 * v], -1.0f / 32.0f - 1e-6f); // at most one ring past u = 0.5
    }
    // The triangles over the bald half were dropped: every shell has about half of the grid.
    EXPECT_LT(s.meshes[0].primitives[1].triangle_count(), s.meshes[0].primitives[0].triangle_count() * 0.6);
}

TEST(add_fur_shells, SixteenBitMaskGradientIsFollowed) {
    fs::path dir = test::temp_dir();
    test::write_bytes(dir / "ramp16.png", test::png_grey16(256, 4, [](int x, int) { return (x + 0.5) / 256.0; }));
    Scene s = make_scene(shapes::grid(1, 1, 16, 16));
    FurOptions o = fur(2, 0.1);
    o.keep_frames = true;
    ASSERT_TRUE(load_png(o.mask, (dir / "ramp16.png").string()).ok());
    FurReport r;
    ASSERT_TRUE(add_fur_shells(s, o, &r).ok());
    ASSERT_EQ(r.frames.size(), 1u);
    const Primitive& base = s.meshes[0].primitives[0];
    for (size_t v = 0; v < base.vertex_count(); ++v) {
        double u = base.uv0[2 * v];
        // Bilinear with REPEAT: inside the ramp the value is u itself; at the wrap it blends the ends.
        if (u < 1.0 / 256 || u > 1 - 1.0 / 256) continue;
        EXPECT_NEAR(r.frames[0].frame.length[v], 0.1 * u, 0.1 * 2e-5) << v; // 16-bit: far finer than 1/255
    }
}

TEST(add_fur_shells, MaskNeedsUvs) {
    Scene s = make_scene(shapes::icosphere(1, 2)); // no TEXCOORD_0
    FurOptions o = fur(4, 0.05);
    o.mask.width = o.mask.height = o.mask.channels = 1;
    o.mask.pixels = {1.0f};
    Status st = add_fur_shells(s, o);
    EXPECT_EQ(st.code, StatusCode::invalid_argument);
    EXPECT_NE(st.message.find("TEXCOORD_0"), std::string::npos) << st.message;
    EXPECT_EQ(s.meshes[0].primitives.size(), 1u); // nothing added on failure
    // Without a mask the same mesh gets box-projected strand UVs.
    Scene ok = make_scene(shapes::icosphere(1, 2));
    ASSERT_TRUE(add_fur_shells(ok, fur(4, 0.05)).ok());
    EXPECT_FALSE(ok.meshes[0].primitives[1].uv1.empty());
    save_valid(ok, "icosphere.glb");
}

TEST(add_fur_shells, RejectsBadInput) {
    Scene s = sphere_scene();
    EXPECT_EQ(add_fur_shells(s, fur(0, 0.05)).code, StatusCode::invalid_argument);
    EXPECT_EQ(add_fur_shells(s, fur(257, 0.05)).code, StatusCode::invalid_argument);
    EXPECT_EQ(add_fur_shells(s, fur(4, -0.1)).code, StatusCode::invalid_argument);
    EXPECT_EQ(add_fur_shells(s, fur(4, std::nan(""))).code, StatusCode::invalid_argument);
    FurOptions o = fur(4, 0.05);
    o.mask.width = o.mask.height = o.mask.channels = 1;
    o.mask.pixels = {1.0f};
    o.mask_channel = 3;
    EXPECT_EQ(add_fur_shells(s, o).code, StatusCode::invalid_argument);
    EXPECT_EQ(s.meshes[0].primitives.size(), 1u);
    Scene empty;
    EXPECT_EQ(add_fur_shells(empty, fur(4, 0.05)).code, StatusCode::invalid_input);
    Primitive points;
    points.mode = PrimitiveMode::points;
    points.positions = {0, 0, 0, 1, 0, 0};
    points.indices = {0, 1};
    Scene no_triangles = make_scene(points);
    EXPECT_EQ(add_fur_shells(no_triangles, fur(4, 0.05)).code, StatusCode::invalid_input);
}

// A NaN corner used to put NaN into the shells and their strand UVs (fuzz_shells); a NaN in a vertex no
// triangle uses is harmless and stays allowed.
TEST(add_fur_shells, NonFiniteTriangleCornerIsAnError) {
    Scene s = sphere_scene();
    s.meshes[0].primitives[0].positions[3 * 5 + 1] = std::nanf("");
    Status st = add_fur_shells(s, fur(4, 0.05));
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("non-finite"), std::string::npos) << st.message;
    EXPECT_EQ(s.meshes[0].primitives.size(), 1u); // nothing added on failure
    Scene spare = sphere_scene();
    Primitive& p = spare.meshes[0].primitives[0];
    p.positions.insert(p.positions.end(), {std::nanf(""), 0.0f, 0.0f});
    p.normals.insert(p.normals.end(), {0.0f, 1.0f, 0.0f});
    p.uv0.insert(p.uv0.end(), {0.0f, 0.0f});
    ASSERT_TRUE(add_fur_shells(spare, fur(4, 0.05)).ok());
}

// Strand UVs are the base UVs (or box-projected positions) divided by the tile size, which may be any
// finite value > 0: a tile of 1e-300 m made them float(5e299) = inf (fuzz_shells). They stay finite now.
TEST(add_fur_shells, StrandUvsStayFiniteForAnyTileSize) {
    for (bool uvs : {true, false}) {
        Scene s = uvs ? sphere_scene() : make_scene(shapes::icosphere(0.5f, 2));
        FurOptions o = fur(2, 0.05);
        o.tile_size = 1e-300;
        ASSERT_TRUE(add_fur_shells(s, o).ok());
        ASSERT_GT(s.meshes[0].primitives.size(), 1u);
        for (size_t k = 1; k < s.meshes[0].primitives.size(); ++k) {
            const Primitive& p = s.meshes[0].primitives[k];
            ASSERT_FALSE(p.uv1.empty());
            for (float x : p.uv1) ASSERT_TRUE(std::isfinite(x)) << (uvs ? "UV layout" : "box projection") << ", primitive " << k;
            for (float x : p.uv0) ASSERT_TRUE(std::isfinite(x)) << (uvs ? "UV layout" : "box projection") << ", primitive " << k;
        }
    }
}

// Without UVs, the strand UVs are box-projected: each triangle onto the axis plane its normal faces most, a
// vertex split into one copy per plane it is used with, the copies numbered in order of first use. Each shell's
// index buffer held to that numbering, rebuilt here from the base with the (vertex, plane) pairs in a map.
TEST(add_fur_shells, BoxProjectionSplitsVerticesByPlaneInOrderOfFirstUse) {
    const Primitive base = shapes::icosphere(0.5f, 2); // no TEXCOORD_0
    ASSERT_TRUE(base.uv0.empty());
    Scene s = make_scene(base);
    ASSERT_TRUE(add_fur_shells(s, fur(2, 0.02)).ok());
    std::map<std::pair<uint32_t, int>, uint32_t> copies;
    std::vector<uint32_t> want;
    auto pos = [&](uint32_t v, int k) { return double(base.positions[3 * size_t(v) + size_t(k)]); };
    for (size_t i = 0; i + 2 < base.indices.size(); i += 3) {
        const uint32_t a = base.indices[i], b = base.indices[i + 1], c = base.indices[i + 2];
        double e1[3], e2[3];
        for (int k = 0; k < 3; ++k) e1[k] = pos(b, k) - pos(a, k), e2[k] = pos(c, k) - pos(a, k);
        const double n[3] = {std::abs(e1[1] * e2[2] - e1[2] * e2[1]), std::abs(e1[2] * e2[0] - e1[0] * e2[2]),
                             std::abs(e1[0] * e2[1] - e1[1] * e2[0])};
        const int axis = n[0] >= n[1] && n[0] >= n[2] ? 0 : n[1] >= n[2] ? 1 : 2;
        for (uint32_t v : {a, b, c}) want.push_back(copies.emplace(std::make_pair(v, axis), uint32_t(copies.size())).first->second);
    }
    ASSERT_GT(copies.size(), base.vertex_count()); // some vertices are split
    ASSERT_EQ(s.meshes[0].primitives.size(), 3u);  // the base and two shells
    for (size_t k = 1; k < 3; ++k) {
        const Primitive& shell = s.meshes[0].primitives[k];
        EXPECT_EQ(shell.vertex_count(), copies.size()) << "shell " << k;
        EXPECT_EQ(shell.indices, want) << "shell " << k;
    }
}

TEST(add_fur_shells, SilhouetteGrowsWithLength) {
    RenderOptions ro;
    ro.width = ro.height = 128;
    ro.camera.orthographic = true;
    ro.camera.ortho_height = 2.0;
    ro.camera.eye = std::array<double, 3>{0, 0, 5};
    ro.camera.target = std::array<double, 3>{0, 0, 0};
    size_t previous = 0;
    for (double length : {0.0, 0.05, 0.12, 0.25}) {
        Scene s = sphere_scene();
        if (length > 0) {
            ASSERT_TRUE(add_fur_shells(s, fur(16, length)).ok());
        }
        RenderResult r;
        ASSERT_TRUE(render_scene(r, s, ro).ok());
        size_t area = mask_area(silhouette_mask(r.color));
        EXPECT_GT(area, previous + 50) << "length " << length;
        previous = area;
    }
}

TEST(add_fur_shells, MaskCutoffHidesTheRightTexels) {
    // A 1 × 1 sheet seen from above, one texel per pixel: shell i must show exactly the texels whose
    // strand height (alpha) reaches its cutoff.
    Scene s = make_scene(shapes::grid(1, 1, 1, 1));
    FurOptions o = fur(4, 0.01);
    o.tile_size = 1.0;
    ASSERT_TRUE(add_fur_shells(s, o).ok());
    const Scene full = s;
    ImageF strands;
    ASSERT_TRUE(decode_image(strands, full.images.back().encoded.data(), full.images.back().encoded.size()).ok());
    ASSERT_EQ(strands.width, 256);
    RenderOptions ro;
    ro.width = ro.height = 256;
    ro.camera.orthographic = true;
    ro.camera.ortho_height = 1.0;
    for (int i = 1; i <= 4; ++i) {
        Scene one = full;
        one.meshes[0].primitives = {full.meshes[0].primitives[size_t(i)]};
        const float cutoff = full.materials[size_t(one.meshes[0].primitives[0].material)].alpha_cutoff;
        RenderResult r;
        ASSERT_TRUE(render_scene(r, one, ro).ok());
        ImageF expected;
        expected.width = expected.height = 256;
        expected.channels = 1;
        size_t shown = 0;
        for (size_t t = 0; t < size_t(256 * 256); ++t) {
            bool on = strands.pixels[4 * t + 3] >= cutoff;
            expected.pixels.push_back(on ? 1.0f : 0.0f);
            shown += on;
        }
        EXPECT_GT(shown, 100u);
        EXPECT_GT(mask_iou(silhouette_mask(r.color), expected), 0.97) << "shell " << i << " cutoff " << cutoff;
    }
}

// Droop over its whole range (0..4) keeps the creature's fur at full length: the tips once turned by
// droop·45°, past the skin's tangent plane from droop 2 on, and the sweep clamp then cut 48 % of the fur at
// droop 2 (mean 0.0115 of 0.04 before the bend kept lengths) and 65 % at droop 4, 1626 vertices bald.
TEST(add_fur_shells, DroopKeepsTheCreaturesFurFullLength) {
    for (double droop : {2.0, 4.0}) {
        Scene s = make_scene(shapes::creature(64, 32), "creature");
        FurOptions o = fur(8, 0.04);
        o.shells.droop = droop;
        o.keep_frames = true;
        FurReport rep;
        ASSERT_TRUE(add_fur_shells(s, o, &rep).ok());
        ASSERT_EQ(rep.frames.size(), 1u);
        const ShellFrame& f = rep.frames[0].frame;
        size_t full = 0, bald = 0;
        for (size_t v = 0; v < f.length.size(); ++v) {
            full += f.length[v] >= 0.95 * f.requested[v];
            bald += f.length[v] == 0;
        }
        const double share = double(full) / double(f.length.size());
        std::printf("droop %.0f: %.1f %% of the creature's vertices keep >= 95 %% of the length, %zu bald\n", droop, 100 * share, bald);
        EXPECT_GE(share, 0.9) << "droop " << droop;
        EXPECT_EQ(bald, 0u) << "droop " << droop;
    }
}

TEST(add_fur_shells, IdenticalBytesForAnyThreadCount) {
    auto run = [](int threads) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
        Scene s = make_scene(shapes::torus(1.0f, 0.6f, 48, 24));
        FurOptions o = fur(8, 0.3);
        o.fins = true;
        o.shells.droop = 0.8;
        o.shells.lod_levels = 2;
        EXPECT_TRUE(add_fur_shells(s, o).ok());
        fs::path f = test::temp_dir() / ("t" + std::to_string(threads) + ".glb");
        EXPECT_TRUE(save_scene(s, f.string()).ok());
        return test::read_bytes(f);
    };
    EXPECT_EQ(run(1), run(2));
}

} // namespace
} // namespace furrow

// tessellate_scene: primitives of one mesh tessellated together (no crack along their border), everything
// else of the scene kept, attributes carried (colours, skin, morph targets), node transforms respected,
// validator-clean output.
#include "tess_test_util.h"
#include "test_support.h"

#include <furrow/shapes.h>
#include <furrow/tessellate.h>

#include <algorithm>

using namespace furrow;
using namespace furrow::test;

namespace {

// A 4 x 2 quad grid cut into two primitives (left and right half, different materials) sharing a border,
// with colours, a skin, a morph target and tangents; plus a lines primitive that must stay as it is.
Scene two_material_scene() {
    Primitive grid = shapes::quad_grid(4, 2, 4, 2);
    const size_t n = grid.vertex_count();
    grid.colors.resize(n * 4);
    grid.joints.resize(n * 4);
    grid.weights.resize(n * 4);
    grid.tangents.assign(n * 4, 0.0f);
    MorphTarget t;
    t.position_deltas.assign(n * 3, 0.0f);
    for (size_t v = 0; v < n; ++v) {
        const float x = grid.positions[v * 3];
        for (int k = 0; k < 4; ++k) grid.colors[v * 4 + size_t(k)] = k == 3 ? 1.0f : (x + 2) / 4;
        grid.joints[v * 4] = 0;
        grid.joints[v * 4 + 1] = 1;
        grid.joints[v * 4 + 2] = uint16_t(2 + v % 3);
        grid.joints[v * 4 + 3] = 5;
        grid.weights[v * 4] = (x + 2) / 4 * 0.7f;
        grid.weights[v * 4 + 1] = (1 - (x + 2) / 4) * 0.7f;
        grid.weights[v * 4 + 2] = 0.2f;
        grid.weights[v * 4 + 3] = 0.1f;
        grid.tangents[v * 4] = 1;
        grid.tangents[v * 4 + 3] = 1;
        t.position_deltas[v * 3 + 1] = 0.5f; // lifts everything
    }
    grid.targets.push_back(t);
    Primitive left = grid, right = grid;
    left.indices.clear();
    left.face_sizes.clear();
    right.indices.clear();
    right.face_sizes.clear();
    for (size_t f = 0; f < grid.face_sizes.size(); ++f) {
        Primitive& dst = (f % 4) < 2 ? left : right; // cells row by row, i fastest
        dst.indices.insert(dst.indices.end(), grid.indices.begin() + long(f * 4), grid.indices.begin() + long(f * 4 + 4));
        dst.face_sizes.push_back(4);
    }
    left.material = 0;
    right.material = 1;
    Primitive lines;
    lines.mode = PrimitiveMode::lines;
    lines.positions = {0, 0, 0, 1, 1, 1};
    lines.indices = {0, 1};
    lines.targets.push_back(MorphTarget{std::vector<float>(6, 0.0f), {}, {}}); // glTF: every primitive of a mesh has the same targets
    Scene s = make_scene(left, "grid");
    s.meshes[0].primitives.push_back(right);
    s.meshes[0].primitives.push_back(lines);
    s.meshes[0].weights = {0.0f};
    s.materials.resize(2);
    s.materials[0].name = "left";
    s.materials[1].name = "right";
    s.materials[1].base_color = {1, 0, 0, 1};
    // A skeleton of 6 joints with one common root (joint 0), so that the skin is valid glTF.
    Skin skin;
    for (int j = 0; j < 6; ++j) {
        Node joint;
        joint.name = "joint" + std::to_string(j);
        s.nodes.push_back(joint);
        const int index = int(s.nodes.size() - 1);
        skin.joints.push_back(index);
        if (j == 0) s.roots.push_back(index);
        else s.nodes[size_t(skin.joints[0])].children.push_back(index);
    }
    s.skins.push_back(skin);
    s.nodes[0].skin = 0;
    return s;
}

Primitive merged_triangles(const Mesh& mesh) {
    Primitive all;
    for (const auto& p : mesh.primitives) {
        if (p.mode != PrimitiveMode::triangles) continue;
        const uint32_t base = uint32_t(all.positions.size() / 3);
        all.positions.insert(all.positions.end(), p.positions.begin(), p.positions.end());
        for (uint32_t i : p.indices) all.indices.push_back(base + i);
    }
    return all;
}

} // namespace

TEST(tessellate_scene, PrimitivesShareTheirBorderWithoutCracks) {
    Scene s = two_material_scene();
    TessellateOptions o;
    o.rates.focus.push_back({{0, 0, 0}, 0.5, 6}); // rates vary along the shared border (x = 0)
    o.rates.uniform = 2;
    SceneTessellateReport rep;
    ASSERT_TRUE(tessellate_scene(s, o, &rep).ok());
    EXPECT_EQ(rep.meshes, 1u);
    EXPECT_EQ(rep.primitives, 2u);
    const Mesh& mesh = s.meshes[0];
    ASSERT_EQ(mesh.primitives.size(), 3u);
    EXPECT_EQ(mesh.primitives[0].material, 0);
    EXPECT_EQ(mesh.primitives[1].material, 1);
    EXPECT_EQ(mesh.primitives[2].mode, PrimitiveMode::lines);
    EXPECT_EQ(mesh.primitives[2].positions, (std::vector<float>{0, 0, 0, 1, 1, 1}));
    // The two halves together: one open sheet, its only boundary the outer rim.
    CheckReport r = check_primitive(merged_triangles(mesh));
    EXPECT_EQ(r.boundary_loops, 1u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_EQ(r.components, 1u);
    // Each half is an open sheet of its own whose border points are those of the other half.
    EXPECT_EQ(check_primitive(mesh.primitives[0]).boundary_loops, 1u);
    EXPECT_EQ(check_primitive(mesh.primitives[1]).boundary_loops, 1u);
    EXPECT_NE(std::find_if(rep.warnings.begin(), rep.warnings.end(),
                           [](const std::string& w) { return w.find("tangents dropped") != std::string::npos; }),
              rep.warnings.end());
}

TEST(tessellate_scene, AttributesCarried) {
    Scene s = two_material_scene();
    ASSERT_TRUE(tessellate_scene(s, uniform_options(SubdivisionScheme::catmark, 3)).ok());
    for (int i = 0; i < 2; ++i) {
        const Primitive& p = s.meshes[0].primitives[size_t(i)];
        const size_t n = p.vertex_count();
        ASSERT_EQ(p.normals.size(), n * 3);
        ASSERT_EQ(p.uv0.size(), n * 2);
        ASSERT_EQ(p.colors.size(), n * 4);
        ASSERT_EQ(p.joints.size(), n * 4);
        ASSERT_EQ(p.weights.size(), n * 4);
        EXPECT_TRUE(p.tangents.empty());
        ASSERT_EQ(p.targets.size(), 1u);
        ASSERT_EQ(p.targets[0].position_deltas.size(), n * 3);
        for (size_t v = 0; v < n; ++v) {
            // Colour follows x (linear input, smooth face-varying interpolation stays within the range).
            EXPECT_NEAR(p.colors[v * 4], (p.positions[v * 3] + 2) / 4, 0.05f);
            EXPECT_FLOAT_EQ(p.colors[v * 4 + 3], 1.0f);
            float sum = 0;
            for (int k = 0; k < 4; ++k) sum += p.weights[v * 4 + size_t(k)];
            EXPECT_NEAR(sum, 1.0f, 1e-5f);
            EXPECT_NEAR(p.targets[0].position_deltas[v * 3 + 1], 0.5f, 1e-5f); // a constant delta stays constant
        }
    }
}

// Node transforms are world space for the view criteria: the same mesh drawn 10x larger gets higher rates.
TEST(tessellate_scene, NodeScaleRaisesViewRates) {
    auto rates_with_scale = [](double scale) {
        Scene s = make_scene(shapes::quad_grid(2, 2, 2, 2), "g");
        s.nodes[0].scale = {scale, scale, scale};
        TessellateOptions o;
        o.rates.camera = TessellationCamera{{0, 30, 0}, 45, 1000};
        o.rates.pixel_error = 4;
        SceneTessellateReport rep;
        EXPECT_TRUE(tessellate_scene(s, o, &rep).ok());
        return rep.totals.max_rate;
    };
    EXPECT_GT(rates_with_scale(10.0), 3 * rates_with_scale(1.0));
}

// The whole budget is shared by the meshes of the scene.
TEST(tessellate_scene, BudgetCoversTheScene) {
    Scene s = make_scene(shapes::icosphere(1, 2), "a");
    Scene b = make_scene(shapes::quad_grid(2, 2, 8, 8), "b");
    s.meshes.push_back(b.meshes[0]);
    Node n;
    n.mesh = 1;
    s.nodes.push_back(n);
    s.roots.push_back(1);
    TessellateOptions o = uniform_options(SubdivisionScheme::catmark, 16);
    o.rates.max_triangles = 40000;
    SceneTessellateReport rep;
    ASSERT_TRUE(tessellate_scene(s, o, &rep).ok());
    EXPECT_LE(rep.triangles_out, 40000u);
    EXPECT_GT(rep.triangles_out, 20000u);
}

TEST(tessellate_scene, OutputIsValidatorClean) {
    Scene s = two_material_scene();
    ASSERT_TRUE(tessellate_scene(s, uniform_options(SubdivisionScheme::catmark, 4)).ok());
    const auto file = temp_dir() / "two.glb";
    Status st = save_scene(s, file.string());
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_VALID_GLTF(file);
}

// An error leaves the scene untouched (here: Loop on quads).
TEST(tessellate_scene, ErrorLeavesSceneUnchanged) {
    Scene s = two_material_scene();
    const auto before = s.meshes[0].primitives[0].indices;
    Status st = tessellate_scene(s, uniform_options(SubdivisionScheme::loop, 2));
    EXPECT_EQ(st.code, StatusCode::unsupported);
    EXPECT_NE(st.message.find("mesh 0 \"grid\""), std::string::npos) << st.message;
    EXPECT_EQ(s.meshes[0].primitives[0].indices, before);
}

// A triangle primitive with faces but no positions used to be skipped and handed back unchanged, indices still
// naming vertices that do not exist (found by fuzz_tessellate): it is an index out of range.
TEST(tessellate_scene, FacesWithoutVerticesAreAnError) {
    Scene s = make_scene(shapes::quad_grid(2, 2, 2, 2), "grid");
    Primitive empty;
    empty.indices = {0, 0, 0};
    s.meshes[0].primitives.push_back(empty);
    Status st = tessellate_scene(s, uniform_options(SubdivisionScheme::bilinear, 2));
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("primitive 1"), std::string::npos) << st.message;
    EXPECT_EQ(s.meshes[0].primitives[0].indices, shapes::quad_grid(2, 2, 2, 2).indices); // left as it was
}

// Surface options used to be checked only by the meshes that had triangles to tessellate: a scene without any
// accepted every option (found by fuzz_tessellate).
TEST(tessellate_scene, OptionsAreCheckedEvenWithNothingToTessellate) {
    Scene empty;
    TessellateOptions o = uniform_options(SubdivisionScheme::catmark, 2);
    ASSERT_TRUE(tessellate_scene(empty, o).ok());
    o.surface.accuracy = 11;
    EXPECT_EQ(tessellate_scene(empty, o).code, StatusCode::invalid_argument);
    o = uniform_options(SubdivisionScheme::catmark, 2);
    o.surface.weld_tolerance = -1;
    EXPECT_EQ(tessellate_scene(empty, o).code, StatusCode::invalid_argument);
}

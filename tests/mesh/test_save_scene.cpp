// save_scene: what furrow writes is valid glTF (Khronos validator: 0 errors, 0 warnings) and reads back the
// same, for every attribute kind furrow models; failures write nothing.
#include "scene_compare.h"
#include "test_support.h"

#include <furrow/shapes.h>

#include <cmath>

using namespace furrow;
using namespace furrow::test;

namespace {

// Saves as .glb and .gltf, validates both, reloads both and compares with the original.
void round_trip(const Scene& s, const std::string& stem) {
    const auto dir = temp_dir();
    for (const char* ext : {".glb", ".gltf"}) {
        const auto out = dir / (stem + ext);
        Status st = save_scene(s, out.string());
        ASSERT_TRUE(st.ok()) << st.message;
        EXPECT_VALID_GLTF(out);
        Scene b;
        LoadOptions as_stored;
        as_stored.recentre = false;
        st = load_scene(b, out.string(), as_stored);
        ASSERT_TRUE(st.ok()) << st.message;
        expect_same_scene(s, b);
    }
}

TEST(save_scene, CustomAttributesColorsAndTwoUvSets) {
    // An engine-layout fur mesh carries _FUR_LAYER (scalar) and _FUR_DIRECTION (vec3) beside COLOR_0/UV1.
    Primitive p = shapes::uv_sphere(1.0f, 16, 8);
    const size_t n = p.vertex_count();
    p.uv1 = p.uv0;
    p.colors.assign(n * 4, 0.5f);
    CustomAttribute layer{"_FUR_LAYER", 1, std::vector<float>(n, 3.0f)};
    CustomAttribute dir{"_FUR_DIRECTION", 3, p.normals};
    p.custom = {layer, dir};
    round_trip(make_scene(p, "fur"), "custom");
}

TEST(save_scene, MorphTargetsAndWeights) {
    Primitive p = shapes::box(1, 1, 1, true);
    MorphTarget t;
    t.position_deltas.assign(p.positions.size(), 0.0f);
    t.position_deltas[1] = 0.25f;
    t.normal_deltas.assign(p.normals.size(), 0.0f);
    p.targets = {t};
    Scene s = make_scene(p, "morph");
    s.meshes[0].weights = {0.5f};
    round_trip(s, "morph");
}

TEST(save_scene, SkinnedMeshWithJointsAndInverseBindMatrices) {
    // Two joints along y; every vertex weighted between them.
    Primitive p = shapes::box(1, 2, 1, true);
    const size_t n = p.vertex_count();
    for (size_t i = 0; i < n; ++i) {
        float w = std::clamp(p.positions[i * 3 + 1] + 0.5f, 0.0f, 1.0f);
        p.joints.insert(p.joints.end(), {0, 1, 0, 0});
        p.weights.insert(p.weights.end(), {1 - w, w, 0, 0});
    }
    Scene s = make_scene(p, "skinned");
    Node j0, j1;
    j0.name = "root_joint";
    j1.name = "tip_joint";
    j1.translation = {0, 1, 0};
    j0.children = {2};
    s.nodes.push_back(j0);
    s.nodes.push_back(j1);
    s.roots.push_back(1);
    s.nodes[0].skin = 0;
    Skin sk;
    sk.joints = {1, 2};
    sk.inverse_bind_matrices = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, //
                                1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1};
    s.skins.push_back(sk);
    round_trip(s, "skin");
}

TEST(save_scene, MoreThan65535VerticesUseUint32Indices) {
    Primitive p = shapes::grid(10, 10, 300, 300); // 90601 vertices
    ASSERT_GT(p.vertex_count(), 65535u);
    Scene s = make_scene(p, "big");
    const auto out = temp_dir() / "big.glb";
    ASSERT_TRUE(save_scene(s, out.string()).ok());
    auto j = gltf_json(out);
    int idx = j["meshes"][0]["primitives"][0]["indices"];
    EXPECT_EQ(j["accessors"][idx]["componentType"], 5125);
    EXPECT_VALID_GLTF(out);
    Primitive small = shapes::grid(1, 1, 4, 4);
    const auto out2 = temp_dir() / "small.glb";
    ASSERT_TRUE(save_scene(make_scene(small, "small"), out2.string()).ok());
    auto j2 = gltf_json(out2);
    int idx2 = j2["meshes"][0]["primitives"][0]["indices"];
    EXPECT_EQ(j2["accessors"][idx2]["componentType"], 5123);
}

TEST(save_scene, QuadsAreFannedOnWrite) {
    Primitive q = shapes::quad_grid(1, 1, 3, 2);
    const auto out = temp_dir() / "q.glb";
    SaveOptions as_given; // the fan is compared triangle by triangle: the scene's order
    as_given.optimize = false;
    ASSERT_TRUE(save_scene(make_scene(q, "q"), out.string(), as_given).ok());
    Scene b;
    ASSERT_TRUE(load_scene(b, out.string()).ok());
    EXPECT_EQ(b.meshes[0].primitives[0].indices, shapes::grid(1, 1, 3, 2).indices);
    EXPECT_VALID_GLTF(out);
}

TEST(save_scene, ZeroLengthNormalsAreRepairedNotWrittenAsNaN) {
    // A degenerate input normal (0,0,0) would be a validator error and NaN after normalisation.
    Primitive p = shapes::grid(1, 1, 2, 2);
    p.normals[0] = p.normals[1] = p.normals[2] = 0.0f;
    p.normals[3] = std::nanf("");
    const auto out = temp_dir() / "n.glb";
    ASSERT_TRUE(save_scene(make_scene(p, "n"), out.string()).ok());
    EXPECT_VALID_GLTF(out);
    Scene b;
    ASSERT_TRUE(load_scene(b, out.string()).ok());
    EXPECT_TRUE(all_finite(b));
    EXPECT_FLOAT_EQ(b.meshes[0].primitives[0].normals[1], 1.0f); // the welded face normal (+y)
}

TEST(save_scene, FarFromOriginKeepsPrecisionThroughNodeTranslation) {
    // A 1 m grid 1e5 m from the origin: recentre() moves the offset into the node in double.
    Primitive p = shapes::grid(1, 1, 4, 4);
    Scene s = make_scene(p, "far");
    s.nodes[0].translation = {0, 0, 0};
    for (size_t i = 0; i < p.positions.size(); i += 3) s.meshes[0].primitives[0].positions[i] += 100000.0f;
    EXPECT_EQ(recentre(s), 1u);
    EXPECT_DOUBLE_EQ(s.nodes[0].translation[0], 100000.0);
    EXPECT_EQ(s.meshes[0].primitives[0].positions, p.positions); // the grid is symmetric about its centre
    round_trip(s, "far");
}

TEST(save_scene, BadSceneIsRefusedAndNothingIsWritten) {
    const auto dir = temp_dir();
    Primitive p = shapes::grid(1, 1, 1, 1);
    Scene s = make_scene(p, "bad");
    s.meshes[0].primitives[0].material = 3; // no such material
    Status st = save_scene(s, (dir / "bad.glb").string());
    EXPECT_EQ(st.code, StatusCode::invalid_argument);
    s.meshes[0].primitives[0].material = -1;
    s.meshes[0].primitives[0].custom.push_back({"NO_UNDERSCORE", 1, std::vector<float>(4, 0.0f)});
    EXPECT_EQ(save_scene(s, (dir / "bad.glb").string()).code, StatusCode::invalid_argument);
    s.meshes[0].primitives[0].custom.clear();
    s.meshes[0].primitives[0].positions[0] = INFINITY;
    EXPECT_EQ(save_scene(s, (dir / "bad.glb").string()).code, StatusCode::invalid_argument);
    EXPECT_TRUE(list_dir(dir).empty());
    EXPECT_EQ(save_scene(make_scene(p), (dir / "no/such/dir/x.glb").string()).code, StatusCode::io_error);
    EXPECT_EQ(save_scene(make_scene(p), (dir / "x.obj").string()).code, StatusCode::unsupported);
    EXPECT_TRUE(list_dir(dir).empty());
}

// Saved to `out`, then read back as stored.
Scene saved_and_reloaded(const Scene& s, const std::filesystem::path& out, const SaveOptions& options) {
    const Status st = save_scene(s, out.string(), options);
    EXPECT_TRUE(st.ok()) << st.message;
    Scene b;
    LoadOptions as_stored;
    as_stored.recentre = false;
    EXPECT_TRUE(load_scene(b, out.string(), as_stored).ok());
    return b;
}

// The primitive `p` of mesh 0 as it reads back when saved alone, and as `together` holds it.
void expect_as_saved_alone(const Scene& together, size_t p, const Primitive& alone, const SaveOptions& options,
                           const std::filesystem::path& dir) {
    const Scene solo = saved_and_reloaded(make_scene(alone, "solo"), dir / "solo.glb", options);
    ASSERT_EQ(solo.meshes.size(), 1u);
    ASSERT_GT(together.meshes[0].primitives.size(), p);
    const Primitive& a = solo.meshes[0].primitives[0];
    const Primitive& b = together.meshes[0].primitives[p];
    EXPECT_EQ(a.indices, b.indices) << "primitive " << p;
    if (options.encoding != Encoding::plain) return; // quantized on the grid of its mesh, which differs alone
    EXPECT_EQ(a.positions, b.positions) << "primitive " << p;
    EXPECT_EQ(a.uv0, b.uv0) << "primitive " << p;
}

TEST(save_scene, RepeatedTrianglesShareOneIndexAccessorAndEachKeepsItsOrder) {
    // Fur shells repeat the base's triangles over new vertices: the writer orders them once and writes one index
    // accessor for the run; each primitive still reads back exactly as it does saved alone.
    const Primitive a = shapes::torus(1.0f, 0.25f, 24, 12);
    Primitive b = a;
    for (float& x : b.positions) x = x * 1.5f + 0.25f;
    const Primitive c = shapes::uv_sphere(1.0f, 16, 8);
    Scene s = make_scene(a, "shells");
    s.meshes[0].primitives.push_back(b);
    s.meshes[0].primitives.push_back(c);
    s.meshes[0].primitives.push_back(c);
    Primitive d = c; // the same vertices and as many indices, every triangle turned over: not a repeat
    for (size_t t = 0; t + 2 < d.indices.size(); t += 3) std::swap(d.indices[t + 1], d.indices[t + 2]);
    s.meshes[0].primitives.push_back(d);
    const auto dir = temp_dir();
    for (Encoding e : {Encoding::plain, Encoding::quantize, Encoding::compress})
        for (bool optimize : {true, false}) {
            SaveOptions o;
            o.encoding = e, o.optimize = optimize;
            const auto out = dir / ("repeated" + std::to_string(int(e)) + (optimize ? "o" : "k") + ".glb");
            const Scene back = saved_and_reloaded(s, out, o);
            ASSERT_EQ(back.meshes[0].primitives.size(), 5u);
            EXPECT_VALID_GLTF(out);
            const nlohmann::json j = gltf_json(out);
            const auto& prim = j["meshes"][0]["primitives"];
            EXPECT_EQ(prim[0]["indices"], prim[1]["indices"]);
            EXPECT_EQ(prim[2]["indices"], prim[3]["indices"]);
            EXPECT_NE(prim[0]["indices"], prim[2]["indices"]);
            EXPECT_NE(prim[3]["indices"], prim[4]["indices"]);
            EXPECT_NE(prim[0]["attributes"]["POSITION"], prim[1]["attributes"]["POSITION"]);
            EXPECT_EQ(prim[0]["attributes"]["TEXCOORD_0"], prim[1]["attributes"]["TEXCOORD_0"]); // the same bytes
            EXPECT_EQ(prim[0]["attributes"]["NORMAL"], prim[1]["attributes"]["NORMAL"]);
            expect_as_saved_alone(back, 1, b, o, dir);
            expect_as_saved_alone(back, 3, c, o, dir);
            expect_as_saved_alone(back, 4, d, o, dir);
        }
}

TEST(save_scene, PolygonsWithTheSameCornersButAnotherShapeAreEachFannedByTheirOwn) {
    // The fan of a polygon depends on its positions (triangulate_polygons): a square fans from corner 0; a dart
    // whose corner 1 is reflex cannot (the diagonal 0-2 runs outside it). Same corners, so the same index list,
    // yet not the same triangles.
    Primitive square;
    square.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    square.indices = {0, 1, 2, 3};
    square.face_sizes = {4};
    Primitive dart = square;
    dart.positions = {0, 0, 0, 0.3f, 0.7f, 0, 1, 1, 0, 0, 1, 0}; // corner 1 pushed in past the diagonal 0-2
    Scene s = make_scene(square, "polygons");
    s.meshes[0].primitives.push_back(dart);
    SaveOptions as_given;
    as_given.optimize = false;
    const auto dir = temp_dir();
    const Scene back = saved_and_reloaded(s, dir / "polygons.glb", as_given);
    ASSERT_EQ(back.meshes[0].primitives.size(), 2u);
    EXPECT_VALID_GLTF(dir / "polygons.glb");
    EXPECT_NE(back.meshes[0].primitives[0].indices, back.meshes[0].primitives[1].indices);
    expect_as_saved_alone(back, 0, square, as_given, dir);
    expect_as_saved_alone(back, 1, dart, as_given, dir);
}

TEST(save_scene, EqualAccessorsAreWrittenOnceAndOnlyThey) {
    // Two attributes with the same description over the same bytes read one accessor; the same bytes with
    // another description (POSITION carries min and max, a custom attribute does not) get their own.
    Primitive p = shapes::uv_sphere(2.0f, 16, 8); // radius 2: its positions are not its normals
    p.uv1 = p.uv0;
    p.custom = {{"_P", 3, p.positions}, {"_Q", 3, p.positions}};
    const Scene s = make_scene(p, "twins");
    round_trip(s, "twins");
    const auto out = temp_dir() / "twins.glb";
    ASSERT_TRUE(save_scene(s, out.string()).ok());
    EXPECT_VALID_GLTF(out);
    const nlohmann::json j = gltf_json(out);
    const auto& at = j["meshes"][0]["primitives"][0]["attributes"];
    EXPECT_EQ(at["TEXCOORD_0"], at["TEXCOORD_1"]);
    EXPECT_EQ(at["_P"], at["_Q"]);
    EXPECT_NE(at["_P"], at["POSITION"]);
    EXPECT_EQ(j["accessors"].size(), j["bufferViews"].size()); // one view each, none left unread
    EXPECT_EQ(j["accessors"].size(), 5u);                      // POSITION, NORMAL, the UVs, _P and _Q, the indices
}

TEST(save_scene, SameSceneGivesSameBytes) {
    Scene s = make_scene(shapes::torus(1.0f, 0.25f, 24, 12), "torus");
    const auto dir = temp_dir();
    ASSERT_TRUE(save_scene(s, (dir / "a.glb").string()).ok());
    ASSERT_TRUE(save_scene(s, (dir / "b.glb").string()).ok());
    EXPECT_EQ(read_bytes(dir / "a.glb"), read_bytes(dir / "b.glb"));
}

} // namespace

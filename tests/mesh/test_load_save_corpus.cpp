// Round trip on real third-party models (../shared/corpus): load -> save (GLB and .gltf) -> validate ->
// reload -> identical geometry, materials, nodes, skins, images; animations and extensions carried over.
#include "scene_compare.h"
#include "test_support.h"

using namespace furrow;
using namespace furrow::test;

namespace {

struct CorpusCase {
    const char* file;
    size_t triangles; // after fan triangulation, as loaded
};

// Triangle counts from ../shared/corpus/MANIFEST.md (quads/pentagons of the spot cage and suzanne fanned).
const CorpusCase k_cases[] = {
    {"duck/Duck.glb", 4212},
    {"duck/Duck.gltf", 4212},
    {"fox/Fox.glb", 576},
    {"box_textured/BoxTextured.gltf", 12},
    {"terrain/terrain.glb", 31422},
    {"spot/spot_triangulated.obj", 5856},
    {"spot/spot_quadrangulated.obj", 5856},
    {"spot/spot_control_mesh.obj", 0}, // mixed polygons: count checked against face_sizes below
    {"bunny_closed/bunny.off", 6966},
    {"stanford_bunny_scan/stanford-bunny.obj", 69451},
    {"alligator/alligator.obj", 5981},
    {"thingi10k_70375/70375.stl", 40},
    {"thingi10k_73342/73342.stl", 420}, // 20 of them degenerate: kept, they are the file's content
    {"suzanne/suzanne.obj", 0},
    {"torus/torus.obj", 0},
};

class LoadSaveCorpus : public ::testing::TestWithParam<CorpusCase> {};

size_t triangles(const Scene& s) {
    size_t n = 0;
    for (const auto& m : s.meshes)
        for (const auto& p : m.primitives) n += p.triangle_count();
    return n;
}

TEST_P(LoadSaveCorpus, RoundTripKeepsSceneAndValidates) {
    const CorpusCase c = GetParam();
    const auto in = corpus(c.file);
    const auto in_bytes = read_bytes(in);
    Scene a;
    Status s = load_scene(a, in.string());
    ASSERT_TRUE(s.ok()) << s.message;
    if (c.triangles) {
        EXPECT_EQ(triangles(a), c.triangles);
    }
    EXPECT_TRUE(all_finite(a));

    const auto dir = temp_dir();
    for (const char* ext : {".glb", ".gltf"}) {
        const auto out = dir / (std::string("out") + ext);
        s = save_scene(a, out.string());
        ASSERT_TRUE(s.ok()) << s.message;
        EXPECT_VALID_GLTF(out);
        Scene b;
        s = load_scene(b, out.string());
        ASSERT_TRUE(s.ok()) << s.message;
        expect_same_scene(a, b);
        // Saving what was loaded from our own output gives the same bytes (determinism, no drift). b is already
        // in the optimized order; optimizing it again would pick another equally good one, so it is kept.
        const auto again = dir / (std::string("again") + ext);
        SaveOptions keep_order;
        keep_order.optimize = false;
        ASSERT_TRUE(save_scene(b, again.string(), keep_order).ok());
        if (std::string(ext) == ".glb") {
            EXPECT_EQ(read_bytes(out), read_bytes(again));
        } else { // the .gltf names its own .bin: compare the binaries, and the JSON but for that name
            EXPECT_EQ(read_bytes(dir / "out.bin"), read_bytes(dir / "again.bin"));
            auto ja = gltf_json(out), jb = gltf_json(again);
            ja["buffers"][0].erase("uri");
            jb["buffers"][0].erase("uri");
            EXPECT_EQ(ja, jb);
        }
    }
    EXPECT_EQ(read_bytes(in), in_bytes) << "the input file was modified";
    // Nothing else (temporary files) left in the output folder.
    EXPECT_EQ(list_dir(dir), (std::vector<std::string>{"again.bin", "again.glb", "again.gltf", "out.bin", "out.glb", "out.gltf"}));
}

INSTANTIATE_TEST_SUITE_P(Corpus, LoadSaveCorpus, ::testing::ValuesIn(k_cases),
                         [](const ::testing::TestParamInfo<CorpusCase>& info) {
                             std::string n = info.param.file;
                             for (char& ch : n)
                                 if (!isalnum(static_cast<unsigned char>(ch))) ch = '_';
                             return n;
                         });

// Everything the Fox carries besides geometry: 1 skin of 24 joints, 3 animations, node hierarchy, texture.
TEST(LoadSaveCorpus, FoxKeepsSkinAnimationsAndTexture) {
    const auto in = corpus("fox/Fox.glb");
    Scene a;
    ASSERT_TRUE(load_scene(a, in.string()).ok());
    ASSERT_EQ(a.skins.size(), 1u);
    EXPECT_EQ(a.skins[0].joints.size(), 24u);
    EXPECT_EQ(a.nodes.size(), 26u);
    const auto out = temp_dir() / "fox.glb";
    ASSERT_TRUE(save_scene(a, out.string()).ok());
    auto src = gltf_json(in), dst = gltf_json(out);
    ASSERT_FALSE(dst.is_null());
    ASSERT_EQ(dst["animations"].size(), 3u);
    for (size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(dst["animations"][i]["name"], src["animations"][i]["name"]);
        EXPECT_EQ(dst["animations"][i]["channels"], src["animations"][i]["channels"]);
        ASSERT_EQ(dst["animations"][i]["samplers"].size(), src["animations"][i]["samplers"].size());
        for (size_t k = 0; k < src["animations"][i]["samplers"].size(); ++k) {
            const auto& ss = src["animations"][i]["samplers"][k];
            const auto& ds = dst["animations"][i]["samplers"][k];
            EXPECT_EQ(ds.value("interpolation", "LINEAR"), ss.value("interpolation", "LINEAR"));
            EXPECT_EQ(dst["accessors"][ds["input"].get<int>()]["count"], src["accessors"][ss["input"].get<int>()]["count"]);
            EXPECT_EQ(dst["accessors"][ds["output"].get<int>()]["count"], src["accessors"][ss["output"].get<int>()]["count"]);
        }
    }
    EXPECT_EQ(dst["nodes"].size(), src["nodes"].size());
    for (size_t i = 0; i < src["nodes"].size(); ++i) EXPECT_EQ(dst["nodes"][i].value("name", ""), src["nodes"][i].value("name", ""));
    EXPECT_EQ(dst["images"].size(), 1u);
    EXPECT_EQ(dst["skins"][0]["joints"], src["skins"][0]["joints"]);
    EXPECT_VALID_GLTF(out);
}

// The Duck's camera and node matrices survive; the camera object is carried in the document.
TEST(LoadSaveCorpus, DuckKeepsCameraAndMatrices) {
    const auto in = corpus("duck/Duck.gltf");
    Scene a;
    ASSERT_TRUE(load_scene(a, in.string()).ok());
    const auto out = temp_dir() / "duck.gltf";
    ASSERT_TRUE(save_scene(a, out.string()).ok());
    auto src = gltf_json(in), dst = gltf_json(out);
    EXPECT_EQ(dst["cameras"], src["cameras"]);
    for (size_t i = 0; i < src["nodes"].size(); ++i)
        if (src["nodes"][i].contains("matrix")) {
            EXPECT_EQ(dst["nodes"][i]["matrix"], src["nodes"][i]["matrix"]);
        }
    EXPECT_VALID_GLTF(out);
}

// The terrain's material has a normal map but the mesh brings no tangents: we write generated tangents so
// that the output has no "generated tangent space" warning (the input has one).
TEST(LoadSaveCorpus, TerrainGetsTangentsForItsNormalMap) {
    Scene a;
    ASSERT_TRUE(load_scene(a, corpus("terrain/terrain.glb").string()).ok());
    EXPECT_TRUE(a.meshes[0].primitives[0].tangents.empty());
    const auto out = temp_dir() / "terrain.glb";
    ASSERT_TRUE(save_scene(a, out.string()).ok());
    Scene b;
    ASSERT_TRUE(load_scene(b, out.string()).ok());
    const auto& t = b.meshes[0].primitives[0].tangents;
    ASSERT_EQ(t.size(), b.meshes[0].primitives[0].vertex_count() * 4);
    for (size_t i = 0; i < t.size(); i += 4) {
        double l = std::sqrt(double(t[i]) * t[i] + double(t[i + 1]) * t[i + 1] + double(t[i + 2]) * t[i + 2]);
        ASSERT_NEAR(l, 1.0, 1e-5);
        ASSERT_TRUE(t[i + 3] == 1.0f || t[i + 3] == -1.0f);
    }
    EXPECT_VALID_GLTF(out);
}

// Quads survive loading from OBJ (for Catmull-Clark) and are fanned only when written to glTF.
TEST(LoadSaveCorpus, SpotQuadsStayQuads) {
    Scene a;
    ASSERT_TRUE(load_scene(a, corpus("spot/spot_quadrangulated.obj").string()).ok());
    const auto& p = a.meshes[0].primitives[0];
    ASSERT_EQ(p.face_sizes.size(), 2928u);
    for (uint32_t s : p.face_sizes) ASSERT_EQ(s, 4u);
    Scene cage;
    ASSERT_TRUE(load_scene(cage, corpus("spot/spot_control_mesh.obj").string()).ok());
    size_t tri = 0, quad = 0, pent = 0;
    for (uint32_t s : cage.meshes[0].primitives[0].face_sizes) tri += s == 3, quad += s == 4, pent += s == 5;
    EXPECT_EQ(tri, 4u);
    EXPECT_EQ(quad, 160u);
    EXPECT_EQ(pent, 16u);
}

} // namespace

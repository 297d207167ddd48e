// load_scene / load_scene_from_memory: glTF accessor features and the errors for what is broken.
#include "gltf_builder.h"
#include "test_support.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

using namespace furrow;
using namespace furrow::test;

namespace {

Status load_json(Scene& s, const std::string& json) {
    return load_scene_from_memory(s, reinterpret_cast<const uint8_t*>(json.data()), json.size(), ".gltf");
}

// A glTF document around a raw buffer, with the accessor/bufferView JSON given by the test.
std::string doc(const std::vector<uint8_t>& bytes, const std::string& prim, const std::string& accessors,
                const std::string& views, const std::string& extra = "") {
    return "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
           "\"meshes\":[{\"primitives\":[" + prim + "]}],\"accessors\":[" + accessors + "],\"bufferViews\":[" + views +
           "],\"buffers\":[{\"byteLength\":" + std::to_string(bytes.size()) +
           ",\"uri\":\"data:application/octet-stream;base64," + base64(bytes) + "\"}]" + extra + "}";
}

TEST(load_scene, TriangleStripIsConvertedKeepingWinding) {
    // Strip 0 1 2 3 -> triangles (0 1 2) and (2 1 3): the second swaps its first two corners.
    TinyGltf g;
    g.positions = {0, 0, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0};
    g.indices = {0, 1, 2, 3};
    g.mode = 5;
    Scene s;
    ASSERT_TRUE(load_json(s, g.json()).ok());
    EXPECT_EQ(s.meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
}

TEST(load_scene, TriangleFanIsConverted) {
    TinyGltf g;
    g.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    g.indices = {0, 1, 2, 3};
    g.mode = 6;
    Scene s;
    ASSERT_TRUE(load_json(s, g.json()).ok());
    EXPECT_EQ(s.meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
}

TEST(load_scene, LineLoopBecomesLines) {
    TinyGltf g;
    g.indices = {0, 1, 2};
    g.mode = 2;
    Scene s;
    ASSERT_TRUE(load_json(s, g.json()).ok());
    EXPECT_EQ(int(s.meshes[0].primitives[0].mode), int(PrimitiveMode::lines));
    EXPECT_EQ(s.meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 1, 2, 2, 0}));
}

TEST(load_scene, InterleavedByteStride) {
    // Position (12 bytes) and uv (8 bytes) interleaved with a 20-byte stride, no indices.
    std::vector<float> inter = {0, 0, 0, 0.1f, 0.2f, 1, 0, 0, 0.3f, 0.4f, 0, 1, 0, 0.5f, 0.6f};
    std::vector<uint8_t> bytes;
    append_bytes(bytes, inter);
    std::string json = doc(bytes, R"({"attributes":{"POSITION":0,"TEXCOORD_0":1}})",
                           R"({"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                              {"bufferView":0,"byteOffset":12,"componentType":5126,"count":3,"type":"VEC2"})",
                           R"({"buffer":0,"byteLength":60,"byteStride":20})");
    Scene s;
    Status st = load_json(s, json);
    ASSERT_TRUE(st.ok()) << st.message;
    const auto& p = s.meshes[0].primitives[0];
    EXPECT_EQ(p.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
    EXPECT_EQ(p.uv0, (std::vector<float>{0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f}));
    EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST(load_scene, SparseAccessorSubstitutesValues) {
    // Base positions all zero (no bufferView), sparse sets vertex 1 and 2.
    std::vector<uint8_t> bytes;
    append_bytes(bytes, std::vector<uint16_t>{1, 2});
    append_bytes(bytes, std::vector<float>{1, 0, 0, 0, 1, 0});
    std::string json = doc(bytes, R"({"attributes":{"POSITION":0}})",
                           R"({"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0],
                              "sparse":{"count":2,"indices":{"bufferView":0,"componentType":5123},"values":{"bufferView":1}}})",
                           R"({"buffer":0,"byteLength":4},{"buffer":0,"byteOffset":4,"byteLength":24})");
    Scene s;
    Status st = load_json(s, json);
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(s.meshes[0].primitives[0].positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
}

TEST(load_scene, QuantizedPositionsAndNormalizedUvsAreDequantized) {
    // KHR_mesh_quantization: int16 positions (not normalized), uint8 normalized UVs, int8 normalized normals.
    std::vector<uint8_t> bytes;
    append_bytes(bytes, std::vector<int16_t>{0, 0, 0, 0, 100, 0, 0, 0, 0, 100, 0, 0}); // 3 × (xyz + pad)
    append_bytes(bytes, std::vector<uint8_t>{0, 0, 0, 0, 255, 0, 0, 0, 0, 255, 0, 0}); // 3 × (uv + pad)
    append_bytes(bytes, std::vector<int8_t>{0, 0, 127, 0, 0, 0, 127, 0, 0, 0, -127, 0}); // 3 × (xyz + pad)
    std::string json = doc(bytes, R"({"attributes":{"POSITION":0,"TEXCOORD_0":1,"NORMAL":2}})",
                           R"({"bufferView":0,"componentType":5122,"count":3,"type":"VEC3","min":[0,0,0],"max":[100,100,0]},
                              {"bufferView":1,"componentType":5121,"normalized":true,"count":3,"type":"VEC2"},
                              {"bufferView":2,"componentType":5120,"normalized":true,"count":3,"type":"VEC3"})",
                           R"({"buffer":0,"byteLength":24,"byteStride":8},{"buffer":0,"byteOffset":24,"byteLength":12,"byteStride":4},
                              {"buffer":0,"byteOffset":36,"byteLength":12,"byteStride":4})",
                           R"(,"extensionsUsed":["KHR_mesh_quantization"],"extensionsRequired":["KHR_mesh_quantization"])");
    Scene s;
    Status st = load_json(s, json);
    ASSERT_TRUE(st.ok()) << st.message;
    const auto& p = s.meshes[0].primitives[0];
    EXPECT_EQ(p.positions, (std::vector<float>{0, 0, 0, 100, 0, 0, 0, 100, 0}));
    EXPECT_EQ(p.uv0, (std::vector<float>{0, 0, 1, 0, 0, 1}));
    EXPECT_EQ(p.normals, (std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, -1}));
    // Written back as float: the extension is no longer needed.
    const auto out = temp_dir() / "q.gltf";
    ASSERT_TRUE(save_scene(s, out.string()).ok());
    auto j = gltf_json(out);
    EXPECT_FALSE(j.contains("extensionsRequired") && !j["extensionsRequired"].empty());
    EXPECT_VALID_GLTF(out);
}

// The same int16 positions without KHR_mesh_quantization declared: not glTF 2.0 (only FLOAT positions are),
// refused with what is missing rather than dequantized as if the extension were there.
TEST(load_scene, QuantizedPositionWithoutTheExtensionIsAnError) {
    std::vector<uint8_t> bytes;
    append_bytes(bytes, std::vector<int16_t>{0, 0, 0, 0, 100, 0, 0, 0, 0, 100, 0, 0});
    const std::string accessor = R"({"bufferView":0,"componentType":5122,"count":3,"type":"VEC3","min":[0,0,0],"max":[100,100,0]})";
    const std::string view = R"({"buffer":0,"byteLength":24,"byteStride":8})";
    Scene s;
    Status st = load_json(s, doc(bytes, R"({"attributes":{"POSITION":0}})", accessor, view));
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("POSITION"), std::string::npos) << st.message;
    EXPECT_NE(st.message.find("KHR_mesh_quantization"), std::string::npos) << st.message;
    // Declared as used (not required) is enough.
    st = load_json(s, doc(bytes, R"({"attributes":{"POSITION":0}})", accessor, view, R"(,"extensionsUsed":["KHR_mesh_quantization"])"));
    EXPECT_TRUE(st.ok()) << st.message;
}

// Unnormalized byte texture coordinates are quantization too; normalized unsigned ones are core glTF.
TEST(load_scene, UnnormalizedByteUvsNeedTheExtension) {
    std::vector<uint8_t> bytes;
    append_bytes(bytes, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
    append_bytes(bytes, std::vector<uint8_t>{0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0});
    auto json = [&](bool normalized) {
        return doc(bytes, R"({"attributes":{"POSITION":0,"TEXCOORD_0":1}})",
                   std::string(R"({"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                              {"bufferView":1,"componentType":5121,"count":3,"type":"VEC2","normalized":)") +
                       (normalized ? "true" : "false") + "}",
                   R"({"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":12,"byteStride":4})");
    };
    Scene s;
    EXPECT_TRUE(load_json(s, json(true)).ok());
    Status st = load_json(s, json(false));
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("TEXCOORD_0"), std::string::npos) << st.message;
}

// glTF 2.0, 3.12: an asset that requires an extension the loader does not know must not be loaded. A vendor
// extension is refused by name; required material/texture extensions are carried through and load.
TEST(load_scene, UnknownRequiredExtensionIsUnsupported) {
    TinyGltf g;
    g.extra_top_level = R"(,"extensionsUsed":["VENDOR_secret_geometry"],"extensionsRequired":["VENDOR_secret_geometry"])";
    Scene s;
    Status st = load_json(s, g.json());
    EXPECT_EQ(st.code, StatusCode::unsupported);
    EXPECT_NE(st.message.find("VENDOR_secret_geometry"), std::string::npos) << st.message;
    g.extra_top_level = R"(,"extensionsUsed":["KHR_texture_transform","KHR_materials_unlit"],"extensionsRequired":["KHR_texture_transform","KHR_materials_unlit"])";
    st = load_json(s, g.json());
    EXPECT_TRUE(st.ok()) << st.message;
}

TEST(load_scene, IndexOutOfRangeIsAnError) {
    TinyGltf g;
    g.indices = {0, 1, 7};
    Scene s;
    Status st = load_json(s, g.json());
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("index 7"), std::string::npos) << st.message;
}

TEST(load_scene, NanPositionIsAnErrorUnlessAllowed) {
    TinyGltf g;
    g.positions[4] = std::nanf("");
    g.min_max = false;
    Scene s;
    Status st = load_json(s, g.json());
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("NaN"), std::string::npos) << st.message;
    LoadOptions o;
    o.allow_non_finite = true;
    const std::string j = g.json();
    EXPECT_TRUE(load_scene_from_memory(s, reinterpret_cast<const uint8_t*>(j.data()), j.size(), ".gltf", o).ok());
}

TEST(load_scene, InvalidModeIsUnsupported) {
    TinyGltf g;
    g.mode = 9;
    Scene s;
    Status st = load_json(s, g.json());
    EXPECT_NE(st.code, StatusCode::ok);
}

TEST(load_scene, AccessorPastEndOfBufferViewIsAnError) {
    std::vector<uint8_t> bytes(36, 0);
    std::string json = doc(bytes, R"({"attributes":{"POSITION":0}})",
                           R"({"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"})",
                           R"({"buffer":0,"byteLength":36})");
    Scene s;
    Status st = load_json(s, json);
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("past the end"), std::string::npos) << st.message;
}

TEST(load_scene, DracoRequiredIsUnsupported) {
    TinyGltf g;
    g.extra_top_level = R"(,"extensionsUsed":["KHR_draco_mesh_compression"],"extensionsRequired":["KHR_draco_mesh_compression"])";
    Scene s;
    Status st = load_json(s, g.json());
    EXPECT_EQ(st.code, StatusCode::unsupported);
    EXPECT_NE(st.message.find("KHR_draco_mesh_compression"), std::string::npos);
}

TEST(load_scene, GarbageAndTruncatedInputsFailCleanly) {
    Scene s;
    const std::string garbage = "{ not json";
    EXPECT_EQ(load_json(s, garbage).code, StatusCode::invalid_input);
    const uint8_t glb_header[] = {'g', 'l', 'T', 'F', 2, 0, 0, 0, 200, 0, 0, 0};
    EXPECT_EQ(load_scene_from_memory(s, glb_header, sizeof glb_header, ".glb").code, StatusCode::invalid_input);
    EXPECT_EQ(load_scene_from_memory(s, glb_header, 0, ".glb").code, StatusCode::invalid_input);
    EXPECT_EQ(load_scene(s, "/nonexistent/file.glb").code, StatusCode::io_error);
    EXPECT_EQ(load_scene(s, "mesh.xyz").code, StatusCode::io_error);
}

TEST(load_scene, ObjWithSeamsSplitsVerticesAndKeepsDoublePrecision) {
    // A quad whose two triangles use different UVs at the shared corner 2 (a seam), 1e5 m from the origin.
    const auto dir = temp_dir();
    write_text(dir / "seam.obj",
               "v 100000.001 0 0\nv 100001.002 0 0\nv 100001.002 1 0\nv 100000.001 1 0\n"
               "vt 0 0\nvt 1 0\nvt 1 1\nvt 0.5 0.5\nvt 0 1\n"
               "f 1/1 2/2 3/3\nf 1/1 3/4 4/5\n");
    Scene s;
    Status st = load_scene(s, (dir / "seam.obj").string());
    ASSERT_TRUE(st.ok()) << st.message;
    const auto& p = s.meshes[0].primitives[0];
    EXPECT_EQ(p.vertex_count(), 5u); // corner 3 split in two by its UVs
    // Recentred: the node carries the centre in double, the float positions the small offsets.
    EXPECT_DOUBLE_EQ(s.nodes[0].translation[0], (100000.001 + 100001.002) / 2);
    // float32 at 1e5 m would be good to 8 mm; relative to the centre it is good to a micrometre.
    EXPECT_NEAR(double(p.positions[0]) + s.nodes[0].translation[0], 100000.001, 1e-6);
    EXPECT_NEAR(double(p.positions[3]) + s.nodes[0].translation[0], 100001.002, 1e-6);
    // OBJ v=0 is the image bottom; glTF v=0 is the top.
    EXPECT_FLOAT_EQ(p.uv0[1], 1.0f);
}

} // namespace

namespace {
Status load_text(Scene& s, const std::string& text, const std::string& ext) {
    return load_scene_from_memory(s, reinterpret_cast<const uint8_t*>(text.data()), text.size(), ext);
}
} // namespace

// OpenMesh's PLY header parser never returns on a header without end_header and indexes an empty element list
// for a property before any element (found by fuzz_load_scene); such headers are refused before it runs.
TEST(load_scene, PlyHeadersOpenMeshCannotSurviveAreRefused) {
    const std::string body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    Scene s;
    Status st = load_text(s, "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face 1\nproperty list uchar int vertex_indices\nend_hekder\n" + body, ".ply");
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("end_header"), std::string::npos) << st.message;
    st = load_text(s, "ply\nformat ascii 1.0\nproperty float x\nelement vertex 3\nend_header\n" + body, ".ply");
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("before any element"), std::string::npos) << st.message;
    st = load_text(s, "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
                      "property float z\nend_header\n" + body, ".ply");
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    st = load_text(s, "ply\nformat ascii 1.0\nelement vertex three\nend_header\n" + body, ".ply");
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    // The body is walked too: a face of 4e9 corners, texture coordinates on a face without corners, and a
    // binary int list count of -1 (4e9 as OpenMesh reads it) looped or asserted in OpenMesh.
    const std::string head = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\n";
    st = load_text(s, "ply\nformat ascii 1.0\n" + head + "property list uchar int vertex_indices\nend_header\n"
                      "0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n", ".ply");
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    st = load_text(s, "ply\nformat ascii 1.0\n" + head + "property list uchar int vertex_indices\n"
                      "property list uchar float texcoord\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 6 0 0 1 0 0 1\n", ".ply");
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    std::string binary = "ply\nformat binary_little_endian 1.0\n" + head + "property list int int vertex_indices\nend_header\n";
    const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    binary.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
    const int32_t face[4] = {-1, 0, 1, 2};
    binary.append(reinterpret_cast<const char*>(face), sizeof face);
    EXPECT_EQ(load_text(s, binary, ".ply").code, StatusCode::invalid_input);
    binary.replace(binary.size() - 16, 4, std::string("\x03\0\0\0", 4)); // a count of 3: the same file is fine
    st = load_text(s, binary, ".ply");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(s.meshes[0].primitives[0].indices.size(), 3u);
    // The same file with a proper header loads.
    st = load_text(s, "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\nend_header\n" + body, ".ply");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(s.meshes[0].primitives[0].vertex_count(), 3u);
    EXPECT_EQ(s.meshes[0].primitives[0].indices.size(), 3u);
}

// OpenMesh's OFF reader reads its counts unchecked: an empty file asked for 2 GB, a short face list repeated
// its last corner count (fuzz_load_scene). Checked first now; a valid file with a quad keeps it.
TEST(load_scene, OffFilesAreCheckedBeforeOpenMeshReadsThem) {
    Scene s;
    EXPECT_EQ(load_text(s, "", ".off").code, StatusCode::invalid_input);
    EXPECT_EQ(load_text(s, "OFF\n", ".off").code, StatusCode::invalid_input);
    EXPECT_EQ(load_text(s, "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n", ".off").code, StatusCode::invalid_input);
    EXPECT_EQ(load_text(s, "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4000000 0 1 2 3\n", ".off").code, StatusCode::invalid_input);
    EXPECT_EQ(load_text(s, "OFF\n4 1 0\n0 0 0\n1 0 0\nx y z\n0 1 0\n4 0 1 2 3\n", ".off").code, StatusCode::invalid_input);
    EXPECT_EQ(load_text(s, "OFF BINARY\n", ".off").code, StatusCode::unsupported);
    EXPECT_EQ(load_text(s, "4OFF\n1 0 0\n0 0 0 1\n", ".off").code, StatusCode::invalid_input);
    Status st = load_text(s, "NOFF\n4 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n4 0 1 2 3\n", ".off");
    ASSERT_TRUE(st.ok()) << st.message;
    const Primitive& p = s.meshes[0].primitives[0];
    EXPECT_EQ(p.vertex_count(), 4u);
    EXPECT_EQ(p.face_sizes, std::vector<uint32_t>{4});
    EXPECT_EQ(p.positions[6], 1.0f); // vertex 2 is (1, 1, 0): the normals after x y z were not read as positions
    EXPECT_EQ(p.positions[7], 1.0f);
}

// OpenMesh asserts on an OBJ face corner without a vertex index, and Debian builds it with assertions on: the
// process aborted (fuzz_load_scene). And furrow reads no materials, so mtllib is not opened (a /dev/zero
// material file was read forever).
TEST(load_scene, ObjCornersWithoutVertexIndexAndMtllibAreHandled) {
    const std::string verts = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    Scene s;
    for (const char* face : {"f /1 2 3\n", "f 1 2 //1\n", "f x/1 2/1 3/1\n"}) {
        Status st = load_text(s, verts + face, ".obj");
        EXPECT_EQ(st.code, StatusCode::invalid_input) << face;
        EXPECT_NE(st.message.find("vertex index"), std::string::npos) << st.message;
    }
    Status st = load_text(s, "mtllib /dev/zero\n" + verts + "usemtl skin\nf 1/1/1 2/1/1 3/1/1 # a comment\n", ".obj");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(s.meshes[0].primitives[0].indices.size(), 3u);
}

// OpenMesh's OBJ reader skips a `v` line whose three coordinates its float stream cannot read, and every later
// vertex shifts by one: "v junk 1 1" gave every later vertex its neighbour's position in the double re-read
// (found by fuzz_load_scene), "v nan 0 0" was reported as "faces reference vertices that do not exist", and a
// coordinate beyond the float range (1e39) silently moved the vertices after it. Each is now refused by line.
TEST(load_scene, ObjVertexLineThatDoesNotParseIsAnError) {
    Scene s;
    for (const char* bad : {"v junk 1 1", "v nan 0 0", "v 1e39 0 0", "v 1 2", "v 0 inf 0"}) {
        const std::string text = std::string("v 0 0 0\n") + bad + "\nv 1 0 0\nv 0 1 0\nf 1 3 4\n";
        Status st = load_text(s, text, ".obj");
        EXPECT_EQ(st.code, StatusCode::invalid_input) << bad;
        EXPECT_NE(st.message.find("line 2"), std::string::npos) << st.message;
        EXPECT_NE(st.message.find(bad), std::string::npos) << st.message;
    }
    // Extra numbers (a w, or vertex colours) are fine, as are plain exponents.
    Status st = load_text(s, "v 0 0 0 1\nv 1e2 0 0 0.5 0.5 0.5\nv 0 1 0\nf 1 2 3\n", ".obj");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(s.meshes[0].primitives[0].positions, (std::vector<float>{0, 0, 0, 100, 0, 0, 0, 1, 0}));
}

// The one-pass OBJ reader (obj_load.cpp). Each behaviour with its own test; then a property test against an
// independent expectation on random OBJ text.
namespace {
const Primitive& first_primitive(const Scene& s) { return s.meshes.at(0).primitives.at(0); }
} // namespace

// A negative index counts back from the last vertex (texcoord, normal) read so far, not from the end of the
// file; a positive index may name a vertex written further down.
TEST(load_scene, ObjNegativeIndicesAreRelative) {
    Scene s;
    Status st = load_text(s, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf 1 2 4\nf -4 -3 -2\n", ".obj");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(first_primitive(s).indices, (std::vector<uint32_t>{0, 1, 2, 0, 1, 3, 0, 1, 2}));
    // Relative texcoords: vt -1 at the first face is the first vt, at the second face the second.
    st = load_text(s, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0\nf 1/-1 2/-1 3/-1\nvt 0.75 0\nf 3/-1 2/-1 1/-1\n", ".obj");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(first_primitive(s).uv0, (std::vector<float>{0.25f, 1, 0.25f, 1, 0.25f, 1, 0.75f, 1, 0.75f, 1, 0.75f, 1}));
    // Beyond the first vertex is out of range.
    st = load_text(s, "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n", ".obj");
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("1 faces reference vertices that do not exist"), std::string::npos) << st.message;
}

// Windows line ends, tabs between words, leading and trailing blanks, a last line without a line end.
TEST(load_scene, ObjCrlfAndTabs) {
    Scene a, b;
    ASSERT_TRUE(load_text(a, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\n", ".obj").ok());
    Status st = load_text(b, "v\t0 0 0\r\n  v 1\t0 0 \r\n\tv 0 1\t 0\t\r\n\r\nvt 0\t0\r\nf\t1/1  2/1\t3/1 \r", ".obj");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(first_primitive(b).positions, first_primitive(a).positions);
    EXPECT_EQ(first_primitive(b).indices, first_primitive(a).indices);
    EXPECT_EQ(first_primitive(b).uv0, first_primitive(a).uv0);
}

// A line ending in '\' goes on on the next line (OpenMesh read the '\' as a corner and dropped the face).
TEST(load_scene, ObjLineContinuation) {
    Scene s;
    Status st = load_text(s, "v 0 0 \\\n 7\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 \\\n3 \\\r\n4\n", ".obj");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(first_primitive(s).face_sizes, (std::vector<uint32_t>{4}));
    EXPECT_EQ(first_primitive(s).positions[2], 7.0f);
    EXPECT_TRUE(s.warnings.empty());
    // A bad number on a continued line is reported at the line the statement starts on.
    st = load_text(s, "v 0 0 0\nv 1 \\\n x 0\n", ".obj");
    EXPECT_NE(st.message.find("OBJ line 2 'v 1 \\': a vertex needs three finite numbers"), std::string::npos) << st.message;
}

// Polygons stay polygons (Catmull-Clark wants the quads), and o, g, s, usemtl, mtllib, l and p lines and
// trailing comments change nothing.
TEST(load_scene, ObjPolygonsAndIgnoredStatements) {
    Scene s;
    Status st = load_text(s, "mtllib none.mtl\no quad\ng a b\nusemtl skin\ns 1\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n"
                             "l 1 2\np 3\nf 1 2 3 4 # the quad\nf 2 5 3\ns off\n", ".obj");
    ASSERT_TRUE(st.ok()) << st.message;
    const Primitive& p = first_primitive(s);
    EXPECT_EQ(p.face_sizes, (std::vector<uint32_t>{4, 3}));
    EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 3, 1, 4, 2}));
    EXPECT_EQ(p.vertex_count(), 5u);
}

// `vn` through v//n and v/t/n corners gives vertex normals; `v x y z r g b` gives vertex colours (alpha 1).
TEST(load_scene, ObjNormalsAndVertexColours) {
    Scene s;
    Status st = load_text(s, "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nvn 0 0 1\nvn 0 0 -1\nf 1//2 2//1 3//2\n", ".obj");
    ASSERT_TRUE(st.ok()) << st.message;
    const Primitive& p = first_primitive(s);
    EXPECT_EQ(p.normals, (std::vector<float>{0, 0, -1, 0, 0, 1, 0, 0, -1}));
    EXPECT_EQ(p.colors, (std::vector<float>{1, 0, 0, 1, 0, 1, 0, 1, 0, 0, 1, 1}));
}

// A face that names a vertex twice keeps its distinct corners; one left with fewer than three is dropped,
// and the load says so.
TEST(load_scene, ObjRepeatedCornersAndDegenerateFaces) {
    Scene s;
    Status st = load_text(s, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2 3\nf 1 1 2\n", ".obj");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(first_primitive(s).indices, (std::vector<uint32_t>{0, 1, 2}));
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_NE(s.warnings[0].find("1 faces with fewer than 3 distinct corners"), std::string::npos) << s.warnings[0];
}

// A `vt` line that is not two numbers is refused by line (OpenMesh failed the whole read without saying where).
TEST(load_scene, ObjTexcoordLineThatDoesNotParseIsAnError) {
    Scene s;
    Status st = load_text(s, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5\nf 1 2 3\n", ".obj");
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("OBJ line 4 'vt 0.5': a texture coordinate needs two numbers"), std::string::npos) << st.message;
}

// Property: on random OBJ text (random spacing, line ends, comments, index styles, relative indices) the
// loader gives what a direct reading of the same statements gives: one vertex per distinct (v, vt) pair in
// order of first use, positions as the nearest float of the written double, uv with v flipped.
TEST(load_scene, ObjMatchesAnIndependentReadingOfRandomText) {
    test::Lcg next(12345);
    for (int round = 0; round < 300; ++round) {
        const size_t nv = 3 + next(20), nt = next(2) ? 1 + next(8) : 0;
        const bool crlf = next(4) == 0;
        auto space = [&] { return std::string(next(3) ? " " : next(2) ? "\t" : "  \t"); };
        auto eol = [&] { return std::string(next(8) == 0 ? " # note" : "") + (crlf ? "\r\n" : "\n"); };
        std::string text = next(2) ? "# random\n" : "";
        std::vector<double> pos;
        std::vector<float> uv;
        for (size_t i = 0; i < nv; ++i) {
            text += "v";
            for (int k = 0; k < 3; ++k) {
                const double x = (double(next(2000001)) - 1e6) / double(1000 + next(1000)); // near the origin: not recentred
                char b[40];
                std::snprintf(b, sizeof b, "%.17g", x);
                text += space() + b;
                pos.push_back(x);
            }
            text += eol();
        }
        for (size_t i = 0; i < nt; ++i) {
            const float u = float(next(1025)) / 1024, v = float(next(1025)) / 1024;
            text += "vt" + space() + std::to_string(u) + space() + std::to_string(v) + eol();
            uv.push_back(std::stof(std::to_string(u)));
            uv.push_back(std::stof(std::to_string(v)));
        }
        // Faces: distinct vertices; every corner with a texcoord, or none.
        std::map<std::pair<size_t, size_t>, uint32_t> first_use;
        std::vector<uint32_t> want_indices, want_sizes;
        std::vector<float> want_pos, want_uv;
        const size_t faces = 1 + next(12);
        for (size_t f = 0; f < faces; ++f) {
            const size_t n = 3 + next(std::min<size_t>(nv - 2, 4));
            const std::vector<uint32_t> corners = test::distinct_corners(next, nv, n);
            text += "f";
            for (size_t c : corners) {
                const size_t t = nt ? next(nt) : 0;
                // Negative (relative) indices as to_string of a negative number: "-" + std::to_string(k) draws
                // GCC 12's -Wrestrict false positive (GCC bug 105329).
                const std::string vi = next(3) ? std::to_string(c + 1) : std::to_string(-static_cast<long long>(nv - c));
                const std::string ti = next(3) ? std::to_string(t + 1) : std::to_string(-static_cast<long long>(nt - t));
                text += space() + vi + (nt ? "/" + ti : "");
                const auto key = std::make_pair(c, nt ? t : 0);
                auto [it, inserted] = first_use.insert({key, uint32_t(first_use.size())});
                if (inserted) {
                    for (int k = 0; k < 3; ++k) want_pos.push_back(float(pos[c * 3 + size_t(k)]));
                    if (nt) want_uv.insert(want_uv.end(), {uv[t * 2], 1.0f - uv[t * 2 + 1]});
                }
                want_indices.push_back(nt ? it->second : uint32_t(c));
            }
            want_sizes.push_back(uint32_t(n));
            text += eol();
        }
        Scene s;
        Status st = load_text(s, text, ".obj");
        ASSERT_TRUE(st.ok()) << st.message << "\n" << text;
        const Primitive& p = first_primitive(s);
        if (!nt) { // without texcoords every vertex is kept, in file order
            want_pos.clear();
            for (double x : pos) want_pos.push_back(float(x));
        }
        EXPECT_EQ(p.positions, want_pos) << text;
        EXPECT_EQ(p.indices, want_indices) << text;
        EXPECT_EQ(p.uv0, want_uv) << text;
        const bool all_triangles = std::all_of(want_sizes.begin(), want_sizes.end(), [](uint32_t n) { return n == 3; });
        EXPECT_EQ(p.face_sizes, all_triangles ? std::vector<uint32_t>{} : want_sizes) << text;
        EXPECT_EQ(s.nodes[0].translation, (std::array<double, 3>{0, 0, 0})) << text;
    }
}

// The reader takes plain corners (v, v/t, v//n, v/t/n, positive indices) in one pass and everything else
// through its general path: on random faces of every corner form, the same text with a '+' before each index
// (which only the general path reads) gives the same scene.
TEST(load_scene, ObjPlainCornersReadAsTheGeneralPathReadsThem) {
    test::Lcg next(777);
    for (int round = 0; round < 200; ++round) {
        const size_t nv = 4 + next(12), nt = 1 + next(5), nn = 1 + next(4);
        std::string head;
        for (size_t i = 0; i < nv; ++i) head += "v " + std::to_string(next(100)) + " " + std::to_string(next(100)) + " " + std::to_string(i) + "\n";
        for (size_t i = 0; i < nt; ++i) head += "vt 0." + std::to_string(next(1000)) + " 0." + std::to_string(next(1000)) + "\n";
        for (size_t i = 0; i < nn; ++i) head += "vn 0 " + std::to_string(next(2)) + " 1\n";
        const int form = int(next(4)); // one corner form per file: v, v/t, v//n, v/t/n
        std::string plain = head, plus = head;
        for (size_t f = 0, faces = 1 + next(10); f < faces; ++f) {
            const std::vector<uint32_t> corners = test::distinct_corners(next, nv, 3 + next(2));
            plain += "f", plus += "f";
            for (uint32_t c : corners) {
                const std::string v = std::to_string(c + 1), t = std::to_string(1 + next(nt)), n = std::to_string(1 + next(nn));
                const std::string a[4] = {v, v + "/" + t, v + "//" + n, v + "/" + t + "/" + n};
                const std::string b[4] = {"+" + v, "+" + v + "/+" + t, "+" + v + "//+" + n, "+" + v + "/+" + t + "/+" + n};
                plain += " " + a[form], plus += " " + b[form];
            }
            plain += "\n", plus += "\n";
        }
        Scene x, y;
        ASSERT_TRUE(load_text(x, plain, ".obj").ok()) << plain;
        ASSERT_TRUE(load_text(y, plus, ".obj").ok()) << plus;
        const Primitive &p = first_primitive(x), &q = first_primitive(y);
        EXPECT_EQ(p.positions, q.positions) << plain;
        EXPECT_EQ(p.indices, q.indices) << plain;
        EXPECT_EQ(p.face_sizes, q.face_sizes) << plain;
        EXPECT_EQ(p.uv0, q.uv0) << plain;
        EXPECT_EQ(p.normals, q.normals) << plain;
        EXPECT_EQ(p.uv0.empty(), form == 0 || form == 2) << plain;
        EXPECT_EQ(p.normals.empty(), form < 2) << plain;
    }
}

// load_scene_from_memory resolves no external URI (mesh.h), but tinygltf opened absolute paths and looked up
// relative ones in the working directory, so the result depended on where the process ran (found while
// fuzzing it). A file in the working directory still finds its .bin.
TEST(load_scene, FromMemoryNoExternalFileIsRead) {
    const auto dir = temp_dir();
    const std::vector<uint8_t> bin{0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 128, 63, 0, 0, 0, 0, 0, 0, 0, 0,
                                   0, 0, 0, 0, 0, 0, 128, 63, 0, 0, 0, 0};
    auto gltf = [&](const std::string& uri) {
        return "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
               "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],\"accessors\":[{\"bufferView\":0,"
               "\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}],"
               "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],\"buffers\":[{\"byteLength\":36,\"uri\":\"" + uri + "\"}]}";
    };
    write_bytes(dir / "tri.bin", bin);
    Scene s;
    Status st = load_json(s, gltf((dir / "tri.bin").string()));
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("not found"), std::string::npos) << st.message; // nothing about the file got out
    // The same document as a file beside its .bin loads, also from the working directory ("" parent).
    write_text(dir / "tri.gltf", gltf("tri.bin"));
    st = load_scene(s, (dir / "tri.gltf").string());
    ASSERT_TRUE(st.ok()) << st.message;
    const auto here = std::filesystem::current_path();
    const std::string name = "load_scene_cwd_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed());
    write_bytes(here / (name + ".bin"), bin);
    write_text(here / (name + ".gltf"), gltf(name + ".bin"));
    st = load_scene(s, name + ".gltf");
    std::filesystem::remove(here / (name + ".bin"));
    std::filesystem::remove(here / (name + ".gltf"));
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(s.meshes[0].primitives[0].vertex_count(), 3u);
}

// ---------------------------------------------------------------------------------------------------------
// External resources (issue 15): the resolver, the resource root, reading only what is used, the limits.
// ---------------------------------------------------------------------------------------------------------

namespace {

// A textured triangle: buffer 0 (positions) at `bin_uri`, image 0 at `image_uri` (texture 0 of material 0);
// with `unused`, also buffer 1 and image 1 that nothing refers to.
struct TexturedTriangle {
    std::vector<uint8_t> bin() const {
        std::vector<uint8_t> b;
        append_bytes(b, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
        append_bytes(b, std::vector<float>{0, 0, 1, 0, 0, 1});
        return b;
    }
    static std::vector<uint8_t> png() {
        const std::vector<uint8_t> rgba{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255};
        return encode_png_rgba8(rgba.data(), 2, 2);
    }
    nlohmann::json doc(const std::string& bin_uri, const std::string& image_uri, bool unused = false) const {
        nlohmann::json j = {
            {"asset", {{"version", "2.0"}}},
            {"scenes", {{{"nodes", {0}}}}},
            {"nodes", {{{"mesh", 0}}}},
            {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}}, {"material", 0}}}}}}},
            {"materials", {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}}},
            {"textures", {{{"source", 0}}}},
            {"images", {{{"uri", image_uri}}}},
            {"accessors", {{{"bufferView", 0}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"},
                            {"min", {0, 0, 0}}, {"max", {1, 1, 0}}},
                           {{"bufferView", 1}, {"componentType", 5126}, {"count", 3}, {"type", "VEC2"}}}},
            {"bufferViews", {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 36}},
                             {{"buffer", 0}, {"byteOffset", 36}, {"byteLength", 24}}}},
            {"buffers", {{{"byteLength", 60}, {"uri", bin_uri}}}}};
        if (unused) {
            j["buffers"].push_back({{"byteLength", 1000000}, {"uri", "unused.bin"}});
            j["images"].push_back({{"uri", "unused.png"}});
        }
        return j;
    }
};

Status load_with(Scene& s, const std::string& text, const LoadOptions& o) {
    return load_scene_from_memory(s, reinterpret_cast<const uint8_t*>(text.data()), text.size(), ".gltf", o);
}

// An engine loads a .gltf and its resources (a .bin and a PNG) from its own storage, here a map in memory.
TEST(load_scene, ResolverReadsGltfBinAndPngFromMemory) {
    const TexturedTriangle t;
    std::map<std::string, std::vector<uint8_t>> files{{"mesh.bin", t.bin()}, {"tex/skin one.png", t.png()}};
    std::vector<std::string> asked;
    LoadOptions o;
    o.resolver = [&](std::vector<uint8_t>& bytes, const ResourceRequest& r) {
        asked.push_back(r.path);
        auto it = files.find(r.path);
        if (it == files.end()) return Status::error(StatusCode::not_found, "is not in the archive");
        bytes = it->second;
        return Status::success();
    };
    Scene s;
    Status st = load_with(s, t.doc("mesh.bin", "tex/skin%20one.png").dump(), o);
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(asked, (std::vector<std::string>{"mesh.bin", "tex/skin one.png"}));
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.meshes[0].primitives[0].positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
    EXPECT_EQ(s.meshes[0].primitives[0].uv0, (std::vector<float>{0, 0, 1, 0, 0, 1}));
    ASSERT_EQ(s.images.size(), 1u);
    EXPECT_EQ(s.images[0].encoded, t.png());
    EXPECT_EQ(s.images[0].mime_type, "image/png");
    EXPECT_EQ(s.images[0].source_uri, "tex/skin%20one.png");
    EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
}

// A buffer and an image nothing refers to are never asked for, and the unused image is not carried to the
// output.
TEST(load_scene, UnusedBufferAndImageAreNeverRequested) {
    const TexturedTriangle t;
    int calls = 0;
    std::vector<std::string> asked;
    LoadOptions o;
    o.resolver = [&](std::vector<uint8_t>& bytes, const ResourceRequest& r) {
        ++calls;
        asked.push_back(r.uri);
        bytes = r.image ? t.png() : t.bin();
        return Status::success();
    };
    Scene s;
    Status st = load_with(s, t.doc("mesh.bin", "used.png", true).dump(), o);
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(calls, 2);
    EXPECT_EQ(asked, (std::vector<std::string>{"mesh.bin", "used.png"}));
    EXPECT_EQ(s.images.size(), 1u);
    // From files: the unused ones do not even exist.
    const auto dir = temp_dir();
    write_text(dir / "a.gltf", t.doc("mesh.bin", "used.png", true).dump());
    write_bytes(dir / "mesh.bin", t.bin());
    write_bytes(dir / "used.png", t.png());
    st = load_scene(s, (dir / "a.gltf").string());
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
    ASSERT_TRUE(save_scene(s, (dir / "out.glb").string()).ok());
    EXPECT_EQ(gltf_json(dir / "out.glb")["images"].size(), 1u);
}

// The default resolver keeps to the input's folder; --resource-root pointing higher allows `../`.
TEST(load_scene, ResourceRootHigherAllowsParentFolder) {
    const TexturedTriangle t;
    const auto dir = temp_dir();
    std::filesystem::create_directories(dir / "models");
    write_text(dir / "models" / "a.gltf", t.doc("mesh.bin", "../shared/skin.png").dump());
    write_bytes(dir / "models" / "mesh.bin", t.bin());
    std::filesystem::create_directories(dir / "shared");
    write_bytes(dir / "shared" / "skin.png", t.png());
    Scene s;
    Status st = load_scene(s, (dir / "models" / "a.gltf").string());
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_EQ(st.message, "image 0 uri '../shared/skin.png' is outside the resource root " +
                              std::filesystem::canonical(dir / "models").string());
    LoadOptions o;
    o.resource_root = dir.string();
    st = load_scene(s, (dir / "models" / "a.gltf").string(), o);
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(s.images.at(0).encoded, t.png());
}

// Every way out of the root is refused, and nothing outside it is read: `../`, `..%2F`, an absolute path, a
// file:// URI, a symbolic link; a NUL byte (raw or %00) and a malformed '%' are refused outright.
TEST(load_scene, EscapesFromTheResourceRootAreRefused) {
    const TexturedTriangle t;
    const auto dir = temp_dir();
    std::filesystem::create_directories(dir / "root" / "sub");
    write_bytes(dir / "root" / "mesh.bin", t.bin());
    write_bytes(dir / "root" / "sub" / "in.png", t.png());
    write_bytes(dir / "secret.png", t.png());
    std::filesystem::create_symlink(dir / "secret.png", dir / "root" / "link.png");
    const std::string root = std::filesystem::canonical(dir / "root").string();
    const std::string secret = std::filesystem::canonical(dir / "secret.png").string();
    const std::vector<std::pair<std::string, std::string>> rows{
        {"../secret.png", "is outside the resource root " + root},
        {"sub/../../secret.png", "is outside the resource root " + root},
        {"..%2Fsecret.png", "is outside the resource root " + root},
        {"%2E%2E/secret.png", "is outside the resource root " + root},
        {secret, "is outside the resource root " + root},
        {"file://" + secret, "is outside the resource root " + root},
        {"file://localhost" + secret, "is outside the resource root " + root},
        {"link.png", "is outside the resource root " + root},
        {"sub/in.png%00.txt", "contains a NUL byte"},
        {std::string("sub/in.png\0.txt", 15), "contains a NUL byte"},
        {"sub/in%zz.png", "'%' not followed by two hex digits"},
        {"http://example.com/a.png", "uses the URI scheme 'http:'"},
        {"file://otherhost/a.png", "names a file on another host"},
        {"sub", "is not a regular file"},
    };
    for (const auto& [uri, expected] : rows) {
        write_text(dir / "root" / "a.gltf", t.doc("mesh.bin", uri).dump());
        Scene s;
        Status st = load_scene(s, (dir / "root" / "a.gltf").string());
        EXPECT_FALSE(st.ok()) << uri;
        EXPECT_EQ(st.message.rfind("image 0 uri '", 0), 0u) << st.message;
        EXPECT_NE(st.message.find(expected), std::string::npos) << uri << ": " << st.message;
        EXPECT_EQ(st.message.find('\0'), std::string::npos);
    }
    // The same resources, named so that they stay inside, load: absolute, file:// and percent-encoded.
    for (const std::string& uri : std::vector<std::string>{root + "/sub/in.png", "file://" + root + "/sub/in.png", "sub%2Fin.png", "sub/./../sub/in.png"}) {
        write_text(dir / "root" / "a.gltf", t.doc("mesh.bin", uri).dump());
        Scene s;
        Status st = load_scene(s, (dir / "root" / "a.gltf").string());
        ASSERT_TRUE(st.ok()) << uri << ": " << st.message;
        EXPECT_EQ(s.images.at(0).encoded, t.png()) << uri;
    }
    // Buffers alike.
    write_text(dir / "root" / "a.gltf", t.doc("../root/../secret.png", "sub/in.png").dump());
    Scene s;
    Status st = load_scene(s, (dir / "root" / "a.gltf").string());
    EXPECT_EQ(st.message, "buffer 0 uri '../root/../secret.png' is outside the resource root " + root);
}

// A resolver's error fails the load, continuing the sentence that names the resource.
TEST(load_scene, ResolverErrorFailsTheLoad) {
    const TexturedTriangle t;
    LoadOptions o;
    o.resolver = [&](std::vector<uint8_t>& bytes, const ResourceRequest& r) {
        if (r.image) return Status::error(StatusCode::io_error, "could not be fetched: archive is corrupt");
        bytes = t.bin();
        return Status::success();
    };
    Scene s;
    Status st = load_with(s, t.doc("mesh.bin", "skin.png").dump(), o);
    EXPECT_EQ(st.code, StatusCode::io_error);
    EXPECT_EQ(st.message, "image 0 uri 'skin.png' could not be fetched: archive is corrupt");
    // not_found: the image is one warning (renders with the factor), a buffer an error.
    o.resolver = [&](std::vector<uint8_t>& bytes, const ResourceRequest& r) {
        if (r.image) return Status::error(StatusCode::not_found, "is not in the archive");
        bytes = t.bin();
        return Status::success();
    };
    st = load_with(s, t.doc("mesh.bin", "skin.png").dump(), o);
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_TRUE(s.images.at(0).encoded.empty());
    o.resolver = [](std::vector<uint8_t>&, const ResourceRequest&) { return Status::error(StatusCode::not_found, "is not in the archive"); };
    st = load_with(s, t.doc("mesh.bin", "skin.png").dump(), o);
    EXPECT_EQ(st.message, "buffer 0 uri 'mesh.bin' is not in the archive");
}

// The limits, each naming the option that raises it (the CLI names its flag instead); the resolver is not asked for what a limit refuses.
TEST(load_scene, LimitsNameTheOptionThatRaisesThem) {
    const TexturedTriangle t;
    int calls = 0;
    LoadOptions o;
    o.resolver = [&](std::vector<uint8_t>& bytes, const ResourceRequest& r) {
        ++calls;
        bytes = r.image ? t.png() : t.bin();
        return Status::success();
    };
    Scene s;
    auto doc = t.doc("mesh.bin", "skin.png");
    // A byteLength of 1e12 is refused before anything is read.
    auto big = doc;
    big["buffers"][0]["byteLength"] = 1000000000000ull;
    Status st = load_with(s, big.dump(), o);
    EXPECT_EQ(st.code, StatusCode::out_of_memory);
    EXPECT_NE(st.message.find("buffer 0 uri 'mesh.bin' is 1000000000000 bytes"), std::string::npos) << st.message;
    EXPECT_NE(st.message.find("LoadOptions::max_resource_bytes"), std::string::npos) << st.message;
    EXPECT_EQ(calls, 0);
    LoadOptions small = o;
    small.max_resource_bytes = 100; // the .bin (60) fits, the PNG then does not
    st = load_with(s, doc.dump(), small);
    EXPECT_NE(st.message.find("image 0 uri 'skin.png' is " + std::to_string(t.png().size()) + " bytes, above the 40 bytes left"),
              std::string::npos) << st.message;
    LoadOptions few = o;
    few.max_nodes = 1;
    auto two = doc;
    two["nodes"].push_back({{"mesh", 0}});
    st = load_with(s, two.dump(), few);
    EXPECT_EQ(st.message, "the file has 2 nodes, above the limit of 1 (LoadOptions::max_nodes raises it)");
    few.max_primitives = 1;
    two = doc;
    two["meshes"][0]["primitives"].push_back(two["meshes"][0]["primitives"][0]);
    st = load_with(s, two.dump(), few);
    EXPECT_EQ(st.message, "the file has 2 primitives, above the limit of 1 (LoadOptions::max_primitives raises it)");
    calls = 0;
    LoadOptions pixels = o;
    pixels.max_image_pixels = 3; // the image is 2x2
    st = load_with(s, doc.dump(), pixels);
    EXPECT_EQ(st.message, "image 0 is 2x2 pixels, above the limit of 3 (LoadOptions::max_image_pixels raises it)");
    pixels.max_image_pixels = 4;
    EXPECT_TRUE(load_with(s, doc.dump(), pixels).ok());
}

// A PNG header claiming 100000 × 100000 (stb_image itself will not say its size) is refused at load, from
// memory too: before, it loaded and only a decoder found out.
TEST(load_scene, OversizedImageHeaderIsRefusedAtLoad) {
    std::vector<uint8_t> png = TexturedTriangle::png();
    for (int at : {16, 20}) { // IHDR width and height, big-endian (the CRC is not checked by a header read)
        png[size_t(at)] = 0x00, png[size_t(at) + 1] = 0x01, png[size_t(at) + 2] = 0x86, png[size_t(at) + 3] = 0xA0;
    }
    const TexturedTriangle t;
    auto doc = t.doc("data:application/octet-stream;base64," + base64(t.bin()), "data:image/png;base64," + base64(png));
    Scene s;
    Status st = load_with(s, doc.dump(), {});
    EXPECT_EQ(st.code, StatusCode::out_of_memory);
    EXPECT_EQ(st.message, "image 0 is 100000x100000 pixels, above the limit of 67108864 (LoadOptions::max_image_pixels raises it)");
}

} // namespace

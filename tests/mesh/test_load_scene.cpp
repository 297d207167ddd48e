// load_scene / load_scene_from_memory: glTF accessor features and the errors for what is broken.
#include "gltf_builder.h"
#include "test_support.h"

#include <cmath>

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

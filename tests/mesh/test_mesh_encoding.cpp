// save_scene's encodings: vertex order (SaveOptions::optimize), KHR_mesh_quantization (--quantize) and
// EXT_meshopt_compression (--compress). Every written file passes the Khronos validator (0/0) and reads back
// in furrow within the documented precision; gltfpack's output reads too; corrupt compressed data is a clean
// error.
#include "scene_compare.h"
#include "test_support.h"

#include <furrow/shapes.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <utility>

using namespace furrow;
using namespace furrow::test;

namespace furrow::mesh_detail { // mesh/src/encoding.h: the writer's int8 unit vectors
std::vector<int8_t> quantize_unit_vectors(const std::vector<float>& v, size_t stride, bool octahedral);
}

namespace {

// World-space position of every vertex of every drawn mesh, in double, per mesh in node order.
std::vector<std::array<double, 3>> world_positions(const Scene& s) {
    std::vector<std::array<double, 3>> out;
    const auto world = s.world_matrices();
    for (int n : s.drawn_nodes()) {
        if (s.nodes[size_t(n)].mesh < 0) continue;
        const auto& m = world[size_t(n)];
        for (const Primitive& p : s.meshes[size_t(s.nodes[size_t(n)].mesh)].primitives)
            for (size_t i = 0; i < p.vertex_count(); ++i) {
                const double x = p.positions[i * 3], y = p.positions[i * 3 + 1], z = p.positions[i * 3 + 2];
                out.push_back({m[0] * x + m[4] * y + m[8] * z + m[12], m[1] * x + m[5] * y + m[9] * z + m[13],
                               m[2] * x + m[6] * y + m[10] * z + m[14]});
            }
    }
    return out;
}

double max_distance(const std::vector<std::array<double, 3>>& a, const std::vector<std::array<double, 3>>& b) {
    EXPECT_EQ(a.size(), b.size());
    double worst = 0;
    for (size_t i = 0; i < std::min(a.size(), b.size()); ++i)
        for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(a[i][size_t(k)] - b[i][size_t(k)]));
    return worst;
}

// The scene in the vertex order save_scene writes with encoding `e`.
Scene optimized(Scene s, Encoding e) {
    for (Mesh& m : s.meshes)
        for (Primitive& p : m.primitives) {
            triangulate(p);
            optimize_vertex_order(p, e);
        }
    return s;
}

// Each triangle starting at its lowest index, corners in the same cyclic order.
std::vector<uint32_t> rotated_to_lowest(std::vector<uint32_t> v) {
    for (size_t t = 0; t + 2 < v.size(); t += 3)
        while (v[t] > v[t + 1] || v[t] > v[t + 2]) std::rotate(v.begin() + std::ptrdiff_t(t), v.begin() + std::ptrdiff_t(t + 1),
                                                               v.begin() + std::ptrdiff_t(t + 3));
    return v;
}

SaveOptions with(Encoding e, int bits = 0) {
    SaveOptions o;
    o.encoding = e;
    o.position_bits = bits;
    return o;
}

Scene load_as_stored(const std::filesystem::path& file) {
    Scene s;
    LoadOptions o;
    o.recentre = false;
    Status st = load_scene(s, file.string(), o);
    EXPECT_TRUE(st.ok()) << file << ": " << st.message;
    return s;
}

Primitive textured_sphere() {
    Primitive p = shapes::uv_sphere(2.0f, 24, 12);
    const size_t n = p.vertex_count();
    p.colors.assign(n * 4, 0.25f);
    p.custom = {CustomAttribute{"_FUR_LAYER", 1, std::vector<float>(n, 3.0f)}};
    return p;
}

} // namespace

TEST(mesh_encoding, OptimizedOrderKeepsEveryCornerAndAttribute) {
    // The multiset of triangles, each as its three corners' (position, uv, colour, custom) tuples, is the same
    // after optimize_vertex_order, and so is the vertex count.
    Primitive p = textured_sphere();
    for (size_t i = 0; i < p.vertex_count(); ++i) p.custom[0].values[i] = float(i), p.colors[i * 4] = float(i % 7) / 7;
    Primitive q = p;
    optimize_vertex_order(q);
    ASSERT_EQ(q.vertex_count(), p.vertex_count());
    EXPECT_NE(q.indices, p.indices);
    auto corners = [](const Primitive& x) {
        std::multiset<std::vector<float>> tris;
        for (size_t t = 0; t + 2 < x.indices.size(); t += 3) {
            std::vector<float> key;
            for (size_t c = 0; c < 3; ++c) {
                const size_t v = x.indices[t + c];
                for (size_t k = 0; k < 3; ++k) key.push_back(x.positions[v * 3 + k]), key.push_back(x.normals[v * 3 + k]);
                key.insert(key.end(), {x.uv0[v * 2], x.uv0[v * 2 + 1], x.colors[v * 4], x.custom[0].values[v]});
            }
            tris.insert(key);
        }
        return tris;
    };
    EXPECT_EQ(corners(p), corners(q));
    Primitive again = p;
    optimize_vertex_order(again);
    EXPECT_EQ(again.indices, q.indices); // deterministic
}

TEST(mesh_encoding, NoOptimizeKeepsTheOrder) {
    const Scene s = make_scene(textured_sphere(), "sphere");
    SaveOptions o;
    o.optimize = false;
    const auto out = temp_dir() / "plain.glb";
    ASSERT_TRUE(save_scene(s, out.string(), o).ok());
    expect_same_scene(s, load_as_stored(out), false);
    EXPECT_FALSE(gltf_json(out).contains("extensionsUsed")); // plain output needs no extension
}

TEST(mesh_encoding, QuantizedAndCompressedReadBackWithinTheDocumentedPrecision) {
    const Scene s = make_scene(textured_sphere(), "sphere");
    const double extent = 4.0; // the sphere's largest bounding-box extent
    for (Encoding e : {Encoding::quantize, Encoding::compress})
        for (const char* ext : {".glb", ".gltf"}) {
            const Scene expected = optimized(s, e); // compress: strip order
            const auto out = temp_dir() / (std::string(e == Encoding::compress ? "c" : "q") + ext);
            Status st = save_scene(s, out.string(), with(e));
            ASSERT_TRUE(st.ok()) << st.message;
            EXPECT_VALID_GLTF(out);
            const nlohmann::json j = gltf_json(out);
            EXPECT_EQ(j["extensionsRequired"].size(), e == Encoding::compress ? 2u : 1u) << j["extensionsRequired"];
            const Scene b = load_as_stored(out);
            const double step = extent / double((1 << default_position_bits) - 1);
            const double err = max_distance(world_positions(expected), world_positions(b));
            EXPECT_LE(err, step / 2 * (1 + 1e-6)) << out;
            EXPECT_GT(err, 0.0) << "positions were not quantized";
            const Primitive &pa = expected.meshes[0].primitives[0], &pb = b.meshes[0].primitives[0];
            // meshopt's index codec may start a triangle at another corner (the winding is kept).
            EXPECT_EQ(rotated_to_lowest(pa.indices), rotated_to_lowest(pb.indices));
            // int8 x, y, z: half a step, plus the renormalisation; compressed: the 8-bit octahedral filter.
            expect_same_floats(pa.normals, pb.normals, e == Encoding::compress ? 0.02f : 1.0f / 127, "normals");
            expect_same_floats(pa.uv0, pb.uv0, 0.5f / 65535, "uv0");
            expect_same_floats(pa.colors, pb.colors, 0.5f / 255 + 1e-7f, "colors");
            ASSERT_EQ(pb.custom.size(), 1u);
            expect_same_floats(pa.custom[0].values, pb.custom[0].values, 0.0f, "custom");
        }
}

TEST(mesh_encoding, CompressedIsSmallerThanQuantizedIsSmallerThanPlain) {
    const Scene s = make_scene(shapes::creature(), "creature");
    const auto dir = temp_dir();
    std::map<int, uintmax_t> size;
    for (Encoding e : {Encoding::plain, Encoding::quantize, Encoding::compress}) {
        const auto out = dir / ("e" + std::to_string(int(e)) + ".glb");
        ASSERT_TRUE(save_scene(s, out.string(), with(e)).ok());
        size[int(e)] = std::filesystem::file_size(out);
    }
    EXPECT_LT(size[1], size[0] * 7 / 10); // 0.64 measured
    EXPECT_LT(size[2], size[1] * 7 / 10);
}

TEST(mesh_encoding, FarTerrainKeepsMillimetres) {
    // A 10 m terrain 5e6 m from the origin (as load_scene's recentring leaves it: small positions, the offset
    // in the node): quantized and compressed, its world positions stay within a millimetre.
    Primitive p = shapes::grid(10.0f, 10.0f, 40, 40);
    for (size_t i = 0; i < p.vertex_count(); ++i) p.positions[i * 3 + 1] = 0.3f * std::sin(float(i) * 0.37f);
    Scene s = make_scene(p, "terrain");
    s.nodes[0].translation = {5.0e6, 120.0, -5.0e6};
    for (Encoding e : {Encoding::quantize, Encoding::compress}) {
        const Scene expected = optimized(s, e);
        const auto out = temp_dir() / ("terrain" + std::to_string(int(e)) + ".glb");
        ASSERT_TRUE(save_scene(s, out.string(), with(e)).ok());
        EXPECT_VALID_GLTF(out);
        const double err = max_distance(world_positions(expected), world_positions(load_as_stored(out)));
        EXPECT_LT(err, 0.5e-3) << "10 m / 16383 / 2 = 0.31 mm";
    }
}

// The dequantization (the grid's translation and scale) goes on the node that draws the mesh when nothing
// else reads that node's transform, as gltfpack writes it; a node with its own transform or children hands
// the mesh to a new child instead. Either way the world positions are the grid's.
TEST(mesh_encoding, DequantizationGoesOnTheDrawingNodeWhenOnlyItsMeshReadsIt) {
    Scene plain = make_scene(textured_sphere(), "sphere");
    Scene parent = plain, moved = plain;
    parent.nodes.push_back(Node{});
    parent.nodes[0].children = {1};
    moved.nodes[0].translation = {1, 2, 3};
    for (const auto& [s, in_place] : {std::pair{&plain, true}, std::pair{&parent, false}, std::pair{&moved, false}}) {
        const auto out = temp_dir() / "sphere.glb";
        ASSERT_TRUE(save_scene(*s, out.string(), with(Encoding::quantize)).ok());
        EXPECT_VALID_GLTF(out);
        const nlohmann::json nodes = gltf_json(out)["nodes"];
        EXPECT_EQ(nodes.size(), s->nodes.size() + (in_place ? 0 : 1));
        EXPECT_EQ(nodes[0].contains("mesh"), in_place);
        EXPECT_EQ(nodes.back().contains("mesh") && nodes.back().contains("scale"), true);
        const double err = max_distance(world_positions(optimized(*s, Encoding::quantize)), world_positions(load_as_stored(out)));
        EXPECT_LE(err, 4.0 / 16383 / 2 * (1 + 1e-6));
    }
}

// --compress rounds each normal to its nearest 8-bit octahedral code, and the OCTAHEDRAL filter writes that
// very code: the file decodes to exactly the int8 vectors the writer chose. (Encoding the decoded vector
// again gave a neighbouring code for about 0.6 % of them, one more step off: the demo terrain's largest
// normal error was 1.20 degrees, gltfpack -cc's 0.85; now both are 0.85.)
TEST(mesh_encoding, CompressedNormalsDecodeToTheirOctahedralRounding) {
    const Scene s = make_scene(shapes::creature(), "creature");
    const auto out = temp_dir() / "creature.glb";
    ASSERT_TRUE(save_scene(s, out.string(), with(Encoding::compress)).ok());
    const std::vector<float> normals = optimized(s, Encoding::compress).meshes[0].primitives[0].normals;
    const std::vector<int8_t> chosen = mesh_detail::quantize_unit_vectors(normals, 3, true);
    const std::vector<float> read = load_as_stored(out).meshes[0].primitives[0].normals;
    ASSERT_EQ(read.size(), normals.size());
    size_t differ = 0;
    for (size_t i = 0; i < read.size(); ++i) differ += std::lround(read[i] * 127.0f) != chosen[i / 3 * 4 + i % 3];
    EXPECT_EQ(differ, 0u) << "of " << read.size() << " components";
}

TEST(mesh_encoding, PositionBitsSetTheStep) {
    const Scene s = make_scene(textured_sphere(), "sphere");
    const Scene expected = optimized(s, Encoding::compress);
    for (int bits : {8, 16}) {
        const auto out = temp_dir() / ("b" + std::to_string(bits) + ".glb");
        ASSERT_TRUE(save_scene(s, out.string(), with(Encoding::compress, bits)).ok());
        EXPECT_VALID_GLTF(out);
        const double step = 4.0 / double((1 << bits) - 1);
        const double err = max_distance(world_positions(expected), world_positions(load_as_stored(out)));
        EXPECT_LE(err, step / 2 * (1 + 1e-6));
        EXPECT_GT(err, step / 8) << "the grid is coarser than asked";
    }
    EXPECT_EQ(save_scene(s, (temp_dir() / "x.glb").string(), with(Encoding::quantize, 17)).code,
              StatusCode::invalid_argument);
}

// Texture coordinates outside [0, 1] (the fur's tiling strand UVs) stay float under --compress and go
// through the EXPONENTIAL filter with 16-bit mantissas: error at most 2^-15 of the larger component
// (meshopt_codec.cpp). Triangle index views use the index codec's version 1 (header byte 0xe1), as gltfpack
// writes them.
TEST(mesh_encoding, CompressedTilingUvsAndIndexCodecVersion) {
    Primitive p = textured_sphere();
    ASSERT_FALSE(p.uv0.empty());
    constexpr float tiles = 10.7f;
    p.uv1 = p.uv0;
    for (float& u : p.uv1) u *= tiles;
    const Scene s = make_scene(p, "tiled");
    const auto out = temp_dir() / "tiled.glb";
    ASSERT_TRUE(save_scene(s, out.string(), with(Encoding::compress)).ok());
    EXPECT_VALID_GLTF(out);
    const nlohmann::json j = gltf_json(out);
    const nlohmann::json& prim = j["meshes"][0]["primitives"][0];
    const nlohmann::json& uv1 = j["accessors"][prim["attributes"]["TEXCOORD_1"].get<size_t>()];
    EXPECT_EQ(uv1["componentType"], 5126);
    EXPECT_EQ(j["bufferViews"][uv1["bufferView"].get<size_t>()]["extensions"]["EXT_meshopt_compression"]["filter"], "EXPONENTIAL");
    const nlohmann::json& idx = j["bufferViews"][j["accessors"][prim["indices"].get<size_t>()]["bufferView"].get<size_t>()]
                                 ["extensions"]["EXT_meshopt_compression"];
    ASSERT_EQ(idx["mode"], "TRIANGLES");
    const std::vector<uint8_t> bytes = read_bytes(out);
    uint32_t json_length = 0;
    std::memcpy(&json_length, bytes.data() + 12, 4);
    const size_t at = 20 + size_t(json_length) + 8 + idx.value("byteOffset", size_t(0));
    ASSERT_LT(at, bytes.size());
    EXPECT_EQ(int(bytes[at]), 0xe1);

    const Primitive pa = optimized(s, Encoding::compress).meshes[0].primitives[0];
    const Primitive pb = load_as_stored(out).meshes[0].primitives[0];
    ASSERT_EQ(pa.uv1.size(), pb.uv1.size());
    double worst = 0;
    for (size_t i = 0; i < pa.uv1.size(); ++i) worst = std::max(worst, double(std::abs(pa.uv1[i] - pb.uv1[i])));
    EXPECT_LE(worst, tiles / 32768.0);
    EXPECT_GT(worst, 0.0) << "the filter is lossy: 16 bits, not 24";
    expect_same_floats(pa.uv0, pb.uv0, 0.5f / 65535, "uv0");
}

namespace {

// The sphere with tiling strand coordinates (uv1 = tiles · uv0) drawn with a material that samples a
// `texels`-wide texture at TEXCOORD_1, as the fur's shells are.
Scene tiled_strand_scene(float tiles, int texels) {
    Primitive p = textured_sphere();
    p.uv1 = p.uv0;
    for (float& u : p.uv1) u = u * tiles - 0.25f * tiles;
    p.material = 0;
    Scene s = make_scene(p, "strands");
    std::vector<uint8_t> rgba(size_t(texels) * size_t(texels) * 4, 200);
    Image im;
    im.mime_type = "image/png";
    im.encoded = encode_png_rgba8(rgba.data(), texels, texels);
    s.images = {im};
    s.textures = {Texture{0, -1}};
    Material m;
    m.base_color_texture = {0, 1};
    s.materials = {m};
    return s;
}

} // namespace

// gltfpack's layout for coordinates outside [0, 1] that a texture samples: normalized uint16 on their
// bounding box, dequantized by KHR_texture_transform on the material (texture_transform.cpp). The file is
// valid, furrow reads back coordinates within half a step (the transform baked into them, the extension
// gone), and the plain copy of that scene declares no transform.
TEST(mesh_encoding, TiledTextureCoordinatesAreQuantizedWithATextureTransform) {
    constexpr float tiles = 10.7f;
    const Scene s = tiled_strand_scene(tiles, 64);
    const auto dir = temp_dir();
    for (Encoding e : {Encoding::quantize, Encoding::compress}) {
        SCOPED_TRACE(int(e));
        const auto out = dir / "strands.glb";
        ASSERT_TRUE(save_scene(s, out.string(), with(e)).ok());
        EXPECT_VALID_GLTF(out);
        const nlohmann::json j = gltf_json(out);
        const nlohmann::json& uv1 = j["accessors"][j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"].get<size_t>()];
        EXPECT_EQ(uv1["componentType"], 5123);
        EXPECT_EQ(uv1["normalized"], true);
        const nlohmann::json& t = j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"];
        EXPECT_NEAR(t["offset"][0].get<double>(), -0.25 * tiles, 1e-5);
        EXPECT_NEAR(t["scale"][0].get<double>(), tiles, 1e-5);
        EXPECT_TRUE(j["extensionsRequired"].dump().find("KHR_texture_transform") != std::string::npos);

        const Scene back = load_as_stored(out);
        const Primitive pa = optimized(s, e).meshes[0].primitives[0];
        const Primitive& pb = back.meshes[0].primitives[0];
        expect_same_floats(pa.uv1, pb.uv1, float(0.5 * tiles / 65535 + 1e-6), "uv1");
        const auto plain = dir / "strands_plain.glb";
        ASSERT_TRUE(save_scene(back, plain.string(), with(Encoding::plain)).ok());
        EXPECT_VALID_GLTF(plain);
        const nlohmann::json jp = gltf_json(plain);
        EXPECT_FALSE(jp.contains("extensionsUsed")) << jp["extensionsUsed"].dump();
        EXPECT_FALSE(jp["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"].contains("extensions"));
    }
}

// The step must keep every coordinate within half a texel of the texture: 2000 tiles of a 64-texel texture
// would not (2000 · 64 / 65535 texels a step), and a set that no texture samples has no material to carry
// the transform. Both stay float.
TEST(mesh_encoding, TextureCoordinatesStayFloatWhereATransformCannotKeepThem) {
    for (bool sampled : {true, false}) {
        Scene s = tiled_strand_scene(sampled ? 2000.0f : 10.7f, 64);
        if (!sampled) s.materials[0].base_color_texture.texcoord = 0;
        const auto out = temp_dir() / "floats.glb";
        ASSERT_TRUE(save_scene(s, out.string(), with(Encoding::compress)).ok());
        EXPECT_VALID_GLTF(out);
        const nlohmann::json j = gltf_json(out);
        EXPECT_EQ(j["accessors"][j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"].get<size_t>()]["componentType"], 5126);
        EXPECT_FALSE(j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"].contains("extensions"));
    }
}

// SaveOptions::drop_unused_uvs leaves out the sets no texture of the material samples (gltfpack's default),
// keeps the sampled ones, and keeps everything of a mesh with extras (vendor data, such as FURROW_shells, may
// read them). Off by default.
TEST(mesh_encoding, DropUnusedUvsKeepsWhatATextureOrVendorDataReads) {
    const auto dir = temp_dir();
    auto sets = [&](const Scene& s, bool drop, const std::string& name) {
        SaveOptions o = with(Encoding::compress);
        o.drop_unused_uvs = drop;
        const auto out = dir / name;
        EXPECT_TRUE(save_scene(s, out.string(), o).ok());
        EXPECT_VALID_GLTF(out);
        const nlohmann::json a = gltf_json(out)["meshes"][0]["primitives"][0]["attributes"];
        return std::make_pair(a.contains("TEXCOORD_0"), a.contains("TEXCOORD_1"));
    };
    Scene s = tiled_strand_scene(10.7f, 64); // the material samples set 1 only: set 0 stays (no gap in TEXCOORD_n)
    EXPECT_EQ(sets(s, false, "kept.glb"), std::make_pair(true, true));
    EXPECT_EQ(sets(s, true, "set1.glb"), std::make_pair(true, true));
    s.materials[0].base_color_texture.texcoord = 0; // samples set 0 only: set 1 goes
    EXPECT_EQ(sets(s, true, "dropped.glb"), std::make_pair(true, false));
    s.materials[0].base_color_texture.texcoord = 1;
    s.meshes[0].extras_json = R"({"vendor":1})";
    EXPECT_EQ(sets(s, true, "vendor.glb"), std::make_pair(true, true));
    s.meshes[0].extras_json.clear();
    s.meshes[0].primitives[0].material = -1;
    EXPECT_EQ(sets(s, true, "untextured.glb"), std::make_pair(false, false));
}

// The loader applies a material's transform (offset, rotation, scale: uv' = T · R · S · uv) to the set its
// textures sample, when every reference to that set agrees; references that disagree keep theirs.
TEST(mesh_encoding, LoaderBakesAgreeingTextureTransforms) {
    const Scene s = tiled_strand_scene(1.0f, 8);
    const auto dir = temp_dir();
    const auto out = dir / "transformed.gltf";
    ASSERT_TRUE(save_scene(s, out.string(), with(Encoding::plain)).ok());
    const Scene ref = load_as_stored(out); // in the written vertex order
    nlohmann::json j = gltf_json(out);
    const nlohmann::json t = {{"offset", {0.5, -2.0}}, {"rotation", 0.3}, {"scale", {3.0, 0.5}}};
    j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"] = t;
    j["extensionsUsed"] = {"KHR_texture_transform"};
    for (bool agree : {true, false}) {
        SCOPED_TRACE(agree);
        j["materials"][0]["emissiveTexture"] = {{"index", 0}, {"texCoord", 1}};
        if (agree) j["materials"][0]["emissiveTexture"]["extensions"]["KHR_texture_transform"] = t;
        std::ofstream(out) << j.dump();
        const Scene back = load_as_stored(out);
        const std::vector<float>& a = ref.meshes[0].primitives[0].uv1;
        const std::vector<float>& b = back.meshes[0].primitives[0].uv1;
        ASSERT_EQ(a.size(), b.size());
        const double c = std::cos(0.3), sn = std::sin(0.3);
        for (size_t i = 0; i < a.size(); i += 2) {
            const double u = 3.0 * a[i], v = 0.5 * a[i + 1];
            const double eu = agree ? 0.5 + c * u + sn * v : a[i], ev = agree ? -2.0 - sn * u + c * v : a[i + 1];
            ASSERT_NEAR(b[i], eu, 1e-5) << i / 2;
            ASSERT_NEAR(b[i + 1], ev, 1e-5) << i / 2;
        }
        const auto plain = dir / "again_plain.glb";
        ASSERT_TRUE(save_scene(back, plain.string(), with(Encoding::plain)).ok());
        EXPECT_VALID_GLTF(plain);
        const nlohmann::json jp = gltf_json(plain);
        EXPECT_EQ(jp["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"].contains("extensions"), !agree);
        EXPECT_EQ(jp.contains("extensionsUsed"), !agree);
        const auto again = dir / "again.glb";
        ASSERT_TRUE(save_scene(back, again.string(), with(Encoding::compress)).ok());
        EXPECT_VALID_GLTF(again);
    }
}

TEST(mesh_encoding, SkinnedAndMorphedMeshesStayFloatAndValid) {
    Primitive p = shapes::box(1, 1, 1, true);
    MorphTarget t;
    t.position_deltas.assign(p.positions.size(), 0.0f);
    t.position_deltas[1] = 0.25f;
    p.targets = {t};
    Scene s = make_scene(p, "morph");
    s.meshes[0].weights = {0.5f};
    const auto out = temp_dir() / "morph.glb";
    ASSERT_TRUE(save_scene(s, out.string(), with(Encoding::compress)).ok());
    EXPECT_VALID_GLTF(out);
    expect_same_scene(s, load_as_stored(out), true, Encoding::compress); // float positions: exact
}

TEST(mesh_encoding, SameBytesEveryTime) {
    const Scene s = make_scene(shapes::creature(), "creature");
    const auto a = temp_dir() / "a.glb", b = temp_dir() / "b.glb";
    ASSERT_TRUE(save_scene(s, a.string(), with(Encoding::compress)).ok());
    ASSERT_TRUE(save_scene(s, b.string(), with(Encoding::compress)).ok());
    EXPECT_EQ(read_bytes(a), read_bytes(b));
}

TEST(mesh_encoding, GltfpackOutputLoads) {
    // gltfpack -cc: quantized, compressed with filters (OCTAHEDRAL normals), a fallback buffer without data.
    if (!std::filesystem::exists("/usr/bin/gltfpack")) GTEST_SKIP() << "gltfpack is not installed";
    const auto dir = temp_dir();
    const auto in = models_dir() / "creature.glb", out = dir / "cc.glb";
    RunResult r = run_program({"/usr/bin/gltfpack", "-i", in.string(), "-o", out.string(), "-cc"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const Scene a = load_as_stored(in), b = load_as_stored(out);
    size_t ta = 0, tb = 0;
    for (const Mesh& m : a.meshes)
        for (const Primitive& p : m.primitives) ta += p.triangle_count();
    for (const Mesh& m : b.meshes)
        for (const Primitive& p : m.primitives) tb += p.triangle_count();
    EXPECT_EQ(ta, tb);
    // Same world bounding box within gltfpack's 14-bit grid.
    auto box = [](const std::vector<std::array<double, 3>>& v) {
        std::array<double, 6> r{1e300, 1e300, 1e300, -1e300, -1e300, -1e300};
        for (const auto& x : v)
            for (size_t k = 0; k < 3; ++k) r[k] = std::min(r[k], x[k]), r[k + 3] = std::max(r[k + 3], x[k]);
        return r;
    };
    const auto ba = box(world_positions(a)), bb = box(world_positions(b));
    for (size_t k = 0; k < 6; ++k) EXPECT_NEAR(ba[k], bb[k], 1e-3) << k;
    for (const Mesh& m : b.meshes)
        for (const Primitive& p : m.primitives)
            for (size_t i = 0; i + 2 < p.normals.size(); i += 3)
                ASSERT_NEAR(std::hypot(p.normals[i], p.normals[i + 1], p.normals[i + 2]), 1.0, 0.02) << "normal " << i / 3;
    // furrow writes it back, plain and compressed, validator-clean.
    for (Encoding e : {Encoding::plain, Encoding::compress}) {
        const auto again = dir / ("again" + std::to_string(int(e)) + ".glb");
        ASSERT_TRUE(save_scene(b, again.string(), with(e)).ok());
        EXPECT_VALID_GLTF(again);
    }
}

TEST(mesh_encoding, CorruptCompressedDataIsACleanError) {
    const Scene s = make_scene(textured_sphere(), "sphere");
    const auto dir = temp_dir();
    const auto out = dir / "c.gltf";
    ASSERT_TRUE(save_scene(s, out.string(), with(Encoding::compress)).ok());
    const nlohmann::json j = gltf_json(out);
    // Garbage in every compressed byte of the .bin: meshoptimizer's decoder refuses it.
    std::vector<uint8_t> bin = read_bytes(dir / "c.bin");
    for (size_t i = 0; i < bin.size(); ++i) bin[i] = uint8_t(i * 131 + 7);
    write_bytes(dir / "c.bin", bin);
    Scene b;
    Status st = load_scene(b, out.string());
    EXPECT_EQ(st.code, StatusCode::invalid_input) << st.message;
    EXPECT_NE(st.message.find("EXT_meshopt_compression"), std::string::npos) << st.message;
    // A count the view's length does not hold, and a stride the mode does not allow.
    for (const char* field : {"count", "byteStride"}) {
        nlohmann::json k = j;
        for (auto& v : k["bufferViews"])
            if (v.contains("extensions")) v["extensions"]["EXT_meshopt_compression"][field] = 1000003;
        write_text(dir / "k.gltf", k.dump());
        write_bytes(dir / "k.bin", read_bytes(dir / "c.bin"));
        std::filesystem::copy_file(dir / "c.bin", dir / "k.bin", std::filesystem::copy_options::overwrite_existing);
        nlohmann::json kk = k;
        kk["buffers"][0]["uri"] = "c.bin";
        write_text(dir / "k.gltf", kk.dump());
        st = load_scene(b, (dir / "k.gltf").string());
        EXPECT_EQ(st.code, StatusCode::invalid_input) << field << ": " << st.message;
    }
}

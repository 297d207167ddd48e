// The bad-input catalog: every kind of broken input, option or output path the `furrow` command must refuse,
// one table row each, across check, convert, render, shells, tessellate and stamp. For every row:
//   - the documented exit code (README "Exit codes": 1 bad input / unwritable output, 2 usage error);
//   - exactly one stderr line starting with "Error:", naming the problem (a fragment of the message) and, for
//     exit code 1, the file it is about ("Error: <file>: <what>");
//   - nothing left behind: the test folder lists the same files afterwards (no output, no temporary);
//   - inputs untouched: every file in the folder has the same bytes afterwards.
// Some rows repeat cases of the per-command tests on purpose: the catalog is complete on its own.
#include "gltf_builder.h"
#include "test_support.h"

#include <furrow/shapes.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <unistd.h>

namespace furrow {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::run_furrow;

// ---------------------------------------------------------------------------------------------------------
// Input builders
// ---------------------------------------------------------------------------------------------------------

// A valid one-quad glTF: accessor 0 = POSITION (4 × VEC3 float), 1 = NORMAL, 2 = indices (6 × uint16), one
// buffer view each, the buffer as a data URI. Rows break exactly the member they are about.
struct Quad {
    std::vector<float> positions{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    std::vector<float> normals{0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    std::vector<uint16_t> indices{0, 1, 2, 0, 2, 3};

    std::vector<uint8_t> bin() const {
        std::vector<uint8_t> b;
        test::append_bytes(b, positions);
        test::append_bytes(b, normals);
        test::append_bytes(b, indices);
        return b;
    }
    json doc(bool data_uri = true) const {
        const std::vector<uint8_t> b = bin();
        json j = {{"asset", {{"version", "2.0"}}},
                  {"scene", 0},
                  {"scenes", json::array({{{"nodes", {0}}}})},
                  {"nodes", json::array({{{"mesh", 0}}})},
                  {"meshes", json::array({{{"primitives",
                                            json::array({{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}}, {"indices", 2}, {"mode", 4}}})}}})},
                  {"accessors", json::array({{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"},
                                              {"min", {0, 0, 0}}, {"max", {1, 1, 0}}},
                                             {{"bufferView", 1}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
                                             {{"bufferView", 2}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}})},
                  {"bufferViews", json::array({{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
                                               {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 48}},
                                               {{"buffer", 0}, {"byteOffset", 96}, {"byteLength", 12}}})},
                  {"buffers", json::array({{{"byteLength", b.size()}}})}};
        if (data_uri) j["buffers"][0]["uri"] = "data:application/octet-stream;base64," + test::base64(b);
        return j;
    }
};

// Writes quad.gltf after `edit` changed its JSON.
std::function<void(const fs::path&)> quad_gltf(const std::string& name, std::function<void(json&)> edit) {
    return [name, edit](const fs::path& dir) {
        json j = Quad{}.doc();
        edit(j);
        test::write_text(dir / name, j.dump());
    };
}

std::vector<uint8_t> make_glb(const std::string& text, const std::vector<uint8_t>& bin, uint32_t version = 2) {
    std::string j = text;
    while (j.size() % 4) j.push_back(' ');
    std::vector<uint8_t> b = bin;
    while (b.size() % 4) b.push_back(0);
    std::string out = "glTF"; // built as a string: GCC 12 warns (falsely) on vector inserts here
    auto u32 = [&out](uint32_t v) {
        for (int k = 0; k < 4; ++k) out.push_back(char(uint8_t(v >> (8 * k))));
    };
    u32(version);
    u32(uint32_t(12 + 8 + j.size() + (b.empty() ? 0 : 8 + b.size())));
    u32(uint32_t(j.size()));
    u32(0x4E4F534A);
    out += j;
    if (!b.empty()) {
        u32(uint32_t(b.size()));
        u32(0x004E4942);
        out.append(reinterpret_cast<const char*>(b.data()), b.size());
    }
    return std::vector<uint8_t>(out.begin(), out.end());
}

// A valid quad GLB whose bytes `edit` then changes.
std::function<void(const fs::path&)> quad_glb(const std::string& name, std::function<void(std::vector<uint8_t>&)> edit,
                                              uint32_t version = 2, bool break_json = false) {
    return [=](const fs::path& dir) {
        Quad q;
        std::string text = q.doc(false).dump();
        if (break_json) text.resize(text.size() - 7);
        std::vector<uint8_t> bytes = make_glb(text, q.bin(), version);
        edit(bytes);
        test::write_bytes(dir / name, bytes);
    };
}

std::vector<uint8_t> pseudo_random_bytes(size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::vector<uint8_t> b(n);
    for (auto& x : b) x = uint8_t(rng() & 0xFF);
    return b;
}

void write_png_grey(const fs::path& file, int channels) {
    ImageF im;
    im.width = im.height = 4;
    im.channels = channels;
    im.pixels.assign(size_t(16 * channels), 1.0f);
    ASSERT_TRUE(save_png(im, file.string()).ok());
}

// What every row starts with: a good mesh with UVs, a ground, colliders, a grey mask, a far-from-perfect but
// valid icosphere without UVs.
void write_common(const fs::path& dir) {
    ASSERT_TRUE(save_scene(make_scene(shapes::uv_sphere(0.5f, 12, 6), "ball"), (dir / "good.glb").string()).ok());
    ASSERT_TRUE(save_scene(make_scene(shapes::icosphere(0.5f, 1), "ico"), (dir / "ico.glb").string()).ok());
    ASSERT_TRUE(save_scene(make_scene(shapes::grid(4, 4, 4, 4), "ground"), (dir / "ground.glb").string()).ok());
    test::write_text(dir / "ball.json", R"({"colliders": [{"shape": "sphere", "radius": 0.3, "path": [[-1, 0.2, 0], [1, 0.2, 0.5]]}]})");
    write_png_grey(dir / "grey.png", 1);
}

std::function<void(const fs::path&)> text_file(const std::string& name, const std::string& text) {
    return [=](const fs::path& dir) { test::write_text(dir / name, text); };
}
std::function<void(const fs::path&)> bytes_file(const std::string& name, const std::vector<uint8_t>& bytes) {
    return [=](const fs::path& dir) { test::write_bytes(dir / name, bytes); };
}
std::function<void(const fs::path&)> folder(const std::string& name) {
    return [=](const fs::path& dir) { fs::create_directories(dir / name); };
}
// good.glb cut to `keep` of its bytes.
std::function<void(const fs::path&)> truncated_copy(const std::string& from, const std::string& to, double keep) {
    return [=](const fs::path& dir) {
        std::vector<uint8_t> b = test::read_bytes(dir / from);
        b.resize(size_t(double(b.size()) * keep));
        test::write_bytes(dir / to, b);
    };
}
std::function<void(const fs::path&)> nothing() {
    return [](const fs::path&) {};
}

// A frame-less PFM heightmap (4 × 4 zeros), stretched over the ground when read.
std::vector<uint8_t> flat_pfm() {
    std::string h = "Pf\n4 4\n-1.0\n";
    std::vector<uint8_t> b(h.begin(), h.end());
    b.resize(b.size() + 64, 0);
    return b;
}

// ---------------------------------------------------------------------------------------------------------
// The table
// ---------------------------------------------------------------------------------------------------------

struct Case {
    std::string name;                             // test name
    std::function<void(const fs::path&)> setup;   // writes the bad input (after write_common)
    std::vector<std::string> args;                // a leading '@' stands for the test folder
    int exit_code;                                // 1 bad input / output, 2 usage
    std::string file;                             // the file the Error line names ('@' = folder); "" = none
    std::string fragment;                         // the Error line contains this
};

// gtest prints a failing row by its name (not as raw bytes).
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

const std::vector<std::string> kShells{"--layers", "2", "--length", "0.05"};
const std::vector<std::string> kStamp{"--colliders", "@/ball.json", "--resolution", "64"};

std::vector<std::string> cat(std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

std::vector<Case> catalog() {
    std::vector<Case> c;
    // ---- files and containers ----------------------------------------------------------------------------
    // An input that does not exist.
    c.push_back({"MissingInput", nothing(), {"check", "@/nope.glb"}, 1, "@/nope.glb", "file not found"});
    // A folder where a mesh file is expected.
    c.push_back({"InputIsAFolder", folder("folder.glb"), {"render", "@/folder.glb", "-o", "@/out.png"}, 1, "@/folder.glb",
                 "is a directory"});
    // A format furrow does not read.
    c.push_back({"UnsupportedInputType", text_file("model.fbx", "Kaydara FBX Binary"), {"convert", "@/model.fbx", "-o", "@/out.glb"},
                 1, "@/model.fbx", "unsupported file type '.fbx'"});
    // A zero-byte .gltf.
    c.push_back({"EmptyGltf", text_file("empty.gltf", ""), cat({"tessellate", "@/empty.gltf", "-o", "@/out.glb"}, {"--uniform", "2"}), 1,
                 "@/empty.gltf", "file is empty"});
    // A zero-byte .glb.
    c.push_back({"EmptyGlb", text_file("empty.glb", ""), {"convert", "@/empty.glb", "-o", "@/out.glb"}, 1, "@/empty.glb", "file is empty"});
    // A GLB cut in half (its chunks run past the end).
    c.push_back({"TruncatedGlb", truncated_copy("good.glb", "cut.glb", 0.5), cat({"shells", "@/cut.glb", "-o", "@/out.glb"}, kShells), 1,
                 "@/cut.glb", "invalid GLB"});
    // Only the 12-byte GLB header.
    c.push_back({"GlbHeaderOnly", quad_glb("hdr.glb", [](std::vector<uint8_t>& b) { b.resize(12); }), {"check", "@/hdr.glb"}, 1,
                 "@/hdr.glb", "invalid GLB"});
    // Random bytes named .glb.
    c.push_back({"GarbageGlb", bytes_file("noise.glb", pseudo_random_bytes(4096, 7)), {"check", "@/noise.glb"}, 1, "@/noise.glb",
                 "GLB magic"});
    // A GLB whose magic is 'glTX'.
    c.push_back({"WrongGlbMagic", quad_glb("magic.glb", [](std::vector<uint8_t>& b) { b[3] = 'X'; }),
                 {"convert", "@/magic.glb", "-o", "@/out.glb"}, 1, "@/magic.glb", "GLB magic"});
    // A GLB container of version 1 (glTF 1.0's binary extension).
    c.push_back({"GlbVersion1", quad_glb("v1.glb", [](std::vector<uint8_t>&) {}, 1), {"render", "@/v1.glb", "-o", "@/out.png"}, 1,
                 "@/v1.glb", "container version 1"});
    // A GLB whose header length is larger than the file.
    c.push_back({"GlbLengthBeyondFile", quad_glb("len.glb", [](std::vector<uint8_t>& b) {
                     uint32_t len = 0;
                     std::memcpy(&len, &b[8], 4);
                     len += 64;
                     std::memcpy(&b[8], &len, 4);
                 }),
                 cat({"tessellate", "@/len.glb", "-o", "@/out.glb"}, {"--uniform", "2"}), 1, "@/len.glb", "invalid GLB"});
    // A GLB whose JSON chunk is cut off (syntax error inside a valid container).
    c.push_back({"GlbJsonSyntaxError", quad_glb("json.glb", [](std::vector<uint8_t>&) {}, 2, true),
                 cat({"stamp", "@/json.glb", "-o", "@/out.glb"}, kStamp), 1, "@/json.glb", "parse error"});
    // A .gltf with a JSON syntax error.
    c.push_back({"GltfJsonSyntaxError", text_file("syntax.gltf", R"({"asset": {"version": "2.0"}, "meshes": [ })"),
                 {"check", "@/syntax.gltf"}, 1, "@/syntax.gltf", "parse error"});
    // Valid JSON that is not an object.
    c.push_back({"GltfRootNotAnObject", text_file("array.gltf", "[1, 2, 3]"), {"convert", "@/array.gltf", "-o", "@/out.glb"}, 1,
                 "@/array.gltf", "not a JSON object"});
    // A binary STL whose facet count is larger than the file.
    c.push_back({"TruncatedBinaryStl", bytes_file("noise.stl", pseudo_random_bytes(1000, 3)), {"convert", "@/noise.stl", "-o", "@/out.glb"},
                 1, "@/noise.stl", "truncated"});
    // Random bytes named .ply.
    c.push_back({"GarbagePly", bytes_file("noise.ply", pseudo_random_bytes(2000, 5)), {"check", "@/noise.ply"}, 1, "@/noise.ply", "ply"});
    // An OBJ without a vertex.
    c.push_back({"ObjWithoutVertices", text_file("empty.obj", "# nothing here\n"), cat({"shells", "@/empty.obj", "-o", "@/out.glb"}, kShells), 1,
                 "@/empty.obj", "no vertices"});
    // An OBJ face referring to vertex 9 of 3.
    // A vertex line with NaN: named by line, not reported as faces pointing at missing vertices.
    c.push_back({"ObjNanVertex", text_file("nan.obj", "v 0 0 0\nv nan 1 0\nv 0 1 0\nf 1 2 3\n"), {"check", "@/nan.obj"}, 1,
                 "@/nan.obj", "OBJ line 2 'v nan 1 0': a vertex needs three finite numbers"});
    c.push_back({"ObjFaceIndexOutOfRange", text_file("face.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
                 cat({"tessellate", "@/face.obj", "-o", "@/out.glb"}, {"--uniform", "2"}), 1, "@/face.obj", "do not exist"});

    // ---- buffers ------------------------------------------------------------------------------------------
    // A buffer view reaching past the end of its buffer.
    c.push_back({"BufferViewOutsideBuffer", quad_gltf("bv.gltf", [](json& j) { j["bufferViews"][0]["byteLength"] = 4000; }),
                 {"convert", "@/bv.gltf", "-o", "@/out.glb"}, 1, "@/bv.gltf", "lies outside its buffer"});
    // A buffer view starting past the end of its buffer.
    c.push_back({"BufferViewOffsetOutsideBuffer", quad_gltf("bvo.gltf", [](json& j) { j["bufferViews"][2]["byteOffset"] = 1000; }),
                 {"check", "@/bvo.gltf"}, 1, "@/bvo.gltf", "lies outside its buffer"});
    // An accessor reading past the end of its buffer view.
    c.push_back({"AccessorPastBufferView", quad_gltf("acc.gltf", [](json& j) { j["accessors"][0]["count"] = 40; }),
                 cat({"shells", "@/acc.gltf", "-o", "@/out.glb"}, kShells), 1, "@/acc.gltf", "reads past the end"});
    // A byteStride smaller than one element.
    c.push_back({"ByteStrideTooSmall", quad_gltf("stride.gltf", [](json& j) { j["bufferViews"][0]["byteStride"] = 4; }),
                 {"render", "@/stride.gltf", "-o", "@/out.png", "--size", "32x24"}, 1, "@/stride.gltf", "byteStride"});
    // A data URI holding fewer bytes than the buffer's byteLength.
    c.push_back({"DataUriShorterThanBuffer", quad_gltf("short_uri.gltf", [](json& j) { j["buffers"][0]["byteLength"] = 4096; }),
                 {"check", "@/short_uri.gltf"}, 1, "@/short_uri.gltf", "decode"});
    // An external .bin that does not exist.
    c.push_back({"MissingBin", quad_gltf("nobin.gltf", [](json& j) { j["buffers"][0]["uri"] = "missing.bin"; }),
                 cat({"tessellate", "@/nobin.gltf", "-o", "@/out.glb"}, {"--uniform", "2"}), 1, "@/nobin.gltf", "missing.bin"});
    // An external .bin shorter than byteLength.
    c.push_back({"BinTooShort",
                 [](const fs::path& dir) {
                     json j = Quad{}.doc(false);
                     j["buffers"][0]["uri"] = "short.bin";
                     test::write_text(dir / "short.gltf", j.dump());
                     std::vector<uint8_t> b = Quad{}.bin();
                     b.resize(50);
                     test::write_bytes(dir / "short.bin", b);
                 },
                 {"convert", "@/short.gltf", "-o", "@/out.gltf"}, 1, "@/short.gltf", "short.bin"});
    // A buffer view naming a buffer that does not exist.
    c.push_back({"BufferDoesNotExist", quad_gltf("buf.gltf", [](json& j) { j["bufferViews"][1]["buffer"] = 5; }),
                 {"check", "@/buf.gltf"}, 1, "@/buf.gltf", "buffer"});

    // ---- accessors ----------------------------------------------------------------------------------------
    // POSITION as VEC2.
    c.push_back({"PositionIsVec2", quad_gltf("vec2.gltf", [](json& j) { j["accessors"][0]["type"] = "VEC2"; j["accessors"][0].erase("min"); j["accessors"][0].erase("max"); }),
                 {"render", "@/vec2.gltf", "-o", "@/out.png", "--size", "32x24"}, 1, "@/vec2.gltf", "expected 3 components"});
    // POSITION with componentType UNSIGNED_INT (only indices may use it).
    c.push_back({"PositionUnsignedInt", quad_gltf("uint.gltf", [](json& j) { j["accessors"][0]["componentType"] = 5125; }),
                 {"convert", "@/uint.gltf", "-o", "@/out.glb"}, 1, "@/uint.gltf", "UNSIGNED_INT"});
    // A componentType that does not exist.
    c.push_back({"InvalidComponentType", quad_gltf("ct.gltf", [](json& j) { j["accessors"][1]["componentType"] = 5130; }),
                 {"check", "@/ct.gltf"}, 1, "@/ct.gltf", "componentType"});
    // Float indices.
    c.push_back({"FloatIndices", quad_gltf("fidx.gltf", [](json& j) { j["accessors"][2]["componentType"] = 5126; j["accessors"][2]["count"] = 3; }),
                 cat({"tessellate", "@/fidx.gltf", "-o", "@/out.glb"}, {"--uniform", "2"}), 1, "@/fidx.gltf", "unsigned integers"});
    // Indices as VEC3 instead of SCALAR.
    c.push_back({"IndicesNotScalar", quad_gltf("vidx.gltf", [](json& j) { j["accessors"][2]["type"] = "VEC3"; j["accessors"][2]["count"] = 2; }),
                 {"check", "@/vidx.gltf"}, 1, "@/vidx.gltf", "SCALAR"});
    // NORMAL with fewer elements than POSITION.
    c.push_back({"AttributeCountMismatch", quad_gltf("cnt.gltf", [](json& j) { j["accessors"][1]["count"] = 3; }),
                 cat({"shells", "@/cnt.gltf", "-o", "@/out.glb"}, kShells), 1, "@/cnt.gltf", "POSITION has 4"});
    // An attribute naming an accessor that does not exist.
    c.push_back({"AccessorDoesNotExist", quad_gltf("noacc.gltf", [](json& j) { j["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 9; }),
                 {"convert", "@/noacc.gltf", "-o", "@/out.glb"}, 1, "@/noacc.gltf", "9"});
    // An index past the last vertex.
    c.push_back({"IndexOutOfRange",
                 [](const fs::path& dir) {
                     Quad q;
                     q.indices = {0, 1, 2, 0, 2, 7};
                     test::write_text(dir / "idx.gltf", q.doc().dump());
                 },
                 cat({"stamp", "@/idx.gltf", "-o", "@/out.glb"}, kStamp), 1, "@/idx.gltf", "out of range"});
    // A triangle list whose index count is not a multiple of 3.
    c.push_back({"IndexCountNotMultipleOf3", quad_gltf("five.gltf", [](json& j) { j["accessors"][2]["count"] = 5; }),
                 {"check", "@/five.gltf"}, 1, "@/five.gltf", "not a multiple of 3"});
    // A NaN position (check reports NaN as a finding; the other commands refuse it).
    c.push_back({"NanPosition",
                 [](const fs::path& dir) {
                     Quad q;
                     q.positions[4] = std::nanf("");
                     json j = q.doc();
                     j["accessors"][0].erase("min"), j["accessors"][0].erase("max");
                     test::write_text(dir / "nan.gltf", j.dump());
                 },
                 cat({"shells", "@/nan.gltf", "-o", "@/out.glb"}, kShells), 1, "@/nan.gltf", "NaN"});
    // An infinite position.
    c.push_back({"InfinitePosition",
                 [](const fs::path& dir) {
                     Quad q;
                     q.positions[6] = INFINITY;
                     json j = q.doc();
                     j["accessors"][0].erase("min"), j["accessors"][0].erase("max");
                     test::write_text(dir / "inf.gltf", j.dump());
                 },
                 {"render", "@/inf.gltf", "-o", "@/out.png", "--size", "32x24"}, 1, "@/inf.gltf", "infinite"});

    // ---- primitives, extensions, references ----------------------------------------------------------------
    // Primitive mode 9 (glTF has 0..6).
    c.push_back({"UnsupportedPrimitiveMode", quad_gltf("mode.gltf", [](json& j) { j["meshes"][0]["primitives"][0]["mode"] = 9; }),
                 cat({"tessellate", "@/mode.gltf", "-o", "@/out.glb"}, {"--uniform", "2"}), 1, "@/mode.gltf", "primitive mode 9"});
    // Draco compression required.
    c.push_back({"DracoRequired", quad_gltf("draco.gltf", [](json& j) {
                     j["extensionsUsed"] = {"KHR_draco_mesh_compression"};
                     j["extensionsRequired"] = {"KHR_draco_mesh_compression"};
                 }),
                 {"convert", "@/draco.gltf", "-o", "@/out.glb"}, 1, "@/draco.gltf", "KHR_draco_mesh_compression is not supported"});
    // EXT_meshopt_compression is decoded; a compressed view that is corrupt or does not add up is refused.
    // Each row makes bufferView 0 (the positions) a compressed view over its own plain bytes, then breaks it.
    struct MeshoptRow {
        const char* name;
        std::function<void(json&)> edit;
        const char* message;
    };
    const std::vector<MeshoptRow> meshopt_rows{
        {"MeshoptCorruptData", [](json&) {}, "the compressed data is corrupt"},
        {"MeshoptCountOverLength", [](json& e) { e["count"] = 1000000; }, "is not the view's byteLength"},
        {"MeshoptStrideNotMultipleOf4", [](json& e) { e["byteStride"] = 6; e["count"] = 8; }, "ATTRIBUTES byteStride must be"},
        {"MeshoptOutsideItsBuffer", [](json& e) { e["byteLength"] = 100000; }, "lies outside buffer 0"},
        {"MeshoptUnknownMode", [](json& e) { e["mode"] = "STRIPS"; }, "unknown mode 'STRIPS'"},
        {"MeshoptFilterOnIndices", [](json& e) { e["mode"] = "INDICES"; e["byteStride"] = 4; e["count"] = 12; e["filter"] = "OCTAHEDRAL"; },
         "a filter is only allowed with ATTRIBUTES"},
        {"MeshoptMissingBuffer", [](json& e) { e["buffer"] = 7; }, "buffer 7 does not exist"},
    };
    for (const MeshoptRow& r : meshopt_rows) {
        const std::string file = std::string(r.name) + ".gltf";
        c.push_back({r.name, quad_gltf(file, [edit = r.edit](json& j) {
                         j["extensionsUsed"] = {"EXT_meshopt_compression"};
                         j["extensionsRequired"] = {"EXT_meshopt_compression"};
                         json e = {{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}, {"byteStride", 12}, {"count", 4},
                                   {"mode", "ATTRIBUTES"}};
                         edit(e);
                         j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"] = e;
                     }),
                     {"render", "@/" + file, "-o", "@/out.png", "--size", "32x24"}, 1, "@/" + file, r.message});
    }
    // A required extension nobody knows (glTF 3.12: the asset must not be loaded).
    c.push_back({"UnknownRequiredExtension", quad_gltf("vendor.gltf", [](json& j) {
                     j["extensionsUsed"] = {"VENDOR_secret_geometry"};
                     j["extensionsRequired"] = {"VENDOR_secret_geometry"};
                 }),
                 cat({"tessellate", "@/vendor.gltf", "-o", "@/out.glb"}, {"--uniform", "2"}), 1, "@/vendor.gltf",
                 "VENDOR_secret_geometry is not supported"});
    // A Draco-compressed primitive without extensionsRequired.
    c.push_back({"DracoPrimitive", quad_gltf("dprim.gltf", [](json& j) {
                     j["extensionsUsed"] = {"KHR_draco_mesh_compression"};
                     j["meshes"][0]["primitives"][0]["extensions"] = {
                         {"KHR_draco_mesh_compression", {{"bufferView", 0}, {"attributes", {{"POSITION", 0}}}}}};
                 }),
                 cat({"shells", "@/dprim.gltf", "-o", "@/out.glb"}, kShells), 1, "@/dprim.gltf", "KHR_draco_mesh_compression"});
    // A primitive's material that does not exist.
    c.push_back({"MaterialDoesNotExist", quad_gltf("mat.gltf", [](json& j) { j["meshes"][0]["primitives"][0]["material"] = 3; }),
                 {"check", "@/mat.gltf"}, 1, "@/mat.gltf", "material 3"});
    // A node's mesh that does not exist.
    c.push_back({"NodeMeshDoesNotExist", quad_gltf("node.gltf", [](json& j) { j["nodes"][0]["mesh"] = 4; }),
                 {"convert", "@/node.gltf", "-o", "@/out.glb"}, 1, "@/node.gltf", "does not exist"});
    // A node that is its own grandparent.
    c.push_back({"NodeCycle", quad_gltf("cycle.gltf", [](json& j) {
                     j["nodes"] = json::array({{{"mesh", 0}, {"children", {1}}}, {{"children", {0}}}});
                 }),
                 {"render", "@/cycle.gltf", "-o", "@/out.png", "--size", "32x24"}, 1, "@/cycle.gltf", "cycle"});

    // ---- images: masks, comb maps, brushes ------------------------------------------------------------------
    c.push_back({"MaskMissing", nothing(), cat({"shells", "@/good.glb", "-o", "@/out.glb", "--mask", "@/nomask.png"}, kShells), 1,
                 "@/nomask.png", "cannot read the mask"});
    // A mask that is not an image.
    c.push_back({"MaskNotAnImage", text_file("text.png", "hello"), cat({"shells", "@/good.glb", "-o", "@/out.glb", "--mask", "@/text.png"}, kShells),
                 1, "@/text.png", "cannot read the mask"});
    // A truncated PNG mask.
    c.push_back({"MaskTruncated", truncated_copy("grey.png", "cut.png", 0.6),
                 cat({"shells", "@/good.glb", "-o", "@/out.glb", "--mask", "@/cut.png"}, kShells), 1, "@/cut.png", "cannot read the mask"});
    // A folder passed as the mask.
    c.push_back({"MaskIsAFolder", folder("maskdir.png"), cat({"shells", "@/good.glb", "-o", "@/out.glb", "--mask", "@/maskdir.png"}, kShells), 1,
                 "@/maskdir.png", "is a directory"});
    // The alpha channel of a grey mask.
    c.push_back({"MaskChannelMissing", nothing(), cat({"shells", "@/good.glb", "-o", "@/out.glb", "--mask", "@/grey.png:a"}, kShells), 1,
                 "@/grey.png", "no alpha channel"});
    // A mask on a mesh without TEXCOORD_0.
    c.push_back({"MaskWithoutUvs", nothing(), cat({"shells", "@/ico.glb", "-o", "@/out.glb", "--mask", "@/grey.png"}, kShells), 1,
                 "@/ico.glb", "TEXCOORD_0"});
    // A grey comb map (it needs two channels of direction).
    c.push_back({"CombMapGrey", nothing(), cat({"shells", "@/good.glb", "-o", "@/out.glb", "--comb", "@/grey.png"}, kShells), 1,
                 "@/grey.png", "colour channels"});
    // A brush image of an image collider that does not exist.
    c.push_back({"BrushImageMissing",
                 text_file("foot.json", R"({"colliders": [{"shape": "image", "image": "foot.png", "size": [0.1, 0.3], "depth": 0.05, "path": [[0, 0, 0]]}]})"),
                 {"stamp", "@/ground.glb", "-o", "@/out.glb", "--colliders", "@/foot.json"}, 1, "@/foot.json", "cannot read 'foot.png'"});

    // ---- colliders and heightmaps -----------------------------------------------------------------------------
    auto stamp_with = [](const std::string& colliders) {
        return std::vector<std::string>{"stamp", "@/ground.glb", "-o", "@/out.glb", "--colliders", colliders, "--heightmap-out", "@/out.pfm"};
    };
    c.push_back({"CollidersJsonSyntax", text_file("syntax.json", R"({"colliders": [ {"shape": "sphere", )"), stamp_with("@/syntax.json"), 1,
                 "@/syntax.json", "malformed JSON"});
    c.push_back({"CollidersUnknownShape", text_file("cone.json", R"({"colliders": [{"shape": "cone", "radius": 1, "path": [[0, 0, 0]]}]})"),
                 stamp_with("@/cone.json"), 1, "@/cone.json", "unknown shape \"cone\""});
    c.push_back({"CollidersNegativeRadius", text_file("neg.json", R"({"colliders": [{"shape": "sphere", "radius": -0.5, "path": [[0, 0, 0]]}]})"),
                 stamp_with("@/neg.json"), 1, "@/neg.json", "colliders[0].radius: must be a finite number > 0"});
    c.push_back({"CollidersMissing", nothing(), stamp_with("@/none.json"), 1, "@/none.json", "cannot open"});
    c.push_back({"CollidersIsAFolder", folder("dir.json"), stamp_with("@/dir.json"), 1, "@/dir.json", "is a directory"});
    c.push_back({"CollidersZeroUp", text_file("up.json", R"({"up": [0, 0, 0], "colliders": []})"), stamp_with("@/up.json"), 1, "@/up.json",
                 "up"});
    c.push_back({"CollidersTimeGoesBack",
                 text_file("time.json", R"({"colliders": [{"shape": "sphere", "radius": 0.3, "path": [[0, 0, 0], [1, 0, 0]], "time": [1, 0]}]})"),
                 stamp_with("@/time.json"), 1, "@/time.json", "must not decrease"});
    c.push_back({"CollidersUnknownKey",
                 text_file("key.json", R"({"colliders": [{"shape": "sphere", "radius": 0.3, "length": 1, "path": [[0, 0, 0]]}]})"),
                 stamp_with("@/key.json"), 1, "@/key.json", "unknown key \"length\""});
    c.push_back({"HeightmapInTruncated", text_file("cut.pfm", "Pf\n10 10\n-1.0\nabc"), cat(cat({"stamp", "@/ground.glb", "-o", "@/out.glb"}, kStamp), {"--heightmap-in", "@/cut.pfm"}),
                 1, "@/cut.pfm", "truncated"});
    c.push_back({"HeightmapInMissing", nothing(), cat(cat({"stamp", "@/ground.glb", "-o", "@/out.glb"}, kStamp), {"--heightmap-in", "@/none.pfm"}), 1,
                 "@/none.pfm", "cannot open"});
    // A heightmap of 40000² texels against the 1 GiB memory guard.
    c.push_back({"HeightmapAboveMemoryGuard", nothing(),
                 {"stamp", "@/ground.glb", "-o", "@/out.glb", "--colliders", "@/ball.json", "--texel", "0.0001"}, 1, "@/ground.glb",
                 "MiB limit"});

    // ---- option values (usage errors, exit 2) -------------------------------------------------------------
    c.push_back({"LayersZero", nothing(), {"shells", "@/good.glb", "-o", "@/out.glb", "--length", "0.05", "--layers", "0"}, 2, "", "--layers"});
    c.push_back({"Layers300", nothing(), {"shells", "@/good.glb", "-o", "@/out.glb", "--length", "0.05", "--layers", "300"}, 2, "", "--layers"});
    c.push_back({"LengthNegative", nothing(), {"shells", "@/good.glb", "-o", "@/out.glb", "--length", "-0.1"}, 2, "", "--length"});
    c.push_back({"LengthNaN", nothing(), {"shells", "@/good.glb", "-o", "@/out.glb", "--length", "nan"}, 2, "", "--length"});
    c.push_back({"LengthMissing", nothing(), {"shells", "@/good.glb", "-o", "@/out.glb"}, 2, "", "--length"});
    c.push_back({"SizeMalformed", nothing(), {"render", "@/good.glb", "-o", "@/out.png", "--size", "10y10"}, 2, "", "--size"});
    c.push_back({"SizeZero", nothing(), {"render", "@/good.glb", "-o", "@/out.png", "--size", "0x10"}, 2, "", "--size"});
    c.push_back({"CameraMalformed", nothing(), {"render", "@/good.glb", "-o", "@/out.png", "--camera", "1,2"}, 2, "", "--camera"});
    c.push_back({"CameraNaN", nothing(), {"render", "@/good.glb", "-o", "@/out.png", "--camera", "nan,0,0"}, 2, "", "--camera"});
    c.push_back({"CameraOnTarget", nothing(), {"render", "@/good.glb", "-o", "@/out.png", "--camera", "1,1,1", "--target", "1,1,1"}, 2, "",
                 "coincide"});
    c.push_back({"UpZero", nothing(), {"render", "@/good.glb", "-o", "@/out.png", "--camera", "0,0,3", "--up", "0,0,0"}, 2, "", "--up"});
    // Output-size guards: refused from the estimate, before anything is evaluated (a 4 km terrain at
    // --max-error 0.01 ran 125 s and wrote 2.2 GB).
    c.push_back({"TessellateOverTheTriangleBudget", nothing(), {"tessellate", "@/good.glb", "-o", "@/out.glb", "--uniform", "2000"}, 1,
                 "@/good.glb", "--max-triangles"});
    c.push_back({"ShellsOverTheTriangleLimit", nothing(), cat({"shells", "@/good.glb", "-o", "@/out.glb", "--max-triangles", "100"}, kShells), 1,
                 "@/good.glb", "--max-triangles"});
    // stamp and tessellate refine for an eye position; a --target or --up they would ignore is refused.
    c.push_back({"UpIgnoredByTessellate", nothing(), {"tessellate", "@/good.glb", "-o", "@/out.glb", "--camera", "0,0,3", "--pixel-error", "2", "--up", "0,0,1"}, 2,
                 "", "--up"});
    c.push_back({"TargetIgnoredByStamp", nothing(), cat({"stamp", "@/ground.glb", "-o", "@/out.glb", "--camera", "0,0,3", "--target", "0,0,0"}, kStamp), 2,
                 "", "--target"});
    c.push_back({"FovOutOfRange", nothing(), {"render", "@/good.glb", "-o", "@/out.png", "--fov", "180"}, 2, "", "--fov"});
    // NaN passed CLI11's range checks and came back from the library as an input error naming the mesh.
    c.push_back({"SliverAngleNaN", nothing(), {"check", "@/good.glb", "--sliver-angle", "nan"}, 2, "", "--sliver-angle"});
    c.push_back({"DroopNaN", nothing(), cat({"shells", "@/good.glb", "-o", "@/out.glb", "--droop", "nan"}, kShells), 2, "", "--droop"});
    c.push_back({"FovNaN", nothing(), {"render", "@/good.glb", "-o", "@/out.png", "--fov", "nan"}, 2, "", "--fov"});
    c.push_back({"MaxErrorNaN", nothing(), {"tessellate", "@/good.glb", "-o", "@/out.glb", "--max-error", "nan"}, 2, "", "--max-error"});
    c.push_back({"TexelNaN", nothing(), {"stamp", "@/ground.glb", "-o", "@/out.glb", "--colliders", "@/ball.json", "--texel", "nan"}, 2, "",
                 "--texel"});
    c.push_back({"TimeInfinite", nothing(), {"stamp", "@/ground.glb", "-o", "@/out.glb", "--colliders", "@/ball.json", "--time", "inf"}, 2, "",
                 "--time"});
    c.push_back({"TessellateNoCriterion", nothing(), {"tessellate", "@/good.glb", "-o", "@/out.glb"}, 2, "", "at least one of"});
    c.push_back({"TessellateUniformZero", nothing(), {"tessellate", "@/good.glb", "-o", "@/out.glb", "--uniform", "0"}, 2, "", "--uniform"});
    c.push_back({"StampNegativeTexel", nothing(), {"stamp", "@/ground.glb", "-o", "@/out.glb", "--colliders", "@/ball.json", "--texel", "-1"}, 2, "",
                 "--texel"});
    c.push_back({"SliverAngleNotANumber", nothing(), {"check", "@/good.glb", "--sliver-angle", "abc"}, 2, "", "--sliver-angle"});
    c.push_back({"UnknownRequirement", nothing(), {"check", "@/good.glb", "--require", "watertight"}, 2, "", "watertight"});
    c.push_back({"UnknownCommand", nothing(), {"frobnicate", "@/good.glb"}, 2, "", "frobnicate"});
    c.push_back({"UnknownOption", nothing(), {"convert", "@/good.glb", "-o", "@/out.glb", "--bogus"}, 2, "", "--bogus"});
    c.push_back({"ThreadsZero", nothing(), {"-j", "0", "check", "@/good.glb"}, 2, "", "--threads"});
    c.push_back({"RenderOutputNotPng", nothing(), {"render", "@/good.glb", "-o", "@/out.jpg"}, 2, "", ".png"});
    c.push_back({"ShellsOutputNotGltf", nothing(), cat({"shells", "@/good.glb", "-o", "@/out.obj"}, kShells), 2, "", ".glb"});
    c.push_back({"ConvertOutputNotGltf", nothing(), {"convert", "@/good.glb", "-o", "@/out.obj"}, 2, "", ".glb"});
    c.push_back({"TessellateOutputNotGltf", nothing(), {"tessellate", "@/good.glb", "-o", "@/out.stl", "--uniform", "2"}, 2, "", ".glb"});

    // ---- output paths -----------------------------------------------------------------------------------------
    c.push_back({"OutputFolderMissing", nothing(), {"convert", "@/good.glb", "-o", "@/missing/out.glb"}, 1, "@/missing/out.glb", "does not exist"});
    c.push_back({"OutputParentIsAFile", nothing(), cat({"tessellate", "@/good.glb", "-o", "@/ground.glb/out.glb"}, {"--uniform", "1"}), 1,
                 "@/ground.glb/out.glb", "does not exist"});
    // A folder the user may not write to (root may write anywhere but /sys, which refuses new files).
    {
        const bool root = ::geteuid() == 0;
        const std::string out = root ? "/sys/furrow-catalog-out.glb" : "@/locked/out.glb";
        c.push_back({"OutputFolderNotWritable",
                     [](const fs::path& dir) {
                         fs::create_directories(dir / "locked");
                         fs::permissions(dir / "locked", fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                                                             fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
                     },
                     cat({"shells", "@/good.glb", "-o", out}, kShells), 1, out, "cannot write"});
    }
    c.push_back({"OutputIsAFolder", folder("out.glb"), cat({"shells", "@/good.glb", "-o", "@/out.glb"}, kShells), 1, "@/out.glb", "is a directory"});
    // A .gltf output that cannot be written must not leave its .bin behind.
    c.push_back({"GltfOutputIsAFolder", folder("out.gltf"), {"convert", "@/good.glb", "-o", "@/out.gltf"}, 1, "@/out.gltf", "is a directory"});
    c.push_back({"RenderOutputFolderMissing", nothing(), {"render", "@/good.glb", "-o", "@/missing/out.png", "--size", "32x24"}, 1,
                 "@/missing/out.png", "does not exist"});
    // The PNG can be written, the depth file cannot: neither is left.
    c.push_back({"DepthOutUnwritable", nothing(), {"render", "@/good.glb", "-o", "@/out.png", "--size", "32x24", "--depth-out", "@/missing/d.pfm"}, 1,
                 "@/missing/d.pfm", "does not exist"});
    // The heightmap folder does not exist: no mesh either.
    c.push_back({"HeightmapOutUnwritable", nothing(), cat(cat({"stamp", "@/ground.glb", "-o", "@/out.glb"}, kStamp), {"--heightmap-out", "@/missing/h.pfm"}),
                 1, "@/missing/h.pfm", "does not exist"});
    c.push_back({"ConvertOutputIsInput", nothing(), {"convert", "@/good.glb", "-o", "@/good.glb"}, 1, "@/good.glb", "refusing to overwrite"});
    c.push_back({"ShellsOutputIsInputOtherSpelling", nothing(), cat({"shells", "@/good.glb", "-o", "@/./good.glb"}, kShells), 1, "@/./good.glb",
                 "refusing to overwrite"});
    c.push_back({"TessellateOutputIsInput", nothing(), {"tessellate", "@/good.glb", "-o", "@/good.glb", "--uniform", "1"}, 1, "@/good.glb",
                 "refusing to overwrite"});
    c.push_back({"StampOutputIsInput", nothing(), cat({"stamp", "@/ground.glb", "-o", "@/ground.glb"}, kStamp), 1, "@/ground.glb",
                 "refusing to overwrite"});
    c.push_back({"StampOutputIsColliders", text_file("c.glb", R"({"colliders": []})"),
                 {"stamp", "@/ground.glb", "-o", "@/c.glb", "--colliders", "@/c.glb"}, 1, "@/c.glb", "refusing to overwrite"});
    c.push_back({"HeightmapOutIsHeightmapIn", bytes_file("h.pfm", flat_pfm()),
                 cat(cat({"stamp", "@/ground.glb", "-o", "@/out.glb"}, kStamp), {"--heightmap-in", "@/h.pfm", "--heightmap-out", "@/h.pfm"}), 1,
                 "@/h.pfm", "refusing to overwrite"});
    c.push_back({"RenderOutputIsInput", bytes_file("pic.png", {1, 2, 3}), {"render", "@/pic.png", "-o", "@/pic.png"}, 1, "@/pic.png",
                 "refusing to overwrite"});
    // convert a.gltf (buffer in data.bin) -o data.gltf would write data.bin over the input's buffer.
    c.push_back({"GltfOutputBinIsInputBuffer",
                 [](const fs::path& dir) {
                     json j = Quad{}.doc(false);
                     j["buffers"][0]["uri"] = "data.bin";
                     test::write_text(dir / "a.gltf", j.dump());
                     std::vector<uint8_t> b = Quad{}.bin();
                     b.resize(b.size() + 16, 7); // so that the output's .bin differs from it
                     j["buffers"][0]["byteLength"] = b.size();
                     test::write_text(dir / "a.gltf", j.dump());
                     test::write_bytes(dir / "data.bin", b);
                 },
                 {"convert", "@/a.gltf", "-o", "@/data.gltf"}, 1, "@/data.gltf", "refusing to overwrite the input"});

    // ---- external resources (README "Threat model"): every way out of the resource root, the limits ----------
    // in/x.gltf names a texture image; @/secret.png lies outside its folder (the default resource root).
    auto textured = [](const std::string& name, const std::string& uri, std::function<void(const fs::path&)> more = {}) {
        return [=](const fs::path& dir) {
            json j = Quad{}.doc();
            j["meshes"][0]["primitives"][0]["material"] = 0;
            j["materials"] = json::array({{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}});
            j["textures"] = json::array({{{"source", 0}}});
            j["images"] = json::array({{{"uri", uri}}});
            fs::create_directories(dir / "in");
            test::write_text(dir / "in" / name, j.dump());
            write_png_grey(dir / "secret.png", 1);
            if (more) more(dir);
        };
    };
    const std::string outside = "is outside the resource root ";
    c.push_back({"ImageUriParentFolder", textured("up.gltf", "../secret.png"), {"convert", "@/in/up.gltf", "-o", "@/out.glb"}, 1,
                 "@/in/up.gltf", "image 0 uri '../secret.png' " + outside});
    c.push_back({"ImageUriPercentEncodedParent", textured("pct.gltf", "..%2Fsecret.png"), {"render", "@/in/pct.gltf", "-o", "@/out.png"},
                 1, "@/in/pct.gltf", "image 0 uri '..%2Fsecret.png' " + outside});
    c.push_back({"ImageUriAbsolutePath", [textured](const fs::path& dir) { textured("abs.gltf", (dir / "secret.png").string())(dir); },
                 cat({"shells", "@/in/abs.gltf", "-o", "@/out.glb"}, kShells), 1, "@/in/abs.gltf", outside});
    c.push_back({"ImageUriFileScheme", [textured](const fs::path& dir) { textured("file.gltf", "file://" + (dir / "secret.png").string())(dir); },
                 {"tessellate", "@/in/file.gltf", "-o", "@/out.glb", "--uniform", "2"}, 1, "@/in/file.gltf", outside});
    c.push_back({"ImageUriSymlinkOutOfRoot",
                 textured("link.gltf", "link.png", [](const fs::path& dir) { fs::create_symlink(dir / "secret.png", dir / "in" / "link.png"); }),
                 cat({"stamp", "@/in/link.gltf", "-o", "@/out.glb"}, kStamp), 1, "@/in/link.gltf", "image 0 uri 'link.png' " + outside});
    c.push_back({"ImageUriPercentNul", textured("nul.gltf", "x.png%00.txt"), {"check", "@/in/nul.gltf"}, 1, "@/in/nul.gltf",
                 "image 0 uri 'x.png%00.txt' contains a NUL byte"});
    c.push_back({"ImageUriRawNul", textured("rawnul.gltf", std::string("x.png\0.txt", 10)), {"convert", "@/in/rawnul.gltf", "-o", "@/out.gltf"},
                 1, "@/in/rawnul.gltf", "image 0 uri 'x.png%00.txt' contains a NUL byte"});
    c.push_back({"BufferUriParentFolder", quad_gltf("bufup.gltf", [](json& j) { j["buffers"][0]["uri"] = "../etc/data.bin"; }),
                 {"check", "@/bufup.gltf"}, 1, "@/bufup.gltf", "buffer 0 uri '../etc/data.bin' " + outside});
    c.push_back({"ImageUriIsAFolder", textured("dir.gltf", "sub", [](const fs::path& dir) { fs::create_directories(dir / "in" / "sub"); }),
                 {"render", "@/in/dir.gltf", "-o", "@/out.png"}, 1, "@/in/dir.gltf", "image 0 uri 'sub' is not a regular file"});
    c.push_back({"ImageUriOtherScheme", textured("http.gltf", "http://example.com/a.png"), {"check", "@/in/http.gltf"}, 1,
                 "@/in/http.gltf", "uses the URI scheme 'http:'"});
    c.push_back({"ResourcesAboveMaxResourceBytes", textured("big.gltf", "t.png", [](const fs::path& dir) { write_png_grey(dir / "in" / "t.png", 4); }),
                 {"convert", "@/in/big.gltf", "-o", "@/out.glb", "--max-resource-bytes", "10"}, 1, "@/in/big.gltf",
                 "left for external resources (--max-resource-bytes raises it)"});
    c.push_back({"BufferByteLengthAboveMaxResourceBytes", quad_gltf("huge.gltf", [](json& j) {
                     j["buffers"][0]["uri"] = "huge.bin";
                     j["buffers"][0]["byteLength"] = 1000000000000ull;
                 }),
                 {"check", "@/huge.gltf"}, 1, "@/huge.gltf", "buffer 0 uri 'huge.bin' is 1000000000000 bytes"});
    // A 1 KB PNG whose header claims 20000 x 20000 pixels (a decompression bomb).
    c.push_back({"ImageHeaderAboveMaxImagePixels",
                 textured("bomb.gltf", "bomb.png", [](const fs::path& dir) {
                     std::vector<uint8_t> png = test::read_bytes(dir / "secret.png");
                     for (size_t at : {16, 20}) png[at] = 0, png[at + 1] = 0, png[at + 2] = 0x4E, png[at + 3] = 0x20;
                     test::write_bytes(dir / "in" / "bomb.png", png);
                 }),
                 {"convert", "@/in/bomb.gltf", "-o", "@/out.glb"}, 1, "@/in/bomb.gltf",
                 "image 0 is 20000x20000 pixels, above the limit of 67108864 (--max-image-pixels raises it)"});
    c.push_back({"NodesAboveMaxNodes", quad_gltf("nodes.gltf", [](json& j) { j["nodes"].push_back(json::object()); }),
                 {"shells", "@/nodes.gltf", "-o", "@/out.glb", "--layers", "2", "--length", "0.05", "--max-nodes", "1"}, 1, "@/nodes.gltf",
                 "the file has 2 nodes, above the limit of 1 (--max-nodes raises it)"});
    c.push_back({"PrimitivesAboveMaxPrimitives", quad_gltf("prims.gltf", [](json& j) {
                     j["meshes"][0]["primitives"].push_back(j["meshes"][0]["primitives"][0]);
                 }),
                 {"tessellate", "@/prims.gltf", "-o", "@/out.glb", "--uniform", "2", "--max-primitives", "1"}, 1, "@/prims.gltf",
                 "the file has 2 primitives, above the limit of 1 (--max-primitives raises it)"});
    c.push_back({"ResourceRootMissing", nothing(), {"convert", "@/good.glb", "-o", "@/out.glb", "--resource-root", "@/nowhere"}, 2, "",
                 "--resource-root"});

    // ---- empty meshes and failed gates ----------------------------------------------------------------------
    c.push_back({"RenderNoMeshes", text_file("nomesh.gltf", R"({"asset": {"version": "2.0"}})"), {"render", "@/nomesh.gltf", "-o", "@/out.png"}, 1,
                 "@/nomesh.gltf", "no triangles"});
    c.push_back({"ShellsPointsOnly", quad_gltf("points.gltf", [](json& j) { j["meshes"][0]["primitives"][0]["mode"] = 0; }),
                 cat({"shells", "@/points.gltf", "-o", "@/out.glb"}, kShells), 1, "@/points.gltf", "no triangles"});
    c.push_back({"TessellateNoFaces", quad_gltf("lines.gltf", [](json& j) { j["meshes"][0]["primitives"][0]["mode"] = 1; }),
                 {"tessellate", "@/lines.gltf", "-o", "@/out.glb", "--uniform", "2"}, 1, "@/lines.gltf", "no triangles"});
    c.push_back({"StampGroundWithoutTriangles", quad_gltf("pts.gltf", [](json& j) { j["meshes"][0]["primitives"][0]["mode"] = 0; }),
                 cat({"stamp", "@/pts.gltf", "-o", "@/out.glb"}, kStamp), 1, "@/pts.gltf", "no triangles"});
    c.push_back({"ConvertObjOnlyComments", text_file("c.obj", "# a\n# b\n"), {"convert", "@/c.obj", "-o", "@/out.glb"}, 1, "@/c.obj", "no vertices"});
    c.push_back({"CheckRequirementFails", nothing(), {"check", "@/ground.glb", "--require", "closed"}, 1, "@/ground.glb",
                 "requirement 'closed' failed: 16 boundary edges"});
    return c;
}

// ---------------------------------------------------------------------------------------------------------
// The assertions
// ---------------------------------------------------------------------------------------------------------

std::string expand(const std::string& s, const fs::path& dir) { return !s.empty() && s[0] == '@' ? dir.string() + s.substr(1) : s; }

// Every file under dir (relative path -> bytes; folders as "<name>/").
std::map<std::string, std::vector<uint8_t>> snapshot(const fs::path& dir) {
    std::map<std::string, std::vector<uint8_t>> files;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        const std::string rel = fs::relative(e.path(), dir).string();
        if (e.is_directory()) files[rel + "/"] = {};
        else files[rel] = test::read_bytes(e.path());
    }
    return files;
}

std::vector<std::string> error_lines(const std::string& err) {
    std::vector<std::string> lines;
    std::istringstream in(err);
    for (std::string line; std::getline(in, line);)
        if (line.rfind("Error:", 0) == 0) lines.push_back(line);
    return lines;
}

class BadInputCatalog : public ::testing::TestWithParam<Case> {};

TEST_P(BadInputCatalog, RefusedCleanly) {
    const Case& c = GetParam();
    const fs::path dir = test::temp_dir();
    write_common(dir);
    c.setup(dir);
    const auto before_list = test::list_dir(dir);
    const auto before = snapshot(dir);
    std::vector<std::string> args;
    for (const auto& a : c.args) args.push_back(expand(a, dir));

    const test::RunResult r = run_furrow(args);

    EXPECT_EQ(r.exit_code, c.exit_code) << r.err;
    const std::vector<std::string> errors = error_lines(r.err);
    ASSERT_EQ(errors.size(), 1u) << "stderr:\n" << r.err;
    if (std::getenv("FURROW_CATALOG_VERBOSE")) std::printf("    %s\n", errors[0].c_str()); // to review the wording
    if (!c.file.empty()) {
        EXPECT_EQ(errors[0].rfind("Error: " + expand(c.file, dir) + ": ", 0), 0u) << errors[0];
    }
    EXPECT_NE(errors[0].find(c.fragment), std::string::npos) << "expected '" << c.fragment << "' in: " << errors[0];
    EXPECT_LT(errors[0].size() - std::min(errors[0].size(), 2 * dir.string().size()), 250u) << "an error line should be short: " << errors[0];
    EXPECT_EQ(test::list_dir(dir), before_list) << "files left behind or removed";
    const auto after = snapshot(dir);
    EXPECT_EQ(after.size(), before.size());
    for (const auto& [name, bytes] : before) {
        auto it = after.find(name);
        ASSERT_NE(it, after.end()) << name << " disappeared";
        EXPECT_TRUE(it->second == bytes) << name << " was modified";
    }
}

INSTANTIATE_TEST_SUITE_P(Catalog, BadInputCatalog, ::testing::ValuesIn(catalog()),
                         [](const ::testing::TestParamInfo<Case>& info) { return info.param.name; });

// The catalog covers every command that reads input and at least 25 distinct kinds of bad input.
TEST(BadInputCatalogCoverage, EveryCommandAndEnoughKinds) {
    const auto cases = catalog();
    EXPECT_GE(cases.size(), 25u);
    std::map<std::string, int> per_command;
    for (const auto& c : cases) {
        for (const auto& a : c.args)
            if (a == "check" || a == "convert" || a == "render" || a == "shells" || a == "tessellate" || a == "stamp") {
                ++per_command[a];
                break;
            }
    }
    for (const char* cmd : {"check", "convert", "render", "shells", "tessellate", "stamp"}) EXPECT_GE(per_command[cmd], 5) << cmd;
    std::set<std::string> names;
    for (const auto& c : cases) EXPECT_TRUE(names.insert(c.name).second) << "duplicate row " << c.name;
}

// Repairable spec violations of the input: the command succeeds, says what it repaired in one warning, and
// its output passes the validator with 0 errors and 0 warnings (it used to inherit the violation).
struct RepairRow {
    std::string name;
    std::function<void(json&)> edit;  // of Quad{}.doc(), written as @/in.gltf
    std::vector<std::string> command; // "@/" = the row's folder; writes @/out.glb
    std::string warning;              // a fragment of the warning
};

std::vector<RepairRow> repairs() {
    // Node 1 is node 0's child and is listed by the scene too (SCENE_NON_ROOT_NODE, as UniGLTF's Kenney kits).
    auto child_listed = [](json& j) {
        j["nodes"].push_back({{"mesh", 0}, {"translation", {0, 0, 1}}});
        j["nodes"][0]["children"] = {1};
        j["scenes"][0]["nodes"] = {0, 1};
    };
    // Node 1 is node 0's child, listed instead of its parent: its root is listed in its place.
    auto only_child_listed = [](json& j) {
        j["nodes"].push_back({{"mesh", 0}, {"translation", {0, 0, 1}}});
        j["nodes"][0]["children"] = {1};
        j["scenes"][0]["nodes"] = {1};
    };
    auto twice = [](json& j) { j["scenes"][0]["nodes"] = {0, 0}; };
    auto ground_child_listed = [child_listed](json& j) { // the quad laid flat (y up), for stamp
        child_listed(j);
        j["nodes"][0]["rotation"] = {-0.70710678, 0, 0, 0.70710678};
    };
    const std::vector<std::string> out{"-o", "@/out.glb"};
    auto cmd = [&](std::vector<std::string> c) {
        c.insert(c.begin() + 2, out.begin(), out.end());
        return c;
    };
    return {
        {"ConvertSceneListsChildNode", child_listed, cmd({"convert", "@/in.gltf"}), "a child of another node"},
        {"ConvertSceneListsOnlyAChild", only_child_listed, cmd({"convert", "@/in.gltf"}), "a child of another node"},
        {"ConvertSceneListsNodeTwice", twice, cmd({"convert", "@/in.gltf"}), "twice"},
        {"TessellateSceneListsChildNode", child_listed, cmd({"tessellate", "@/in.gltf", "--uniform", "2"}), "a child of another node"},
        {"StampSceneListsChildNode", ground_child_listed, cat(cmd({"stamp", "@/in.gltf"}), kStamp), "a child of another node"},
        {"ShellsSceneListsChildNode", child_listed, cat(cmd({"shells", "@/in.gltf"}), kShells), "a child of another node"},
    };
}

class RepairCatalog : public ::testing::TestWithParam<RepairRow> {};

TEST_P(RepairCatalog, RepairedWithOneWarning) {
    const RepairRow& c = GetParam();
    const fs::path dir = test::temp_dir();
    write_common(dir);
    json j = Quad{}.doc();
    c.edit(j);
    test::write_text(dir / "in.gltf", j.dump());
    std::vector<std::string> args;
    for (const std::string& a : c.command) args.push_back(a.rfind("@/", 0) == 0 ? (dir / a.substr(2)).string() : a);
    const auto r = run_furrow(args);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(error_lines(r.err).empty()) << r.err;
    EXPECT_NE(r.err.find("Warning: " + (dir / "in.gltf").string() + ": "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.warning), std::string::npos) << r.err;
    EXPECT_VALID_GLTF(dir / "out.glb");
    Scene s;
    ASSERT_TRUE(load_scene(s, (dir / "out.glb").string()).ok());
    EXPECT_TRUE(s.warnings.empty()) << s.warnings.front(); // nothing left to repair
}

INSTANTIATE_TEST_SUITE_P(Catalog, RepairCatalog, ::testing::ValuesIn(repairs()),
                         [](const ::testing::TestParamInfo<RepairRow>& i) { return i.param.name; });

// Not an error, documented: a glTF whose texture image file is missing loads with one warning naming the
// image and renders with the material's factor (exit 0).
TEST(BadInputCatalogCoverage, MissingTextureImageIsOneWarning) {
    const fs::path dir = test::temp_dir();
    json j = Quad{}.doc();
    j["meshes"][0]["primitives"][0]["material"] = 0;
    j["materials"] = json::array({{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}, {"doubleSided", true}}});
    j["textures"] = json::array({{{"source", 0}}});
    j["images"] = json::array({{{"uri", "gone.png"}}});
    test::write_text(dir / "tex.gltf", j.dump());
    const auto r = run_furrow({"render", (dir / "tex.gltf").string(), "-o", (dir / "o.png").string(), "--size", "32x24"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(error_lines(r.err).empty()) << r.err;
    EXPECT_NE(r.err.find("Warning: " + (dir / "tex.gltf").string() + ": "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("gone.png"), std::string::npos) << r.err;
}

// `../` outside the input's folder is refused by default; --resource-root pointing higher allows it, and the
// image (of a texture no material uses: the quad has no UVs) is then embedded in a validator-clean output.
TEST(BadInputCatalogCoverage, ResourceRootHigherAllowsParentFolder) {
    const fs::path dir = test::temp_dir();
    json j = Quad{}.doc();
    j["textures"] = json::array({{{"source", 0}}});
    j["images"] = json::array({{{"uri", "../textures/grey.png"}}});
    fs::create_directories(dir / "models");
    fs::create_directories(dir / "textures");
    test::write_text(dir / "models" / "a.gltf", j.dump());
    write_png_grey(dir / "textures" / "grey.png", 1);
    const std::string in = (dir / "models" / "a.gltf").string(), out = (dir / "out.glb").string();
    auto r = run_furrow({"convert", in, "-o", out});
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_FALSE(fs::exists(out));
    r = run_furrow({"convert", in, "-o", out, "--resource-root", dir.string()});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_VALID_GLTF(out);
    Scene s;
    ASSERT_TRUE(load_scene(s, out).ok());
    ASSERT_EQ(s.images.size(), 1u);
    EXPECT_EQ(s.images[0].encoded, test::read_bytes(dir / "textures" / "grey.png"));
}

} // namespace
} // namespace furrow

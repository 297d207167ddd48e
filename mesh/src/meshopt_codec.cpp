// EXT_meshopt_compression (Khronos glTF extension registry; meshoptimizer's codec, Kapoulkine), both ways.
//
// Writer (compress_buffer_views), on the glTF JSON and binary chunk the plain writer produced:
//   1. Each buffer view is classified from the accessors that use it: an index view (ELEMENT_ARRAY_BUFFER)
//      is encoded with meshopt_encodeIndexBuffer when it is the index list of a triangle primitive (mode
//      TRIANGLES), else with meshopt_encodeIndexSequence (INDICES: points and lines); a vertex view
//      (ARRAY_BUFFER) with meshopt_encodeVertexBuffer (ATTRIBUTES), whose stride must be a multiple of 4 up
//      to 256 — the writer pads quantized attributes to that. Triangle lists use the index codec's
//      version 1 and come in strip order (vertex_order.cpp). Images and animation data are copied as they
//      are (the codec gains little on them, and a viewer then reads them without the decoder).
//   2. Compressed views keep their byteOffset/byteLength but move to buffer 1, a fallback buffer that holds
//      no data; the encoded bytes go to buffer 0 and the view's extension object says where. With no data in
//      the fallback, a loader without the decoder cannot read the file: the extension is required (the
//      extension's specification; Blender 3.4 refuses such a file, hence plain output stays the default).
//   Normals and tangents (normalized int8) go through the OCTAHEDRAL filter first (gltfpack -cc does the
//   same): decoded, each is exactly what --quantize's octahedral rounding wrote (octahedral()). Texture
//   coordinates that stayed float (outside [0, 1], such as the fur's tiling strand UVs) go through the
//   EXPONENTIAL filter with 16-bit mantissas (k_uv_mantissa_bits). Every other view decodes to exactly the
//   bytes --quantize writes. Both encoders and the filter
//   are deterministic.
//
// Loader (decode_meshopt_views), on the parsed model, before any accessor is read: each view with the
// extension is checked (buffer, offset and length inside the buffer; mode; stride and count within the
// mode's limits; count × stride equal to the view's byteLength; the file's decoded total under a budget)
// before anything is allocated, then decoded into a buffer of its own that the view then points to. The
// OCTAHEDRAL, QUATERNION and EXPONENTIAL filters are undone in place (gltfpack -cc writes them). Corrupt
// data gives meshoptimizer's negative return code, reported as invalid_input.
#include "encoding.h"
#include "document.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <utility>
#include <cstring>

namespace furrow::mesh_detail {

namespace {

using nlohmann::json;
constexpr int k_array_buffer = 34962, k_element_array_buffer = 34963;

size_t component_size(int type) {
    switch (type) {
    case 5120: case 5121: return 1;
    case 5122: case 5123: return 2;
    case 5125: case 5126: return 4;
    default: return 0;
    }
}

size_t type_count(const std::string& t) {
    if (t == "SCALAR") return 1;
    if (t == "VEC2") return 2;
    if (t == "VEC3") return 3;
    if (t == "VEC4" || t == "MAT2") return 4;
    if (t == "MAT3") return 9;
    if (t == "MAT4") return 16;
    return 0;
}

struct ViewUse {
    size_t element = 0;   // bytes per element (the view's byteStride when it has one)
    size_t count = 0;     // elements
    bool triangles = false;
    bool unit_vectors = false; // NORMAL or TANGENT as normalized int8 in 4 bytes: the OCTAHEDRAL filter
    bool float_uvs = false;    // TEXCOORD_n kept float (outside [0, 1]): the EXPONENTIAL filter
};

// Mantissa bits of the EXPONENTIAL filter on float texture coordinates: each (u, v) keeps a shared exponent
// and 16-bit signed mantissas, so its error is at most 2^-15 of its larger component (3e-4 at u = 10).
// 14 bits would be 13 % smaller on the demo's strand UVs and still below gltfpack -cc's error there (its
// 12-bit grid over the range), but the strand pattern moves visibly: the three.js silhouette IoU of a
// compressed 16-shell creature against the plain file fell from 0.9944 to 0.9915 (tests/viewer).
constexpr int k_uv_mantissa_bits = 16;

// Step 1: element size and count of every view from its accessor; which index views are triangle lists.
std::map<size_t, ViewUse> view_uses(const json& j) {
    std::map<size_t, ViewUse> uses;
    const json& acc = j.contains("accessors") ? j["accessors"] : json::array();
    const json& views = j.contains("bufferViews") ? j["bufferViews"] : json::array();
    for (const json& a : acc) {
        if (!a.contains("bufferView")) continue;
        const size_t v = a["bufferView"].get<size_t>();
        ViewUse& u = uses[v];
        u.element = component_size(a.value("componentType", 0)) * type_count(a.value("type", std::string()));
        if (v < views.size() && views[v].contains("byteStride")) u.element = views[v]["byteStride"].get<size_t>();
        u.count = a.value("count", size_t(0));
    }
    auto mark_float_uvs = [&](const json& attributes) {
        for (const auto& [name, index] : attributes.items()) {
            if (name.rfind("TEXCOORD_", 0) != 0 || !index.is_number_unsigned()) continue;
            const size_t ai = index.get<size_t>();
            if (ai < acc.size() && acc[ai].contains("bufferView") && acc[ai].value("componentType", 0) == 5126)
                uses[acc[ai]["bufferView"].get<size_t>()].float_uvs = true;
        }
    };
    auto mark_unit_vectors = [&](const json& attributes) {
        for (const char* name : {"NORMAL", "TANGENT"}) {
            if (!attributes.contains(name)) continue;
            const size_t ai = attributes[name].get<size_t>();
            if (ai < acc.size() && acc[ai].contains("bufferView") && acc[ai].value("componentType", 0) == 5120 &&
                acc[ai].value("normalized", false))
                uses[acc[ai]["bufferView"].get<size_t>()].unit_vectors = true;
        }
    };
    if (j.contains("meshes"))
        for (const json& m : j["meshes"])
            for (const json& p : m.value("primitives", json::array())) {
                if (p.contains("attributes")) mark_unit_vectors(p["attributes"]), mark_float_uvs(p["attributes"]);
                if (p.contains("indices") && p.value("mode", 4) == 4) {
                    const size_t ai = p["indices"].get<size_t>();
                    if (ai < acc.size() && acc[ai].contains("bufferView"))
                        uses[acc[ai]["bufferView"].get<size_t>()].triangles = true;
                }
            }
    return uses;
}

// Step 1 for one view: the encoded bytes and the extension's mode, or false to copy it as it is.
// The OCTAHEDRAL filter (meshopt_encodeFilterOct, 8 bits): a unit vector as its octahedral x, y and a scale,
// which the vertex codec packs tighter than x, y, z; the decoder gives normalized int8 x, y, z back (w kept).
// --compress writes vectors that are already decoded codes (mesh_quantize.cpp), but encoding such a vector
// again gives a neighbouring code for about 0.6 % of them (the decode rounds), which would move them by one
// more step and code worse. So each vector whose new code does not decode to it exactly takes the code
// within two steps that does, when there is one: the file then decodes to exactly what --quantize's
// octahedral rounding chose (test mesh_encoding.CompressedNormalsDecodeToTheirOctahedralRounding).
constexpr std::pair<int, int> k_nearest_codes_first[] = {
    {1, 0},   {-1, 0}, {0, 1},  {0, -1}, {1, 1},  {-1, 1}, {1, -1}, {-1, -1}, {2, 0},  {-2, 0},  {0, 2},  {0, -2},
    {2, 1},   {-2, 1}, {2, -1}, {-2, -1}, {1, 2}, {-1, 2}, {1, -2}, {-1, -2}, {2, 2}, {-2, 2}, {2, -2}, {-2, -2}};
std::vector<uint8_t> octahedral(const uint8_t* data, size_t count) {
    std::vector<float> v(count * 4);
    for (size_t i = 0; i < count * 4; ++i) v[i] = std::max(float(int8_t(data[i])) / 127.0f, -1.0f);
    std::vector<uint8_t> out(count * 4);
    meshopt_encodeFilterOct(out.data(), count, 4, 8, v.data());
    std::vector<uint8_t> decoded = out;
    meshopt_decodeFilterOct(decoded.data(), count, 4);
    for (size_t i = 0; i < count; ++i) {
        if (std::memcmp(&decoded[i * 4], data + i * 4, 3) == 0) continue;
        const int x = int8_t(out[i * 4]), y = int8_t(out[i * 4 + 1]);
        for (const auto& [dx, dy] : k_nearest_codes_first) {
            if (std::abs(x + dx) > 127 || std::abs(y + dy) > 127) continue;
            uint8_t code[4] = {uint8_t(int8_t(x + dx)), uint8_t(int8_t(y + dy)), out[i * 4 + 2], out[i * 4 + 3]};
            meshopt_decodeFilterOct(code, 1, 4);
            if (std::memcmp(code, data + i * 4, 3) != 0) continue;
            out[i * 4] = uint8_t(int8_t(x + dx)), out[i * 4 + 1] = uint8_t(int8_t(y + dy));
            break;
        }
    }
    return out;
}

bool encode_view(std::vector<uint8_t>& out, std::string& mode, std::string& filter, const uint8_t* data, size_t bytes,
                 int target, const ViewUse& u) {
    if (u.element == 0 || u.count == 0 || u.count * u.element != bytes) return false;
    if (target == k_element_array_buffer && (u.element == 2 || u.element == 4)) {
        std::vector<uint32_t> idx(u.count);
        uint32_t max_index = 0;
        for (size_t i = 0; i < u.count; ++i) {
            if (u.element == 2) {
                uint16_t s;
                std::memcpy(&s, data + i * 2, 2);
                idx[i] = s;
            } else {
                std::memcpy(&idx[i], data + i * 4, 4);
            }
            max_index = std::max(max_index, idx[i]);
        }
        const bool tri = u.triangles && u.count % 3 == 0;
        // Index codec version 1 (the extension allows 0 and 1; every decoder since meshoptimizer 0.14 and
        // three.js's MeshoptDecoder read it; gltfpack writes it): it also codes a triangle's third vertex
        // against the last one seen, smaller on strip-ordered triangles. The setting is global to
        // meshoptimizer; every writer in furrow sets the same value, so the bytes do not depend on threads.
        meshopt_encodeIndexVersion(1);
        const size_t vertices = size_t(max_index) + 1;
        out.resize(tri ? meshopt_encodeIndexBufferBound(u.count, vertices) : meshopt_encodeIndexSequenceBound(u.count, vertices));
        const size_t n = tri ? meshopt_encodeIndexBuffer(out.data(), out.size(), idx.data(), u.count)
                             : meshopt_encodeIndexSequence(out.data(), out.size(), idx.data(), u.count);
        if (n == 0) return false;
        out.resize(n);
        mode = tri ? "TRIANGLES" : "INDICES";
        return true;
    }
    if (target == k_array_buffer && u.element % 4 == 0 && u.element <= 256) {
        std::vector<uint8_t> filtered;
        if (u.unit_vectors && u.element == 4) {
            filtered = octahedral(data, u.count);
            data = filtered.data();
            filter = "OCTAHEDRAL";
        } else if (u.float_uvs && u.element == 8) {
            std::vector<float> v(u.count * 2);
            std::memcpy(v.data(), data, v.size() * 4);
            filtered.resize(u.count * 8);
            meshopt_encodeFilterExp(filtered.data(), u.count, 8, k_uv_mantissa_bits, v.data());
            data = filtered.data();
            filter = "EXPONENTIAL";
        }
        out.resize(meshopt_encodeVertexBufferBound(u.count, u.element));
        const size_t n = meshopt_encodeVertexBuffer(out.data(), out.size(), data, u.count, u.element);
        if (n == 0) return false;
        out.resize(n);
        mode = "ATTRIBUTES";
        return true;
    }
    return false;
}

void add_extension_name(json& j, const char* key, const std::string& name) {
    if (!j.contains(key)) j[key] = json::array();
    for (const json& e : j[key])
        if (e == name) return;
    j[key].push_back(name);
}

} // namespace

void compress_buffer_views(CompressedBin& out, json& j, const std::vector<uint8_t>& bin) {
    out = CompressedBin{};
    out.fallback_bytes = bin.size();
    if (!j.contains("bufferViews")) {
        out.bin = bin;
        return;
    }
    const std::map<size_t, ViewUse> uses = view_uses(j);
    bool any = false;
    for (size_t v = 0; v < j["bufferViews"].size(); ++v) {
        json& view = j["bufferViews"][v];
        const size_t offset = view.value("byteOffset", size_t(0)), length = view.value("byteLength", size_t(0));
        if (offset > bin.size() || length > bin.size() - offset) continue; // the writer made it; cannot happen
        while (out.bin.size() % 4) out.bin.push_back(0);
        std::vector<uint8_t> encoded;
        std::string mode, filter;
        auto it = uses.find(v);
        if (it != uses.end() &&
            encode_view(encoded, mode, filter, bin.data() + offset, length, view.value("target", 0), it->second)) {
            json ext = {{"buffer", 0}, {"byteOffset", out.bin.size()}, {"byteLength", encoded.size()},
                        {"byteStride", it->second.element}, {"count", it->second.count}, {"mode", mode}};
            if (!filter.empty()) ext["filter"] = filter;
            if (mode == "ATTRIBUTES") view["byteStride"] = it->second.element;
            view["buffer"] = 1;
            view["extensions"]["EXT_meshopt_compression"] = ext;
            out.bin.insert(out.bin.end(), encoded.begin(), encoded.end());
            any = true;
        } else {
            view["byteOffset"] = out.bin.size();
            out.bin.insert(out.bin.end(), bin.begin() + std::ptrdiff_t(offset), bin.begin() + std::ptrdiff_t(offset + length));
        }
    }
    while (out.bin.size() % 4) out.bin.push_back(0);
    if (!any) {
        out.fallback_bytes = 0;
        return;
    }
    add_extension_name(j, "extensionsUsed", "EXT_meshopt_compression");
    add_extension_name(j, "extensionsRequired", "EXT_meshopt_compression");
}

namespace {

struct MeshoptView {
    int buffer = -1;
    size_t offset = 0, length = 0, stride = 0, count = 0;
    std::string mode, filter = "NONE";
};

Status bad(size_t view, const std::string& what) {
    return Status::error(StatusCode::invalid_input, "bufferView " + std::to_string(view) + " EXT_meshopt_compression: " + what);
}

// A non-negative integer member of the extension object, or false.
bool member(size_t& out, const tinygltf::Value& ext, const char* key) {
    if (!ext.Has(key) || !ext.Get(key).IsNumber()) return false;
    const double d = ext.Get(key).GetNumberAsDouble();
    if (!(d >= 0 && d <= 9.0e15) || d != double(size_t(d))) return false;
    out = size_t(d);
    return true;
}

// The loader's checks, all before any allocation.
Status read_extension(MeshoptView& v, const tinygltf::Model& m, size_t index, const tinygltf::Value& ext,
                      size_t& budget) {
    size_t buffer = 0;
    if (!ext.IsObject() || !member(buffer, ext, "buffer") || !member(v.length, ext, "byteLength") ||
        !member(v.stride, ext, "byteStride") || !member(v.count, ext, "count") || !ext.Has("mode") ||
        !ext.Get("mode").IsString())
        return bad(index, "needs buffer, byteLength, byteStride, count and mode");
    if (ext.Has("byteOffset") && !member(v.offset, ext, "byteOffset")) return bad(index, "byteOffset is not a valid offset");
    v.mode = ext.Get("mode").Get<std::string>();
    if (ext.Has("filter")) {
        if (!ext.Get("filter").IsString()) return bad(index, "filter is not a string");
        v.filter = ext.Get("filter").Get<std::string>();
    }
    if (buffer >= m.buffers.size()) return bad(index, "buffer " + std::to_string(buffer) + " does not exist");
    v.buffer = int(buffer);
    const size_t have = m.buffers[buffer].data.size();
    if (v.offset > have || v.length > have - v.offset)
        return bad(index, "its data (" + std::to_string(v.offset) + "+" + std::to_string(v.length) + ") lies outside buffer " +
                              std::to_string(buffer) + " (" + std::to_string(have) + " bytes)");
    if (v.mode == "ATTRIBUTES") {
        if (v.stride == 0 || v.stride % 4 != 0 || v.stride > 256) return bad(index, "ATTRIBUTES byteStride must be 4..256, a multiple of 4");
    } else if (v.mode == "TRIANGLES" || v.mode == "INDICES") {
        if (v.stride != 2 && v.stride != 4) return bad(index, v.mode + " byteStride must be 2 or 4");
        if (v.mode == "TRIANGLES" && v.count % 3 != 0) return bad(index, "TRIANGLES count is not a multiple of 3");
        if (v.filter != "NONE") return bad(index, "a filter is only allowed with ATTRIBUTES");
    } else {
        return bad(index, "unknown mode '" + v.mode.substr(0, 32) + "'");
    }
    if (v.filter == "OCTAHEDRAL" ? (v.stride != 4 && v.stride != 8)
        : v.filter == "QUATERNION" ? v.stride != 8
        : v.filter == "EXPONENTIAL" ? v.stride % 4 != 0
                                    : v.filter != "NONE")
        return bad(index, "filter '" + v.filter.substr(0, 32) + "' does not fit byteStride " + std::to_string(v.stride));
    if (v.count > (size_t(1) << 32) || v.count * v.stride != m.bufferViews[index].byteLength)
        return bad(index, "count × byteStride (" + std::to_string(v.count) + " × " + std::to_string(v.stride) +
                              ") is not the view's byteLength " + std::to_string(m.bufferViews[index].byteLength));
    if (v.count * v.stride > budget)
        return Status::error(StatusCode::out_of_memory, "bufferView " + std::to_string(index) +
                                                            " EXT_meshopt_compression: the decoded data would exceed " +
                                                            "LoadOptions::max_file_bytes");
    budget -= v.count * v.stride;
    return Status::success();
}

Status decode_view(std::vector<uint8_t>& out, const tinygltf::Model& m, size_t index, const MeshoptView& v) {
    out.assign(v.count * v.stride, 0);
    const unsigned char* src = m.buffers[size_t(v.buffer)].data.data() + v.offset;
    int rc = 0;
    if (v.mode == "ATTRIBUTES") rc = meshopt_decodeVertexBuffer(out.data(), v.count, v.stride, src, v.length);
    else if (v.mode == "TRIANGLES") rc = meshopt_decodeIndexBuffer(out.data(), v.count, v.stride, src, v.length);
    else rc = meshopt_decodeIndexSequence(out.data(), v.count, v.stride, src, v.length);
    if (rc != 0) return bad(index, "the compressed data is corrupt (meshoptimizer error " + std::to_string(rc) + ")");
    if (v.filter == "OCTAHEDRAL") meshopt_decodeFilterOct(out.data(), v.count, v.stride);
    else if (v.filter == "QUATERNION") meshopt_decodeFilterQuat(out.data(), v.count, v.stride);
    else if (v.filter == "EXPONENTIAL") meshopt_decodeFilterExp(out.data(), v.count, v.stride);
    return Status::success();
}

} // namespace

Status decode_meshopt_views(tinygltf::Model& m, size_t max_decoded_bytes) {
    size_t budget = max_decoded_bytes;
    for (size_t i = 0; i < m.bufferViews.size(); ++i) {
        auto it = m.bufferViews[i].extensions.find("EXT_meshopt_compression");
        if (it == m.bufferViews[i].extensions.end()) continue;
        MeshoptView v;
        if (Status s = read_extension(v, m, i, it->second, budget); !s.ok()) return s;
        tinygltf::Buffer decoded;
        if (Status s = decode_view(decoded.data, m, i, v); !s.ok()) return s;
        m.buffers.push_back(std::move(decoded));
        tinygltf::BufferView& view = m.bufferViews[i];
        view.buffer = int(m.buffers.size() - 1);
        view.byteOffset = 0;
        view.byteStride = v.mode == "ATTRIBUTES" ? v.stride : 0;
        view.extensions.erase(it);
    }
    // The data is plain now: nothing of the extension is left to write back.
    for (auto* list : {&m.extensionsUsed, &m.extensionsRequired})
        list->erase(std::remove(list->begin(), list->end(), "EXT_meshopt_compression"), list->end());
    for (auto& b : m.buffers) b.extensions.erase("EXT_meshopt_compression");
    return Status::success();
}

} // namespace furrow::mesh_detail

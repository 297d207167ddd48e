// glTF 2.0 loading (Khronos glTF 2.0 specification, sections 3.6 "Binary data storage" and 3.7 "Geometry";
// KHR_mesh_quantization). tinygltf parses the JSON/GLB container; accessors are decoded here, with every
// offset checked, because tinygltf trusts the file's numbers.
#include "document.h"
#include "encoding.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>

namespace furrow {
namespace mesh_detail {

namespace {

int component_bytes(int type) {
    switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0; // INT and DOUBLE are not valid glTF accessor types
    }
}

int type_components(int type) {
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
    }
}

double read_component(const uint8_t* p, int type, bool normalized) {
    switch (type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f;
        std::memcpy(&f, p, 4);
        return f;
    }
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
        int8_t v;
        std::memcpy(&v, p, 1);
        return normalized ? std::max(double(v) / 127.0, -1.0) : double(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? double(*p) / 255.0 : double(*p);
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? std::max(double(v) / 32767.0, -1.0) : double(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? double(v) / 65535.0 : double(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return double(v);
    }
    default: return 0;
    }
}

// A checked view of `count` elements of `elem_bytes` at `offset` with `stride` inside buffer view `bv`.
Status view_range(const uint8_t*& base, const tinygltf::Model& m, int bv_index, size_t offset, size_t stride,
                  size_t count, size_t elem_bytes, const std::string& what) {
    if (bv_index < 0 || size_t(bv_index) >= m.bufferViews.size())
        return Status::error(StatusCode::invalid_input, what + ": bufferView " + std::to_string(bv_index) + " does not exist");
    const auto& bv = m.bufferViews[size_t(bv_index)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= m.buffers.size())
        return Status::error(StatusCode::invalid_input, what + ": buffer " + std::to_string(bv.buffer) + " does not exist");
    const auto& buf = m.buffers[size_t(bv.buffer)];
    if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset)
        return Status::error(StatusCode::invalid_input,
                             what + ": bufferView " + std::to_string(bv_index) + " lies outside its buffer (" +
                                 std::to_string(bv.byteOffset) + "+" + std::to_string(bv.byteLength) + " > " +
                                 std::to_string(buf.data.size()) + " bytes)");
    if (count > 0) {
        // last element end = offset + stride*(count-1) + elem_bytes, computed without overflow
        if (stride != 0 && count - 1 > (SIZE_MAX - elem_bytes - offset) / stride)
            return Status::error(StatusCode::invalid_input, what + ": accessor size overflows");
        size_t end = offset + stride * (count - 1) + elem_bytes;
        if (end > bv.byteLength)
            return Status::error(StatusCode::invalid_input,
                                 what + ": accessor reads past the end of bufferView " + std::to_string(bv_index) +
                                     " (" + std::to_string(end) + " > " + std::to_string(bv.byteLength) + " bytes)");
    }
    base = buf.data.data() + bv.byteOffset + offset;
    return Status::success();
}

// Decodes any accessor to doubles (count × components), applying sparse substitution.
Status read_accessor(std::vector<double>& out, const tinygltf::Model& m, int index, int& components) {
    std::string what = "accessor " + std::to_string(index);
    if (index < 0 || size_t(index) >= m.accessors.size())
        return Status::error(StatusCode::invalid_input, what + " does not exist");
    const auto& a = m.accessors[size_t(index)];
    const int cbytes = component_bytes(a.componentType);
    components = type_components(a.type);
    if (cbytes == 0 || components == 0)
        return Status::error(StatusCode::invalid_input, what + ": invalid componentType " +
                                                            std::to_string(a.componentType) + " or type");
    if (components > 4 && cbytes != 4)
        return Status::error(StatusCode::unsupported, what + ": matrices of 8/16-bit components are not supported");
    if (a.count > (size_t(1) << 31))
        return Status::error(StatusCode::out_of_memory, what + ": count " + std::to_string(a.count) + " is too large");
    const size_t elem = size_t(cbytes) * size_t(components);
    out.assign(a.count * size_t(components), 0.0);
    if (a.bufferView >= 0) {
        size_t stride = elem;
        const auto& bvs = m.bufferViews;
        if (size_t(a.bufferView) < bvs.size() && bvs[size_t(a.bufferView)].byteStride != 0) {
            stride = bvs[size_t(a.bufferView)].byteStride;
            if (stride < elem)
                return Status::error(StatusCode::invalid_input,
                                     what + ": byteStride " + std::to_string(stride) + " is smaller than an element");
        }
        const uint8_t* base = nullptr;
        Status s = view_range(base, m, a.bufferView, a.byteOffset, stride, a.count, elem, what);
        if (!s.ok()) return s;
        for (size_t i = 0; i < a.count; ++i)
            for (int c = 0; c < components; ++c)
                out[i * size_t(components) + size_t(c)] =
                    read_component(base + i * stride + size_t(c) * size_t(cbytes), a.componentType, a.normalized);
    }
    if (a.sparse.isSparse) {
        const auto& sp = a.sparse;
        if (sp.count < 0 || size_t(sp.count) > a.count)
            return Status::error(StatusCode::invalid_input, what + ": sparse count out of range");
        const int ibytes = component_bytes(sp.indices.componentType);
        if (ibytes == 0 || sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT ||
            sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
            sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_SHORT)
            return Status::error(StatusCode::invalid_input, what + ": invalid sparse index type");
        const uint8_t* ib = nullptr;
        const uint8_t* vb = nullptr;
        Status s = view_range(ib, m, sp.indices.bufferView, size_t(std::max(0, sp.indices.byteOffset)), size_t(ibytes),
                              size_t(sp.count), size_t(ibytes), what + " sparse indices");
        if (!s.ok()) return s;
        s = view_range(vb, m, sp.values.bufferView, size_t(std::max(0, sp.values.byteOffset)), elem, size_t(sp.count),
                       elem, what + " sparse values");
        if (!s.ok()) return s;
        for (int k = 0; k < sp.count; ++k) {
            size_t target = size_t(read_component(ib + size_t(k) * size_t(ibytes), sp.indices.componentType, false));
            if (target >= a.count)
                return Status::error(StatusCode::invalid_input, what + ": sparse index " + std::to_string(target) +
                                                                    " out of range (" + std::to_string(a.count) + ")");
            for (int c = 0; c < components; ++c)
                out[target * size_t(components) + size_t(c)] =
                    read_component(vb + size_t(k) * elem + size_t(c) * size_t(cbytes), a.componentType, a.normalized);
        }
    }
    return Status::success();
}

} // namespace

Status read_accessor_floats(std::vector<float>& out, const tinygltf::Model& model, int index, int& components) {
    std::vector<double> tmp;
    Status s = read_accessor(tmp, model, index, components);
    if (!s.ok()) return s;
    out.resize(tmp.size());
    for (size_t i = 0; i < tmp.size(); ++i) out[i] = float(tmp[i]);
    return s;
}

Status read_accessor_uints(std::vector<uint32_t>& out, const tinygltf::Model& model, int index, int& components) {
    if (index >= 0 && size_t(index) < model.accessors.size()) {
        const auto& a = model.accessors[size_t(index)];
        if (a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
            a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
            a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
            return Status::error(StatusCode::invalid_input, "accessor " + std::to_string(index) +
                                                                ": indices/joints must be unsigned integers");
        if (a.normalized)
            return Status::error(StatusCode::invalid_input, "accessor " + std::to_string(index) +
                                                                ": indices/joints must not be normalized");
    }
    std::vector<double> tmp;
    Status s = read_accessor(tmp, model, index, components);
    if (!s.ok()) return s;
    out.resize(tmp.size());
    for (size_t i = 0; i < tmp.size(); ++i) out[i] = uint32_t(tmp[i]);
    return s;
}

} // namespace mesh_detail

namespace {

using mesh_detail::read_accessor_floats;
using mesh_detail::read_accessor_uints;

std::string prim_name(size_t mesh, size_t prim) {
    return "mesh " + std::to_string(mesh) + " primitive " + std::to_string(prim);
}

bool all_finite(const std::vector<float>& v) {
    for (float x : v)
        if (!std::isfinite(x)) return false;
    return true;
}

// Reads attribute `name` with the expected component count into `out`.
Status read_attribute(std::vector<float>& out, const tinygltf::Model& m, const std::map<std::string, int>& attrs,
                      const std::string& name, int expected, size_t vertex_count, const std::string& where,
                      bool required = false) {
    auto it = attrs.find(name);
    if (it == attrs.end()) {
        if (required) return Status::error(StatusCode::invalid_input, where + ": has no " + name + " attribute");
        return Status::success();
    }
    // glTF 2.0 (3.6.2.2): UNSIGNED_INT is only allowed for indices; no vertex attribute (not even with
    // KHR_mesh_quantization) may use it. It used to be read as if it were valid.
    if (it->second >= 0 && size_t(it->second) < m.accessors.size() &&
        m.accessors[size_t(it->second)].componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        return Status::error(StatusCode::invalid_input, where + " " + name + ": accessor " + std::to_string(it->second) +
                                                            ": componentType 5125 (UNSIGNED_INT) is only allowed for indices");
    int comps = 0;
    Status s = read_accessor_floats(out, m, it->second, comps);
    if (!s.ok()) return Status::error(s.code, where + " " + name + ": " + s.message);
    if (comps != expected && !(name.rfind("COLOR_", 0) == 0 && comps == 3))
        return Status::error(StatusCode::invalid_input, where + " " + name + ": expected " + std::to_string(expected) +
                                                            " components, accessor has " + std::to_string(comps));
    if (vertex_count != SIZE_MAX && out.size() / size_t(comps) != vertex_count)
        return Status::error(StatusCode::invalid_input, where + " " + name + ": has " +
                                                            std::to_string(out.size() / size_t(comps)) +
                                                            " elements, POSITION has " + std::to_string(vertex_count));
    if (name.rfind("COLOR_", 0) == 0 && comps == 3) { // RGB colours become RGBA with alpha 1
        std::vector<float> rgba(vertex_count * 4);
        for (size_t i = 0; i < vertex_count; ++i) {
            rgba[i * 4 + 0] = out[i * 3 + 0];
            rgba[i * 4 + 1] = out[i * 3 + 1];
            rgba[i * 4 + 2] = out[i * 3 + 2];
            rgba[i * 4 + 3] = 1.0f;
        }
        out = std::move(rgba);
    }
    return Status::success();
}

Status decode_primitive(Primitive& p, const tinygltf::Model& m, const tinygltf::Primitive& src, size_t mi, size_t pi,
                        const LoadOptions& options, std::vector<std::string>& warnings) {
    const std::string where = prim_name(mi, pi);
    if (src.extensions.count("KHR_draco_mesh_compression"))
        return Status::error(StatusCode::unsupported, where + ": KHR_draco_mesh_compression is not supported");
    const auto& attrs = src.attributes;
    Status s = read_attribute(p.positions, m, attrs, "POSITION", 3, SIZE_MAX, where, true);
    if (!s.ok()) return s;
    const size_t n = p.vertex_count();
    if (!options.allow_non_finite && !all_finite(p.positions))
        return Status::error(StatusCode::invalid_input, where + ": POSITION contains NaN or infinite values");
    if (!(s = read_attribute(p.normals, m, attrs, "NORMAL", 3, n, where)).ok()) return s;
    if (!(s = read_attribute(p.tangents, m, attrs, "TANGENT", 4, n, where)).ok()) return s;
    if (!(s = read_attribute(p.uv0, m, attrs, "TEXCOORD_0", 2, n, where)).ok()) return s;
    if (!(s = read_attribute(p.uv1, m, attrs, "TEXCOORD_1", 2, n, where)).ok()) return s;
    if (!(s = read_attribute(p.colors, m, attrs, "COLOR_0", 4, n, where)).ok()) return s;
    if (!(s = read_attribute(p.weights, m, attrs, "WEIGHTS_0", 4, n, where)).ok()) return s;
    if (auto it = attrs.find("JOINTS_0"); it != attrs.end()) {
        std::vector<uint32_t> j;
        int comps = 0;
        if (!(s = read_accessor_uints(j, m, it->second, comps)).ok())
            return Status::error(s.code, where + " JOINTS_0: " + s.message);
        if (comps != 4 || j.size() != n * 4)
            return Status::error(StatusCode::invalid_input, where + " JOINTS_0: must be VEC4 with one entry per vertex");
        p.joints.resize(j.size());
        for (size_t i = 0; i < j.size(); ++i) {
            if (j[i] > 65535) return Status::error(StatusCode::invalid_input, where + " JOINTS_0: joint index too large");
            p.joints[i] = uint16_t(j[i]);
        }
    }
    if (p.joints.empty() != p.weights.empty())
        return Status::error(StatusCode::invalid_input, where + ": JOINTS_0 and WEIGHTS_0 must come together");
    for (const auto& [name, acc] : attrs) {
        static const std::set<std::string> known{"POSITION", "NORMAL",   "TANGENT",  "TEXCOORD_0",
                                                 "TEXCOORD_1", "COLOR_0", "JOINTS_0", "WEIGHTS_0"};
        if (known.count(name)) continue;
        if (!name.empty() && name[0] == '_') {
            CustomAttribute c;
            c.name = name;
            if (!(s = read_accessor_floats(c.values, m, acc, c.components)).ok())
                return Status::error(s.code, where + " " + name + ": " + s.message);
            if (c.components < 1 || c.components > 4 || c.values.size() != n * size_t(c.components))
                return Status::error(StatusCode::invalid_input, where + " " + name + ": must be SCALAR..VEC4, one per vertex");
            p.custom.push_back(std::move(c));
        } else {
            warnings.push_back(where + ": attribute " + name + " is not kept (furrow keeps POSITION, NORMAL, TANGENT, "
                                                                "TEXCOORD_0/1, COLOR_0, JOINTS_0, WEIGHTS_0 and _CUSTOM)");
        }
    }
    for (size_t t = 0; t < src.targets.size(); ++t) {
        MorphTarget mt;
        const std::string tw = where + " target " + std::to_string(t);
        if (!(s = read_attribute(mt.position_deltas, m, src.targets[t], "POSITION", 3, n, tw)).ok()) return s;
        if (!(s = read_attribute(mt.normal_deltas, m, src.targets[t], "NORMAL", 3, n, tw)).ok()) return s;
        if (!(s = read_attribute(mt.tangent_deltas, m, src.targets[t], "TANGENT", 3, n, tw)).ok()) return s;
        p.targets.push_back(std::move(mt));
    }

    // Indices (or the implicit 0..n-1), then the mode's connectivity.
    std::vector<uint32_t> idx;
    if (src.indices >= 0) {
        int comps = 0;
        if (!(s = read_accessor_uints(idx, m, src.indices, comps)).ok())
            return Status::error(s.code, where + " indices: " + s.message);
        if (comps != 1) return Status::error(StatusCode::invalid_input, where + ": indices must be SCALAR");
        for (size_t i = 0; i < idx.size(); ++i)
            if (idx[i] >= n)
                return Status::error(StatusCode::invalid_input, where + ": index " + std::to_string(idx[i]) + " at " +
                                                                    std::to_string(i) + " is out of range (" +
                                                                    std::to_string(n) + " vertices)");
    } else {
        idx.resize(n);
        for (size_t i = 0; i < n; ++i) idx[i] = uint32_t(i);
    }
    switch (src.mode) {
    case TINYGLTF_MODE_TRIANGLES:
        if (idx.size() % 3 != 0)
            return Status::error(StatusCode::invalid_input, where + ": triangle index count " +
                                                                std::to_string(idx.size()) + " is not a multiple of 3");
        p.indices = std::move(idx);
        break;
    case TINYGLTF_MODE_TRIANGLE_STRIP:
        // Every other triangle swaps its first two corners to keep the strip's winding.
        for (size_t i = 2; i < idx.size(); ++i) {
            if (i % 2 == 0) p.indices.insert(p.indices.end(), {idx[i - 2], idx[i - 1], idx[i]});
            else p.indices.insert(p.indices.end(), {idx[i - 1], idx[i - 2], idx[i]});
        }
        break;
    case TINYGLTF_MODE_TRIANGLE_FAN:
        for (size_t i = 2; i < idx.size(); ++i) p.indices.insert(p.indices.end(), {idx[0], idx[i - 1], idx[i]});
        break;
    case TINYGLTF_MODE_POINTS:
        p.mode = PrimitiveMode::points;
        p.indices = std::move(idx);
        break;
    case TINYGLTF_MODE_LINE:
        if (idx.size() % 2 != 0)
            return Status::error(StatusCode::invalid_input, where + ": line index count is odd");
        p.mode = PrimitiveMode::lines;
        p.indices = std::move(idx);
        break;
    case TINYGLTF_MODE_LINE_STRIP:
    case TINYGLTF_MODE_LINE_LOOP:
        p.mode = PrimitiveMode::lines;
        for (size_t i = 1; i < idx.size(); ++i) p.indices.insert(p.indices.end(), {idx[i - 1], idx[i]});
        if (src.mode == TINYGLTF_MODE_LINE_LOOP && idx.size() > 2) p.indices.insert(p.indices.end(), {idx.back(), idx[0]});
        break;
    default:
        return Status::error(StatusCode::unsupported, where + ": primitive mode " + std::to_string(src.mode) +
                                                          " is not a glTF mode (0..6)");
    }
    p.material = src.material;
    if (p.material >= int(m.materials.size()))
        return Status::error(StatusCode::invalid_input, where + ": material " + std::to_string(p.material) + " does not exist");
    return Status::success();
}

Material decode_material(const tinygltf::Material& src) {
    Material mat;
    mat.name = src.name;
    const auto& pbr = src.pbrMetallicRoughness;
    for (size_t i = 0; i < 4 && i < pbr.baseColorFactor.size(); ++i) mat.base_color[i] = float(pbr.baseColorFactor[i]);
    mat.base_color_texture.texture = pbr.baseColorTexture.index;
    mat.base_color_texture.texcoord = pbr.baseColorTexture.texCoord;
    mat.metallic = float(pbr.metallicFactor);
    mat.roughness = float(pbr.roughnessFactor);
    for (size_t i = 0; i < 3 && i < src.emissiveFactor.size(); ++i) mat.emissive[i] = float(src.emissiveFactor[i]);
    mat.alpha_mode = src.alphaMode == "MASK" ? AlphaMode::mask : src.alphaMode == "BLEND" ? AlphaMode::blend : AlphaMode::opaque;
    mat.alpha_cutoff = float(src.alphaCutoff);
    mat.double_sided = src.doubleSided;
    return mat;
}

// Image loader callback: keep the encoded bytes as they are; the rasterizer decodes on demand.
// `model` is the model tinygltf is filling. For an image in a bufferView, tinygltf 2.7 hands over
// buffer.data + byteOffset and byteLength without checking them against the buffer's size, so a bufferView
// reaching past its buffer was a heap read overflow here (found by fuzz_render); it is checked first.
bool keep_image_bytes(tinygltf::Image* image, const int index, std::string* err, std::string*, int, int,
                      const unsigned char* bytes, int size, void* model) {
    const auto* m = static_cast<const tinygltf::Model*>(model);
    if (image->bufferView >= 0) {
        const size_t bv = size_t(image->bufferView);
        const bool inside = m && bv < m->bufferViews.size() && size_t(m->bufferViews[bv].buffer) < m->buffers.size() &&
                            m->bufferViews[bv].byteOffset <= m->buffers[size_t(m->bufferViews[bv].buffer)].data.size() &&
                            m->bufferViews[bv].byteLength <=
                                m->buffers[size_t(m->bufferViews[bv].buffer)].data.size() - m->bufferViews[bv].byteOffset;
        if (!inside || size < 0) {
            if (err) *err += "image " + std::to_string(index) + ": its bufferView lies outside its buffer\n";
            return false;
        }
    }
    if (size < 0) return false;
    image->image.assign(bytes, bytes + size);
    if (image->mimeType.empty() && size >= 4) {
        if (bytes[0] == 0x89 && bytes[1] == 'P' && bytes[2] == 'N' && bytes[3] == 'G') image->mimeType = "image/png";
        else if (bytes[0] == 0xFF && bytes[1] == 0xD8) image->mimeType = "image/jpeg";
    }
    return true;
}

// Required extensions furrow reads or carries through faithfully (glTF 2.0, 3.12: a loader must refuse an
// asset that requires an extension it does not support). KHR_mesh_quantization and EXT_meshopt_compression
// are decoded; the others only
// touch materials, textures or lights, which are written back unchanged. Anything else that is required
// (Draco, GPU instancing, a vendor's private extension) changes what the data means: refused, by
// name, rather than read as if it were plain glTF.
bool required_extension_supported(const std::string& e) {
    static const std::set<std::string> k_supported{"KHR_mesh_quantization", "EXT_meshopt_compression",
                                                   "KHR_texture_transform", "KHR_texture_basisu",
                                                   "KHR_lights_punctual", "EXT_texture_webp"};
    return k_supported.count(e) || e.rfind("KHR_materials_", 0) == 0;
}

// Without KHR_mesh_quantization, glTF 2.0 (3.7.2.1) allows only FLOAT positions, normals and tangents, and
// FLOAT or normalized unsigned byte/short texture coordinates. A quantized POSITION in a file that does not
// declare the extension used to be dequantized silently; other tools refuse or misread such a file.
Status check_core_attribute_types(const tinygltf::Model& m) {
    if (std::find(m.extensionsUsed.begin(), m.extensionsUsed.end(), "KHR_mesh_quantization") != m.extensionsUsed.end())
        return Status::success();
    auto check = [&](const std::map<std::string, int>& attrs, const std::string& where) {
        for (const auto& [name, index] : attrs) {
            if (index < 0 || size_t(index) >= m.accessors.size()) continue; // reported where it is read
            const auto& a = m.accessors[size_t(index)];
            // UNSIGNED_INT and unknown types are refused where the attribute is read, with their own message.
            if (a.componentType < TINYGLTF_COMPONENT_TYPE_BYTE || a.componentType > TINYGLTF_COMPONENT_TYPE_FLOAT ||
                a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT || a.componentType == TINYGLTF_COMPONENT_TYPE_INT)
                continue;
            const bool is_float = a.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT;
            bool ok = true;
            if (name == "POSITION" || name == "NORMAL" || name == "TANGENT") ok = is_float;
            else if (name.rfind("TEXCOORD_", 0) == 0)
                ok = is_float || (a.normalized && (a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                                   a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT));
            if (!ok)
                return Status::error(StatusCode::invalid_input,
                                     where + " " + name + ": componentType " + std::to_string(a.componentType) +
                                         (a.normalized ? " (normalized)" : "") +
                                         " needs KHR_mesh_quantization, which the file does not declare in extensionsUsed");
        }
        return Status::success();
    };
    for (size_t mi = 0; mi < m.meshes.size(); ++mi)
        for (size_t pi = 0; pi < m.meshes[mi].primitives.size(); ++pi) {
            const auto& prim = m.meshes[mi].primitives[pi];
            Status s = check(prim.attributes, prim_name(mi, pi));
            if (!s.ok()) return s;
            for (size_t ti = 0; ti < prim.targets.size(); ++ti) {
                s = check(prim.targets[ti], prim_name(mi, pi) + " morph target " + std::to_string(ti));
                if (!s.ok()) return s;
            }
        }
    return Status::success();
}

Status check_node_graph(const tinygltf::Model& m) {
    // Each node has at most one parent and there are no cycles (glTF 3.5.3).
    std::vector<int> parent(m.nodes.size(), -1);
    for (size_t i = 0; i < m.nodes.size(); ++i)
        for (int c : m.nodes[i].children) {
            if (c < 0 || size_t(c) >= m.nodes.size())
                return Status::error(StatusCode::invalid_input, "node " + std::to_string(i) + ": child " +
                                                                    std::to_string(c) + " does not exist");
            if (parent[size_t(c)] != -1 || size_t(c) == i)
                return Status::error(StatusCode::invalid_input, "node " + std::to_string(c) + " has more than one parent");
            parent[size_t(c)] = int(i);
        }
    for (size_t i = 0; i < m.nodes.size(); ++i) {
        size_t steps = 0;
        for (int p = parent[i]; p != -1; p = parent[size_t(p)])
            if (++steps > m.nodes.size())
                return Status::error(StatusCode::invalid_input, "node hierarchy has a cycle at node " + std::to_string(i));
    }
    return Status::success();
}

// The default scene's root nodes, repaired: glTF 2.0 §3.5.2 says a scene lists root nodes only, and exporters
// (UniGLTF, in Kenney's kits) list children too (the validator's SCENE_NON_ROOT_NODE), which a writer that
// copies the list passes on. A listed child is replaced by its root ancestor: dropped when that root is
// listed anyway (the usual case: the child was drawn through it), added otherwise (its siblings come along).
// Duplicates are dropped. Each repair is one warning. The node graph is a forest here (check_node_graph).
std::vector<int> scene_roots(const tinygltf::Model& model, int scene_index, std::vector<std::string>& warnings) {
    std::vector<int> parent(model.nodes.size(), -1);
    for (size_t i = 0; i < model.nodes.size(); ++i)
        for (int c : model.nodes[i].children) parent[size_t(c)] = int(i);
    std::vector<int> roots;
    std::vector<char> entry(model.nodes.size(), 0), root_added(model.nodes.size(), 0);
    std::string children, duplicates;
    for (int r : model.scenes[size_t(scene_index)].nodes) {
        if (entry[size_t(r)]) duplicates += (duplicates.empty() ? "" : ", ") + std::to_string(r);
        entry[size_t(r)] = 1;
        int root = r;
        while (parent[size_t(root)] >= 0) root = parent[size_t(root)];
        if (root != r) children += (children.empty() ? "" : ", ") + std::to_string(r);
        if (!root_added[size_t(root)]) roots.push_back(root);
        root_added[size_t(root)] = 1;
    }
    // A root listed after one of its children keeps the place the child gave it; the order of roots does not
    // change what is drawn.
    const std::string scene = "scene " + std::to_string(scene_index);
    if (!children.empty())
        warnings.push_back(scene + " lists node " + children + ", a child of another node (glTF requires root "
                           "nodes); listing its root node instead");
    if (!duplicates.empty()) warnings.push_back(scene + " lists node " + duplicates + " twice; listed once");
    return roots;
}

// Images keep their encoded bytes (moved out of the model: the writer embeds them from the scene).
Status convert_images(Scene& scene, tinygltf::Model& model, const LoadOptions& options) {
    for (auto& img : model.images) {
        Image im;
        im.name = img.name;
        im.mime_type = img.mimeType;
        im.source_uri = img.uri;
        im.encoded = std::move(img.image);
        img.image.clear();
        // The decoders (render, shells) allocate width × height before they look at the pixels: a 1 KB PNG
        // can claim 100000 × 100000. Refused here, from the header, before anything decodes it.
        int w = 0, h = 0;
        if (!im.encoded.empty() && mesh_detail::image_dimensions(im.encoded.data(), im.encoded.size(), w, h) &&
            (w <= 0 || h <= 0 || size_t(w) * size_t(h) > options.max_image_pixels))
            return Status::error(StatusCode::out_of_memory,
                                 "image " + std::to_string(scene.images.size()) + " is " + std::to_string(w) + "x" +
                                     std::to_string(h) + " pixels, above the limit of " +
                                     std::to_string(options.max_image_pixels) + " (LoadOptions::max_image_pixels raises it)");
        if (im.encoded.empty())
            scene.warnings.push_back("image " + std::to_string(scene.images.size()) + " ('" + mesh_detail::printable_uri(img.uri) +
                                     "') could not be read; its texture renders as the material factor");
        scene.images.push_back(std::move(im));
    }
    return Status::success();
}

Status convert_model(Scene& out, tinygltf::Model&& model, const LoadOptions& options) {
    for (const auto& e : model.extensionsRequired) {
        if (!required_extension_supported(e))
            return Status::error(StatusCode::unsupported, "required extension " + e + " is not supported");
    }
    // EXT_meshopt_compression: decoded first, so that every accessor below reads plain bytes.
    if (Status d = mesh_detail::decode_meshopt_views(model, options.max_file_bytes); !d.ok()) return d;
    size_t primitives = 0;
    for (const auto& mesh : model.meshes) primitives += mesh.primitives.size();
    Status s = mesh_detail::check_scene_counts(model.nodes.size(), primitives, options);
    if (!s.ok()) return s;
    s = check_node_graph(model);
    if (!s.ok()) return s;
    s = check_core_attribute_types(model);
    if (!s.ok()) return s;
    Scene scene;
    for (size_t mi = 0; mi < model.meshes.size(); ++mi) {
        Mesh mesh;
        mesh.name = model.meshes[mi].name;
        for (double w : model.meshes[mi].weights) mesh.weights.push_back(float(w));
        for (size_t pi = 0; pi < model.meshes[mi].primitives.size(); ++pi) {
            Primitive p;
            s = decode_primitive(p, model, model.meshes[mi].primitives[pi], mi, pi, options, scene.warnings);
            if (!s.ok()) return s;
            mesh.primitives.push_back(std::move(p));
        }
        scene.meshes.push_back(std::move(mesh));
    }
    for (size_t i = 0; i < model.nodes.size(); ++i) {
        const auto& src = model.nodes[i];
        Node n;
        n.name = src.name;
        n.mesh = src.mesh;
        n.skin = src.skin;
        n.camera = src.camera;
        n.children = src.children;
        if (n.mesh >= int(model.meshes.size()) || n.skin >= int(model.skins.size()) ||
            n.camera >= int(model.cameras.size()))
            return Status::error(StatusCode::invalid_input, "node " + std::to_string(i) + " references a mesh, skin or camera that does not exist");
        if (src.matrix.size() == 16) {
            n.has_matrix = true;
            std::copy(src.matrix.begin(), src.matrix.end(), n.matrix.begin());
        }
        if (src.translation.size() == 3) std::copy(src.translation.begin(), src.translation.end(), n.translation.begin());
        if (src.rotation.size() == 4) std::copy(src.rotation.begin(), src.rotation.end(), n.rotation.begin());
        if (src.scale.size() == 3) std::copy(src.scale.begin(), src.scale.end(), n.scale.begin());
        n.weights = src.weights;
        scene.nodes.push_back(std::move(n));
    }
    if (!model.scenes.empty()) {
        int si = model.defaultScene >= 0 && size_t(model.defaultScene) < model.scenes.size() ? model.defaultScene : 0;
        for (int r : model.scenes[size_t(si)].nodes)
            if (r < 0 || size_t(r) >= model.nodes.size())
                return Status::error(StatusCode::invalid_input, "scene " + std::to_string(si) + ": node " + std::to_string(r) + " does not exist");
        scene.roots = scene_roots(model, si, scene.warnings);
    } else {
        // No scene: every parentless node is a root, so that nothing is lost.
        std::vector<char> child(model.nodes.size(), 0);
        for (const auto& n : model.nodes)
            for (int c : n.children) child[size_t(c)] = 1;
        for (size_t i = 0; i < model.nodes.size(); ++i)
            if (!child[i]) scene.roots.push_back(int(i));
    }
    for (const auto& mat : model.materials) scene.materials.push_back(decode_material(mat));
    for (const auto& t : model.textures) {
        if (t.source >= int(model.images.size()) || t.sampler >= int(model.samplers.size()))
            return Status::error(StatusCode::invalid_input, "a texture references an image or sampler that does not exist");
        scene.textures.push_back({t.source, t.sampler});
    }
    for (size_t i = 0; i < scene.materials.size(); ++i)
        if (scene.materials[i].base_color_texture.texture >= int(scene.textures.size()))
            return Status::error(StatusCode::invalid_input, "material " + std::to_string(i) + ": texture does not exist");
    for (const auto& smp : model.samplers) scene.samplers.push_back({smp.magFilter, smp.minFilter, smp.wrapS, smp.wrapT});
    s = convert_images(scene, model, options);
    if (!s.ok()) return s;
    for (size_t i = 0; i < model.skins.size(); ++i) {
        const auto& src = model.skins[i];
        Skin sk;
        sk.name = src.name;
        sk.joints = src.joints;
        sk.skeleton = src.skeleton;
        for (int j : sk.joints)
            if (j < 0 || size_t(j) >= model.nodes.size())
                return Status::error(StatusCode::invalid_input, "skin " + std::to_string(i) + ": joint node does not exist");
        if (src.inverseBindMatrices >= 0) {
            int comps = 0;
            s = read_accessor_floats(sk.inverse_bind_matrices, model, src.inverseBindMatrices, comps);
            if (!s.ok()) return Status::error(s.code, "skin " + std::to_string(i) + " inverseBindMatrices: " + s.message);
            if (comps != 16 || sk.inverse_bind_matrices.size() != sk.joints.size() * 16)
                return Status::error(StatusCode::invalid_input, "skin " + std::to_string(i) + ": inverseBindMatrices must be one MAT4 per joint");
        }
        scene.skins.push_back(std::move(sk));
    }
    // Animation samplers are re-encoded on save; check them now so that a bad file fails at load.
    for (size_t a = 0; a < model.animations.size(); ++a) {
        for (const auto& smp : model.animations[a].samplers) {
            std::vector<float> tmp;
            int comps = 0;
            for (int acc : {smp.input, smp.output}) {
                s = read_accessor_floats(tmp, model, acc, comps);
                if (!s.ok()) return Status::error(s.code, "animation " + std::to_string(a) + ": " + s.message);
            }
        }
        for (const auto& ch : model.animations[a].channels)
            if (ch.sampler < 0 || size_t(ch.sampler) >= model.animations[a].samplers.size() ||
                ch.target_node >= int(model.nodes.size()))
                return Status::error(StatusCode::invalid_input, "animation " + std::to_string(a) + ": channel references a missing sampler or node");
    }
    mesh_detail::bake_texture_transforms(scene, model); // the coordinates the textures are sampled at
    auto doc = std::make_shared<mesh_detail::Document>();
    doc->model = std::move(model);
    scene.document = std::move(doc);
    if (options.recentre) recentre(scene, options.recentre_threshold);
    out = std::move(scene);
    return Status::success();
}

} // namespace

Status load_gltf_bytes(Scene& out, const uint8_t* data, size_t size, const ResourceResolver& resolver,
                       const LoadOptions& options) {
    if (size > std::numeric_limits<unsigned int>::max())
        return Status::error(StatusCode::out_of_memory, "file is larger than 4 GiB");
    // External resources are decided and read first (gltf_resources.cpp); tinygltf then sees only tokens for
    // them and its file callbacks serve those from memory. Any other path it asks for does not exist: the
    // file system is out of its reach, whatever it makes of a URI (before, it opened any absolute path and
    // tried relative ones in the working directory too).
    mesh_detail::PreparedGltf prepared;
    if (Status s = mesh_detail::prepare_gltf(prepared, data, size, resolver, options); !s.ok()) return s;
    if (!prepared.bytes.empty()) {
        data = prepared.bytes.data();
        size = prepared.bytes.size();
    }
    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    loader.SetImageLoader(keep_image_bytes, &model);
    tinygltf::FsCallbacks served{};
    served.FileExists = [](const std::string& p, void* files) {
        return static_cast<std::map<std::string, std::vector<uint8_t>>*>(files)->count(p) > 0;
    };
    served.ExpandFilePath = [](const std::string& p, void*) { return p; };
    served.ReadWholeFile = [](std::vector<unsigned char>* out, std::string*, const std::string& p, void* files) {
        auto& map = *static_cast<std::map<std::string, std::vector<uint8_t>>*>(files);
        auto it = map.find(p);
        if (it == map.end()) return false;
        out->swap(it->second);
        return true;
    };
    served.WriteWholeFile = [](std::string*, const std::string&, const std::vector<unsigned char>&, void*) { return false; };
    served.user_data = &prepared.files;
    loader.SetFsCallbacks(served);
    std::string err, warn;
    bool ok;
    const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    if (glb) {
        // GLB container version 1 is glTF 1.0's binary extension: tinygltf reads it as if it were 2.0.
        if (size >= 12) {
            uint32_t version = 0;
            std::memcpy(&version, data + 4, 4);
            if (version != 2)
                return Status::error(StatusCode::unsupported, "invalid GLB: container version " + std::to_string(version) +
                                                                  " is not supported (glTF 2.0 is version 2)");
        }
        ok = loader.LoadBinaryFromMemory(&model, &err, &warn, data, unsigned(size), "");
    } else {
        if (size == 0) return Status::error(StatusCode::invalid_input, "file is empty");
        ok = loader.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(data), unsigned(size), "");
    }
    if (!ok) {
        std::string msg = err.empty() ? "not a valid glTF file" : err;
        // tinygltf's messages are multi-line; keep the first line (the CLI prints one line).
        while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
        if (auto nl = msg.find('\n'); nl != std::string::npos) msg = msg.substr(0, nl);
        // tinygltf quotes a data URI it cannot decode in full: the line could be megabytes of base64.
        if (auto b64 = msg.find(";base64,"); b64 != std::string::npos) {
            size_t start = b64 + 8, end = start;
            while (end < msg.size() && msg[end] != ' ' && msg[end] != '\'' && msg[end] != '"') ++end;
            if (end - start > 16) msg.replace(start + 16, end - start - 16, "...");
        }
        return Status::error(StatusCode::invalid_input, (glb ? "invalid GLB: " : "invalid glTF: ") + msg);
    }
    for (size_t i = 0; i < model.buffers.size() && i < prepared.buffer_uris.size(); ++i)
        if (!prepared.buffer_uris[i].empty()) model.buffers[i].uri = prepared.buffer_uris[i];
    for (size_t i = 0; i < model.images.size() && i < prepared.image_uris.size(); ++i)
        if (!prepared.image_uris[i].empty()) model.images[i].uri = prepared.image_uris[i];
    Status s = convert_model(out, std::move(model), options);
    if (s.ok() && !warn.empty()) {
        size_t at = 0;
        while (at < warn.size()) {
            size_t nl = warn.find('\n', at);
            std::string line = warn.substr(at, nl == std::string::npos ? std::string::npos : nl - at);
            if (!line.empty()) out.warnings.push_back(line);
            if (nl == std::string::npos) break;
            at = nl + 1;
        }
    }
    return s;
}

} // namespace furrow

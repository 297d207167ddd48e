// KHR_texture_transform and furrow's texture coordinates, both ways.
//
// Reference: the KHR_texture_transform specification (Khronos, 2018): a texture reference may carry
// offset, rotation and scale, applied to its TEXCOORD_n set as uv' = T(offset) · R(rotation) · S(scale) · uv.
// gltfpack (meshoptimizer) uses it to dequantize texture coordinates outside [0, 1]: the stored values are
// normalized integers q in [0, 1] and the material maps them back, uv = offset + scale · q.
//
// Loader (bake_texture_transforms). furrow's tools read texture coordinates directly (a fur mask is sampled at
// TEXCOORD_0, the rasterizer samples the base colour), so a transform left in the material would make them
// read the wrong texels of a gltfpack or furrow --compress file. Where every texture reference of a material
// on a set has the same transform, it is applied to that set of each primitive drawn with the material and
// removed from the references: the scene's coordinates are then the ones the textures are sampled at, and the
// rendering is unchanged. A material whose references on one set disagree, that redirects a set (the
// extension's texCoord), or whose own extensions sample textures keeps its transforms as they are.
//
// Writer (texture_uv_grids). With --quantize / --compress, a set outside [0, 1] (the fur's tiling strand
// coordinates) is stored like gltfpack stores it: normalized uint16 on the bounding box of the set over the
// primitives drawn with the material, dequantized by a transform on the material's references to that set.
// It is used only when the step keeps every coordinate within half a texel of the largest texture sampled at
// that set; otherwise, or when the set is sampled by no texture (no material could carry the transform), the
// coordinates stay float as before.
//
// Writer (sampled_uv_sets). SaveOptions::drop_unused_uvs (gltfpack's default) leaves out the sets no texture
// of a material samples; a material whose extensions sample textures, or whose transform redirects a
// reference to another set, keeps both.
#include "document.h"
#include "encoding.h"

#include <algorithm>
#include <cmath>

namespace furrow::mesh_detail {
namespace {

constexpr const char* kExtension = "KHR_texture_transform";

// A texture reference of a material's core: its texture, its set and its extensions.
struct TextureSlot {
    int* index;
    int* texcoord;
    tinygltf::ExtensionMap* extensions;
};

std::vector<TextureSlot> core_texture_slots(tinygltf::Material& m) {
    auto& pbr = m.pbrMetallicRoughness;
    return {{&pbr.baseColorTexture.index, &pbr.baseColorTexture.texCoord, &pbr.baseColorTexture.extensions},
            {&pbr.metallicRoughnessTexture.index, &pbr.metallicRoughnessTexture.texCoord, &pbr.metallicRoughnessTexture.extensions},
            {&m.normalTexture.index, &m.normalTexture.texCoord, &m.normalTexture.extensions},
            {&m.occlusionTexture.index, &m.occlusionTexture.texCoord, &m.occlusionTexture.extensions},
            {&m.emissiveTexture.index, &m.emissiveTexture.texCoord, &m.emissiveTexture.extensions}};
}

// Whether a material extension samples a texture (any nested object with an "index"): its references are not
// the core's, so neither the loader nor the writer changes the coordinates such a material reads.
bool samples_textures(const tinygltf::Value& v) {
    if (v.IsObject()) {
        if (v.Has("index")) return true;
        for (const std::string& k : v.Keys())
            if (samples_textures(v.Get(k))) return true;
    } else if (v.IsArray()) {
        for (size_t i = 0; i < v.ArrayLen(); ++i)
            if (samples_textures(v.Get(int(i)))) return true;
    }
    return false;
}

bool extensions_sample_textures(const tinygltf::Material& m) {
    for (const auto& [name, value] : m.extensions)
        if (samples_textures(value)) return true;
    return false;
}

// The core references of a material to one texture-coordinate set (those that sample a texture).
std::vector<TextureSlot> references_to(tinygltf::Material& m, int set) {
    std::vector<TextureSlot> refs;
    for (const TextureSlot& s : core_texture_slots(m))
        if (*s.index >= 0 && *s.texcoord == set) refs.push_back(s);
    return refs;
}

// uv' = offset + R(rotation) · diag(scale) · uv, the specification's matrix.
struct Transform {
    double ou = 0, ov = 0, rotation = 0, su = 1, sv = 1;
    bool operator==(const Transform& o) const {
        return ou == o.ou && ov == o.ov && rotation == o.rotation && su == o.su && sv == o.sv;
    }
};

// The transform of one reference; false when it cannot be baked (it redirects the set, or a value is not a
// finite number).
bool read_transform(const tinygltf::Value& e, Transform& t) {
    if (!e.IsObject() || e.Has("texCoord")) return false;
    auto number = [](const tinygltf::Value& v, double& out) {
        if (!v.IsNumber()) return false;
        out = v.GetNumberAsDouble();
        return std::isfinite(out);
    };
    auto pair = [&](const char* key, double& a, double& b) {
        if (!e.Has(key)) return true;
        const tinygltf::Value& v = e.Get(key);
        return v.IsArray() && v.ArrayLen() == 2 && number(v.Get(0), a) && number(v.Get(1), b);
    };
    return pair("offset", t.ou, t.ov) && pair("scale", t.su, t.sv) && (!e.Has("rotation") || number(e.Get("rotation"), t.rotation));
}

// Applies t to every uv pair; false (uv untouched) when a result is not a finite float.
bool transform_uvs(std::vector<float>& uv, const Transform& t) {
    const double c = std::cos(t.rotation), s = std::sin(t.rotation);
    std::vector<float> out(uv.size());
    for (size_t i = 0; i + 1 < uv.size(); i += 2) {
        const double u = double(uv[i]) * t.su, v = double(uv[i + 1]) * t.sv;
        const double a = t.ou + c * u + s * v, b = t.ov - s * u + c * v;
        if (!(std::abs(a) <= 3e38 && std::abs(b) <= 3e38)) return false;
        out[i] = float(a), out[i + 1] = float(b);
    }
    uv.swap(out);
    return true;
}

std::vector<float>& uv_set(Primitive& p, int set) { return set == 0 ? p.uv0 : p.uv1; }
const std::vector<float>& uv_set(const Primitive& p, int set) { return set == 0 ? p.uv0 : p.uv1; }

// Whether a value names the extension anywhere (a texture reference inside a material extension).
bool names_extension(const tinygltf::Value& v) {
    if (v.IsObject()) {
        for (const std::string& k : v.Keys())
            if (k == kExtension || names_extension(v.Get(k))) return true;
    } else if (v.IsArray()) {
        for (size_t i = 0; i < v.ArrayLen(); ++i)
            if (names_extension(v.Get(int(i)))) return true;
    }
    return false;
}

// Whether any texture reference of the model still carries the extension.
bool any_reference_transformed(tinygltf::Model& model) {
    for (tinygltf::Material& m : model.materials) {
        for (const TextureSlot& s : core_texture_slots(m))
            if (s.extensions->count(kExtension)) return true;
        for (const auto& [name, value] : m.extensions)
            if (names_extension(value)) return true;
    }
    return false;
}

void drop_declaration(tinygltf::Model& model) {
    for (auto* list : {&model.extensionsUsed, &model.extensionsRequired})
        list->erase(std::remove(list->begin(), list->end(), kExtension), list->end());
}

} // namespace

void bake_texture_transforms(Scene& scene, tinygltf::Model& model) {
    bool baked = false;
    for (size_t mi = 0; mi < model.materials.size(); ++mi) {
        tinygltf::Material& mat = model.materials[mi];
        if (extensions_sample_textures(mat)) continue;
        for (int set : {0, 1}) {
            // 1. The set's references: all with the same bakeable transform, or none transformed.
            const std::vector<TextureSlot> refs = references_to(mat, set);
            Transform t;
            size_t transformed = 0;
            bool consistent = true;
            for (const TextureSlot& s : refs) {
                auto it = s.extensions->find(kExtension);
                if (it == s.extensions->end()) continue;
                Transform ti;
                consistent = consistent && read_transform(it->second, ti) && (transformed == 0 || ti == t);
                t = ti;
                ++transformed;
            }
            if (transformed == 0 || transformed != refs.size() || !consistent) continue;
            // 2. The set of every primitive drawn with the material, all or none.
            std::vector<std::vector<float>> out;
            std::vector<std::vector<float>*> targets;
            for (Mesh& mesh : scene.meshes)
                for (Primitive& p : mesh.primitives)
                    if (p.material == int(mi) && !uv_set(p, set).empty()) targets.push_back(&uv_set(p, set));
            for (std::vector<float>* uv : targets) {
                out.push_back(*uv);
                if (!transform_uvs(out.back(), t)) consistent = false;
            }
            if (!consistent) continue;
            for (size_t k = 0; k < targets.size(); ++k) targets[k]->swap(out[k]);
            // 3. The references no longer transform.
            for (const TextureSlot& s : refs) s.extensions->erase(kExtension);
            baked = true;
        }
    }
    if (baked && !any_reference_transformed(model)) drop_declaration(model);
}

std::array<bool, 2> sampled_uv_sets(const tinygltf::Material& material) {
    if (extensions_sample_textures(material)) return {true, true};
    tinygltf::Material copy = material; // core_texture_slots hands out writable references
    std::array<bool, 2> out{false, false};
    for (int set : {0, 1})
        for (const TextureSlot& s : references_to(copy, set)) {
            out[size_t(set)] = true;
            // A transform that redirects the reference (its texCoord) may read the other set: keep both.
            auto it = s.extensions->find(kExtension);
            if (it != s.extensions->end() && (!it->second.IsObject() || it->second.Has("texCoord"))) return {true, true};
        }
    return out;
}

std::vector<std::array<UvGrid, 2>> texture_uv_grids(tinygltf::Model& m, const Scene& scene) {
    std::vector<std::array<UvGrid, 2>> grids(m.materials.size());
    bool any = false;
    for (size_t mi = 0; mi < m.materials.size(); ++mi) {
        tinygltf::Material& mat = m.materials[mi];
        if (extensions_sample_textures(mat)) continue;
        for (int set : {0, 1}) {
            // 1. The references to the set; the largest texture they sample (in texels).
            const std::vector<TextureSlot> refs = references_to(mat, set);
            int texels = 0;
            bool known = true;
            for (const TextureSlot& s : refs) {
                if (s.extensions->count(kExtension)) known = false; // a carried transform: not composed
                const int image = size_t(*s.index) < scene.textures.size() ? scene.textures[size_t(*s.index)].image : -1;
                int w = 0, h = 0;
                if (image < 0 || size_t(image) >= scene.images.size() || scene.images[size_t(image)].encoded.empty() ||
                    !image_dimensions(scene.images[size_t(image)].encoded.data(), scene.images[size_t(image)].encoded.size(), w, h))
                    known = false;
                texels = std::max({texels, w, h});
            }
            if (refs.empty() || !known) continue;
            // 2. The set's bounding box over the primitives drawn with the material.
            double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
            bool finite = true;
            for (const Mesh& mesh : scene.meshes)
                for (const Primitive& p : mesh.primitives) {
                    if (p.material != int(mi)) continue;
                    const std::vector<float>& uv = uv_set(p, set);
                    for (size_t i = 0; i < uv.size(); ++i) {
                        finite = finite && std::isfinite(uv[i]);
                        lo[i % 2] = std::min(lo[i % 2], double(uv[i]));
                        hi[i % 2] = std::max(hi[i % 2], double(uv[i]));
                    }
                }
            if (!finite || !(lo[0] <= hi[0] && lo[1] <= hi[1])) continue;
            if (lo[0] >= 0 && lo[1] >= 0 && hi[0] <= 1 && hi[1] <= 1) continue; // plain normalized integers
            // 3. A step of at most one texel of the largest texture: each coordinate within half a texel.
            UvGrid& g = grids[mi][size_t(set)];
            g.offset = {lo[0], lo[1]};
            g.scale = {hi[0] > lo[0] ? hi[0] - lo[0] : 1.0, hi[1] > lo[1] ? hi[1] - lo[1] : 1.0};
            if (std::max(g.scale[0], g.scale[1]) / 65535.0 * texels > 1.0) continue;
            g.used = true;
            tinygltf::Value::Object e;
            e["offset"] = tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(g.offset[0]), tinygltf::Value(g.offset[1])});
            e["scale"] = tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(g.scale[0]), tinygltf::Value(g.scale[1])});
            for (const TextureSlot& s : refs) (*s.extensions)[kExtension] = tinygltf::Value(e);
            any = true;
        }
    }
    if (any) {
        for (auto* list : {&m.extensionsUsed, &m.extensionsRequired})
            if (std::find(list->begin(), list->end(), kExtension) == list->end()) list->push_back(kExtension);
    }
    return grids;
}

std::vector<uint16_t> quantize_uv(const std::vector<float>& uv, const UvGrid& g) {
    std::vector<uint16_t> q(uv.size());
    for (size_t i = 0; i < uv.size(); ++i) {
        const double x = (double(uv[i]) - g.offset[i % 2]) / g.scale[i % 2];
        q[i] = uint16_t(std::lround(std::clamp(x, 0.0, 1.0) * 65535.0));
    }
    return q;
}

} // namespace furrow::mesh_detail

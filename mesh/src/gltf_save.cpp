// glTF 2.0 writing. The output is rebuilt from the Scene: one binary buffer, one tightly packed buffer view per
// accessor, every image embedded, and the rest of the source document (animations, cameras, extras, unknown
// extensions) carried over. Target: the Khronos glTF-Validator reports 0 errors and 0 warnings.
#include "document.h"
#include "encoding.h"

#include <furrow_kernel/atomic_file.h>
#include <furrow_kernel/no_throw.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <sstream>
#include <unordered_map>

#ifndef FURROW_VERSION_STRING
#define FURROW_VERSION_STRING "0.1.0"
#endif

namespace furrow {
namespace {

// The binary chunk as a list of parts, one per buffer view with the zero padding before it. The parts go to
// the file as they are (kernel::ByteSpan): one vector grown by doubling held up to 1.5x the chunk at its
// peak, and the GLB was then assembled in a second copy, so a writing command peaked near 3x its output.
// Each part is the writer's own array, adopted rather than copied (a copy held every attribute twice until the
// file was written), or bytes of the Scene being saved, which outlives the writer.
struct BinParts {
    std::vector<kernel::ByteSpan> parts;             // in file order, padding included
    std::vector<std::shared_ptr<const void>> owners; // keep the adopted parts' bytes alive
    size_t size = 0;

    // Zero bytes up to the next multiple of 4 (glTF aligns every view, and the GLB's chunks, to 4 bytes).
    void pad_to_4() {
        static const unsigned char zeros[4] = {};
        const size_t pad = (4 - size % 4) % 4;
        if (pad) parts.push_back({zeros, pad});
        size += pad;
    }
    // Appends `bytes` at `data` after padding to 4, keeping `owner` with them (null: the bytes are the Scene's);
    // returns their offset.
    size_t append(const void* data, size_t bytes, std::shared_ptr<const void> owner) {
        pad_to_4();
        const size_t offset = size;
        if (bytes) parts.push_back({data, bytes});
        if (owner) owners.push_back(std::move(owner));
        size += bytes;
        return offset;
    }
    template <class T>
    size_t adopt(const std::shared_ptr<const std::vector<T>>& v) {
        return append(v->data(), v->size() * sizeof(T), v);
    }
    // One contiguous copy, for the meshopt encoder (its output is a fraction of this).
    std::vector<uint8_t> flatten() const {
        std::vector<uint8_t> out;
        out.reserve(size);
        for (const kernel::ByteSpan& p : parts)
            out.insert(out.end(), static_cast<const uint8_t*>(p.data), static_cast<const uint8_t*>(p.data) + p.size);
        return out;
    }
};

// An array the writer made, shared with the binary chunk that writes it.
template <class T>
using Shared = std::shared_ptr<const std::vector<T>>;
template <class T>
Shared<T> share(std::vector<T>&& v) {
    return std::make_shared<const std::vector<T>>(std::move(v));
}

// Appends typed, 4-byte aligned data to the single output buffer.
class BinWriter {
public:
    tinygltf::Model& m;
    BinParts bin;
    explicit BinWriter(tinygltf::Model& model) : m(model) {}

    // A view of the Scene's own bytes (owner null) or of an adopted array.
    int add_view(const void* data, size_t bytes, int target, size_t stride = 0, std::shared_ptr<const void> owner = nullptr) {
        tinygltf::BufferView bv;
        bv.buffer = 0;
        bv.byteOffset = bin.append(data, bytes, std::move(owner));
        bv.byteLength = bytes;
        bv.byteStride = stride;
        bv.target = target;
        m.bufferViews.push_back(std::move(bv));
        return int(m.bufferViews.size() - 1);
    }

    // Accessor `a` (all but its view) of `bytes` bytes at `data` in a view of `target` and `stride`. An accessor
    // with the same description over the same bytes is written once and shared, as glTF lets any number of
    // primitives read one accessor: the viewer layout's fur shells repeat their base's triangles and texture
    // coordinates once per shell. Candidates are found by a fingerprint (the description and a sample of the
    // bytes) and compared whole.
    int add_accessor(tinygltf::Accessor a, const void* data, size_t bytes, int target, size_t stride, std::shared_ptr<const void> owner) {
        const uint64_t key = fingerprint(a, data, bytes, target, stride);
        const auto [first, last] = written_.equal_range(key);
        for (auto it = first; it != last; ++it) {
            const Written& w = it->second;
            const tinygltf::Accessor& b = m.accessors[size_t(w.accessor)];
            if (w.bytes == bytes && w.target == target && w.stride == stride && b.componentType == a.componentType &&
                b.normalized == a.normalized && b.count == a.count && b.type == a.type && b.minValues == a.minValues &&
                b.maxValues == a.maxValues && (bytes == 0 || std::memcmp(w.data, data, bytes) == 0)) // (no null to memcmp)
                return w.accessor;
        }
        a.bufferView = add_view(data, bytes, target, stride, std::move(owner));
        m.accessors.push_back(std::move(a));
        const int index = int(m.accessors.size() - 1);
        written_.emplace(key, Written{index, data, bytes, target, stride});
        return index;
    }

    // Float accessor of `components` (1,2,3,4,16) per element. min/max when asked (POSITION, animation input).
    int add_floats(const Shared<float>& shared, int components, bool min_max, int target = TINYGLTF_TARGET_ARRAY_BUFFER) {
        const std::vector<float>& v = *shared;
        tinygltf::Accessor a;
        a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
        a.count = v.size() / size_t(components);
        a.type = components == 1 ? TINYGLTF_TYPE_SCALAR
                 : components == 2 ? TINYGLTF_TYPE_VEC2
                 : components == 3 ? TINYGLTF_TYPE_VEC3
                 : components == 4 ? TINYGLTF_TYPE_VEC4
                                   : TINYGLTF_TYPE_MAT4;
        if (min_max) {
            a.minValues.assign(size_t(components), INFINITY);
            a.maxValues.assign(size_t(components), -INFINITY);
            for (size_t i = 0; i < v.size(); ++i) {
                size_t c = i % size_t(components);
                a.minValues[c] = std::min(a.minValues[c], double(v[i]));
                a.maxValues[c] = std::max(a.maxValues[c], double(v[i]));
            }
        }
        return add_accessor(std::move(a), v.data(), v.size() * sizeof(float), target, 0, shared);
    }

    int add_floats(std::vector<float>&& v, int components, bool min_max, int target = TINYGLTF_TARGET_ARRAY_BUFFER) {
        return add_floats(share(std::move(v)), components, min_max, target);
    }

    // An integer vertex attribute (KHR_mesh_quantization) of `components` values in elements of `stride`
    // bytes (4-byte aligned: a VEC3 of uint16 is stored in 8 bytes). min/max when asked (POSITION).
    template <class T>
    int add_integers(std::vector<T>&& values, int component_type, int components, size_t stride, bool normalized,
                     bool min_max) {
        const Shared<T> shared = share(std::move(values));
        const std::vector<T>& v = *shared;
        tinygltf::Accessor a;
        const size_t per = stride / sizeof(T);
        a.componentType = component_type;
        a.normalized = normalized;
        a.count = v.size() / per;
        a.type = components == 2 ? TINYGLTF_TYPE_VEC2 : components == 3 ? TINYGLTF_TYPE_VEC3 : TINYGLTF_TYPE_VEC4;
        if (min_max) {
            a.minValues.assign(size_t(components), INFINITY);
            a.maxValues.assign(size_t(components), -INFINITY);
            for (size_t i = 0; i < a.count; ++i)
                for (size_t c = 0; c < size_t(components); ++c) {
                    a.minValues[c] = std::min(a.minValues[c], double(v[i * per + c]));
                    a.maxValues[c] = std::max(a.maxValues[c], double(v[i * per + c]));
                }
        }
        return add_accessor(std::move(a), v.data(), v.size() * sizeof(T), TINYGLTF_TARGET_ARRAY_BUFFER,
                            per == size_t(components) ? 0 : stride, shared);
    }

    int add_joints(std::vector<uint16_t>&& joints) {
        const Shared<uint16_t> j = share(std::move(joints));
        tinygltf::Accessor a;
        a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
        a.count = j->size() / 4;
        a.type = TINYGLTF_TYPE_VEC4;
        return add_accessor(std::move(a), j->data(), j->size() * sizeof(uint16_t), TINYGLTF_TARGET_ARRAY_BUFFER, 0, j);
    }

    // uint16 when every index fits below the primitive-restart value 65535, else uint32.
    int add_indices(std::vector<uint32_t>&& idx, size_t vertex_count) {
        tinygltf::Accessor a;
        a.count = idx.size();
        a.type = TINYGLTF_TYPE_SCALAR;
        if (vertex_count <= 65535) {
            const Shared<uint16_t> s = share(std::vector<uint16_t>(idx.begin(), idx.end()));
            a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
            return add_accessor(std::move(a), s->data(), s->size() * 2, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER, 0, s);
        }
        const Shared<uint32_t> s = share(std::move(idx));
        a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
        return add_accessor(std::move(a), s->data(), s->size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER, 0, s);
    }

private:
    struct Written {
        int accessor;
        const void* data; // alive until the file is written: adopted by `bin`, or the Scene's own
        size_t bytes;
        int target;
        size_t stride;
    };
    std::unordered_multimap<uint64_t, Written> written_; // by fingerprint

    // The description, the length and up to 64 words spread over the bytes, mixed (splitmix64's finaliser).
    static uint64_t fingerprint(const tinygltf::Accessor& a, const void* data, size_t bytes, int target, size_t stride) {
        uint64_t h = 0;
        auto mix = [&h](uint64_t x) {
            h ^= x + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
            h ^= h >> 30, h *= 0xbf58476d1ce4e5b9ull, h ^= h >> 27, h *= 0x94d049bb133111ebull, h ^= h >> 31;
        };
        mix(bytes), mix(uint64_t(a.count)), mix(uint64_t(a.componentType)), mix(uint64_t(a.type)), mix(uint64_t(target)), mix(stride);
        const auto* p = static_cast<const unsigned char*>(data);
        const size_t words = bytes / 8, step = std::max<size_t>(1, words / 64);
        for (size_t i = 0; i < words; i += step) {
            uint64_t x;
            std::memcpy(&x, p + 8 * i, 8);
            mix(x);
        }
        for (size_t i = 8 * words; i < bytes; ++i) mix(p[i]);
        return h;
    }
};

// Whether a vector of v (xyz each) is too short or not finite to normalise: unit_vectors' test.
bool any_degenerate(const std::vector<float>& v) {
    for (size_t i = 0; i + 2 < v.size(); i += 3) {
        const double l = std::sqrt(double(v[i]) * v[i] + double(v[i + 1]) * v[i + 1] + double(v[i + 2]) * v[i + 2]);
        if (!(l > 1e-20) || !std::isfinite(l)) return true;
    }
    return false;
}

// glTF requires unit normals and tangents (validator: ACCESSOR_VECTOR3_NON_UNIT). A zero or non-finite
// vector takes the fallback (the welded angle-weighted normal), else +Y.
std::vector<float> unit_vectors(std::vector<float> out, size_t stride, const std::vector<float>& fallback) {
    for (size_t i = 0; i * stride < out.size(); ++i) {
        float* p = &out[i * stride];
        double l = std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]);
        if (!(l > 1e-20) || !std::isfinite(l)) {
            const float* f = fallback.size() >= (i + 1) * 3 ? &fallback[i * 3] : nullptr;
            double fl = f ? std::sqrt(double(f[0]) * f[0] + double(f[1]) * f[1] + double(f[2]) * f[2]) : 0;
            if (f && fl > 1e-20 && std::isfinite(fl)) {
                p[0] = float(f[0] / fl), p[1] = float(f[1] / fl), p[2] = float(f[2] / fl);
            } else {
                p[0] = 0, p[1] = 1, p[2] = 0;
            }
        } else if (std::abs(l - 1.0) > 1e-6) { // leave unit vectors bit-exact, so re-saving changes nothing
            p[0] = float(p[0] / l), p[1] = float(p[1] / l), p[2] = float(p[2] / l);
        }
        if (stride == 4) p[3] = p[3] < 0 ? -1.0f : 1.0f;
    }
    return out;
}

// WEIGHTS_0 must sum to 1 (validator: ACCESSOR_WEIGHTS_NON_NORMALIZED); renormalise in double.
std::vector<float> normalized_weights(const std::vector<float>& w) {
    std::vector<float> out(w.size());
    for (size_t i = 0; i + 3 < w.size(); i += 4) {
        double s = 0;
        for (int k = 0; k < 4; ++k) s += std::max(0.0f, std::isfinite(w[i + size_t(k)]) ? w[i + size_t(k)] : 0.0f);
        for (int k = 0; k < 4; ++k) {
            float x = std::isfinite(w[i + size_t(k)]) ? std::max(0.0f, w[i + size_t(k)]) : 0.0f;
            out[i + size_t(k)] = s > 0 ? float(x / s) : (k == 0 ? 1.0f : 0.0f);
        }
    }
    return out;
}

std::vector<float> clamped01(const std::vector<float>& v) {
    std::vector<float> out(v.size());
    for (size_t i = 0; i < v.size(); ++i) out[i] = std::isfinite(v[i]) ? std::min(1.0f, std::max(0.0f, v[i])) : 0.0f;
    return out;
}

// Per-vertex tangents from UV derivatives (Lengyel 2001, "Computing Tangent Space Basis Vectors for an
// Arbitrary Mesh"), Gram-Schmidt against the normal. Only used when a material has a normal texture and the
// primitive brings no TANGENT: the validator warns when a viewer would have to invent the tangent space.
std::vector<float> generate_tangents(const std::vector<float>& pos, const std::vector<float>& nrm,
                                     const std::vector<float>& uv, const std::vector<uint32_t>& tris) {
    const size_t n = pos.size() / 3;
    std::vector<double> t(n * 3, 0.0), b(n * 3, 0.0);
    for (size_t f = 0; f + 2 < tris.size(); f += 3) {
        uint32_t i0 = tris[f], i1 = tris[f + 1], i2 = tris[f + 2];
        double e1[3], e2[3];
        for (int k = 0; k < 3; ++k) {
            e1[k] = double(pos[i1 * 3 + size_t(k)]) - pos[i0 * 3 + size_t(k)];
            e2[k] = double(pos[i2 * 3 + size_t(k)]) - pos[i0 * 3 + size_t(k)];
        }
        double du1 = double(uv[i1 * 2]) - uv[i0 * 2], dv1 = double(uv[i1 * 2 + 1]) - uv[i0 * 2 + 1];
        double du2 = double(uv[i2 * 2]) - uv[i0 * 2], dv2 = double(uv[i2 * 2 + 1]) - uv[i0 * 2 + 1];
        double det = du1 * dv2 - du2 * dv1;
        if (std::abs(det) < 1e-20) continue;
        double r = 1.0 / det;
        for (uint32_t v : {i0, i1, i2})
            for (int k = 0; k < 3; ++k) {
                t[v * 3 + size_t(k)] += (e1[k] * dv2 - e2[k] * dv1) * r;
                b[v * 3 + size_t(k)] += (e2[k] * du1 - e1[k] * du2) * r;
            }
    }
    std::vector<float> out(n * 4);
    for (size_t v = 0; v < n; ++v) {
        double N[3] = {nrm[v * 3], nrm[v * 3 + 1], nrm[v * 3 + 2]};
        double T[3] = {t[v * 3], t[v * 3 + 1], t[v * 3 + 2]};
        double d = N[0] * T[0] + N[1] * T[1] + N[2] * T[2];
        for (int k = 0; k < 3; ++k) T[k] -= N[k] * d;
        double l = std::sqrt(T[0] * T[0] + T[1] * T[1] + T[2] * T[2]);
        if (!(l > 1e-20)) { // any direction perpendicular to N
            double a[3] = {std::abs(N[0]) < 0.9 ? 1.0 : 0.0, std::abs(N[0]) < 0.9 ? 0.0 : 1.0, 0.0};
            T[0] = a[1] * N[2] - a[2] * N[1];
            T[1] = a[2] * N[0] - a[0] * N[2];
            T[2] = a[0] * N[1] - a[1] * N[0];
            l = std::sqrt(T[0] * T[0] + T[1] * T[1] + T[2] * T[2]);
            if (!(l > 1e-20)) T[0] = 1, T[1] = T[2] = 0, l = 1;
        }
        double C[3] = {N[1] * T[2] - N[2] * T[1], N[2] * T[0] - N[0] * T[2], N[0] * T[1] - N[1] * T[0]};
        double w = C[0] * b[v * 3] + C[1] * b[v * 3 + 1] + C[2] * b[v * 3 + 2] < 0 ? -1.0 : 1.0;
        out[v * 4 + 0] = float(T[0] / l);
        out[v * 4 + 1] = float(T[1] / l);
        out[v * 4 + 2] = float(T[2] / l);
        out[v * 4 + 3] = float(w);
    }
    return out;
}

// The three attribute kinds that KHR_mesh_quantization shrinks (mesh_quantize.cpp); float otherwise.
int add_position(BinWriter& w, const Shared<float>& positions, const mesh_detail::PositionGrid& grid) {
    if (!grid.quantized) return w.add_floats(positions, 3, true);
    return w.add_integers(mesh_detail::quantize_positions(*positions, grid), TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, 3,
                          8, false, true);
}

int add_unit_vectors(BinWriter& w, const Shared<float>& v, int components, bool quantize, bool octahedral) {
    if (!quantize) return w.add_floats(v, components, false);
    return w.add_integers(mesh_detail::quantize_unit_vectors(*v, size_t(components), octahedral), TINYGLTF_COMPONENT_TYPE_BYTE,
                          components, 4, true, false);
}

// grid: the material's grid for this texture-coordinate set (texture_transform.cpp), for values outside [0, 1].
int add_unorm(BinWriter& w, const Shared<float>& v, int components, bool quantize, const mesh_detail::UvGrid& grid = {}) {
    std::vector<uint16_t> q;
    if (quantize && grid.used) q = mesh_detail::quantize_uv(*v, grid);
    else if (!quantize || !mesh_detail::quantize_unorm16(q, *v)) return w.add_floats(v, components, false);
    return w.add_integers(std::move(q), TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, components, size_t(components) * 2, true, false);
}

int add_colors(BinWriter& w, std::vector<float>&& rgba, bool quantize) {
    std::vector<uint8_t> q;
    if (!quantize || !mesh_detail::quantize_unorm8(q, rgba)) return w.add_floats(std::move(rgba), 4, false);
    return w.add_integers(std::move(q), TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, 4, 4, true, false);
}

// The written topology of a primitive: n-gons fanned for glTF (the caller's primitive is left as it is) and,
// with SaveOptions::optimize, meshoptimizer's vertex order (vertex_order.cpp) as a remap of the vertices.
struct VertexOrder {
    PrimitiveMode mode = PrimitiveMode::triangles;
    std::vector<uint32_t> indices;
    std::vector<uint32_t> remap; // old → new vertex; empty = the source order

    template <class T>
    std::vector<T> apply(const std::vector<T>& v, size_t per_vertex) const {
        return mesh_detail::remapped(v, remap, per_vertex);
    }
};

// The last primitive's topology as written, for the next one: fur shells (one primitive per shell, the same
// triangles over a new copy of the vertices) and LOD or variant copies repeat a primitive's index list. A
// primitive whose mode, vertex count and indices equal the last one's (triangles, lines or points; not
// polygons, whose fans depend on their positions) takes its order instead of running meshoptimizer again
// (whose steps depend on nothing else, vertex_order.cpp); its indices are then the same bytes, which
// BinWriter writes once. The Stanford bunny's 32 shells (`furrow -j 1 shells stanford-bunny.obj --layers 32
// --length 0.003`, four interleaved runs): 0.94-1.40 -> 0.35-0.45 s; saving that output again (`furrow -j 1
// bench io --quick --repeat 5 x.glb`, two interleaved runs) 563-665 -> 111-137 ms, 77-88x -> 13-18x the memcpy
// of its bytes. Only the last primitive is kept: a run of shells is consecutive, and the memo then holds one
// index list, not one per distinct primitive.
struct TopologyMemo {
    const Primitive* src = nullptr; // the last primitive written (the Scene outlives the writer)
    VertexOrder order;              // its order, indices included

    bool repeats(const Primitive& p) const {
        // Polygons are fanned by their positions (triangulate_polygons), not by their indices alone.
        return src && p.face_sizes.empty() && src->face_sizes.empty() && p.mode == src->mode &&
               p.vertex_count() == src->vertex_count() && p.indices == src->indices;
    }
};

VertexOrder vertex_order(const Primitive& src, const SaveOptions& options) {
    VertexOrder o;
    o.mode = src.mode;
    const bool optimize = options.optimize && o.mode == PrimitiveMode::triangles;
    const bool strip = options.encoding == Encoding::compress; // meshopt_optimizeVertexCacheStrip, as gltfpack -cc
    if (!src.face_sizes.empty() && src.mode == PrimitiveMode::triangles) {
        triangulate_polygons(o.indices, src.indices.data(), src.indices.size(), src.face_sizes.data(), src.face_sizes.size(),
                             src.positions.data(), src.vertex_count());
        if (optimize) o.remap = mesh_detail::optimized_vertex_remap(o.indices, src.vertex_count(), strip);
        return o;
    }
    // Read from the source's indices, not from a copy of them (a third index list at the writer's peak).
    if (optimize)
        o.remap = mesh_detail::optimized_vertex_remap(o.indices, src.indices.data(), src.indices.size(), src.vertex_count(), strip);
    if (o.remap.empty()) o.indices = src.indices; // not optimised, or not eligible (the writer reports a bad index)
    return o;
}

// keep_uv: the texture-coordinate sets written (SaveOptions::drop_unused_uvs leaves the others out).
Status write_primitive(tinygltf::Primitive& out, const Primitive& src, bool needs_tangents, BinWriter& w,
                       const std::string& where, const SaveOptions& options, const mesh_detail::PositionGrid& grid,
                       const std::array<mesh_detail::UvGrid, 2>& uv_grids, std::array<bool, 2> keep_uv, TopologyMemo& memo) {
    const bool quantize = options.encoding != Encoding::plain;
    const size_t n = src.vertex_count();
    if (n == 0 || src.positions.size() != n * 3)
        return Status::error(StatusCode::invalid_argument, where + ": has no vertices");
    auto check_size = [&](const std::vector<float>& v, size_t per, const char* name) -> Status {
        if (!v.empty() && v.size() != n * per)
            return Status::error(StatusCode::invalid_argument, where + ": " + name + " has " + std::to_string(v.size()) +
                                                                   " values, expected " + std::to_string(n * per));
        return Status::success();
    };
    Status s;
    if (!(s = check_size(src.normals, 3, "normals")).ok() || !(s = check_size(src.tangents, 4, "tangents")).ok() ||
        !(s = check_size(src.uv0, 2, "uv0")).ok() || !(s = check_size(src.uv1, 2, "uv1")).ok() ||
        !(s = check_size(src.colors, 4, "colors")).ok() || !(s = check_size(src.weights, 4, "weights")).ok())
        return s;
    if (!src.joints.empty() && src.joints.size() != n * 4)
        return Status::error(StatusCode::invalid_argument, where + ": joints must have 4 per vertex");
    if (src.joints.empty() != src.weights.empty())
        return Status::error(StatusCode::invalid_argument, where + ": joints and weights must come together");
    for (float x : src.positions)
        if (!std::isfinite(x)) return Status::error(StatusCode::invalid_argument, where + ": positions contain NaN or Inf");

    const bool repeated = memo.repeats(src);
    VertexOrder order = repeated ? memo.order : vertex_order(src, options);
    for (uint32_t i : order.indices)
        if (i >= n) return Status::error(StatusCode::invalid_argument, where + ": index " + std::to_string(i) + " out of range");
    if (order.mode == PrimitiveMode::triangles && order.indices.empty())
        return Status::error(StatusCode::invalid_argument, where + ": has no faces");
    // Each per-vertex array is put in the written order as it is written, one at a time: the writer never holds
    // a second copy of the whole primitive (that copy was a whole output's bytes at the peak of every command).
    const Shared<float> positions = share(order.apply(src.positions, 3));

    // Fallback for zero-length normals, and the source when NORMAL is missing: computed only when needed (on a
    // 3 MB OBJ with normals, welding and computing them was a tenth of `convert`).
    std::vector<float> welded_normals;
    if (order.mode == PrimitiveMode::triangles &&
        ((needs_tangents && src.normals.empty()) || any_degenerate(src.normals))) {
        welded_normals.resize(n * 3);
        compute_vertex_normals(welded_normals.data(), positions->data(), n, order.indices.data(), order.indices.size());
    }
    out.attributes["POSITION"] = add_position(w, positions, grid);
    const Shared<float> uv0 = share(order.apply(src.uv0, 2));
    Shared<float> normals = share(std::vector<float>{});
    if (!src.normals.empty()) normals = share(unit_vectors(order.apply(src.normals, 3), 3, welded_normals));
    else if (needs_tangents && !uv0->empty()) normals = share(unit_vectors(welded_normals, 3, {}));
    // Morph targets' normal and tangent deltas are float; their base vectors stay float with them.
    const bool quantize_vectors = quantize && src.targets.empty(), oct = options.encoding == Encoding::compress;
    if (!normals->empty()) out.attributes["NORMAL"] = add_unit_vectors(w, normals, 3, quantize_vectors, oct);
    if (!src.tangents.empty())
        out.attributes["TANGENT"] =
            add_unit_vectors(w, share(unit_vectors(order.apply(src.tangents, 4), 4, {})), 4, quantize_vectors, oct);
    else if (needs_tangents && !uv0->empty() && !normals->empty())
        out.attributes["TANGENT"] = add_unit_vectors(w, share(generate_tangents(*positions, *normals, *uv0, order.indices)),
                                                     4, quantize_vectors, oct);
    if (!uv0->empty() && keep_uv[0]) out.attributes["TEXCOORD_0"] = add_unorm(w, uv0, 2, quantize, uv_grids[0]);
    if (!src.uv1.empty() && keep_uv[1])
        out.attributes["TEXCOORD_1"] = add_unorm(w, share(order.apply(src.uv1, 2)), 2, quantize, uv_grids[1]);
    if (!src.colors.empty()) out.attributes["COLOR_0"] = add_colors(w, clamped01(order.apply(src.colors, 4)), quantize);
    if (!src.joints.empty()) {
        std::vector<float> weights = normalized_weights(order.apply(src.weights, 4));
        // A joint with zero weight has no effect; glTF wants it written as 0 (ACCESSOR_JOINTS_USED_ZERO_WEIGHT).
        std::vector<uint16_t> joints = order.apply(src.joints, 4);
        for (size_t i = 0; i < joints.size(); ++i)
            if (weights[i] == 0.0f) joints[i] = 0;
        out.attributes["JOINTS_0"] = w.add_joints(std::move(joints));
        out.attributes["WEIGHTS_0"] = w.add_floats(std::move(weights), 4, false);
    }
    for (const auto& c : src.custom) {
        if (c.name.empty() || c.name[0] != '_')
            return Status::error(StatusCode::invalid_argument, where + ": custom attribute '" + c.name + "' must start with '_'");
        if (c.components < 1 || c.components > 4 || c.values.size() != n * size_t(c.components))
            return Status::error(StatusCode::invalid_argument, where + ": custom attribute " + c.name + " has the wrong size");
        for (float x : c.values)
            if (!std::isfinite(x)) return Status::error(StatusCode::invalid_argument, where + ": " + c.name + " contains NaN or Inf");
        out.attributes[c.name] = w.add_floats(order.apply(c.values, size_t(c.components)), c.components, false);
    }
    for (const auto& t : src.targets) {
        std::map<std::string, int> target;
        if (!t.position_deltas.empty()) {
            if (!(s = check_size(t.position_deltas, 3, "morph position deltas")).ok()) return s;
            target["POSITION"] = w.add_floats(order.apply(t.position_deltas, 3), 3, true); // min/max required on morph POSITION
        }
        if (!t.normal_deltas.empty() && !normals->empty()) {
            if (!(s = check_size(t.normal_deltas, 3, "morph normal deltas")).ok()) return s;
            target["NORMAL"] = w.add_floats(order.apply(t.normal_deltas, 3), 3, false);
        }
        if (!t.tangent_deltas.empty() && out.attributes.count("TANGENT")) {
            if (!(s = check_size(t.tangent_deltas, 3, "morph tangent deltas")).ok()) return s;
            target["TANGENT"] = w.add_floats(order.apply(t.tangent_deltas, 3), 3, false);
        }
        out.targets.push_back(std::move(target));
    }
    if (!repeated) memo.src = &src, memo.order = order;
    out.indices = w.add_indices(std::move(order.indices), n);
    out.mode = order.mode == PrimitiveMode::points ? TINYGLTF_MODE_POINTS
               : order.mode == PrimitiveMode::lines ? TINYGLTF_MODE_LINE
                                                    : TINYGLTF_MODE_TRIANGLES;
    out.material = src.material;
    return Status::success();
}

std::vector<double> vec(const double* p, size_t n) { return std::vector<double>(p, p + n); }

using mesh_detail::decimal;
std::vector<double> decimals(const float* p, size_t n) {
    std::vector<double> out(n);
    for (size_t i = 0; i < n; ++i) out[i] = decimal(p[i]);
    return out;
}

// Reference checks: never write a dangling index.
Status check_references(const Scene& scene, const tinygltf::Model& src) {
    auto bad = [](const std::string& what) { return Status::error(StatusCode::invalid_argument, what); };
    for (size_t i = 0; i < scene.nodes.size(); ++i) {
        const Node& n = scene.nodes[i];
        if (n.mesh >= int(scene.meshes.size())) return bad("node " + std::to_string(i) + ": mesh does not exist");
        if (n.skin >= int(scene.skins.size())) return bad("node " + std::to_string(i) + ": skin does not exist");
        if (n.camera >= int(src.cameras.size())) return bad("node " + std::to_string(i) + ": camera does not exist");
        for (int c : n.children)
            if (c < 0 || c >= int(scene.nodes.size())) return bad("node " + std::to_string(i) + ": child does not exist");
    }
    for (int r : scene.roots)
        if (r < 0 || r >= int(scene.nodes.size())) return bad("scene root " + std::to_string(r) + " does not exist");
    for (size_t i = 0; i < scene.textures.size(); ++i)
        if (scene.textures[i].image >= int(scene.images.size()) || scene.textures[i].sampler >= int(scene.samplers.size()))
            return bad("texture " + std::to_string(i) + ": image or sampler does not exist");
    for (size_t i = 0; i < scene.materials.size(); ++i)
        if (scene.materials[i].base_color_texture.texture >= int(scene.textures.size()))
            return bad("material " + std::to_string(i) + ": texture does not exist");

    return Status::success();
}

// Materials: properties furrow does not model are kept from the source material. Notes which materials have
// a normal texture (their primitives need tangents).
Status write_materials(tinygltf::Model& m, const Scene& scene, std::vector<bool>& material_needs_tangents) {
    auto bad = [](const std::string& what) { return Status::error(StatusCode::invalid_argument, what); };
    m.materials.resize(scene.materials.size());
    material_needs_tangents.assign(scene.materials.size(), false);
    for (size_t i = 0; i < scene.materials.size(); ++i) {
        const Material& a = scene.materials[i];
        tinygltf::Material& o = m.materials[i];
        o.name = a.name;
        o.pbrMetallicRoughness.baseColorFactor = decimals(a.base_color.data(), a.base_color.size());
        o.pbrMetallicRoughness.baseColorTexture.index = a.base_color_texture.texture;
        o.pbrMetallicRoughness.baseColorTexture.texCoord = a.base_color_texture.texcoord;
        o.pbrMetallicRoughness.metallicFactor = decimal(a.metallic);
        o.pbrMetallicRoughness.roughnessFactor = decimal(a.roughness);
        o.emissiveFactor = decimals(a.emissive.data(), a.emissive.size());
        o.alphaMode = a.alpha_mode == AlphaMode::mask ? "MASK" : a.alpha_mode == AlphaMode::blend ? "BLEND" : "OPAQUE";
        o.alphaCutoff = decimal(a.alpha_cutoff);
        o.doubleSided = a.double_sided;
        material_needs_tangents[i] = o.normalTexture.index >= 0;
        for (int t : {o.normalTexture.index, o.occlusionTexture.index, o.emissiveTexture.index,
                      o.pbrMetallicRoughness.metallicRoughnessTexture.index})
            if (t >= int(scene.textures.size())) return bad("material " + std::to_string(i) + ": texture does not exist");
    }

    return Status::success();
}

// Meshes: every primitive's attributes into the binary chunk; extras and extensions kept from the source.
// The position grid of every mesh (mesh_quantize.cpp); none for plain output, and none for a mesh that a
// skinned node draws (its node transform is ignored, so it cannot carry the dequantization).
std::vector<mesh_detail::PositionGrid> position_grids(const Scene& scene, const SaveOptions& options) {
    std::vector<mesh_detail::PositionGrid> grids(scene.meshes.size());
    if (options.encoding == Encoding::plain) return grids;
    const int bits = options.position_bits == 0 ? default_position_bits : options.position_bits;
    std::vector<char> skinned(scene.meshes.size(), 0);
    for (const Node& n : scene.nodes)
        if (n.mesh >= 0 && size_t(n.mesh) < scene.meshes.size() && n.skin >= 0) skinned[size_t(n.mesh)] = 1;
    for (size_t i = 0; i < scene.meshes.size(); ++i)
        if (!skinned[i]) grids[i] = mesh_detail::position_grid(scene.meshes[i], bits);
    return grids;
}

Status write_meshes(tinygltf::Model& m, const Scene& scene, const tinygltf::Model& src, const std::vector<bool>& material_needs_tangents,
                    BinWriter& w, const SaveOptions& options, const std::vector<mesh_detail::PositionGrid>& grids,
                    const std::vector<std::array<mesh_detail::UvGrid, 2>>& uv_grids) {
    auto bad = [](const std::string& what) { return Status::error(StatusCode::invalid_argument, what); };
    std::vector<tinygltf::Mesh> meshes(scene.meshes.size());
    TopologyMemo memo;
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
        const Mesh& mesh = scene.meshes[mi];
        tinygltf::Mesh& o = meshes[mi];
        if (mi < src.meshes.size()) {
            o.extras = src.meshes[mi].extras;
            o.extensions = src.meshes[mi].extensions;
        }
        o.name = mesh.name;
        if (mesh.primitives.empty()) return bad("mesh " + std::to_string(mi) + " has no primitives");
        if (!mesh.extras_json.empty() && !nlohmann::json::parse(mesh.extras_json, nullptr, false).is_object())
            return bad("mesh " + std::to_string(mi) + ": extras_json is not a JSON object");
        const size_t targets = mesh.primitives[0].targets.size();
        for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
            const Primitive& p = mesh.primitives[pi];
            const std::string where = "mesh " + std::to_string(mi) + " primitive " + std::to_string(pi);
            if (p.material >= int(scene.materials.size())) return bad(where + ": material does not exist");
            if (p.targets.size() != targets) return bad(where + ": all primitives of a mesh need the same morph targets");
            tinygltf::Primitive op;
            if (mi < src.meshes.size() && pi < src.meshes[mi].primitives.size()) {
                op.extras = src.meshes[mi].primitives[pi].extras;
                op.extensions = src.meshes[mi].primitives[pi].extensions;
            }
            bool tangents = p.material >= 0 && material_needs_tangents[size_t(p.material)];
            const std::array<mesh_detail::UvGrid, 2> floats{};
            std::array<bool, 2> keep_uv{true, true};
            const bool vendor_data = o.extras.Type() != tinygltf::NULL_TYPE || !o.extensions.empty() || !mesh.extras_json.empty() ||
                                     op.extras.Type() != tinygltf::NULL_TYPE || !op.extensions.empty();
            if (options.drop_unused_uvs && !vendor_data) {
                keep_uv = p.material >= 0 ? mesh_detail::sampled_uv_sets(m.materials[size_t(p.material)]) : std::array<bool, 2>{false, false};
                keep_uv[0] = keep_uv[0] || keep_uv[1]; // TEXCOORD_n must be numbered without gaps
            }
            Status s = write_primitive(op, p, tangents, w, where, options, grids[mi],
                                       p.material >= 0 && size_t(p.material) < uv_grids.size() ? uv_grids[size_t(p.material)] : floats,
                                       keep_uv, memo);
            if (!s.ok()) return s;
            o.primitives.push_back(std::move(op));
        }
        if (!mesh.weights.empty()) {
            if (mesh.weights.size() != targets) return bad("mesh " + std::to_string(mi) + ": weights do not match its morph targets");
            o.weights.assign(mesh.weights.begin(), mesh.weights.end());
        }
    }
    m.meshes = std::move(meshes);

    return Status::success();
}

// Whether node i's own transform is identity and nothing but its mesh reads it: no children, camera, node
// extension (a light), skin joint or animation channel.
bool transform_reads_only_its_mesh(const tinygltf::Model& m, const Scene& scene, size_t i) {
    const tinygltf::Node& n = m.nodes[i];
    if (!n.matrix.empty() || !n.translation.empty() || !n.rotation.empty() || !n.scale.empty() || !n.children.empty() ||
        n.camera >= 0 || !n.extensions.empty())
        return false;
    for (const Skin& skin : scene.skins)
        if (std::find(skin.joints.begin(), skin.joints.end(), int(i)) != skin.joints.end()) return false;
    for (const tinygltf::Animation& a : m.animations)
        for (const tinygltf::AnimationChannel& c : a.channels)
            if (c.target_node == int(i)) return false;
    return true;
}

// KHR_mesh_quantization's dequantization is a node transform: the mesh's grid (translation and uniform
// scale). A node whose own transform only its mesh reads takes the grid itself, as gltfpack does; any other
// hands the mesh to a new child (appended after the scene's nodes, so every existing index stays valid)
// that takes it. The node's own transform, children, camera and animation channels are untouched, so the
// world positions are the grid's.
void add_dequantizing_nodes(tinygltf::Model& m, const Scene& scene, const std::vector<mesh_detail::PositionGrid>& grids) {
    for (size_t i = 0; i < scene.nodes.size(); ++i) {
        const int mesh = scene.nodes[i].mesh;
        if (mesh < 0 || size_t(mesh) >= grids.size() || !grids[size_t(mesh)].quantized) continue;
        const mesh_detail::PositionGrid& g = grids[size_t(mesh)];
        if (transform_reads_only_its_mesh(m, scene, i)) {
            m.nodes[i].translation = vec(g.offset.data(), 3);
            m.nodes[i].scale = {g.scale, g.scale, g.scale};
            continue;
        }
        tinygltf::Node child;
        child.mesh = mesh;
        child.translation = vec(g.offset.data(), 3);
        child.scale = {g.scale, g.scale, g.scale};
        m.nodes[i].mesh = -1;
        m.nodes[i].children.push_back(int(m.nodes.size()));
        m.nodes.push_back(std::move(child));
    }
}

// Nodes (identity transforms left out) and the default scene's roots.
void write_nodes(tinygltf::Model& m, const Scene& scene, const std::vector<mesh_detail::PositionGrid>& grids) {
    m.nodes.resize(scene.nodes.size());
    for (size_t i = 0; i < scene.nodes.size(); ++i) {
        const Node& n = scene.nodes[i];
        tinygltf::Node& o = m.nodes[i];
        o.name = n.name;
        o.mesh = n.mesh;
        o.skin = n.skin;
        o.camera = n.camera;
        o.children = n.children;
        o.matrix.clear();
        o.translation.clear();
        o.rotation.clear();
        o.scale.clear();
        if (n.has_matrix) {
            const std::array<double, 16> id{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
            if (n.matrix != id) o.matrix = vec(n.matrix.data(), 16);
        } else {
            if (n.translation != std::array<double, 3>{0, 0, 0}) o.translation = vec(n.translation.data(), 3);
            if (n.rotation != std::array<double, 4>{0, 0, 0, 1}) o.rotation = vec(n.rotation.data(), 4);
            if (n.scale != std::array<double, 3>{1, 1, 1}) o.scale = vec(n.scale.data(), 3);
        }
        o.weights = n.weights;
    }
    add_dequantizing_nodes(m, scene, grids);
    if (m.scenes.empty()) m.scenes.resize(1);
    int si = m.defaultScene >= 0 && size_t(m.defaultScene) < m.scenes.size() ? m.defaultScene : 0;
    m.scenes[size_t(si)].nodes = scene.roots;
    m.defaultScene = si;

}

// Textures, samplers, and images (embedded; a missing source file keeps its reference).
Status write_textures(tinygltf::Model& m, const Scene& scene, BinWriter& w) {
    auto bad = [](const std::string& what) { return Status::error(StatusCode::invalid_argument, what); };
    m.textures.resize(scene.textures.size());
    for (size_t i = 0; i < scene.textures.size(); ++i) {
        m.textures[i].source = scene.textures[i].image;
        m.textures[i].sampler = scene.textures[i].sampler;
    }
    m.samplers.resize(scene.samplers.size());
    for (size_t i = 0; i < scene.samplers.size(); ++i) {
        m.samplers[i].magFilter = scene.samplers[i].mag_filter;
        m.samplers[i].minFilter = scene.samplers[i].min_filter;
        m.samplers[i].wrapS = scene.samplers[i].wrap_s;
        m.samplers[i].wrapT = scene.samplers[i].wrap_t;
    }
    m.images.resize(scene.images.size());
    for (size_t i = 0; i < scene.images.size(); ++i) {
        const Image& a = scene.images[i];
        tinygltf::Image& o = m.images[i];
        o.name = a.name;
        o.image.clear();
        o.width = o.height = o.component = o.bits = o.pixel_type = -1;
        if (!a.encoded.empty()) {
            if (a.mime_type != "image/png" && a.mime_type != "image/jpeg")
                return bad("image " + std::to_string(i) + ": mime type '" + a.mime_type + "' is not image/png or image/jpeg");
            o.bufferView = w.add_view(a.encoded.data(), a.encoded.size(), 0);
            o.mimeType = a.mime_type;
            o.uri.clear();
        } else if (!a.source_uri.empty()) {
            o.bufferView = -1; // the source file was missing: keep the reference rather than invent pixels
            o.uri = a.source_uri;
            o.mimeType.clear();
        } else {
            return bad("image " + std::to_string(i) + " has no data");
        }
    }

    return Status::success();
}

// Skins with their inverse bind matrices.
Status write_skins(tinygltf::Model& m, const Scene& scene, BinWriter& w) {
    auto bad = [](const std::string& what) { return Status::error(StatusCode::invalid_argument, what); };
    m.skins.resize(scene.skins.size());
    for (size_t i = 0; i < scene.skins.size(); ++i) {
        const Skin& a = scene.skins[i];
        tinygltf::Skin& o = m.skins[i];
        o.name = a.name;
        o.joints = a.joints;
        o.skeleton = a.skeleton;
        for (int j : a.joints)
            if (j < 0 || j >= int(scene.nodes.size())) return bad("skin " + std::to_string(i) + ": joint does not exist");
        if (a.skeleton >= int(scene.nodes.size())) return bad("skin " + std::to_string(i) + ": skeleton does not exist");
        o.inverseBindMatrices = -1;
        if (!a.inverse_bind_matrices.empty()) {
            if (a.inverse_bind_matrices.size() != a.joints.size() * 16)
                return bad("skin " + std::to_string(i) + ": inverse bind matrices do not match its joints");
            o.inverseBindMatrices = w.add_floats(std::vector<float>(a.inverse_bind_matrices), 16, false, 0);
        }
    }

    return Status::success();
}

// Animations: samplers re-encoded from the source accessors (shared accessors stay shared).
Status write_animations(tinygltf::Model& m, const Scene& scene, const tinygltf::Model& src, BinWriter& w) {
    auto bad = [](const std::string& what) { return Status::error(StatusCode::invalid_argument, what); };
    std::map<int, int> remap;
    for (auto& anim : m.animations) {
        for (auto& smp : anim.samplers) {
            for (int* acc : {&smp.input, &smp.output}) {
                auto it = remap.find(*acc);
                if (it != remap.end()) {
                    *acc = it->second;
                    continue;
                }
                std::vector<float> v;
                int comps = 0;
                Status s = mesh_detail::read_accessor_floats(v, src, *acc, comps);
                if (!s.ok()) return s;
                int out = w.add_floats(std::move(v), comps, acc == &smp.input, 0);
                remap[*acc] = out;
                *acc = out;
            }
        }
        for (const auto& ch : anim.channels)
            if (ch.target_node >= int(scene.nodes.size())) return bad("animation channel targets a node that does not exist");
    }

    return Status::success();
}

// The source document without its buffers, accessors and views (rebuilt from the Scene): copying the whole
// model copied every buffer of the input, a whole input's bytes at the writer's peak.
void copy_document(tinygltf::Model& m, const tinygltf::Model& src) {
    m.animations = src.animations;
    m.materials = src.materials;
    m.meshes = src.meshes;
    m.nodes = src.nodes;
    m.textures = src.textures;
    m.images = src.images;
    m.skins = src.skins;
    m.samplers = src.samplers;
    m.cameras = src.cameras;
    m.scenes = src.scenes;
    m.lights = src.lights;
    m.defaultScene = src.defaultScene;
    m.extensionsUsed = src.extensionsUsed;
    m.extensionsRequired = src.extensionsRequired;
    m.asset = src.asset;
    m.extras = src.extras;
    m.extensions = src.extensions;
    m.extras_json_string = src.extras_json_string;
    m.extensions_json_string = src.extensions_json_string;
}

// The output document `m` and its binary chunk `bin`.
Status build_model(tinygltf::Model& m, BinParts& bin, const Scene& scene, const SaveOptions& options) {
    static const tinygltf::Model empty;
    const tinygltf::Model& src = scene.document ? scene.document->model : empty;
    copy_document(m, src);
    BinWriter w(m);
    if (Status s = check_references(scene, src); !s.ok()) return s;
    std::vector<bool> material_needs_tangents;
    if (Status s = write_materials(m, scene, material_needs_tangents); !s.ok()) return s;
    const std::vector<mesh_detail::PositionGrid> grids = position_grids(scene, options);
    std::vector<std::array<mesh_detail::UvGrid, 2>> uv_grids;
    if (options.encoding != Encoding::plain) uv_grids = mesh_detail::texture_uv_grids(m, scene);
    if (Status s = write_meshes(m, scene, src, material_needs_tangents, w, options, grids, uv_grids); !s.ok()) return s;
    write_nodes(m, scene, grids);
    if (Status s = write_textures(m, scene, w); !s.ok()) return s;
    if (Status s = write_skins(m, scene, w); !s.ok()) return s;
    if (Status s = write_animations(m, scene, src, w); !s.ok()) return s;

    // --- the document block
    auto drop = [](std::vector<std::string>& v, const std::string& e) { v.erase(std::remove(v.begin(), v.end(), e), v.end()); };
    drop(m.extensionsUsed, "KHR_mesh_quantization"); // a loaded file's are decoded; declared again if written
    drop(m.extensionsRequired, "KHR_mesh_quantization");
    drop(m.extensionsUsed, "EXT_meshopt_compression"); // the loader decodes it; save_scene adds it back
    drop(m.extensionsRequired, "EXT_meshopt_compression");
    const bool quantized = std::any_of(m.accessors.begin(), m.accessors.end(), [](const tinygltf::Accessor& a) {
        return a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT &&
               (a.normalized || a.type == TINYGLTF_TYPE_VEC3); // not indices or joints
    });
    if (quantized) {
        m.extensionsUsed.push_back("KHR_mesh_quantization");
        m.extensionsRequired.push_back("KHR_mesh_quantization");
    }
    m.asset.version = "2.0";
    m.asset.generator = "furrow " FURROW_VERSION_STRING;
    m.asset.minVersion.clear();
    w.bin.pad_to_4();
    bin = std::move(w.bin);
    return Status::success();
}

// The document as JSON, without the binary buffer (tinygltf would base64 it; save_scene adds the buffers).
Status serialise_document(nlohmann::json& j, tinygltf::Model& m) {
    tinygltf::TinyGLTF writer;
    writer.SetImageWriter(nullptr, nullptr); // images are embedded (or kept as references); never write files
    std::ostringstream out;
    if (!writer.WriteGltfSceneToStream(&m, out, false, false))
        return Status::error(StatusCode::io_error, "serialising the glTF failed");
    j = nlohmann::json::parse(out.str(), nullptr, false);
    if (j.is_discarded()) return Status::error(StatusCode::io_error, "internal: serialised glTF is not JSON");
    // tinygltf writes an object with no properties (a bare `{}` node, say) as null; glTF wants `{}`.
    for (auto& [key, value] : j.items())
        if (value.is_array())
            for (auto& e : value)
                if (e.is_null()) e = nlohmann::json::object();
    // It also writes every primitive's mode: TRIANGLES (4) is the default, left out (as gltfpack does).
    if (j.contains("meshes"))
        for (auto& mesh : j["meshes"])
            if (mesh.is_object() && mesh.contains("primitives"))
                for (auto& p : mesh["primitives"])
                    if (p.is_object() && p.contains("mode") && p["mode"] == 4) p.erase("mode");
    return Status::success();
}

// GLB container (glTF 2.0 §4.4): header, JSON chunk (padded with spaces), binary chunk (padded with zeros by
// BinParts), written from its parts without assembling the file in memory.
Status write_glb(const std::string& path, std::string text, const BinParts& bin) {
    while (text.size() % 4) text.push_back(' ');
    // The GLB header stores the file's length in 32 bits: a larger file cannot be written as GLB at all
    // (it used to be truncated silently into a corrupt file).
    const uint64_t size = 12 + 8 + uint64_t(text.size()) + (bin.size == 0 ? 0 : 8 + uint64_t(bin.size));
    if (size > UINT32_MAX)
        return Status::error(StatusCode::invalid_argument,
                             "the GLB would be " + std::to_string(size) + " bytes, over the format's limit of " +
                                 std::to_string(UINT32_MAX) + " (4 GiB); write .gltf with a .bin, or less geometry");
    std::vector<uint8_t> header, bin_header;
    auto u32 = [](std::vector<uint8_t>& out, uint32_t v) {
        for (int k = 0; k < 4; ++k) out.push_back(uint8_t(v >> (8 * k)));
    };
    header = {'g', 'l', 'T', 'F'};
    u32(header, 2);
    u32(header, uint32_t(size));
    u32(header, uint32_t(text.size()));
    u32(header, 0x4E4F534A); // JSON
    std::vector<kernel::ByteSpan> spans{{header.data(), header.size()}, {text.data(), text.size()}};
    if (bin.size > 0) {
        u32(bin_header, uint32_t(bin.size));
        u32(bin_header, 0x004E4942); // BIN
        spans.push_back({bin_header.data(), bin_header.size()});
        spans.insert(spans.end(), bin.parts.begin(), bin.parts.end());
    }
    return kernel::atomic_write(path, spans);
}

std::string lower_ext(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
    return e;
}

} // namespace

Status save_scene(const Scene& scene, const std::string& path, const SaveOptions& options) {
    return kernel::no_throw("writing the scene", [&]() -> Status {
        const std::string ext = lower_ext(path);
        if (ext != ".glb" && ext != ".gltf")
            return Status::error(StatusCode::unsupported, "cannot write '" + ext + "' (furrow writes .glb or .gltf)");
        if (options.position_bits < 0 || options.position_bits > 16)
            return Status::error(StatusCode::invalid_argument, "SaveOptions::position_bits " +
                                                                   std::to_string(options.position_bits) + " is not in 0..16");
        tinygltf::Model m;
        BinParts bin;
        if (Status s = build_model(m, bin, scene, options); !s.ok()) return s;
        nlohmann::json j;
        if (Status s = serialise_document(j, m); !s.ok()) return s;
        // Mesh::extras_json (checked to be an object by write_meshes) replaces the mesh's extras.
        for (size_t mi = 0; mi < scene.meshes.size(); ++mi)
            if (!scene.meshes[mi].extras_json.empty()) j["meshes"][mi]["extras"] = nlohmann::json::parse(scene.meshes[mi].extras_json);
        // EXT_meshopt_compression: buffer 0 gets the encoded views, buffer 1 is the data-less fallback.
        nlohmann::json fallback;
        if (options.encoding == Encoding::compress && bin.size > 0) {
            mesh_detail::CompressedBin compressed;
            mesh_detail::compress_buffer_views(compressed, j, bin.flatten());
            bin = BinParts{};
            bin.adopt(share(std::move(compressed.bin))); // padded to 4 by the encoder
            if (compressed.fallback_bytes > 0)
                fallback = {{"byteLength", compressed.fallback_bytes},
                            {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}};
        }
        auto buffers = [&](nlohmann::json first) {
            nlohmann::json list = nlohmann::json::array({std::move(first)});
            if (!fallback.is_null()) list.push_back(fallback);
            return list;
        };
        if (ext == ".glb") {
            if (bin.size > 0) j["buffers"] = buffers({{"byteLength", bin.size}});
            return write_glb(path, j.dump(), bin);
        }
        if (bin.size > 0) {
            const std::string bin_name = std::filesystem::path(path).stem().string() + ".bin";
            j["buffers"] = buffers({{"byteLength", bin.size}, {"uri", bin_name}});
            const std::string bin_path = (std::filesystem::path(path).parent_path() / bin_name).string();
            const std::string text = j.dump(options.pretty_json ? 2 : -1);
            // Both files or neither (the .bin used to be renamed into place before the .gltf was tried, so an
            // unwritable .gltf path left a stray .bin behind).
            return kernel::atomic_write_pair(bin_path, bin.parts, path, text.data(), text.size());
        }
        const std::string text = j.dump(options.pretty_json ? 2 : -1);
        return kernel::atomic_write(path, text.data(), text.size());
    });
}

} // namespace furrow

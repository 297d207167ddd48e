// Scene comparison for round-trip tests: geometry after triangulation, materials, nodes, skins, images.
#pragma once

#include <furrow/mesh.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace furrow {
// The former OFF and PLY reader (mesh/src/openmesh_load.cpp: a validation pass, then OpenMesh's reader;
// internal to furrow::mesh, reachable because the library is static), the oracle of the one-pass readers.
Status load_openmesh_bytes(Scene& out, const std::string& bytes, const std::string& ext, const LoadOptions& options);
} // namespace furrow

namespace furrow::test {

// A mesh file's text read by the one-pass reader of its extension (".off", ".ply", ...).
inline Status load_text(Scene& s, const std::string& text, const char* ext) {
    return load_scene_from_memory(s, reinterpret_cast<const uint8_t*>(text.data()), text.size(), ext);
}

// A float array's bit patterns (NaN compares equal to itself, -0 differs from 0).
inline std::vector<uint32_t> float_bits(const std::vector<float>& v) {
    std::vector<uint32_t> out(v.size());
    if (!v.empty()) std::memcpy(out.data(), v.data(), v.size() * sizeof(float));
    return out;
}

// Two readings of one mesh file (a one-pass reader against the former OpenMesh-based one): the same first
// primitive, bit for bit where the file's bytes may be garbage (normals, uvs), the same warnings and the same
// recentring. `shown` is the file as a failure message shows it.
inline void expect_same_reading(const Scene& now, const Scene& before, const std::string& shown) {
    ASSERT_EQ(now.meshes.size(), before.meshes.size());
    const Primitive& p = now.meshes[0].primitives.at(0);
    const Primitive& q = before.meshes[0].primitives.at(0);
    EXPECT_EQ(p.positions, q.positions) << shown;
    EXPECT_EQ(p.indices, q.indices) << shown;
    EXPECT_EQ(p.face_sizes, q.face_sizes) << shown;
    EXPECT_EQ(float_bits(p.normals), float_bits(q.normals)) << shown;
    EXPECT_EQ(p.colors, q.colors) << shown;
    EXPECT_EQ(float_bits(p.uv0), float_bits(q.uv0)) << shown;
    EXPECT_EQ(now.warnings, before.warnings) << shown;
    EXPECT_EQ(now.nodes[0].translation, before.nodes[0].translation) << shown;
}

inline void expect_same_floats(const std::vector<float>& a, const std::vector<float>& b, float tol, const std::string& what) {
    ASSERT_EQ(a.size(), b.size()) << what;
    size_t bad = 0;
    float worst = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        float d = std::abs(a[i] - b[i]);
        if (!(d <= tol)) ++bad, worst = std::max(worst, d);
    }
    EXPECT_EQ(bad, 0u) << what << ": " << bad << " values differ, worst by " << worst;
}

// `b` was written from `a` and read back: geometry must be identical (normals up to renormalisation).
// `optimized`: b was written with SaveOptions::optimize (the default), so a's triangles are compared in the
// order optimize_vertex_order gives them for `encoding` (tests/mesh/test_vertex_order.cpp checks that order on
// its own).
inline void expect_same_scene(const Scene& a, const Scene& b, bool optimized = true, Encoding encoding = Encoding::plain) {
    ASSERT_EQ(a.meshes.size(), b.meshes.size());
    for (size_t mi = 0; mi < a.meshes.size(); ++mi) {
        ASSERT_EQ(a.meshes[mi].primitives.size(), b.meshes[mi].primitives.size());
        EXPECT_EQ(a.meshes[mi].name, b.meshes[mi].name);
        for (size_t pi = 0; pi < a.meshes[mi].primitives.size(); ++pi) {
            Primitive pa = a.meshes[mi].primitives[pi], pb = b.meshes[mi].primitives[pi];
            triangulate(pa);
            triangulate(pb);
            if (optimized) optimize_vertex_order(pa, encoding);
            const std::string w = "mesh " + std::to_string(mi) + " prim " + std::to_string(pi);
            EXPECT_EQ(int(pa.mode), int(pb.mode)) << w;
            expect_same_floats(pa.positions, pb.positions, 0.0f, w + " positions");
            EXPECT_EQ(pa.indices, pb.indices) << w;
            if (!pa.normals.empty()) expect_same_floats(pa.normals, pb.normals, 2e-6f, w + " normals");
            expect_same_floats(pa.uv0, pb.uv0, 0.0f, w + " uv0");
            expect_same_floats(pa.uv1, pb.uv1, 0.0f, w + " uv1");
            expect_same_floats(pa.colors, pb.colors, 0.0f, w + " colors");
            ASSERT_EQ(pa.joints.size(), pb.joints.size()) << w;
            for (size_t i = 0; i < pa.joints.size(); ++i) // a joint with zero weight is written as 0
                if (pa.weights[i] > 0) {
                    ASSERT_EQ(pa.joints[i], pb.joints[i]) << w << " joint " << i;
                }
            expect_same_floats(pa.weights, pb.weights, 1e-6f, w + " weights");
            ASSERT_EQ(pa.targets.size(), pb.targets.size()) << w;
            for (size_t t = 0; t < pa.targets.size(); ++t)
                expect_same_floats(pa.targets[t].position_deltas, pb.targets[t].position_deltas, 0.0f, w + " morph");
            ASSERT_EQ(pa.custom.size(), pb.custom.size()) << w;
            for (const auto& ca : pa.custom) { // glTF attributes have no order: match by name
                auto it = std::find_if(pb.custom.begin(), pb.custom.end(), [&](const auto& cb) { return cb.name == ca.name; });
                ASSERT_NE(it, pb.custom.end()) << w << " lost " << ca.name;
                EXPECT_EQ(ca.components, it->components);
                expect_same_floats(ca.values, it->values, 0.0f, w + " " + ca.name);
            }
            EXPECT_EQ(pa.material, pb.material) << w;
        }
    }
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    auto wa = a.world_matrices(), wb = b.world_matrices();
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        EXPECT_EQ(a.nodes[i].name, b.nodes[i].name);
        EXPECT_EQ(a.nodes[i].mesh, b.nodes[i].mesh);
        EXPECT_EQ(a.nodes[i].skin, b.nodes[i].skin);
        EXPECT_EQ(a.nodes[i].children, b.nodes[i].children);
        for (int k = 0; k < 16; ++k) EXPECT_NEAR(wa[i][size_t(k)], wb[i][size_t(k)], 1e-12 * (1 + std::abs(wa[i][size_t(k)])));
    }
    EXPECT_EQ(a.roots, b.roots);
    ASSERT_EQ(a.materials.size(), b.materials.size());
    for (size_t i = 0; i < a.materials.size(); ++i) {
        const Material &x = a.materials[i], &y = b.materials[i];
        EXPECT_EQ(x.name, y.name);
        EXPECT_EQ(x.base_color, y.base_color);
        EXPECT_EQ(x.base_color_texture.texture, y.base_color_texture.texture);
        EXPECT_EQ(x.base_color_texture.texcoord, y.base_color_texture.texcoord);
        EXPECT_EQ(int(x.alpha_mode), int(y.alpha_mode));
        EXPECT_EQ(x.alpha_cutoff, y.alpha_cutoff);
        EXPECT_EQ(x.double_sided, y.double_sided);
        EXPECT_EQ(x.metallic, y.metallic);
        EXPECT_EQ(x.roughness, y.roughness);
    }
    ASSERT_EQ(a.textures.size(), b.textures.size());
    for (size_t i = 0; i < a.textures.size(); ++i) {
        EXPECT_EQ(a.textures[i].image, b.textures[i].image);
        EXPECT_EQ(a.textures[i].sampler, b.textures[i].sampler);
    }
    ASSERT_EQ(a.samplers.size(), b.samplers.size());
    ASSERT_EQ(a.images.size(), b.images.size());
    for (size_t i = 0; i < a.images.size(); ++i) {
        EXPECT_EQ(a.images[i].encoded, b.images[i].encoded) << "image " << i;
        EXPECT_EQ(a.images[i].mime_type, b.images[i].mime_type) << "image " << i;
    }
    ASSERT_EQ(a.skins.size(), b.skins.size());
    for (size_t i = 0; i < a.skins.size(); ++i) {
        EXPECT_EQ(a.skins[i].joints, b.skins[i].joints);
        EXPECT_EQ(a.skins[i].skeleton, b.skins[i].skeleton);
        expect_same_floats(a.skins[i].inverse_bind_matrices, b.skins[i].inverse_bind_matrices, 0.0f, "ibm");
    }
}

} // namespace furrow::test

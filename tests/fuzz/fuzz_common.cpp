#include "fuzz_common.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <deque>
#include <map>
#include <unistd.h>

// Every harness runs the library on one thread. libFuzzer keeps an input when it reaches new code; with TBB's
// scheduling in play, which code one input reached varied from run to run, and two seeded runs of one build
// drifted apart early. (They still differ a little: comparisons of pointer values change with address-space
// layout.) Output bytes do not depend on the thread count (tests/cli/test_determinism.cpp).
static const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);

namespace furrow::fuzz {

void rejected(const char* step, const Status& status) {
    static const bool verbose = std::getenv("FURROW_FUZZ_VERBOSE") != nullptr;
    static const bool expect_ok = std::getenv("FURROW_FUZZ_EXPECT_OK") != nullptr;
    if (verbose || expect_ok) std::fprintf(stderr, "  %s: code %d: %s\n", step, int(status.code), status.message.c_str());
    FUZZ_CHECK(!expect_ok, "FURROW_FUZZ_EXPECT_OK is set and %s refused the input", step);
    FUZZ_CHECK(!status.message.empty(), "%s gave an error without a message (code %d)", step, int(status.code));
}

// The sizes are read from the headers here, not with stbi_info: that would run stb_image's JPEG marker
// parsing before decode_image's own checks, which is exactly the code under test.
bool small_image(const uint8_t* p, size_t n, size_t max_pixels) {
    auto be16 = [&](size_t at) { return size_t(p[at]) << 8 | p[at + 1]; };
    auto be32 = [&](size_t at) { return be16(at) << 16 | be16(at + 2); };
    if (n >= 24 && p[0] == 0x89 && p[1] == 'P' && p[2] == 'N' && p[3] == 'G') // IHDR is the first chunk
        return be32(16) * be32(20) <= max_pixels;
    if (n >= 3 && p[0] == 0xFF && p[1] == 0xD8) { // every SOFn frame header (ITU-T T.81 B.2.2)
        for (size_t i = 2; i + 8 < n;) {
            if (p[i] != 0xFF || p[i + 1] == 0xFF || p[i + 1] == 0x00 || (p[i + 1] >= 0xD0 && p[i + 1] <= 0xD8)) {
                ++i;
                continue;
            }
            const uint8_t m = p[i + 1];
            if (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC && be16(i + 5) * be16(i + 7) > max_pixels)
                return false;
            i += 2 + be16(i + 2);
        }
    }
    return true;
}

std::string scratch_path(const std::string& name) {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir && *dir ? dir : "/tmp") + "/furrow-fuzz-" + std::to_string(getpid()) + "-" + name;
}

SmallMesh crop(const Primitive& p, size_t seed, size_t max_faces, bool polygons) {
    std::vector<size_t> start, size;
    if (p.face_sizes.empty()) {
        for (size_t f = 0; f * 3 < p.indices.size(); ++f) start.push_back(f * 3), size.push_back(3);
    } else {
        size_t at = 0;
        for (uint32_t s : p.face_sizes) start.push_back(at), size.push_back(s), at += s;
    }
    std::multimap<uint32_t, size_t> faces_of;
    for (size_t f = 0; f < start.size(); ++f)
        for (size_t c = 0; c < size[f]; ++c) faces_of.insert({p.indices[start[f] + c], f});
    SmallMesh m;
    std::map<uint32_t, uint32_t> renumber;
    std::vector<char> taken(start.size(), 0);
    std::deque<size_t> queue{seed % std::max<size_t>(start.size(), 1)};
    size_t faces = 0;
    while (!queue.empty() && faces < max_faces) {
        const size_t f = queue.front();
        queue.pop_front();
        if (taken[f]) continue;
        size_t fresh = 0;
        for (size_t c = 0; c < size[f]; ++c) fresh += renumber.count(p.indices[start[f] + c]) ? 0 : 1;
        if (renumber.size() + fresh > kMaxVertices) continue;
        if (!polygons && size[f] != 3) continue;
        taken[f] = 1;
        ++faces;
        for (size_t c = 0; c < size[f]; ++c) {
            const uint32_t v = p.indices[start[f] + c];
            auto [it, inserted] = renumber.insert({v, uint32_t(renumber.size())});
            if (inserted) {
                m.positions.insert(m.positions.end(), {p.positions[v * 3], p.positions[v * 3 + 1], p.positions[v * 3 + 2]});
                if (!p.uv0.empty()) m.uvs.insert(m.uvs.end(), {p.uv0[v * 2], p.uv0[v * 2 + 1]});
            }
            m.indices.push_back(it->second);
            auto [b, e] = faces_of.equal_range(v);
            for (auto k = b; k != e; ++k)
                if (!taken[k->second]) queue.push_back(k->second);
        }
        m.face_sizes.push_back(uint32_t(size[f]));
    }
    return m;
}

void check_scene(const Scene& scene, bool allow_non_finite) {
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi)
        for (size_t pi = 0; pi < scene.meshes[mi].primitives.size(); ++pi) {
            const Primitive& p = scene.meshes[mi].primitives[pi];
            FUZZ_CHECK(p.positions.size() % 3 == 0, "mesh %zu primitive %zu: positions %zu", mi, pi, p.positions.size());
            const size_t n = p.vertex_count();
            auto sized = [&](const std::vector<float>& v, size_t per, const char* what) {
                FUZZ_CHECK(v.empty() || v.size() == n * per, "mesh %zu primitive %zu: %s has %zu values for %zu vertices", mi,
                           pi, what, v.size(), n);
            };
            sized(p.normals, 3, "normals");
            sized(p.tangents, 4, "tangents");
            sized(p.uv0, 2, "uv0");
            sized(p.uv1, 2, "uv1");
            sized(p.colors, 4, "colors");
            sized(p.weights, 4, "weights");
            FUZZ_CHECK(p.joints.empty() || p.joints.size() == n * 4, "joints %zu for %zu vertices", p.joints.size(), n);
            for (const MorphTarget& t : p.targets) {
                sized(t.position_deltas, 3, "position deltas");
                sized(t.normal_deltas, 3, "normal deltas");
                sized(t.tangent_deltas, 3, "tangent deltas");
            }
            for (const CustomAttribute& c : p.custom) {
                FUZZ_CHECK(c.components >= 1 && c.components <= 4, "custom %s components %d", c.name.c_str(), c.components);
                sized(c.values, size_t(c.components), c.name.c_str());
            }
            if (!allow_non_finite) FUZZ_CHECK(finite(p.positions), "mesh %zu primitive %zu: non-finite position", mi, pi);
            for (size_t i = 0; i < p.indices.size(); ++i)
                FUZZ_CHECK(p.indices[i] < n, "mesh %zu primitive %zu: index %u at %zu >= %zu vertices", mi, pi, p.indices[i], i, n);
            if (p.mode == PrimitiveMode::triangles) {
                if (p.face_sizes.empty()) {
                    FUZZ_CHECK(p.indices.size() % 3 == 0, "%zu triangle indices", p.indices.size());
                } else {
                    size_t sum = 0;
                    for (uint32_t s : p.face_sizes) {
                        FUZZ_CHECK(s >= 3, "a face of %u corners", s);
                        sum += s;
                    }
                    FUZZ_CHECK(sum == p.indices.size(), "face sizes sum to %zu, %zu indices", sum, p.indices.size());
                }
            } else {
                FUZZ_CHECK(p.face_sizes.empty(), "face sizes on points/lines");
                if (p.mode == PrimitiveMode::lines) FUZZ_CHECK(p.indices.size() % 2 == 0, "odd line index count");
            }
            FUZZ_CHECK(p.material >= -1 && p.material < int(scene.materials.size()), "material %d of %zu", p.material,
                       scene.materials.size());
        }
    const int nodes = int(scene.nodes.size());
    for (const Node& n : scene.nodes) {
        FUZZ_CHECK(n.mesh >= -1 && n.mesh < int(scene.meshes.size()), "node mesh %d", n.mesh);
        FUZZ_CHECK(n.skin >= -1 && n.skin < int(scene.skins.size()), "node skin %d", n.skin);
        for (int c : n.children) FUZZ_CHECK(c >= 0 && c < nodes, "child %d of %d nodes", c, nodes);
    }
    for (int r : scene.roots) FUZZ_CHECK(r >= 0 && r < nodes, "root %d of %d nodes", r, nodes);
    for (const Texture& t : scene.textures) {
        FUZZ_CHECK(t.image >= -1 && t.image < int(scene.images.size()), "texture image %d", t.image);
        FUZZ_CHECK(t.sampler >= -1 && t.sampler < int(scene.samplers.size()), "texture sampler %d", t.sampler);
    }
    for (const Material& m : scene.materials)
        FUZZ_CHECK(m.base_color_texture.texture >= -1 && m.base_color_texture.texture < int(scene.textures.size()),
                   "material texture %d", m.base_color_texture.texture);
    for (const Skin& s : scene.skins) {
        for (int j : s.joints) FUZZ_CHECK(j >= 0 && j < nodes, "joint %d of %d nodes", j, nodes);
        FUZZ_CHECK(s.inverse_bind_matrices.empty() || s.inverse_bind_matrices.size() == s.joints.size() * 16,
                   "%zu inverse bind values for %zu joints", s.inverse_bind_matrices.size(), s.joints.size());
    }
    // Cycles were refused at load, so this terminates; every node gets a matrix.
    FUZZ_CHECK(scene.world_matrices().size() == scene.nodes.size(), "world matrices");
}

} // namespace furrow::fuzz

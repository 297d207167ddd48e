// The fuzz seed corpus, made from the project's own models/ (never from ../shared/corpus):
//
//   furrow_fuzz_make_seeds MODELS_DIR OUT_DIR     -> OUT_DIR/<target>/<seed>
//
// Seeds are small on purpose (a few KB): libFuzzer mutates faster and reaches the interesting code sooner
// from a 40-triangle piece of a model than from the whole model. Each harness's seeds are in its own input
// layout (fuzz_common.h for the small meshes). Deterministic: the same models give the same bytes.
#include "fuzz_common.h"

#include <furrow/deform.h>
#include <furrow/render.h>

#include <nlohmann/json.hpp>
#include <stb_image_write.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>

using namespace furrow;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

fs::path g_out;

void die(const std::string& what) {
    std::fprintf(stderr, "furrow_fuzz_make_seeds: %s\n", what.c_str());
    std::exit(1);
}

std::vector<uint8_t> read_file(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    if (!in) die("cannot read " + p.string());
    return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), {});
}

void seed(const std::string& target, const std::string& name, const std::vector<uint8_t>& bytes) {
    fs::create_directories(g_out / target);
    std::ofstream out(g_out / target / name, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!out) die("cannot write " + (g_out / target / name).string());
}

std::vector<uint8_t> prefixed(uint8_t first, const std::vector<uint8_t>& rest) {
    std::vector<uint8_t> b{first};
    b.insert(b.end(), rest.begin(), rest.end());
    return b;
}

std::vector<uint8_t> text_bytes(const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); }

Scene load(const fs::path& p) {
    Scene s;
    Status st = load_scene(s, p.string());
    if (!st.ok() || s.meshes.empty() || s.meshes[0].primitives.empty()) die(p.string() + ": " + st.message);
    return s;
}

// A crop as a Primitive with angle-weighted normals (what the models carry).
Primitive to_primitive(const fuzz::SmallMesh& m) {
    Primitive p;
    p.positions = m.positions;
    p.uv0 = m.uvs;
    p.indices = m.indices;
    bool tris = true;
    for (uint32_t s : m.face_sizes) tris &= s == 3;
    if (!tris) p.face_sizes = m.face_sizes;
    Primitive t = p;
    triangulate(t);
    p.normals.resize(p.positions.size());
    compute_vertex_normals(p.normals.data(), t.positions.data(), t.vertex_count(), t.indices.data(), t.indices.size());
    for (size_t v = 0; v < p.vertex_count(); ++v)
        if (p.normals[3 * v] == 0 && p.normals[3 * v + 1] == 0 && p.normals[3 * v + 2] == 0) p.normals[3 * v + 1] = 1;
    return p;
}

std::vector<uint8_t> glb_of(const Scene& scene, const SaveOptions& options = {}) {
    const std::string tmp = fuzz::scratch_path("seed.glb");
    Status s = save_scene(scene, tmp, options);
    if (!s.ok()) die("save_scene: " + s.message);
    std::vector<uint8_t> b = read_file(tmp);
    fs::remove(tmp);
    return b;
}

std::string base64(const uint8_t* p, size_t n) {
    static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < n; i += 3) {
        const uint32_t v = uint32_t(p[i]) << 16 | (i + 1 < n ? uint32_t(p[i + 1]) << 8 : 0) | (i + 2 < n ? p[i + 2] : 0);
        out += k[v >> 18 & 63];
        out += k[v >> 12 & 63];
        out += i + 1 < n ? k[v >> 6 & 63] : '=';
        out += i + 2 < n ? k[v & 63] : '=';
    }
    return out;
}

// A .gltf with its buffer in a data URI (what load_scene_from_memory can read), from a GLB.
std::vector<uint8_t> gltf_of_glb(const std::vector<uint8_t>& glb) {
    auto u32 = [&](size_t at) { return uint32_t(glb[at]) | uint32_t(glb[at + 1]) << 8 | uint32_t(glb[at + 2]) << 16 | uint32_t(glb[at + 3]) << 24; };
    const uint32_t json_len = u32(12);
    json j = json::parse(glb.begin() + 20, glb.begin() + 20 + json_len);
    const size_t bin_at = 20 + json_len;
    if (bin_at + 8 <= glb.size() && j.contains("buffers")) {
        const uint32_t bin_len = u32(bin_at);
        j["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(glb.data() + bin_at + 8, bin_len);
    }
    return text_bytes(j.dump());
}

// ---- text formats of a crop ------------------------------------------------------------------------------
template <class F>
void each_face(const fuzz::SmallMesh& m, F&& f) {
    size_t at = 0;
    for (uint32_t s : m.face_sizes) f(&m.indices[at], s), at += s;
}

std::string obj_of(const Primitive& p, const fuzz::SmallMesh& m) {
    std::ostringstream o;
    o.precision(9);
    o << "# furrow fuzz seed\n";
    for (size_t v = 0; v < p.vertex_count(); ++v) o << "v " << p.positions[3 * v] << ' ' << p.positions[3 * v + 1] << ' ' << p.positions[3 * v + 2] << '\n';
    for (size_t v = 0; v < p.uv0.size() / 2; ++v) o << "vt " << p.uv0[2 * v] << ' ' << 1 - p.uv0[2 * v + 1] << '\n';
    for (size_t v = 0; v < p.vertex_count(); ++v) o << "vn " << p.normals[3 * v] << ' ' << p.normals[3 * v + 1] << ' ' << p.normals[3 * v + 2] << '\n';
    each_face(m, [&](const uint32_t* c, uint32_t s) {
        o << 'f';
        for (uint32_t k = 0; k < s; ++k)
            o << ' ' << c[k] + 1 << '/' << (p.uv0.empty() ? std::string() : std::to_string(c[k] + 1)) << '/' << c[k] + 1;
        o << '\n';
    });
    return o.str();
}

std::string ply_ascii_of(const Primitive& p, const fuzz::SmallMesh& m) {
    std::ostringstream o;
    o.precision(9);
    o << "ply\nformat ascii 1.0\ncomment furrow fuzz seed\nelement vertex " << p.vertex_count()
      << "\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
         "property float u\nproperty float v\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
      << "element face " << m.face_sizes.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
    for (size_t v = 0; v < p.vertex_count(); ++v) {
        for (int k = 0; k < 3; ++k) o << p.positions[3 * v + k] << ' ';
        for (int k = 0; k < 3; ++k) o << p.normals[3 * v + k] << ' ';
        o << (p.uv0.empty() ? 0 : p.uv0[2 * v]) << ' ' << (p.uv0.empty() ? 0 : 1 - p.uv0[2 * v + 1]) << ' ';
        o << (v * 37) % 256 << ' ' << (v * 91) % 256 << ' ' << 200 << '\n';
    }
    each_face(m, [&](const uint32_t* c, uint32_t s) {
        o << s;
        for (uint32_t k = 0; k < s; ++k) o << ' ' << c[k];
        o << '\n';
    });
    return o.str();
}

std::vector<uint8_t> ply_binary_of(const Primitive& p, const fuzz::SmallMesh& m) {
    std::ostringstream h;
    h << "ply\nformat binary_little_endian 1.0\nelement vertex " << p.vertex_count()
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << m.face_sizes.size()
      << "\nproperty list uchar int vertex_indices\nend_header\n";
    fuzz::Writer w;
    w.append(text_bytes(h.str()));
    for (float x : p.positions) w.f32(x);
    each_face(m, [&](const uint32_t* c, uint32_t s) {
        w.u8(uint8_t(s));
        for (uint32_t k = 0; k < s; ++k) w.u32(c[k]);
    });
    return w.bytes;
}

std::string off_of(const Primitive& p, const fuzz::SmallMesh& m) {
    std::ostringstream o;
    o.precision(9);
    o << "OFF\n" << p.vertex_count() << ' ' << m.face_sizes.size() << " 0\n";
    for (size_t v = 0; v < p.vertex_count(); ++v) o << p.positions[3 * v] << ' ' << p.positions[3 * v + 1] << ' ' << p.positions[3 * v + 2] << '\n';
    each_face(m, [&](const uint32_t* c, uint32_t s) {
        o << s;
        for (uint32_t k = 0; k < s; ++k) o << ' ' << c[k];
        o << '\n';
    });
    return o.str();
}

std::string stl_ascii_of(const Primitive& tri) {
    std::ostringstream o;
    o.precision(9);
    o << "solid seed\n";
    for (size_t f = 0; f < tri.indices.size() / 3; ++f) {
        o << " facet normal 0 1 0\n  outer loop\n";
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = tri.indices[3 * f + k];
            o << "   vertex " << tri.positions[3 * v] << ' ' << tri.positions[3 * v + 1] << ' ' << tri.positions[3 * v + 2] << '\n';
        }
        o << "  endloop\n endfacet\n";
    }
    o << "endsolid seed\n";
    return o.str();
}

std::vector<uint8_t> stl_binary_of(const Primitive& tri) {
    fuzz::Writer w;
    for (int k = 0; k < 80; ++k) w.u8(k < 10 ? uint8_t("furrow-stl"[k]) : 0);
    w.u32(uint32_t(tri.indices.size() / 3));
    for (size_t f = 0; f < tri.indices.size() / 3; ++f) {
        w.f32(0), w.f32(1), w.f32(0);
        for (int k = 0; k < 3; ++k)
            for (int c = 0; c < 3; ++c) w.f32(tri.positions[3 * tri.indices[3 * f + k] + c]);
        w.u16(0);
    }
    return w.bytes;
}

// A crop of the ground as a quad patch: its vertices (i, j) for i in [i0, i0 + n], j in [j0, j0 + n] of the
// 65 × 65 grid ground.glb was made from (models/README.md), one quad per cell.
fuzz::SmallMesh ground_quads(const Primitive& g, int i0, int j0, int n) {
    fuzz::SmallMesh m;
    const int row = 65;
    if (g.vertex_count() != size_t(row * row)) die("ground.glb is not the 65 x 65 grid of models/README.md");
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const size_t v = size_t((j0 + j) * row + i0 + i);
            m.positions.insert(m.positions.end(), {g.positions[3 * v], g.positions[3 * v + 1], g.positions[3 * v + 2]});
            m.uvs.insert(m.uvs.end(), {g.uv0[2 * v], g.uv0[2 * v + 1]});
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const uint32_t a = uint32_t(j * (n + 1) + i), b = a + uint32_t(n + 1), c = b + 1, d = a + 1;
            m.indices.insert(m.indices.end(), {a, b, c, d});
            m.face_sizes.push_back(4);
        }
    return m;
}

fuzz::SmallMesh fanned(const fuzz::SmallMesh& m) {
    fuzz::SmallMesh t = m;
    t.indices.clear();
    t.face_sizes.clear();
    each_face(m, [&](const uint32_t* c, uint32_t s) {
        for (uint32_t k = 1; k + 1 < s; ++k) t.indices.insert(t.indices.end(), {c[0], c[k], c[k + 1]}), t.face_sizes.push_back(3);
    });
    return t;
}

// ---- the creature scene with everything the glTF reader handles that the models do not carry themselves:
// a downscaled embedded texture, a two-joint skin and a morph target.
Scene creature_piece(const Scene& creature, const fuzz::SmallMesh& m) {
    Primitive p = to_primitive(m);
    MorphTarget t;
    for (float n : p.normals) t.position_deltas.push_back(0.01f * n);
    p.targets.push_back(t);
    float lo = 1e30f, hi = -1e30f;
    for (size_t v = 0; v < p.vertex_count(); ++v) lo = std::min(lo, p.positions[3 * v]), hi = std::max(hi, p.positions[3 * v]);
    for (size_t v = 0; v < p.vertex_count(); ++v) {
        const float w = hi > lo ? (p.positions[3 * v] - lo) / (hi - lo) : 0.5f;
        p.joints.insert(p.joints.end(), {0, 1, 0, 0});
        p.weights.insert(p.weights.end(), {1 - w, w, 0, 0});
    }
    p.material = 0;
    Scene s = make_scene(std::move(p), "creature_piece");
    s.meshes[0].weights = {0.5f};
    s.materials = creature.materials;
    s.materials[0].base_color_texture.texture = 0;
    s.samplers = creature.samplers;
    s.textures = {{0, creature.samplers.empty() ? -1 : 0}};
    ImageF full;
    if (creature.images.empty() || !decode_image(full, creature.images[0].encoded.data(), creature.images[0].encoded.size()).ok())
        die("creature.glb has no readable texture");
    const int W = 16, H = 8;
    std::vector<uint8_t> rgba(W * H * 4);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            for (int c = 0; c < 4; ++c) {
                const int sx = x * full.width / W, sy = y * full.height / H;
                const float v = c < full.channels ? full.pixels[(size_t(sy) * size_t(full.width) + size_t(sx)) * size_t(full.channels) + size_t(c)] : 1.0f;
                rgba[size_t(y * W + x) * 4 + size_t(c)] = uint8_t(std::lround(v * 255));
            }
    s.images = {{"albedo", "image/png", encode_png_rgba8(rgba.data(), W, H), ""}};
    Node j0, j1;
    j0.name = "root_joint";
    j1.name = "tail_joint";
    j1.translation = {0.1, 0, 0};
    s.nodes.push_back(j0);
    s.nodes.push_back(j1);
    s.nodes[1].children = {2};
    s.roots.push_back(1);
    s.nodes[0].skin = 0;
    s.skins.push_back({"skin", {1, 2}, {}, 1});
    return s;
}

// ---- harness inputs for the tool harnesses (layouts in fuzz_shells.cpp, fuzz_tessellate.cpp, ...) --------
std::vector<uint8_t> shells_input(const fuzz::SmallMesh& m, uint8_t flags, float length) {
    fuzz::Writer w;
    fuzz::write_mesh(w, m, false);
    w.u8(flags);
    w.u8(8);                              // layers
    w.f32(length);                        // length
    w.range(1.5, 0, 11);                  // spacing power
    w.range(0.3, -0.5, 4.5);              // droop
    w.f32(0), w.f32(-1), w.f32(0);        // gravity
    w.range(1, -0.5, 10.5);               // comb strength
    w.u8(2);                              // LOD levels
    w.range(2, 0.5, 101);                 // max even thickness
    w.flag(true);                         // feature clamp
    w.range(0.45, -0.1, 1.1);             // safe fraction
    w.range(0.25, -0.1, 1.1);             // min area ratio
    if (flags & 1)
        for (size_t v = 0; v < m.vertex_count(); ++v) w.u8(uint8_t((v * 53) % 256)); // mask
    if (flags & 2)
        for (size_t k = 0; k < 3 * m.vertex_count(); ++k) w.range(k % 3 == 0 ? 0.5 : 0.0, -2, 2); // comb
    if ((flags & 4) && (flags & 1))
        for (int k = 0; k < 16; ++k) w.u8(uint8_t(k * 16)); // mask image
    if ((flags & 4) && (flags & 2))
        for (int k = 0; k < 8; ++k) w.u8(uint8_t(128 + k * 8)); // comb image
    return w.bytes;
}

struct TessSeed {
    uint8_t scheme = 0, flags = 0;
    int uniform = 0, max_rate = 4;
    bool camera = false;
    float max_error = 0;
};

std::vector<uint8_t> tessellate_input(const fuzz::SmallMesh& m, const TessSeed& t) {
    fuzz::Writer w;
    fuzz::write_mesh(w, m, true);
    w.u8(t.flags);
    w.u8(t.scheme);
    w.u8(1);                 // boundary: edge and corner
    w.u8(1);                 // uv interpolation: corners only
    w.range(60, 0, 180);     // crease angle
    w.u8(1);                 // accuracy 2
    w.flag(true);            // weld tolerance 0
    w.flag(false);           // do not refuse bad topology
    w.u8(uint8_t(t.uniform));
    w.u8(uint8_t(t.max_rate - 1));
    w.flag(t.camera);
    if (t.camera) {
        w.f32(0), w.f32(3), w.f32(-6); // eye
        w.range(45, 1, 179);
        w.u16(1079);
        w.flag(true);                   // distance
        w.range(1, 0, 10);
        w.range(9, 0.01, 100);
        w.flag(true), w.range(8, 0.1, 50); // pixel error
        w.flag(false);                     // no screen error
    }
    w.f32(t.max_error);
    w.u8(1);                                              // one focus point
    w.range(0, -10, 10), w.range(0, -10, 10), w.range(0, -10, 10);
    w.range(1, 0.001, 10);
    w.u8(4);
    w.u8(1);                                              // one instance
    w.range(2, -10, 10);
    w.range(1, -100, 100), w.range(0, -100, 100), w.range(0, -100, 100);
    if (t.flags & 2)
        for (size_t k = 0; k < 3 * m.vertex_count(); ++k) w.u8(uint8_t(40 + (k * 29) % 200)); // colour
    if (t.flags & 4)
        for (size_t k = 0; k < 3 * m.vertex_count(); ++k) w.range(k % 3 == 1 ? 0.05 : 0.0, -1, 1); // vertex data
    if (t.flags & 8)
        for (size_t v = 0; v < m.vertex_count(); ++v) { // joints, weights
            w.u8(0), w.u8(1), w.u8(0), w.u8(0);
            w.u8(uint8_t(255 - (v * 5) % 256)), w.u8(uint8_t((v * 5) % 256)), w.u8(0), w.u8(0);
        }
    if (t.flags & 0x80)
        for (size_t f = 0; f < m.face_sizes.size(); ++f) w.u8(uint8_t(f % 2)); // face groups
    return w.bytes;
}

// One collider of fuzz_stamp's layout, placed at `centre`.
void stamp_collider(fuzz::Writer& w, const Collider& c, const std::array<double, 3>& centre) {
    w.u8(uint8_t(c.shape));
    w.f32(float(c.radius > 0 ? c.radius : 0.1));
    w.f32(float(c.length));
    for (double s : c.size) w.f32(float(s > 0 ? s : 0.2));
    w.f32(float(c.depth > 0 ? c.depth : 0.05));
    w.range(c.axis[0], -1, 1), w.range(c.axis[1], -1, 1), w.range(c.axis[2], -1, 1);
    if (c.shape == ColliderShape::image) { // a 6 × 6 sample of the brush
        w.u8(5), w.u8(5);
        for (int y = 0; y < 6; ++y)
            for (int x = 0; x < 6; ++x) {
                const ImageF& b = *c.brush;
                const size_t sx = size_t(x * b.width / 6), sy = size_t(y * b.height / 6);
                w.u8(uint8_t(std::lround(255 * b.pixels[(sy * size_t(b.width) + sx) * size_t(b.channels)])));
            }
    }
    const size_t points = std::min<size_t>(c.path.size(), 4);
    w.u8(uint8_t(points - 1));
    const bool timed = !c.time.empty();
    w.u8(uint8_t((timed ? 1 : 0) | (c.heading.size() == 1 ? 2 : 0)));
    for (size_t k = 0; k < points; ++k) {
        // The model's path, moved so that its first point sits at the crop's centre.
        for (int a = 0; a < 3; ++a) w.f32(float(c.path[k][size_t(a)] - c.path[0][size_t(a)] + centre[size_t(a)]));
        if (timed) w.range(k ? c.time[k] - c.time[k - 1] : c.time[0], 0, 2);
    }
    if (c.heading.size() == 1) w.range(c.heading[0], -720, 720);
}

std::vector<uint8_t> stamp_input(const fuzz::SmallMesh& ground, uint8_t flags, const std::vector<const Collider*>& cs) {
    fuzz::Writer w;
    fuzz::write_mesh(w, ground, false);
    w.u8(flags);
    if (flags & 0x40) w.range(0, -1, 1), w.range(1, -1, 1), w.range(0, -1, 1);
    w.u8(40);                                  // resolution 42
    w.flag(false);                             // snow depth unlimited
    w.flag(true), w.range(0.08, 0, 0.5);       // rim width
    w.range(0.5, 0, 1.5);                      // rim height
    w.range(0.3, 0, 1);                        // compaction
    w.flag(true), w.range(0.2, 0, 2);          // refill
    w.flag(false);                             // no margin
    w.flag(false);                             // latest time
    w.flag(true), w.range(0.01, 0, 0.1);       // max error
    w.u8(7);                                   // max rate 8
    if (flags & 8) {
        w.range(0, -20, 20), w.range(6, -20, 20), w.range(8, -20, 20);
        w.range(45, 1, 179);
        w.u16(1079);
        w.range(1, 0.1, 10);
    }
    if (flags & 0x10) {
        w.u8(3), w.u8(3);
        for (int k = 0; k < 16; ++k) w.range(-0.01 * (k % 5), -0.2, 0.1);
    }
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (size_t v = 0; v < ground.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], ground.positions[3 * v + a]), hi[a] = std::max(hi[a], ground.positions[3 * v + a]);
    w.u8(uint8_t(cs.size() - 1));
    for (size_t k = 0; k < cs.size(); ++k) {
        const Collider& c = *cs[k];
        // Centre over the crop, its lowest point a little below the surface (as the models' colliders sit).
        const double bottom = c.shape == ColliderShape::box ? c.size[1] / 2 : c.shape == ColliderShape::image ? 0.0 : c.radius;
        const double f = (double(k) + 1) / double(cs.size() + 1);
        stamp_collider(w, c, {lo[0] + f * (hi[0] - lo[0]), hi[1] + bottom - 0.05, lo[2] + f * (hi[2] - lo[2])});
    }
    return w.bytes;
}

std::vector<uint8_t> render_header(uint8_t flags, int w, int h, RenderMode mode) {
    fuzz::Writer b;
    b.u8(flags);
    b.u8(uint8_t(w - 1)), b.u8(uint8_t(h - 1));
    b.u8(uint8_t(mode));
    b.u8(0); // ssaa 1
    if (flags & 0x20) b.f32(0.6f), b.f32(0.5f), b.f32(0.8f);
    if (flags & 0x40) b.range(0, -10, 10), b.range(0.3, -10, 10), b.range(0, -10, 10);
    b.range(0, -1, 1), b.range(1, -1, 1), b.range(0, -1, 1);
    b.range(45, 0.5, 179.5);
    b.flag(false);
    b.flag(false);
    b.flag(true), b.range(0.2, 0, 1), b.range(0.3, 0, 1), b.range(0.4, 0, 1);
    b.range(-0.35, -1, 1), b.range(0.55, -1, 1), b.range(0.75, -1, 1);
    b.range(0.25, 0, 1);
    b.flag(true);
    b.bytes.resize(64, 0);
    return b.bytes;
}

} // namespace

int main(int argc, char** argv) {
    if (argc != 3) die("usage: furrow_fuzz_make_seeds MODELS_DIR OUT_DIR");
    const fs::path models = argv[1];
    g_out = argv[2];
    std::error_code ec;
    fs::remove_all(g_out, ec);

    const Scene ground = load(models / "ground.glb");
    const Scene creature = load(models / "creature.glb");
    const Primitive& gp = ground.meshes[0].primitives[0];
    const Primitive& cp = creature.meshes[0].primitives[0];

    // Pieces: a 5 × 5 quad patch of the ground's hills, triangles of the creature's back and of an ear.
    const fuzz::SmallMesh gq = ground_quads(gp, 30, 12, 5);
    const fuzz::SmallMesh gt = fanned(gq);
    const fuzz::SmallMesh c1 = fuzz::crop(cp, 1000, 40, false);
    const fuzz::SmallMesh c2 = fuzz::crop(cp, cp.indices.size() / 3 * 3 / 4, 40, false);

    // --- load_scene: byte 0 = format (.glb .gltf .obj .ply .off .stl)
    {
        Scene g = make_scene(to_primitive(gq), "ground_piece");
        g.materials = ground.materials;
        g.meshes[0].primitives[0].material = 0;
        const std::vector<uint8_t> gglb = glb_of(g);
        const std::vector<uint8_t> cglb = glb_of(creature_piece(creature, c1));
        seed("load_scene", "ground_piece.glb", prefixed(0, gglb));
        seed("load_scene", "ground_piece.gltf", prefixed(1, gltf_of_glb(gglb)));
        seed("load_scene", "creature_piece_skin_morph_texture.glb", prefixed(0, cglb));
        seed("load_scene", "creature_piece_skin_morph_texture.gltf", prefixed(1, gltf_of_glb(cglb)));
        // KHR_mesh_quantization + EXT_meshopt_compression (the decoder's checks and meshoptimizer's decoders).
        SaveOptions compress;
        compress.encoding = Encoding::compress;
        seed("load_scene", "ground_piece_compressed.glb", prefixed(0, glb_of(g, compress)));
        const Primitive gqp = to_primitive(gq), c2p = to_primitive(c2);
        // Loaded from the harness's scratch resource root (byte 0 bit 5): a triangle in data.bin, textured by
        // tex.png, both beside the file.
        const json external = {
            {"asset", {{"version", "2.0"}}},
            {"scenes", {{{"nodes", {0}}}}},
            {"nodes", {{{"mesh", 0}}}},
            {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}}}, {"material", 0}}}}}}},
            {"materials", {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}}},
            {"textures", {{{"source", 0}}}},
            {"images", {{{"uri", "tex.png"}}}},
            {"accessors", {{{"bufferView", 0}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"},
                            {"min", {0, 0, 0}}, {"max", {1, 1, 0}}}}},
            {"bufferViews", {{{"buffer", 0}, {"byteLength", 36}}}},
            {"buffers", {{{"byteLength", 36}, {"uri", "data.bin"}}}}};
        seed("load_scene", "external_bin_and_png_in_root.gltf", prefixed(0x21, text_bytes(external.dump())));
        seed("load_scene", "ground_quads.obj", prefixed(2, text_bytes(obj_of(gqp, gq))));
        seed("load_scene", "creature_piece.obj", prefixed(2, text_bytes(obj_of(c2p, c2))));
        seed("load_scene", "ground_quads_ascii.ply", prefixed(3, text_bytes(ply_ascii_of(gqp, gq))));
        seed("load_scene", "creature_piece_binary.ply", prefixed(3, ply_binary_of(c2p, c2)));
        seed("load_scene", "ground_quads.off", prefixed(4, text_bytes(off_of(gqp, gq))));
        Primitive tri = to_primitive(c1);
        seed("load_scene", "creature_piece_ascii.stl", prefixed(5, text_bytes(stl_ascii_of(tri))));
        seed("load_scene", "creature_piece_binary.stl", prefixed(5, stl_binary_of(tri)));

        // --- render: header + a scene
        seed("render", "creature_piece_shaded.glb", [&] { auto b = render_header(0x40, 24, 16, RenderMode::shaded); b.insert(b.end(), cglb.begin(), cglb.end()); return b; }());
        seed("render", "creature_piece_wireframe_ortho.gltf", [&] { auto b = render_header(0x11, 16, 16, RenderMode::wireframe); auto t = gltf_of_glb(cglb); b.insert(b.end(), t.begin(), t.end()); return b; }());
        seed("render", "ground_piece_depth.glb", [&] { auto b = render_header(0x20, 20, 12, RenderMode::depth); b.insert(b.end(), gglb.begin(), gglb.end()); return b; }());
        seed("render", "ground_piece_normals.glb", [&] { auto b = render_header(0x00, 12, 12, RenderMode::normals); b.insert(b.end(), gglb.begin(), gglb.end()); return b; }());
        seed("render", "creature_piece_uv.glb", [&] { auto b = render_header(0x00, 12, 12, RenderMode::uv); b.insert(b.end(), cglb.begin(), cglb.end()); return b; }());
        // The engine-layout fur of the piece carries custom attributes for the attribute mode.
        Scene fur = make_scene(to_primitive(c1));
        Primitive& fp = fur.meshes[0].primitives[0];
        CustomAttribute layer{"_FUR_LAYER", 1, {}};
        for (size_t v = 0; v < fp.vertex_count(); ++v) layer.values.push_back(float(v % 7) / 6.0f);
        fp.custom.push_back(layer);
        const std::vector<uint8_t> fglb = glb_of(fur);
        seed("render", "creature_piece_attribute.glb", [&] { auto b = render_header(0x00, 20, 10, RenderMode::attribute); b.insert(b.end(), fglb.begin(), fglb.end()); return b; }());
    }

    // --- colliders: the models' file, and one document per shape from it
    {
        const std::vector<uint8_t> file = read_file(models / "colliders.json");
        seed("colliders", "colliders.json", file);
        const json doc = json::parse(file.begin(), file.end());
        std::set<std::string> shapes;
        for (const json& c : doc["colliders"]) {
            const std::string s = c["shape"].get<std::string>();
            if (!shapes.insert(s).second) continue;
            json one = {{"up", doc["up"]}, {"colliders", json::array({c})}};
            seed("colliders", s + ".json", text_bytes(one.dump(1)));
        }
        json timed = json::parse(R"({"_comment": "a timed sweep with headings", "colliders": [{"shape": "capsule",
          "radius": 0.12, "length": 1.0, "axis": [0, 0, 1], "name": "log", "path": [[0, 0.02, 0], [0.3, 0, 0.1], [0.6, 0.05, 0.3]],
          "time": [0, 0.5, 1.0], "heading": [0, 30, 75]}]})");
        seed("colliders", "timed_capsule.json", text_bytes(timed.dump(1)));
    }

    // --- shells
    seed("shells", "creature_back.bin", shells_input(c1, 0x00, 0.02f));
    seed("shells", "creature_ear_mask_comb.bin", shells_input(c2, 0x03, 0.03f));
    seed("shells", "creature_back_scene_viewer.bin", shells_input(c1, 0x07, 0.02f));
    seed("shells", "creature_ear_scene_engine_fins.bin", shells_input(c2, 0x1d, 0.02f));
    seed("shells", "ground_piece_scene.bin", shells_input(gt, 0x04, 0.1f));
    seed("shells", "creature_back_scene_instanced.bin", shells_input(c1, 0x57, 0.02f));
    seed("shells", "creature_ear_scene_instanced_lod_simplify_fins.bin", shells_input(c2, 0xdd, 0.02f));
    seed("shells", "creature_back_scene_viewer_lod_simplify.bin", shells_input(c1, 0x87, 0.02f));

    // --- tessellate
    seed("tessellate", "ground_quads_catmark_uniform.bin", tessellate_input(gq, {0, 0x01, 4, 4, false, 0}));
    seed("tessellate", "ground_quads_bilinear_camera.bin", tessellate_input(gq, {2, 0x13, 0, 8, true, 0}));
    seed("tessellate", "creature_back_loop_max_error.bin", tessellate_input(c1, {1, 0x11, 0, 6, false, 0.001f}));
    seed("tessellate", "creature_ear_catmark_skin_groups.bin", tessellate_input(c2, {0, 0x8f, 2, 4, false, 0}));
    seed("tessellate", "ground_quads_scene_all.bin", tessellate_input(gq, {0, 0x2f, 3, 4, false, 0}));

    // --- stamp: the models' colliders, one of each shape, on the ground piece
    {
        ColliderSet set;
        Status s = load_colliders(set, (models / "colliders.json").string());
        if (!s.ok()) die("colliders.json: " + s.message);
        std::map<ColliderShape, const Collider*> first;
        for (const Collider& c : set.colliders) first.insert({c.shape, &c});
        const Collider* sphere = first.at(ColliderShape::sphere);
        const Collider* box = first.at(ColliderShape::box);
        const Collider* capsule = first.at(ColliderShape::capsule);
        const Collider* image = first.at(ColliderShape::image);
        seed("stamp", "ground_piece_sphere.bin", stamp_input(gt, 0x03, {sphere}));
        seed("stamp", "ground_piece_box_capsule_camera.bin", stamp_input(gt, 0x0a, {box, capsule}));
        seed("stamp", "ground_piece_footprints_base.bin", stamp_input(gt, 0x16, {image, image, sphere}));
        seed("stamp", "ground_piece_no_tessellation.bin", stamp_input(gt, 0x41, {capsule}));
    }

    // --- heightmap: byte 0 = reader (.pfm, .png heightmap, decode_image)
    {
        Heightmap hm;
        const int n = 12;
        hm.frame.width = hm.frame.height = n;
        hm.frame.texel = 20.0 / 64;
        hm.frame.origin = {-2, 0, -5};
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) hm.values.push_back(gp.positions[3 * size_t((20 + j) * 65 + 20 + i) + 1] - 0.1f * float((i + j) % 3 == 0));
        const std::string pfm = fuzz::scratch_path("seed.pfm"), png = fuzz::scratch_path("seed.png");
        if (!save_heightmap(hm, pfm).ok() || !save_heightmap(hm, png).ok()) die("save_heightmap failed");
        seed("heightmap", "ground_heights.pfm", prefixed(0, read_file(pfm)));
        seed("heightmap", "ground_heights.png", prefixed(1, read_file(png)));
        fs::remove(pfm), fs::remove(png);
        // A plain PFM (no furrow line), big-endian, as other tools write it.
        fuzz::Writer w;
        w.append(text_bytes("Pf\n4 3\n1.0\n"));
        for (int k = 0; k < 12; ++k) {
            const float v = hm.values[size_t(k)];
            uint32_t b;
            std::memcpy(&b, &v, 4);
            w.u8(uint8_t(b >> 24)), w.u8(uint8_t(b >> 16)), w.u8(uint8_t(b >> 8)), w.u8(uint8_t(b));
        }
        seed("heightmap", "plain_big_endian.pfm", prefixed(0, w.bytes));
        seed("heightmap", "footprint.png", prefixed(2, read_file(models / "footprint.png")));
        // A small JPEG of the brush (the other format decode_image reads).
        ImageF brush;
        if (!load_png(brush, (models / "footprint.png").string()).ok()) die("footprint.png");
        std::vector<uint8_t> grey(16 * 40);
        for (int y = 0; y < 40; ++y)
            for (int x = 0; x < 16; ++x)
                grey[size_t(y * 16 + x)] = uint8_t(std::lround(255 * brush.pixels[size_t(y * brush.height / 40 * brush.width + x * brush.width / 16) * size_t(brush.channels)]));
        std::vector<uint8_t> jpg;
        stbi_write_jpg_to_func([](void* ctx, void* d, int sz) {
            auto* v = static_cast<std::vector<uint8_t>*>(ctx);
            v->insert(v->end(), static_cast<uint8_t*>(d), static_cast<uint8_t*>(d) + sz);
        }, &jpg, 16, 40, 1, grey.data(), 90);
        seed("heightmap", "footprint_small.jpg", prefixed(2, jpg));
    }
    std::printf("fuzz seeds written to %s\n", g_out.string().c_str());
    return 0;
}

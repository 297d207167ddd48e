// Fur on a whole scene: shells (and fins, and LOD levels) as glTF a stock viewer can show.
//
// Reference: Lengyel et al., "Real-Time Fur over Arbitrary Surfaces" (I3D 2001): shells with an alpha-tested
// strand texture, fins near silhouettes, fewer shells at a distance; NVIDIA, "Fur (using Shells and Fins)"
// (2007 SDK white paper): fins faded by the angle between view and surface. What is specific here is how
// that maps onto core glTF 2.0 with no custom shader:
//   - alpha test = MASK with alphaCutoff = the shell's height fraction, one material per shell, the strand
//     texture on TEXCOORD_1 (so TEXCOORD_0 keeps the model's own UVs);
//   - shading = COLOR_0 × strand texture: the base albedo is sampled at each vertex (base colour factor ×
//     texture × vertex colour) and darkened toward the roots, a cheap stand-in for self-shadowing;
//   - LOD levels live on nodes outside the default scene, so a viewer shows level 0 only; with
//     lod_simplify_error their bases are also simplified (simplify_lod.cpp), on the same vertices and frame;
//   - everything an animated model needs rides along: JOINTS_0/WEIGHTS_0 and morph deltas are copied from
//     the base vertex, and the shells stay in the base's mesh, so its node, skin and weights apply.
// Lengths are given in world units and converted per mesh with the scale of its (bind-pose) world matrix,
// so `--length 0.02` means 2 cm on the 0.01-scaled Duck as on the creature.
#include "shells_internal.h"

#include <furrow/shells.h>
#include <furrow_kernel/affine.h>
#include <furrow_kernel/no_throw.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <unordered_map>

namespace furrow {
namespace {

using kernel::Mat4; // column-major, as glTF stores it

using kernel::det3;

// Solves M·x = b for the linear part of M (Cramer); returns b if M is singular.
std::array<double, 3> solve3(const Mat4& m, const std::array<double, 3>& b) {
    double d = det3(m);
    if (!(std::abs(d) > 1e-300) || !std::isfinite(d)) return b;
    auto col = [&](int c) { return std::array<double, 3>{m[size_t(4 * c)], m[size_t(4 * c + 1)], m[size_t(4 * c + 2)]}; };
    auto det_cols = [](const std::array<double, 3>& a, const std::array<double, 3>& bb, const std::array<double, 3>& c) {
        return a[0] * (bb[1] * c[2] - bb[2] * c[1]) - bb[0] * (a[1] * c[2] - a[2] * c[1]) + c[0] * (a[1] * bb[2] - a[2] * bb[1]);
    };
    return {det_cols(b, col(1), col(2)) / d, det_cols(col(0), b, col(2)) / d, det_cols(col(0), col(1), b) / d};
}

using shells_detail::parallel;

// How one mesh sits in the world: object units per world unit and gravity in object space.
struct Placement {
    double scale = 1.0; // world units per object unit
    std::array<double, 3> gravity{0, -1, 0};
    int node = -1;
};

Placement placement_of(const Scene& scene, const std::vector<Mat4>& world, int node_index, const std::array<double, 3>& g) {
    Placement pl;
    pl.node = node_index;
    const Mat4 m = scene.mesh_placement(node_index, world); // the bind pose for a skinned mesh
    double d = det3(m);
    pl.scale = std::isfinite(d) && std::abs(d) > 1e-300 ? std::cbrt(std::abs(d)) : 1.0;
    std::array<double, 3> go = solve3(m, g);
    double len = std::sqrt(go[0] * go[0] + go[1] * go[1] + go[2] * go[2]);
    if (len > 0 && std::isfinite(len)) pl.gravity = {go[0] / len, go[1] / len, go[2] / len};
    return pl;
}

int add_texture(Scene& scene, const std::string& name, const std::vector<uint8_t>& png, int wrap_t) {
    Image im;
    im.name = name;
    im.mime_type = "image/png";
    im.encoded = png;
    scene.images.push_back(std::move(im));
    Sampler s;
    s.mag_filter = 9729; // LINEAR
    // LINEAR, not a *_MIPMAP_* filter: a viewer told to mip-map builds the chain by box filtering, which
    // averages each strand with the empty texels around it; the averaged alpha falls below the upper shells'
    // cutoffs (they vanish) and above the lowest ones' (they turn solid), so distant fur reads as a smooth
    // hull. Sampling the base level keeps every shell's coverage at any distance, at the cost of shimmer
    // under motion (README, "Fur in real viewers").
    s.min_filter = 9729;
    s.wrap_s = 10497;     // REPEAT: the textures tile
    s.wrap_t = wrap_t;
    scene.samplers.push_back(s);
    Texture t;
    t.image = int(scene.images.size()) - 1;
    t.sampler = int(scene.samplers.size()) - 1;
    scene.textures.push_back(t);
    return int(scene.textures.size()) - 1;
}

int add_material(Scene& scene, const std::string& name, int texture, int texcoord, float cutoff, bool double_sided) {
    Material m;
    m.name = name;
    m.base_color_texture.texture = texture;
    m.base_color_texture.texcoord = texcoord;
    m.metallic = 0.0f; // fur is a dielectric; glTF's default metallic 1 would render it almost black
    m.roughness = 0.85f;
    m.alpha_mode = AlphaMode::mask;
    m.alpha_cutoff = cutoff;
    m.double_sided = double_sided;
    scene.materials.push_back(m);
    return int(scene.materials.size()) - 1;
}

// Decoded base-colour textures, by image index (decoded once per call).
struct TextureCache {
    std::map<int, ImageF> images;
    // Decodes the image of the texture that vertex_albedo will sample for p, as a task of `tasks` (PNG and
    // JPEG decoding is sequential and can cost as much as the frame of a large mesh; it does not depend on
    // the frame, so it runs on another core meanwhile). The map entry is made here, on the calling thread;
    // the task only fills it, and get() must not run before the tasks are waited for.
    void prefetch(const Scene& scene, const Primitive& p, tbb::task_group& tasks) {
        if (p.material < 0 || p.material >= int(scene.materials.size())) return;
        const Material& m = scene.materials[size_t(p.material)];
        const std::vector<float>& uv = m.base_color_texture.texcoord == 1 ? p.uv1 : p.uv0;
        const int texture = m.base_color_texture.texture;
        if (uv.size() != 2 * p.vertex_count() || texture < 0 || texture >= int(scene.textures.size())) return;
        const int image = scene.textures[size_t(texture)].image;
        if (image < 0 || image >= int(scene.images.size()) || images.count(image)) return;
        ImageF* slot = &images[image];
        const std::vector<uint8_t>* bytes = &scene.images[size_t(image)].encoded;
        tasks.run([slot, bytes] {
            if (bytes->empty() || !decode_image(*slot, bytes->data(), bytes->size()).ok()) *slot = ImageF{};
        });
    }
    const ImageF* get(const Scene& scene, int texture) {
        if (texture < 0 || texture >= int(scene.textures.size())) return nullptr;
        int image = scene.textures[size_t(texture)].image;
        if (image < 0 || image >= int(scene.images.size())) return nullptr;
        auto it = images.find(image);
        if (it == images.end()) {
            ImageF im;
            const auto& bytes = scene.images[size_t(image)].encoded;
            if (bytes.empty() || !decode_image(im, bytes.data(), bytes.size()).ok()) im = ImageF{};
            it = images.emplace(image, std::move(im)).first;
        }
        return it->second.width > 0 ? &it->second : nullptr;
    }
};

// Linear RGB albedo per vertex: baseColorFactor × baseColorTexture (sRGB-decoded) × COLOR_0.
std::vector<float> vertex_albedo(const Scene& scene, const Primitive& p, TextureCache& cache) {
    const size_t n = p.vertex_count();
    std::array<float, 4> factor{1, 1, 1, 1};
    const ImageF* image = nullptr;
    const std::vector<float>* uv = nullptr;
    int wrap_s = 10497, wrap_t = 10497;
    if (p.material >= 0 && p.material < int(scene.materials.size())) {
        const Material& m = scene.materials[size_t(p.material)];
        factor = m.base_color;
        image = cache.get(scene, m.base_color_texture.texture);
        uv = m.base_color_texture.texcoord == 1 ? &p.uv1 : &p.uv0;
        if (uv->size() != 2 * n) image = nullptr;
        if (image) {
            int s = scene.textures[size_t(m.base_color_texture.texture)].sampler;
            if (s >= 0 && s < int(scene.samplers.size())) wrap_s = scene.samplers[size_t(s)].wrap_s, wrap_t = scene.samplers[size_t(s)].wrap_t;
        }
    }
    std::vector<float> rgb(3 * n);
    parallel(n, 2048, [&](size_t v) {
        for (int c = 0; c < 3; ++c) {
            float x = factor[size_t(c)];
            if (image) {
                int ch = image->channels >= 3 ? c : 0;
                x *= srgb_to_linear(shells_detail::sample_bilinear(*image, ch, (*uv)[2 * v], (*uv)[2 * v + 1], wrap_s, wrap_t));
            }
            if (p.colors.size() == 4 * n) x *= p.colors[4 * v + size_t(c)];
            rgb[3 * v + size_t(c)] = std::clamp(x, 0.0f, 1.0f);
        }
    });
    return rgb;
}

// The shell vertex set: which base vertex each output vertex copies, and its strand-texture UV (TEXCOORD_1).
struct ShellVertices {
    std::vector<uint32_t> src;
    std::vector<float> uv0, uv1; // uv0 only when the base has none (box projection)
    std::vector<uint32_t> indices; // kept triangles, in output vertex indices
};

// A strand-texture coordinate as a float. The texture repeats, and beyond 2^24 a float has no fractional
// bits left, so the pattern is lost there anyway; clamping keeps the coordinate finite when the tile is tiny
// against the mesh or the UV layout nearly degenerate (found by fuzz_shells: float(uv · 1e45) = inf).
float tile_coord(double x) {
    constexpr double kMax = 16777216.0;
    return std::isnan(x) ? 0.0f : float(std::clamp(x, -kMax, kMax)); // NaN: 0 · inf for a UV of 0
}

ShellVertices shell_vertices(const Primitive& p, const std::vector<uint32_t>& tris, const std::vector<uint8_t>& keep,
                             double tile_obj) {
    ShellVertices sv;
    const size_t n = p.vertex_count(), T = tris.size() / 3;
    auto pos = [&](uint32_t v, int k) { return double(p.positions[3 * size_t(v) + size_t(k)]); };
    // World-to-texture scale from the UV layout: object units per UV unit, as the root of the area ratio.
    double a3 = 0, auv = 0;
    if (p.uv0.size() == 2 * n) {
        for (size_t f = 0; f < T; ++f) {
            uint32_t a = tris[3 * f], b = tris[3 * f + 1], c = tris[3 * f + 2];
            double e1[3], e2[3];
            for (int k = 0; k < 3; ++k) e1[k] = pos(b, k) - pos(a, k), e2[k] = pos(c, k) - pos(a, k);
            double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
            a3 += 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
            double u1 = double(p.uv0[2 * b]) - p.uv0[2 * a], v1 = double(p.uv0[2 * b + 1]) - p.uv0[2 * a + 1];
            double u2 = double(p.uv0[2 * c]) - p.uv0[2 * a], v2 = double(p.uv0[2 * c + 1]) - p.uv0[2 * a + 1];
            auv += 0.5 * std::abs(u1 * v2 - u2 * v1);
        }
    }
    if (auv > 0 && a3 > 0 && std::isfinite(auv) && std::isfinite(a3)) {
        const double k = std::sqrt(a3 / auv) / tile_obj;
        std::vector<uint32_t> map(n, UINT32_MAX);
        for (size_t f = 0; f < T; ++f) {
            if (!keep[f]) continue;
            for (int c = 0; c < 3; ++c) {
                uint32_t v = tris[3 * f + size_t(c)];
                if (map[v] == UINT32_MAX) {
                    map[v] = uint32_t(sv.src.size());
                    sv.src.push_back(v);
                    sv.uv1.push_back(tile_coord(double(p.uv0[2 * v]) * k));
                    sv.uv1.push_back(tile_coord(double(p.uv0[2 * v + 1]) * k));
                }
                sv.indices.push_back(map[v]);
            }
        }
        return sv;
    }
    // No usable UVs: box projection, each triangle onto the plane its normal faces most; a vertex used by
    // triangles of different planes is split (positions stay identical, so no crack). A copy's id by (vertex,
    // plane) in a flat table, numbered in order of first use, as a std::map of the pairs numbered them: on the
    // Stanford bunny (callgrind --branch-sim=yes) 64.6 -> 16.1 M instructions, 1.99 -> 0.12 M mispredicted
    // branches; `bench shells -j 1 --layers 32 --repeat 5` set-up, three interleaved runs, 213.5/219.4/209.2
    // -> 202.4/200.8/187.9 ms.
    std::vector<uint32_t> copy(3 * n, UINT32_MAX);
    for (size_t f = 0; f < T; ++f) {
        if (!keep[f]) continue;
        uint32_t a = tris[3 * f], b = tris[3 * f + 1], c = tris[3 * f + 2];
        double e1[3], e2[3];
        for (int k = 0; k < 3; ++k) e1[k] = pos(b, k) - pos(a, k), e2[k] = pos(c, k) - pos(a, k);
        double nrm[3] = {std::abs(e1[1] * e2[2] - e1[2] * e2[1]), std::abs(e1[2] * e2[0] - e1[0] * e2[2]),
                         std::abs(e1[0] * e2[1] - e1[1] * e2[0])};
        int axis = nrm[0] >= nrm[1] && nrm[0] >= nrm[2] ? 0 : nrm[1] >= nrm[2] ? 1 : 2;
        for (uint32_t v : {a, b, c}) {
            uint32_t& id = copy[3 * size_t(v) + size_t(axis)];
            if (id == UINT32_MAX) {
                id = uint32_t(sv.src.size());
                sv.src.push_back(v);
                int i0 = (axis + 1) % 3, i1 = (axis + 2) % 3;
                float u = tile_coord(pos(v, i0) / tile_obj), w = tile_coord(pos(v, i1) / tile_obj);
                sv.uv1.push_back(u);
                sv.uv1.push_back(w);
                sv.uv0.push_back(u);
                sv.uv0.push_back(w);
            }
            sv.indices.push_back(id);
        }
    }
    return sv;
}

// Everything per base primitive that every shell, fin and LOD level reads.
struct Grown {
    size_t mesh = 0, prim = 0;
    ShellFrame frame;
    ShellVertices sv;
    std::vector<float> albedo; // per base vertex
    std::vector<uint32_t> tris;
    size_t dropped = 0;
    std::optional<Primitive> refined; // the base primitive refined where clamps starved its faces
    // FurOptions::lod_simplify_error > 0: the simplified base of LOD level k >= 1 at [k - 1] (same vertices and
    // frame, fewer triangles); empty: every level grows on `tris`.
    struct Level {
        std::vector<uint32_t> tris;
        ShellVertices sv;
        size_t dropped = 0;
    };
    std::vector<Level> lods;
};

// The base primitive the shells of `g` grow from: its refinement, if it got one.
const Primitive& base_of(const Scene& scene, const Grown& g) { return g.refined ? *g.refined : scene.meshes[g.mesh].primitives[g.prim]; }

// Copies the per-vertex attributes that follow the base vertex (normals, UVs, skin, morph deltas).
void copy_attributes(Primitive& out, const Primitive& base, const std::vector<uint32_t>& src, const std::vector<float>& uv0_override) {
    const size_t m = src.size();
    auto gather = [&](std::vector<float>& dst, const std::vector<float>& from, size_t per) {
        if (from.size() != per * base.vertex_count()) return;
        dst.resize(per * m);
        for (size_t i = 0; i < m; ++i)
            for (size_t k = 0; k < per; ++k) dst[per * i + k] = from[per * size_t(src[i]) + k];
    };
    gather(out.normals, base.normals, 3);
    if (!uv0_override.empty()) out.uv0 = uv0_override;
    else gather(out.uv0, base.uv0, 2);
    gather(out.weights, base.weights, 4);
    if (base.joints.size() == 4 * base.vertex_count() && !out.weights.empty()) {
        out.joints.resize(4 * m);
        for (size_t i = 0; i < m; ++i)
            for (size_t k = 0; k < 4; ++k) out.joints[4 * i + k] = base.joints[4 * size_t(src[i]) + k];
    }
    out.targets.resize(base.targets.size());
    for (size_t t = 0; t < base.targets.size(); ++t) {
        gather(out.targets[t].position_deltas, base.targets[t].position_deltas, 3);
        if (!out.normals.empty()) gather(out.targets[t].normal_deltas, base.targets[t].normal_deltas, 3);
    }
}

// FurOptions::max_triangles against an upper bound of what would be added: every base triangle on every shell
// of every level, and two fin triangles per edge (3 edges per triangle at most) on every level.
size_t added_per_base_triangle(const FurOptions& opt) {
    size_t shells = 0;
    for (int k = 0; k < opt.shells.lod_levels; ++k) shells += size_t(std::max(1, opt.shells.layers >> k)) + (opt.fins ? 6 : 0);
    return shells;
}

size_t base_triangles(const Scene& scene, const std::vector<std::pair<size_t, size_t>>& work) {
    size_t base = 0;
    for (const auto& [mi, pi] : work) base += scene.meshes[mi].primitives[pi].triangle_count();
    return base;
}

// How many triangles the refinement may make of a primitive of T triangles: FurOptions::refine_budget, and
// within max_triangles, the room the limit leaves shared among the primitives by their triangle counts (so
// the shells of the refined bases still fit).
size_t refine_budget(size_t T, size_t all_base, const FurOptions& opt) {
    size_t budget = 8 * T + opt.refine_budget;
    if (opt.max_triangles > 0 && all_base > 0) {
        const double allowed = double(opt.max_triangles) / double(added_per_base_triangle(opt)); // all bases
        const double share = std::floor(allowed * double(T) / double(all_base));
        budget = std::min(budget, size_t(std::max(double(T), share)));
    }
    return budget;
}

Status check_triangle_limit(const Scene& scene, const std::vector<std::pair<size_t, size_t>>& work, const FurOptions& opt) {
    if (opt.max_triangles == 0) return Status::success();
    const size_t base = base_triangles(scene, work), shells = added_per_base_triangle(opt);
    const double estimate = double(base) * double(shells);
    if (estimate <= double(opt.max_triangles)) return Status::success();
    return Status::error(StatusCode::invalid_argument,
                         "the shells would add up to " + std::to_string(size_t(estimate)) + " triangles (" +
                             std::to_string(base) + " base triangles × " + std::to_string(shells) + "), over the limit of " +
                             std::to_string(opt.max_triangles) + " (raise it with --max-triangles)");
}

// The shell frame of one base primitive: the mask sampled at its vertices, the comb carried from UV space to
// object space, then compute_shell_frame. `o` holds the length in object units and gravity in object space.
Status grow_frame(ShellFrame& frame, const Primitive& p, const std::vector<uint32_t>& tris, const FurOptions& opt, const ShellOptions& o) {
    const size_t n = p.vertex_count();
    const bool has_mask = !opt.mask.pixels.empty(), has_comb = !opt.comb.pixels.empty();
    std::vector<float> mask, comb;
    if (has_mask) {
        mask.resize(n);
        parallel(n, 2048, [&](size_t v) {
            mask[v] = shells_detail::sample_bilinear(opt.mask, opt.mask_channel, p.uv0[2 * v], p.uv0[2 * v + 1]);
        });
    }
    if (has_comb) {
        // The comb's (x, y) lives in UV space: carry it to object space with the UV gradients of the
        // triangles around each copy (dp/du, dp/dv), as a tangent frame would.
        std::vector<double> du(3 * n, 0.0), dv(3 * n, 0.0);
        for (size_t f = 0; f + 3 <= tris.size(); f += 3) {
            uint32_t a = tris[f], b = tris[f + 1], c = tris[f + 2];
            double e1[3], e2[3];
            for (int k = 0; k < 3; ++k)
                e1[k] = double(p.positions[3 * b + k]) - p.positions[3 * a + k], e2[k] = double(p.positions[3 * c + k]) - p.positions[3 * a + k];
            double u1 = double(p.uv0[2 * b]) - p.uv0[2 * a], v1 = double(p.uv0[2 * b + 1]) - p.uv0[2 * a + 1];
            double u2 = double(p.uv0[2 * c]) - p.uv0[2 * a], v2 = double(p.uv0[2 * c + 1]) - p.uv0[2 * a + 1];
            double det = u1 * v2 - u2 * v1;
            if (!(std::abs(det) > 1e-20)) continue;
            for (uint32_t v : {a, b, c})
                for (int k = 0; k < 3; ++k) {
                    du[3 * v + k] += (e1[k] * v2 - e2[k] * v1) / det;
                    dv[3 * v + k] += (e2[k] * u1 - e1[k] * u2) / det;
                }
        }
        comb.resize(3 * n);
        for (size_t v = 0; v < n; ++v) {
            double cx = 2.0 * shells_detail::sample_bilinear(opt.comb, 0, p.uv0[2 * v], p.uv0[2 * v + 1]) - 1.0;
            double cy = 2.0 * shells_detail::sample_bilinear(opt.comb, 1, p.uv0[2 * v], p.uv0[2 * v + 1]) - 1.0;
            double lu = std::sqrt(du[3 * v] * du[3 * v] + du[3 * v + 1] * du[3 * v + 1] + du[3 * v + 2] * du[3 * v + 2]);
            double lv = std::sqrt(dv[3 * v] * dv[3 * v] + dv[3 * v + 1] * dv[3 * v + 1] + dv[3 * v + 2] * dv[3 * v + 2]);
            for (int k = 0; k < 3; ++k) {
                double x = (lu > 0 ? cx * du[3 * v + k] / lu : 0) - (lv > 0 ? cy * dv[3 * v + k] / lv : 0); // "up" = −v
                comb[3 * v + k] = float(x);
            }
        }
    }
    return compute_shell_frame(frame, p.positions.data(), n, tris.data(), tris.size(), has_mask ? mask.data() : nullptr,
                               has_comb ? comb.data() : nullptr, o);
}

// Shells of LOD level k: N, N/2, N/4, ... (at least 1).
int layers_of(int N, int k) { return std::max(1, N >> k); }

// Everything a shell vertex is made of, gathered once per output vertex from the base and its frame: each
// shell is then one streaming pass over these arrays (no indirection through the base vertex per shell).
struct ShellSource {
    size_t m = 0;  // output vertices per shell
    Primitive proto; // the attributes every shell copies (normals, UVs, skin, morph deltas)
    std::vector<float> len, dir, root, lean, sag, albedo;
    // Every component of lean (of sag) is +0, bit for bit (no comb; no droop): the shells pass none, which
    // instanced_shell_positions takes as +0, the same bits, and read 12 bytes a vertex less each.
    bool no_lean = false, no_sag = false;
};

ShellSource shell_source(const Grown& g, const ShellVertices& sv, const Primitive& base) {
    ShellSource r;
    const size_t m = sv.src.size();
    r.m = m;
    copy_attributes(r.proto, base, sv.src, sv.uv0);
    r.proto.uv1 = sv.uv1;
    r.len.resize(m), r.dir.resize(3 * m), r.root.resize(3 * m), r.lean.resize(3 * m), r.sag.resize(3 * m), r.albedo.resize(3 * m);
    // Everything a shell vertex is made of, gathered once per output vertex: each shell is then one
    // streaming pass over these arrays (no indirection through the base vertex per shell).
    parallel(m, 4096, [&](size_t i) {
        const uint32_t v = sv.src[i];
        r.len[i] = g.frame.length[v];
        for (size_t k = 0; k < 3; ++k) {
            const size_t j = 3 * size_t(v) + k;
            r.root[3 * i + k] = base.positions[j];
            r.dir[3 * i + k] = g.frame.direction[j];
            r.lean[3 * i + k] = g.frame.lean[j];
            r.sag[3 * i + k] = g.frame.sag[j];
            r.albedo[3 * i + k] = g.albedo[j];
        }
    });
    auto positive_zeros = [](const std::vector<float>& v) {
        return std::all_of(v.begin(), v.end(), [](float x) { return std::bit_cast<uint32_t>(x) == 0; });
    };
    r.no_lean = positive_zeros(r.lean);
    r.no_sag = positive_zeros(r.sag);
    return r;
}

// Positions and colours of shell `layer` of `layers`.
void fill_shell(const ShellSource& r, const FurOptions& opt, int layer, int layers, float* positions, float* colors) {
    // The one shell formula (shell_positions, the instanced layout's reference): copies of a position land on
    // the same float, and an instanced shader rebuilds exactly these positions.
    instanced_shell_positions(positions, r.root.data(), r.dir.data(), r.len.data(), r.no_lean ? nullptr : r.lean.data(),
                              r.no_sag ? nullptr : r.sag.data(), r.m, layer, layers, opt.shells.spacing_power);
    const double s = shell_height_fraction(layer, layers, opt.shells.spacing_power);
    const float shade = float(opt.root_shade + (1.0 - opt.root_shade) * s);
    for (size_t i = 0; i < r.m; ++i) {
        for (size_t k = 0; k < 3; ++k) colors[4 * i + k] = r.albedo[3 * i + k] * shade;
        colors[4 * i + 3] = 1.0f;
    }
}

// The viewer layout of one level: one primitive per shell, each with its own MASK material. One task per
// shell, copies of the shared attributes included: the copying is most of the bytes, so it must not run on
// one thread.
std::vector<Primitive> viewer_shells(const ShellSource& r, const ShellVertices& sv, const FurOptions& opt, int n_k, const std::vector<int>& materials) {
    std::vector<Primitive> shells(static_cast<size_t>(n_k));
    parallel(size_t(n_k), 1, [&](size_t i) {
        Primitive& out = shells[i];
        out = r.proto;
        out.positions.resize(3 * r.m);
        out.colors.resize(4 * r.m);
        fill_shell(r, opt, int(i) + 1, n_k, out.positions.data(), out.colors.data());
        out.indices = sv.indices;
        out.material = materials[i];
    });
    return shells;
}

// The engine layout of one level: all shells in one primitive (every array sized once, each shell fills its
// own slice), with _FUR_LAYER, _FUR_LENGTH and _FUR_DIRECTION for a shader.
Primitive engine_shells(const ShellSource& r, const ShellVertices& sv, const FurOptions& opt, int n_k, int material) {
    Primitive all;
    all.material = material;
    const size_t copies = size_t(n_k);
    auto sized = [&](std::vector<float>& v, const std::vector<float>& per_shell) { v.resize(copies * per_shell.size()); };
    all.positions.resize(copies * 3 * r.m);
    all.colors.resize(copies * 4 * r.m);
    all.indices.resize(copies * sv.indices.size());
    sized(all.normals, r.proto.normals);
    sized(all.uv0, r.proto.uv0);
    sized(all.uv1, r.proto.uv1);
    sized(all.weights, r.proto.weights);
    all.joints.resize(copies * r.proto.joints.size());
    all.targets.resize(r.proto.targets.size());
    for (size_t t = 0; t < r.proto.targets.size(); ++t) {
        sized(all.targets[t].position_deltas, r.proto.targets[t].position_deltas);
        sized(all.targets[t].normal_deltas, r.proto.targets[t].normal_deltas);
    }
    CustomAttribute layer{"_FUR_LAYER", 1, {}}, length{"_FUR_LENGTH", 1, {}}, direction{"_FUR_DIRECTION", 3, {}};
    layer.values.resize(copies * r.m);
    length.values.resize(copies * r.m);
    direction.values.resize(copies * 3 * r.m);
    parallel(copies, 1, [&](size_t i) {
        auto put = [&](std::vector<float>& v, const std::vector<float>& per_shell) {
            std::copy(per_shell.begin(), per_shell.end(), v.begin() + std::ptrdiff_t(i * per_shell.size()));
        };
        fill_shell(r, opt, int(i) + 1, n_k, all.positions.data() + i * 3 * r.m, all.colors.data() + i * 4 * r.m);
        const uint32_t offset = uint32_t(i * r.m);
        uint32_t* idx = all.indices.data() + i * sv.indices.size();
        for (size_t x = 0; x < sv.indices.size(); ++x) idx[x] = offset + sv.indices[x];
        put(all.normals, r.proto.normals);
        put(all.uv0, r.proto.uv0);
        put(all.uv1, r.proto.uv1);
        put(all.weights, r.proto.weights);
        std::copy(r.proto.joints.begin(), r.proto.joints.end(), all.joints.begin() + std::ptrdiff_t(i * r.proto.joints.size()));
        for (size_t t = 0; t < r.proto.targets.size(); ++t) {
            put(all.targets[t].position_deltas, r.proto.targets[t].position_deltas);
            put(all.targets[t].normal_deltas, r.proto.targets[t].normal_deltas);
        }
        std::fill_n(layer.values.begin() + std::ptrdiff_t(i * r.m), r.m, float(shell_height_fraction(int(i) + 1, n_k, opt.shells.spacing_power)));
        put(length.values, r.len);
        put(direction.values, r.dir);
    });
    all.custom = {std::move(layer), std::move(length), std::move(direction)};
    return all;
}

// The instanced layout's shell base: the kept base triangles once, at the roots, with what a vertex shader
// needs to place any shell (instanced_shell_positions) and colour it (COLOR_0 = albedo; the shader multiplies
// by root_shade + (1 − root_shade)·s). _FUR_LEAN and _FUR_SAG only when some vertex has comb or droop.
// `sv` is the level's base: the full one, or its simplification (FurOptions::lod_simplify_error).
Primitive instanced_base(const ShellSource& r, const ShellVertices& sv, int material) {
    Primitive b = r.proto;
    b.material = material;
    b.positions = r.root;
    b.indices = sv.indices;
    b.colors.resize(4 * r.m);
    for (size_t i = 0; i < r.m; ++i) {
        for (size_t k = 0; k < 3; ++k) b.colors[4 * i + k] = r.albedo[3 * i + k];
        b.colors[4 * i + 3] = 1.0f;
    }
    b.custom = {CustomAttribute{"_FUR_DIRECTION", 3, r.dir}, CustomAttribute{"_FUR_LENGTH", 1, r.len}};
    auto nonzero = [](const std::vector<float>& v) { return std::any_of(v.begin(), v.end(), [](float x) { return x != 0.0f; }); };
    if (nonzero(r.lean)) b.custom.push_back(CustomAttribute{"_FUR_LEAN", 3, r.lean});
    if (nonzero(r.sag)) b.custom.push_back(CustomAttribute{"_FUR_SAG", 3, r.sag});
    return b;
}

// Fins: a quad standing on every manifold edge of the welded mesh, from the base to the tips.
std::optional<Primitive> fins_of(const Grown& g, const std::vector<uint32_t>& tris, const Primitive& base, const FurOptions& opt,
                                 double scale, int material, size_t& quads) {
    const size_t n = base.vertex_count();
    std::vector<uint32_t> remap(n);
    weld_positions(remap.data(), base.positions.data(), n);
    std::map<std::pair<uint32_t, uint32_t>, std::vector<std::pair<size_t, int>>> edges; // welded edge -> (face, corner)
    const size_t T = tris.size() / 3;
    for (size_t f = 0; f < T; ++f)
        for (int c = 0; c < 3; ++c) {
            uint32_t a = remap[tris[3 * f + c]], b = remap[tris[3 * f + (c + 1) % 3]];
            if (a == b) continue;
            edges[{std::min(a, b), std::max(a, b)}].push_back({f, c});
        }
    Primitive fins;
    fins.material = material;
    std::vector<uint32_t> src;
    std::vector<float> fin_uv, fin_normal;
    std::vector<uint8_t> is_tip;
    auto face_normal = [&](size_t f) {
        const float* p0 = &base.positions[3 * size_t(tris[3 * f])];
        const float* p1 = &base.positions[3 * size_t(tris[3 * f + 1])];
        const float* p2 = &base.positions[3 * size_t(tris[3 * f + 2])];
        double e1[3] = {double(p1[0]) - p0[0], double(p1[1]) - p0[1], double(p1[2]) - p0[2]};
        double e2[3] = {double(p2[0]) - p0[0], double(p2[1]) - p0[1], double(p2[2]) - p0[2]};
        std::array<double, 3> c{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        double l = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        if (l > 0) c = {c[0] / l, c[1] / l, c[2] / l};
        return c;
    };
    const double fin_span = 2.0 * std::max(opt.shells.length / scale, 1e-12); // object units per texture width
    for (const auto& [key, uses] : edges) {
        if (uses.size() != 2) continue;
        const auto [f, c] = uses[0];
        uint32_t a = tris[3 * f + size_t(c)], b = tris[3 * f + size_t((c + 1) % 3)];
        if (!(g.frame.length[a] > 0 || g.frame.length[b] > 0)) continue;
        double el = 0;
        for (int k = 0; k < 3; ++k) el += std::pow(double(base.positions[3 * b + k]) - base.positions[3 * a + k], 2);
        el = std::sqrt(el);
        // A per-edge offset along the texture, from the edge's welded ids, so neighbouring fins differ.
        const double u0 = double((uint64_t(key.first) * 2654435761ULL + key.second * 40503ULL) % 1024ULL) / 1024.0;
        const double u1 = u0 + el / fin_span;
        auto n0 = face_normal(f), n1 = face_normal(uses[1].first);
        std::array<double, 3> fnrm{n0[0] + n1[0], n0[1] + n1[1], n0[2] + n1[2]};
        double fl = std::sqrt(fnrm[0] * fnrm[0] + fnrm[1] * fnrm[1] + fnrm[2] * fnrm[2]);
        if (fl > 0) fnrm = {fnrm[0] / fl, fnrm[1] / fl, fnrm[2] / fl};
        const uint32_t first = uint32_t(src.size());
        const uint32_t corners[4] = {a, b, b, a};
        const double us[4] = {u0, u1, u1, u0}, vs[4] = {1, 1, 0, 0};
        for (int q = 0; q < 4; ++q) {
            src.push_back(corners[q]);
            is_tip.push_back(q >= 2);
            fin_uv.push_back(tile_coord(us[q])); // edge / fin span overflowed a float too (fuzz_shells)
            fin_uv.push_back(float(vs[q]));
            for (int k = 0; k < 3; ++k) fin_normal.push_back(float(fnrm[size_t(k)]));
        }
        // Both windings are drawn (double-sided material); this one faces the first face's side.
        fins.indices.insert(fins.indices.end(), {first, first + 1, first + 2, first, first + 2, first + 3});
        ++quads;
    }
    if (src.empty()) return std::nullopt;
    copy_attributes(fins, base, src, fin_uv);
    fins.uv0 = fin_uv;
    const size_t fm = src.size();
    fins.positions.resize(3 * fm);
    fins.colors.resize(4 * fm);
    for (size_t i = 0; i < fm; ++i) {
        const uint32_t v = src[i];
        const double h = is_tip[i] ? g.frame.length[v] : 0.0;
        const auto tip = shells_detail::strand_offset(&g.frame.direction[3 * v], &g.frame.lean[3 * v], &g.frame.sag[3 * v], 1.0);
        for (int k = 0; k < 3; ++k) {
            const size_t j = 3 * size_t(v) + size_t(k);
            fins.positions[3 * i + k] = float(double(base.positions[j]) + h * tip[size_t(k)]);
            fins.colors[4 * i + k] = g.albedo[3 * v + k] * float(is_tip[i] ? 1.0 : opt.root_shade);
        }
        fins.colors[4 * i + 3] = 1.0f;
    }
    fins.custom.push_back(CustomAttribute{"_FUR_FIN_NORMAL", 3, fin_normal});
    return fins;
}

// Model only what is there: a triangle whose three corners are bald would sit on the skin. `dropped` counts
// the others.
std::vector<uint8_t> kept_faces(const std::vector<uint32_t>& tris, const ShellFrame& frame, size_t& dropped) {
    const size_t T = tris.size() / 3;
    std::vector<uint8_t> keep(T, 0);
    for (size_t f = 0; f < T; ++f)
        keep[f] = frame.length[tris[3 * f]] > 0 || frame.length[tris[3 * f + 1]] > 0 || frame.length[tris[3 * f + 2]] > 0;
    dropped = T - size_t(std::count(keep.begin(), keep.end(), uint8_t(1)));
    return keep;
}

// FurOptions::lod_simplify_error: the simplified base of every LOD level k >= 1 (simplify_lod.cpp) with its
// shell vertex set, and per level its base triangles and meshopt's error in the report.
void simplify_levels(Grown& g, const Primitive& base, const FurOptions& opt, double tile_obj, FurReport& rep) {
    const int levels = opt.shells.lod_levels;
    rep.lod_base_triangles.resize(size_t(levels), 0);
    rep.lod_simplify_error.resize(size_t(levels), 0.0);
    const bool simplify = opt.lod_simplify_error > 0;
    for (int k = 0; k < levels; ++k) {
        if (k == 0 || !simplify) {
            rep.lod_base_triangles[size_t(k)] += g.tris.size() / 3;
            continue;
        }
        shells_detail::SimplifiedBase sb = shells_detail::simplify_base(base, g.tris, k, opt.lod_simplify_error);
        Grown::Level lv;
        lv.tris = std::move(sb.tris);
        lv.sv = shell_vertices(base, lv.tris, kept_faces(lv.tris, g.frame, lv.dropped), tile_obj);
        rep.lod_base_triangles[size_t(k)] += lv.tris.size() / 3;
        rep.lod_simplify_error[size_t(k)] = std::max(rep.lod_simplify_error[size_t(k)], sb.relative_error);
        g.lods.push_back(std::move(lv));
    }
}

// The frame and shell vertex set of one base primitive (refined where clamps starve its faces), after the
// checks that must pass before the scene changes.
Status grow_base(Grown& g, const Scene& scene, const Placement& pl, const FurOptions& opt, size_t all_base, FurReport& rep) {
    const Primitive& p = scene.meshes[g.mesh].primitives[g.prim];
    const size_t n = p.vertex_count();
    if (!p.face_sizes.empty()) {
        Primitive t;
        t.indices = p.indices;
        t.face_sizes = p.face_sizes;
        triangulate(t);
        g.tris = std::move(t.indices);
    } else {
        g.tris = p.indices;
    }
    for (uint32_t i : g.tris)
        if (i >= n) return Status::error(StatusCode::invalid_input, "mesh " + std::to_string(g.mesh) + ": index out of range");
    // Shells are offsets of the base positions: one NaN or infinite corner puts NaN into the shells and their
    // strand UVs (found by fuzz_shells). load_scene refuses such positions unless allow_non_finite is set.
    for (uint32_t i : g.tris)
        if (!std::isfinite(p.positions[3 * size_t(i)]) || !std::isfinite(p.positions[3 * size_t(i) + 1]) ||
            !std::isfinite(p.positions[3 * size_t(i) + 2]))
            return Status::error(StatusCode::invalid_input, "mesh " + std::to_string(g.mesh) + " primitive " +
                                                                std::to_string(g.prim) + ": a triangle corner has a non-finite position");
    ShellOptions o = opt.shells;
    o.length = opt.shells.length / pl.scale;
    o.gravity = pl.gravity;
    Status s = grow_frame(g.frame, p, g.tris, opt, o);
    if (s.ok() && opt.refine_starved) {
        // Coarse faces whose corners are all clamped: bisected until fur grows inside them (the base
        // primitive is then replaced by its refinement, committed with the shells).
        Primitive q; // p's refinement (a copy made at the first split)
        shells_detail::Refinement refined;
        s = shells_detail::refine_starved_faces(p, q, g.tris, g.frame, o.length,
                                         [&](const Primitive& r, const std::vector<uint32_t>& t, ShellFrame& f) { return grow_frame(f, r, t, opt, o); },
                                         refine_budget(g.tris.size() / 3, all_base, opt), opt.refine_tolerance, refined);
        if (s.ok() && refined.faces_split > 0) {
            q.indices = g.tris;
            q.face_sizes.clear();
            g.refined = std::move(q);
            rep.refined_faces += refined.faces_split;
            rep.refine_rounds += refined.rounds;
        }
    }
    if (!s.ok()) return Status::error(s.code, "mesh " + std::to_string(g.mesh) + " primitive " + std::to_string(g.prim) + ": " + s.message);
    const size_t T = g.tris.size() / 3;
    const double tile_world = opt.tile_size > 0 ? opt.tile_size : 4.0 * std::max(opt.shells.length, 1e-12);
    g.sv = shell_vertices(base_of(scene, g), g.tris, kept_faces(g.tris, g.frame, g.dropped), tile_world / pl.scale);
    simplify_levels(g, base_of(scene, g), opt, tile_world / pl.scale, rep);
    if (opt.keep_frames) rep.frames.push_back(FurFrame{g.mesh, g.prim, o.length, g.tris, g.frame});
    rep.primitives += 1;
    rep.base_triangles += T;
    rep.welded_vertices += g.frame.welded_vertices;
    rep.clamped_vertices += g.frame.clamped_vertices;
    rep.clamped_by_ray += g.frame.clamped_by_ray;
    rep.clamped_by_fold += g.frame.clamped_by_fold;
    rep.clamped_by_even_cap += g.frame.clamped_by_even_cap;
    rep.bald_vertices += g.frame.bald_vertices;
    return Status::success();
}

// Alpha cutoff of shell i (1..n) of a level with n of the N shells. Shell i sits at s(i/n) and stands for the
// slab of strands between its neighbours. Its cutoff shows the strands' cross-section at the middle of the
// lowest full-resolution layer of that slab: s((i − 1/2)/N) with all N shells (so the top shell still shows
// the tips), and with fewer, thicker slabs the wider, lower part of each cone, which keeps a coarse level as
// dense as the full one (strand thickness compensated).
float shell_cutoff(int i, int n, const ShellOptions& so) {
    const double t = double(i - 1) / double(n) + 0.5 / double(so.layers);
    return float(std::clamp(std::pow(t, so.spacing_power), 1.0 / 255.0, 1.0));
}

// The materials: one per shell and level (viewer layout) or one for all (engine, instanced), and the fins'.
struct ShellMaterials {
    std::vector<std::vector<int>> shell; // [level][shell i - 1], viewer layout
    int engine = -1, fins = -1;          // engine: the engine and instanced layouts' one shell material
    int strand_texture = -1;
};

ShellMaterials add_fur_materials(Scene& scene, const FurOptions& opt, const std::vector<uint8_t>& density_png,
                                 const std::vector<uint8_t>* fin_png) {
    const ShellOptions& so = opt.shells;
    ShellMaterials mat;
    const int density_tex = add_texture(scene, "fur_strands", density_png, 10497);
    if (opt.fins) {
        const int fin_tex = add_texture(scene, "fur_fins", *fin_png, 33071);
        mat.fins = add_material(scene, "fur_fins", fin_tex, 0, 0.5f, true);
    }
    const int N = so.layers, levels = so.lod_levels;
    mat.strand_texture = density_tex;
    mat.shell.resize(size_t(levels));
    if (opt.layout == ShellLayout::viewer) {
        for (int k = 0; k < levels; ++k)
            for (int i = 1; i <= layers_of(N, k); ++i)
                mat.shell[size_t(k)].push_back(add_material(
                    scene, "fur_shell_" + (levels > 1 ? "lod" + std::to_string(k) + "_" : std::string()) + std::to_string(i), density_tex, 1,
                    shell_cutoff(i, layers_of(N, k), so), false));
    } else {
        // The cutoff is the shader's, per shell (engine: from _FUR_LAYER; instanced: FURROW_shells.cutoffs).
        mat.engine = add_material(scene, opt.layout == ShellLayout::engine ? "fur_shells_engine" : "fur_shells_instanced",
                                  density_tex, 1, 0.5f, false);
    }
    return mat;
}

// The shells (every level) and fins of one grown base, appended to added[level][mesh]; in the instanced
// layout, its shell base instead of the shells, appended to bases[level][mesh] (levels k >= 1 only when they
// grow on a simplified base: otherwise every level draws level 0's).
void emit_grown(const Grown& g, const Primitive& base, const FurOptions& opt, const ShellMaterials& mat, double scale,
                size_t original_meshes, std::vector<std::vector<Primitive>>& added, std::vector<std::vector<Primitive>>& bases,
                FurReport& rep) {
    if (g.sv.src.empty()) return;
    const ShellSource r = shell_source(g, g.sv, base);
    const int levels = opt.shells.lod_levels;
    if (opt.layout == ShellLayout::instanced) {
        bases[g.mesh].push_back(instanced_base(r, g.sv, mat.engine));
        rep.shell_triangles += g.sv.indices.size() / 3;
        rep.dropped_triangles += g.dropped;
        for (size_t k = 1; k <= g.lods.size(); ++k) {
            const Grown::Level& lv = g.lods[k - 1];
            bases[k * original_meshes + g.mesh].push_back(instanced_base(shell_source(g, lv.sv, base), lv.sv, mat.engine));
            rep.shell_triangles += lv.sv.indices.size() / 3;
        }
    }
    for (int k = 0; k < levels && opt.layout != ShellLayout::instanced; ++k) {
        // Level k's base: the full one, or its simplification (then its own shell vertices).
        const bool own = k > 0 && !g.lods.empty();
        const ShellVertices& sv = own ? g.lods[size_t(k - 1)].sv : g.sv;
        const std::optional<ShellSource> rk = own ? std::optional<ShellSource>(shell_source(g, sv, base)) : std::nullopt;
        const ShellSource& src = rk ? *rk : r;
        const int n_k = layers_of(opt.shells.layers, k);
        std::vector<Primitive>& dst = added[size_t(k) * original_meshes + g.mesh];
        if (opt.layout == ShellLayout::viewer) {
            for (auto& sh : viewer_shells(src, sv, opt, n_k, mat.shell[size_t(k)])) {
                rep.shell_triangles += sh.indices.size() / 3;
                dst.push_back(std::move(sh));
            }
        } else {
            dst.push_back(engine_shells(src, sv, opt, n_k, mat.engine));
            rep.shell_triangles += dst.back().indices.size() / 3;
        }
        rep.dropped_triangles += (own ? g.lods[size_t(k - 1)].dropped : g.dropped) * size_t(n_k);
    }
    if (!opt.fins) return;
    // Fins stand on the edges of each level's own base; fin_quads counts level 0's.
    std::optional<Primitive> fins = fins_of(g, g.tris, base, opt, scale, mat.fins, rep.fin_quads);
    for (int k = 0; k < levels && fins; ++k) {
        size_t uncounted = 0;
        const bool own = k > 0 && !g.lods.empty();
        std::optional<Primitive> fk = own ? fins_of(g, g.lods[size_t(k - 1)].tris, base, opt, scale, mat.fins, uncounted) : fins;
        if (!fk) continue;
        rep.shell_triangles += fk->indices.size() / 3;
        added[size_t(k) * original_meshes + g.mesh].push_back(std::move(*fk));
    }
}

// A node outside the default scene drawing `mesh` where node `src_node` draws its source: same skin and
// morph weights, or (not skinned) the source's world matrix. Returns its index.
int add_offscene_node(Scene& scene, int mesh, int src_node, const std::vector<Mat4>& world, const std::string& name) {
    const Node& src = scene.nodes[size_t(src_node)];
    Node node;
    node.name = name;
    node.mesh = mesh;
    node.skin = src.skin;
    node.weights = src.weights;
    if (src.skin < 0) { // a skinned mesh ignores its node's transform (glTF 2.0, 3.7.3.3)
        node.has_matrix = true;
        node.matrix = world[size_t(src_node)];
    }
    scene.nodes.push_back(std::move(node));
    return int(scene.nodes.size()) - 1;
}

std::string node_name(const Scene& scene, int node, size_t mesh) {
    const std::string& n = scene.nodes[size_t(node)].name;
    return n.empty() ? "mesh" + std::to_string(mesh) : n;
}

// A JSON number: floats with the 9 digits that give them back exactly, doubles with 17.
std::string json_number(double x, int digits) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.*g", digits, x);
    return buf;
}

// The instanced layout's extras, {"FURROW_shells": {...}}: everything a renderer needs besides the per-vertex
// attributes, per LOD level the shell heights s and alpha cutoffs and, when the level grows on a simplified
// base, the index of that base's mesh (README "Instanced layout"). level_mesh[k] < 0: level 0's base.
std::string furrow_shells_extras(const FurOptions& opt, const ShellMaterials& mat, bool lean, bool sag,
                                 const std::vector<int>& level_mesh) {
    const ShellOptions& so = opt.shells;
    std::string j = "{\"FURROW_shells\":{\"version\":1,\"layers\":";
    j += std::to_string(so.layers);
    j += ",\"spacing_power\":";
    j += json_number(so.spacing_power, 17);
    j += ",\"root_shade\":";
    j += json_number(opt.root_shade, 17);
    j += ",\"material\":";
    j += std::to_string(mat.engine);
    j += ",\"strand_texture\":";
    j += std::to_string(mat.strand_texture);
    j += ",\"strand_texcoord\":1,\"attributes\":{\"direction\":\"_FUR_DIRECTION\",\"length\":\"_FUR_LENGTH\"";
    if (lean) j += ",\"lean\":\"_FUR_LEAN\"";
    if (sag) j += ",\"sag\":\"_FUR_SAG\"";
    j += "},\"levels\":[";
    for (int k = 0; k < so.lod_levels; ++k) {
        const int n = layers_of(so.layers, k);
        std::string heights, cutoffs;
        for (int i = 1; i <= n; ++i) {
            if (i > 1) heights += ',', cutoffs += ',';
            heights += json_number(shell_height_fraction(i, n, so.spacing_power), 17);
            cutoffs += json_number(shell_cutoff(i, n, so), 9);
        }
        if (k > 0) j += ',';
        j += "{\"layers\":";
        j += std::to_string(n);
        if (size_t(k) < level_mesh.size() && level_mesh[size_t(k)] >= 0) {
            j += ",\"mesh\":";
            j += std::to_string(level_mesh[size_t(k)]);
        }
        j += ",\"heights\":[";
        j += heights;
        j += "],\"cutoffs\":[";
        j += cutoffs;
        j += "]}";
    }
    j += "]}}";
    return j;
}

// The instanced layout's shell bases: per furred mesh, a mesh "<mesh>_fur_shells" of its shell bases (with
// the base's morph weights) on a node "<node>_fur_shells" outside the default scene, and per LOD level k >= 1
// grown on a simplified base, "<mesh>_fur_shells_lod<k>" on "<node>_fur_shells_lod<k>", named by level 0's extras.
void attach_instanced(Scene& scene, std::vector<std::vector<Primitive>>& bases, const std::vector<int>& mesh_node,
                      const std::vector<Mat4>& world, const FurOptions& opt, const ShellMaterials& mat, FurReport& rep) {
    const size_t original_meshes = mesh_node.size(), levels = size_t(opt.shells.lod_levels);
    for (size_t mi = 0; mi < original_meshes; ++mi) {
        if (bases[mi].empty()) continue;
        auto has = [&](const char* name) {
            for (size_t k = 0; k < levels; ++k)
                for (const Primitive& p : bases[k * original_meshes + mi])
                    for (const CustomAttribute& c : p.custom)
                        if (c.name == name) return true;
            return false;
        };
        const bool lean = has("_FUR_LEAN"), sag = has("_FUR_SAG");
        std::vector<int> level_mesh(levels, -1);
        const std::string node = node_name(scene, mesh_node[mi], mi);
        for (size_t k = 0; k < levels; ++k) {
            std::vector<Primitive>& prims = bases[k * original_meshes + mi];
            if (prims.empty()) continue;
            // Every primitive of a glTF mesh carries the same attributes: zero lean/sag where one base has none.
            // (A plain pair, not a structured binding: clang 14 cannot capture a binding in the lambda.)
            for (const std::pair<const char*, bool>& attribute : {std::pair{"_FUR_LEAN", lean}, std::pair{"_FUR_SAG", sag}}) {
                const std::string name = attribute.first;
                if (!attribute.second) continue;
                for (Primitive& p : prims)
                    if (std::none_of(p.custom.begin(), p.custom.end(), [&](const CustomAttribute& c) { return c.name == name; }))
                        p.custom.push_back(CustomAttribute{name, 3, std::vector<float>(3 * p.vertex_count(), 0.0f)});
            }
            const std::string suffix = k == 0 ? "_fur_shells" : "_fur_shells_lod" + std::to_string(k);
            Mesh m;
            m.name = scene.meshes[mi].name + suffix;
            m.weights = scene.meshes[mi].weights;
            rep.shell_primitives += prims.size();
            m.primitives = std::move(prims);
            scene.meshes.push_back(std::move(m));
            level_mesh[k] = int(scene.meshes.size()) - 1;
            const int n = add_offscene_node(scene, level_mesh[k], mesh_node[mi], world, node + suffix);
            (k == 0 ? rep.shell_nodes : rep.lod_nodes).push_back(n);
        }
        const int own = level_mesh[0];
        level_mesh[0] = -1;
        scene.meshes[size_t(own)].extras_json = furrow_shells_extras(opt, mat, lean, sag, level_mesh);
    }
}

// Refined bases in place of their originals; level 0 into the meshes themselves; level k >= 1 into copies on
// nodes outside the scene.
void attach(Scene& scene, std::vector<Grown>& grown, std::vector<std::vector<Primitive>>& added, const std::vector<int>& mesh_node,
            const std::vector<Mat4>& world, int levels, size_t original_meshes, FurReport& rep) {
    for (Grown& g : grown)
        if (g.refined) {
            scene.meshes[g.mesh].primitives[g.prim] = std::move(*g.refined);
            g.refined.reset();
        }
    for (size_t mi = 0; mi < original_meshes; ++mi) {
        auto& lvl0 = added[mi];
        if (lvl0.empty()) continue;
        std::vector<Primitive> base_prims; // the LOD meshes' own copy of the skin (none without LOD levels)
        if (levels > 1) base_prims = scene.meshes[mi].primitives;
        for (auto& p : lvl0) {
            scene.meshes[mi].primitives.push_back(std::move(p));
            ++rep.shell_primitives;
        }
        for (int k = 1; k < levels; ++k) {
            Mesh lod;
            lod.name = scene.meshes[mi].name + "_fur_lod" + std::to_string(k);
            lod.weights = scene.meshes[mi].weights;
            lod.primitives = base_prims;
            for (auto& p : added[size_t(k) * original_meshes + mi]) {
                lod.primitives.push_back(std::move(p));
                ++rep.shell_primitives;
            }
            scene.meshes.push_back(std::move(lod));
            rep.lod_nodes.push_back(add_offscene_node(scene, int(scene.meshes.size()) - 1, mesh_node[mi], world,
                                                      node_name(scene, mesh_node[mi], mi) + "_fur_lod" + std::to_string(k)));
        }
    }
}

// The meshes the scene draws, each placed by its first such node (-1: not drawn).
std::vector<int> drawn_mesh_nodes(const Scene& scene) {
    std::vector<int> mesh_node(scene.meshes.size(), -1);
    for (int i : scene.drawn_nodes()) {
        const int m = scene.nodes[size_t(i)].mesh;
        if (m >= 0 && m < int(scene.meshes.size()) && mesh_node[size_t(m)] < 0) mesh_node[size_t(m)] = i;
    }
    return mesh_node;
}

// The base primitives to grow fur on (triangles of drawn meshes), checked before anything is added.
Status collect_work(std::vector<std::pair<size_t, size_t>>& work, const Scene& scene, const std::vector<int>& mesh_node,
                    const FurOptions& opt) {
    const bool has_mask = !opt.mask.pixels.empty(), has_comb = !opt.comb.pixels.empty();
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
        if (mesh_node[mi] < 0) continue;
        const Mesh& mesh = scene.meshes[mi];
        for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
            const Primitive& p = mesh.primitives[pi];
            if (p.mode != PrimitiveMode::triangles || p.vertex_count() == 0 || p.triangle_count() == 0) continue;
            if ((has_mask || has_comb) && p.uv0.size() != 2 * p.vertex_count())
                return Status::error(StatusCode::invalid_argument,
                                     "mesh " + std::to_string(mi) + (mesh.name.empty() ? "" : " ('" + mesh.name + "')") + " primitive " +
                                         std::to_string(pi) + " has no TEXCOORD_0; " + (has_mask ? "a fur mask" : "a comb map") +
                                         " is sampled at the UVs");
            work.emplace_back(mi, pi);
        }
    }
    if (work.empty()) return Status::error(StatusCode::invalid_input, "no triangles to grow fur on");
    return check_triangle_limit(scene, work, opt);
}

} // namespace

Status validate(const FurOptions& opt) {
    auto bad = [](const std::string& m) { return Status::error(StatusCode::invalid_argument, m); };
    if (Status s = validate(opt.shells); !s.ok()) return s;
    if (!std::isfinite(opt.tile_size) || opt.tile_size < 0) return bad("tile size must be a finite number >= 0");
    if (!(opt.root_shade >= 0 && opt.root_shade <= 1)) return bad("root shade must be in 0..1");
    if (!(opt.lod_simplify_error >= 0 && opt.lod_simplify_error <= 1)) return bad("LOD simplify error must be in 0..1");
    if (!(opt.refine_tolerance >= 0 && opt.refine_tolerance <= 1)) return bad("refine tolerance must be in 0..1");
    if (!opt.mask.pixels.empty()) {
        const ImageF& m = opt.mask;
        if (m.width <= 0 || m.height <= 0 || m.channels <= 0 || m.pixels.size() != size_t(m.width) * size_t(m.height) * size_t(m.channels))
            return bad("the mask image is malformed");
        if (opt.mask_channel < 0 || opt.mask_channel >= m.channels)
            return bad("the mask has " + std::to_string(m.channels) + " channel(s); channel " + std::to_string(opt.mask_channel) +
                       " does not exist");
    }
    const ImageF& c = opt.comb;
    if (!c.pixels.empty() && (c.channels < 2 || c.pixels.size() != size_t(c.width) * size_t(c.height) * size_t(c.channels)))
        return bad("the comb map needs at least 2 channels (r = along u, g = up the image)");
    return Status::success();
}

Status add_fur_shells(Scene& scene, const FurOptions& opt, FurReport* report) {
    return kernel::no_throw("adding fur shells", [&]() -> Status {
        const auto started = std::chrono::steady_clock::now();
        FurReport local;
        FurReport& rep = report ? *report : local;
        rep = FurReport{};
        // --- options and input, checked before anything is added to the scene
        if (Status s = validate(opt); !s.ok()) return s;
        const std::vector<Mat4> world = scene.world_matrices();
        const std::vector<int> mesh_node = drawn_mesh_nodes(scene);
        std::vector<std::pair<size_t, size_t>> work;
        if (Status s = collect_work(work, scene, mesh_node, opt); !s.ok()) return s;
        const size_t all_base = base_triangles(scene, work);

        // The strand textures depend on the options alone: drawn and encoded (or found in the cache) on another
        // core while the frames are computed, as are the base-colour textures (below). Waited for on every way
        // out.
        std::shared_ptr<const std::vector<uint8_t>> density_png, fin_png;
        TextureCache cache; // before the task group: its tasks write into it until they are waited for
        tbb::task_group texture_task;
        struct Join {
            tbb::task_group& g;
            ~Join() { g.wait(); }
        } join_textures{texture_task};
        texture_task.run([&] {
            density_png = shells_detail::strand_texture_png(opt.strands, false);
            if (opt.fins) fin_png = shells_detail::strand_texture_png(opt.strands, true);
        });

        // --- grow: the frame and the vertex set per base primitive
        std::vector<Grown> grown(work.size());
        std::vector<Placement> placement(scene.meshes.size());
        for (size_t mi = 0; mi < scene.meshes.size(); ++mi)
            if (mesh_node[mi] >= 0) placement[mi] = placement_of(scene, world, mesh_node[mi], opt.shells.gravity);
        for (const auto& [mi, pi] : work) cache.prefetch(scene, scene.meshes[mi].primitives[pi], texture_task);
        for (size_t wi = 0; wi < work.size(); ++wi) {
            Grown& g = grown[wi];
            g.mesh = work[wi].first;
            g.prim = work[wi].second;
            if (Status s = grow_base(g, scene, placement[g.mesh], opt, all_base, rep); !s.ok()) return s;
        }
        texture_task.wait();
        for (Grown& g : grown) g.albedo = vertex_albedo(scene, base_of(scene, g), cache);
        // --- textures and materials (appended: existing indices stay valid)
        const ShellMaterials mat = add_fur_materials(scene, opt, *density_png, fin_png.get());

        // --- emit the primitives of every level, then attach them
        const auto setup_done = std::chrono::steady_clock::now();
        rep.setup_seconds = std::chrono::duration<double>(setup_done - started).count();
        const size_t original_meshes = scene.meshes.size();
        std::vector<std::vector<Primitive>> added(size_t(opt.shells.lod_levels) * original_meshes); // [level][mesh]
        std::vector<std::vector<Primitive>> bases(size_t(opt.shells.lod_levels) * original_meshes); // instanced: [level][mesh]
        for (const Grown& g : grown)
            emit_grown(g, base_of(scene, g), opt, mat, placement[g.mesh].scale, original_meshes, added, bases, rep);
        attach(scene, grown, added, mesh_node, world, opt.shells.lod_levels, original_meshes, rep);
        attach_instanced(scene, bases, mesh_node, world, opt, mat, rep);
        rep.emit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_done).count();
        return Status::success();
    });
}

} // namespace furrow

// The scene pipeline of `furrow stamp`: heightmap from colliders → adaptive tessellation of the ground where
// the heightmap has detail → displacement with welded normals → primitives rebuilt with their materials.
//
// References: the seed technique ("Fancy Shaders part 3": tessellated ground displaced by a stamped
// heightmap); OpenSubdiv Bfr tessellation (via furrow::tessellate, bilinear scheme so the ground keeps its
// shape: the surface of a bilinear-subdivided triangle is the triangle itself); DiagSplit (M. Fisher et al.,
// "DiagSplit: Parallel, Crack-free, Adaptive Tessellation for Micropolygon Rendering", SIGGRAPH Asia 2009)
// for edge rates that depend on the edge alone — here the larger detail rate of the edge's two faces, so both
// faces agree and no crack opens. The tessellation is a separate step (tessellate_ground) with a plain
// triangles-in, triangles-out boundary.
#include "deform_internal.h"

#include <furrow/tessellate.h>
#include <furrow_kernel/no_throw.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <unordered_map>

namespace furrow {

using namespace deform_detail;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

using Mat = std::array<double, 16>; // column-major

Vec3 xform_point(const Mat& m, const Vec3& p) {
    return {m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12], m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13],
            m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14]};
}

// Inverse of an affine matrix; false if singular.
bool invert_affine(const Mat& m, Mat& out) {
    const double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6], i = m[10];
    const double A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
    const double det = a * A + b * B + c * C;
    if (!(std::abs(det) > 1e-300) || !std::isfinite(det)) return false;
    const double inv = 1.0 / det;
    // Rows of the inverse 3x3.
    const double r[9] = {A * inv, -(b * i - c * h) * inv, (b * f - c * e) * inv,
                         B * inv, (a * i - c * g) * inv, -(a * f - c * d) * inv,
                         C * inv, -(a * h - b * g) * inv, (a * e - b * d) * inv};
    out = {r[0], r[3], r[6], 0, r[1], r[4], r[7], 0, r[2], r[5], r[8], 0, 0, 0, 0, 1};
    const Vec3 t = xform_point(out, Vec3{m[12], m[13], m[14]});
    out[12] = -t.x, out[13] = -t.y, out[14] = -t.z;
    return true;
}

std::vector<uint32_t> triangle_indices(const Primitive& p) {
    if (p.face_sizes.empty()) return p.indices;
    Primitive q;
    q.indices = p.indices;
    q.face_sizes = p.face_sizes;
    q.positions = p.positions;
    triangulate(q);
    return q.indices;
}

bool is_ground_primitive(const Primitive& p) { return p.mode == PrimitiveMode::triangles && p.positions.size() >= 9 && !p.indices.empty(); }

// ---- the mesh being deformed, in world space, all its triangle primitives concatenated ------------------
struct WorkMesh {
    std::vector<float> positions;  // world
    std::vector<uint32_t> indices; // triangles
    std::vector<uint32_t> groups;  // per triangle: slot in `prims`
    std::vector<float> uvs;        // uv0 if every primitive has it
    struct Channel {
        std::string name; // "uv1", "color", or a custom attribute's name
        int components = 0;
        std::vector<float> values;
    };
    std::vector<Channel> channels;
};

// Pairs of welded points -> the rate both faces of the edge agree on (DiagSplit: a function of the edge only).
struct EdgeRates {
    struct Key {
        uint32_t bits[6];
        bool operator==(const Key& o) const { return std::equal(bits, bits + 6, o.bits); }
    };
    struct Hash {
        size_t operator()(const Key& k) const {
            uint64_t h = 1469598103934665603ull;
            for (uint32_t b : k.bits) h = (h ^ b) * 1099511628211ull;
            return size_t(h);
        }
    };
    std::unordered_map<Key, int, Hash> rate;

    static Key key(const float* a, const float* b) {
        Key k;
        float fa[3] = {a[0] + 0.0f, a[1] + 0.0f, a[2] + 0.0f}, fb[3] = {b[0] + 0.0f, b[1] + 0.0f, b[2] + 0.0f}; // −0 == +0
        if (std::lexicographical_compare(fb, fb + 3, fa, fa + 3)) std::swap(fa, fb);
        std::memcpy(k.bits, fa, 12);
        std::memcpy(k.bits + 3, fb, 12);
        return k;
    }
    void build(const float* P, const uint32_t* idx, size_t tris, const std::vector<int>& face_rate) {
        rate.reserve(tris * 2);
        for (size_t t = 0; t < tris; ++t) {
            if (face_rate[t] <= 1) continue;
            for (int c = 0; c < 3; ++c) {
                const float* a = P + 3 * size_t(idx[3 * t + size_t(c)]);
                const float* b = P + 3 * size_t(idx[3 * t + size_t((c + 1) % 3)]);
                int& r = rate[key(a, b)];
                r = std::max(r, face_rate[t]);
            }
        }
    }
    double operator()(const float* a, const float* b) const {
        auto it = rate.find(key(a, b));
        return it == rate.end() ? 1.0 : double(it->second);
    }
};

// One tessellation pass with per-triangle rates; the result replaces `m`.
Status tessellate_pass(WorkMesh& m, const std::vector<int>& face_rate, const StampOptions& o, StampReport& rep) {
    EdgeRates edges;
    edges.build(m.positions.data(), m.indices.data(), m.indices.size() / 3, face_rate);
    if (edges.rate.empty()) return Status::success();
    TessellateInput in;
    in.positions = m.positions.data();
    in.vertex_count = m.positions.size() / 3;
    in.indices = m.indices.data();
    in.index_count = m.indices.size();
    in.face_groups = m.groups.data();
    if (!m.uvs.empty()) in.uvs = m.uvs.data();
    for (const auto& ch : m.channels) in.attributes.push_back({ch.values.data(), ch.components});
    TessellateOptions to;
    to.surface.scheme = SubdivisionScheme::bilinear;
    to.surface.boundary = BoundaryInterpolation::edge_and_corner;
    to.surface.uv_interpolation = UvInterpolation::linear;
    to.rates.edge_rate = [&edges](const float* a, const float* b) { return edges(a, b); };
    to.rates.max_rate = std::max(1, o.max_rate);
    to.rates.max_triangles = o.max_triangles;
    TessellateOutput out;
    Status s = tessellate(out, in, to);
    if (!s.ok()) return s;
    for (const auto& w : out.stats.warnings) rep.warnings.push_back("tessellation: " + w);
    WorkMesh next;
    next.positions = std::move(out.positions);
    next.indices = std::move(out.indices);
    next.groups.resize(out.triangle_faces.size());
    for (size_t t = 0; t < out.triangle_faces.size(); ++t) next.groups[t] = m.groups[out.triangle_faces[t]];
    next.uvs = std::move(out.uvs);
    for (size_t c = 0; c < m.channels.size(); ++c)
        next.channels.push_back({m.channels[c].name, m.channels[c].components, std::move(out.attributes[c])});
    m = std::move(next);
    return Status::success();
}

} // namespace

namespace {

// Calls f(M, primitive) for every ground primitive the scene draws, M its placement (Scene::mesh_placement).
template <class F>
void for_each_ground_primitive(const Scene& scene, F&& f) {
    const auto world = scene.world_matrices();
    for (int n : scene.drawn_nodes()) {
        const Node& node = scene.nodes[size_t(n)];
        if (node.mesh < 0 || size_t(node.mesh) >= scene.meshes.size()) continue;
        const Mat M = scene.mesh_placement(n, world);
        for (const Primitive& p : scene.meshes[size_t(node.mesh)].primitives)
            if (is_ground_primitive(p)) f(M, p);
    }
}

Vec3 vertex(const Primitive& p, size_t v) { return {p.positions[3 * v], p.positions[3 * v + 1], p.positions[3 * v + 2]}; }

// The colliders moved by −O: their paths are world positions.
ColliderSet shifted(const ColliderSet& set, const Vec3& O) {
    ColliderSet out = set;
    for (Collider& c : out.colliders)
        for (auto& p : c.path) p = arr(d3(p) - O);
    return out;
}

} // namespace

void scene_triangles(std::vector<float>& positions, std::vector<uint32_t>& indices, const Scene& scene,
                     const std::array<double, 3>& origin) {
    positions.clear();
    indices.clear();
    const Vec3 O = d3(origin);
    for_each_ground_primitive(scene, [&](const Mat& M, const Primitive& p) {
        const uint32_t base = uint32_t(positions.size() / 3);
        for (size_t v = 0; v < p.vertex_count(); ++v) {
            const Vec3 q = xform_point(M, vertex(p, v)) - O; // in double, relative to `origin`, then rounded
            positions.insert(positions.end(), {float(q.x), float(q.y), float(q.z)});
        }
        for (uint32_t i : triangle_indices(p))
            if (i < p.vertex_count()) indices.push_back(base + i);
            else indices.push_back(base); // out of range: a degenerate corner, never a crash
    });
}

std::array<double, 3> ground_origin(const Scene& scene) {
    double lo[3] = {kInf, kInf, kInf}, hi[3] = {-kInf, -kInf, -kInf};
    for_each_ground_primitive(scene, [&](const Mat& M, const Primitive& p) {
        for (size_t v = 0; v < p.vertex_count(); ++v) {
            const Vec3 q = xform_point(M, vertex(p, v));
            const double c[3] = {q.x, q.y, q.z};
            for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], c[k]), hi[k] = std::max(hi[k], c[k]);
        }
    });
    if (!(lo[0] <= hi[0]) || !std::isfinite(lo[0] + lo[1] + lo[2] + hi[0] + hi[1] + hi[2])) return {0, 0, 0};
    const std::array<double, 3> c{0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
    const double diagonal = std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    // A ground around the origin keeps its frame (and its bits); one further away than its own size is
    // worked on relative to its centre.
    return norm(d3(c)) > diagonal ? c : std::array<double, 3>{0, 0, 0};
}

namespace {

// The tessellation step (triangles in world space in, triangles out): refines the ground where the heightmap
// has detail, leaves flat snow alone. Pass 1 cuts detailed triangles longer than 8 texels to about that size,
// so that pass 2 refines a neighbourhood of each stamp and not a whole large ground triangle; pass 2 gives
// every edge the detail rate of its finer face.
Status tessellate_ground(WorkMesh& w, const Heightmap& hm, const StampOptions& o, StampReport& rep) {
    const double texel = hm.frame.texel;
    DetailRateOptions dr;
    dr.max_error = o.max_error > 0 ? o.max_error : 0.25 * texel;
    dr.min_spacing = texel; // finer than the map resolves buys nothing
    dr.max_rate = 1 << 20;
    dr.camera = o.camera;
    std::vector<int> rates;
    triangle_detail_rates(rates, hm, w.positions.data(), w.indices.data(), w.indices.size() / 3, dr);
    const double coarse = 8 * texel;
    bool split = false;
    for (size_t t = 0; t < rates.size(); ++t) {
        if (rates[t] <= 1) continue;
        const uint32_t* c = &w.indices[3 * t];
        // Lengths in the heightmap's plane, as in triangle_detail_rates (a vertical face needs no cuts for its
        // height: the map does not vary along up).
        auto T = [&](int k) {
            const double q[3] = {w.positions[3 * size_t(c[k])], w.positions[3 * size_t(c[k]) + 1], w.positions[3 * size_t(c[k]) + 2]};
            return hm.frame.to_texel(q);
        };
        const auto t0 = T(0), t1 = T(1), t2 = T(2);
        auto planar = [&](const std::array<double, 3>& a, const std::array<double, 3>& b) { return texel * std::hypot(b[0] - a[0], b[1] - a[1]); };
        const double longest = std::max({planar(t0, t1), planar(t1, t2), planar(t2, t0)});
        rates[t] = deform_detail::clamped_int(std::ceil(longest / coarse), 1, std::max(1, o.max_rate));
        split = split || rates[t] > 1;
    }
    if (split) {
        Status s = tessellate_pass(w, rates, o, rep);
        if (!s.ok()) return s;
    }
    dr.max_rate = std::max(1, o.max_rate);
    triangle_detail_rates(rates, hm, w.positions.data(), w.indices.data(), w.indices.size() / 3, dr);
    return tessellate_pass(w, rates, o, rep);
}

// ---- deform_mesh, in stages -------------------------------------------------------------------------------
// What the ground primitives of one mesh share, and how they are gathered.
struct Gathered {
    std::vector<size_t> slots;     // primitive indices deformed
    std::vector<uint32_t> vbase;   // first work-mesh vertex of each slot
    bool tess = false;             // tessellated (else displaced in place)
    bool all_uv = true, all_uv1 = true, all_col = true, all_nrm = true;
    std::vector<std::pair<std::string, int>> customs; // custom attributes present with one width everywhere
    std::vector<float> object;     // object-space position per input vertex (work-mesh order, before tessellation)
    std::vector<float> world;      // its world position relative to O, as gathered
};

// Which primitives are ground, which attributes every one of them has; whether the mesh is tessellated.
Gathered survey_mesh(const Mesh& mesh, bool skinned, const StampOptions& o, StampReport& rep) {
    Gathered g;
    for (size_t k = 0; k < mesh.primitives.size(); ++k)
        if (is_ground_primitive(mesh.primitives[k])) g.slots.push_back(k);
    if (g.slots.empty()) return g;
    bool morphed = false;
    for (size_t k : g.slots) {
        const Primitive& p = mesh.primitives[k];
        morphed = morphed || !p.targets.empty();
        g.all_uv = g.all_uv && !p.uv0.empty();
        g.all_uv1 = g.all_uv1 && !p.uv1.empty();
        g.all_col = g.all_col && !p.colors.empty();
        g.all_nrm = g.all_nrm && p.normals.size() == p.positions.size();
    }
    g.tess = o.tessellate && !skinned && !morphed;
    if (o.tessellate && !g.tess)
        rep.warnings.push_back("mesh '" + mesh.name + "' is " + (skinned ? "skinned" : "morphed") +
                               ": displaced without tessellation (its vertex layout is kept)");
    for (const auto& c : mesh.primitives[g.slots[0]].custom) {
        bool everywhere = true;
        for (size_t k : g.slots) {
            bool found = false;
            for (const auto& d : mesh.primitives[k].custom) found = found || (d.name == c.name && d.components == c.components);
            everywhere = everywhere && found;
        }
        if (everywhere) g.customs.push_back({c.name, c.components});
    }
    return g;
}

const std::vector<float>* channel_source(const Primitive& p, const WorkMesh::Channel& ch) {
    if (ch.name == "uv1") return &p.uv1;
    if (ch.name == "color") return &p.colors;
    if (ch.name == "normal") return &p.normals;
    for (const auto& d : p.custom)
        if (d.name == ch.name && d.components == ch.components) return &d.values;
    return nullptr;
}

// All ground primitives of the mesh concatenated, positions in world space relative to O (formed in double,
// rounded to float after the origin is taken off). Normals ride along as a channel (object space) so that
// tessellation interpolates them where the surface does not move.
WorkMesh gather_world(const Mesh& mesh, Gathered& g, const Mat& M, const Vec3& O) {
    WorkMesh w;
    if (g.tess) {
        if (g.all_uv1) w.channels.push_back({"uv1", 2, {}});
        if (g.all_col) w.channels.push_back({"color", 4, {}});
        for (const auto& c : g.customs) w.channels.push_back({c.first, c.second, {}});
    }
    if (g.all_nrm) w.channels.push_back({"normal", 3, {}});
    for (size_t s = 0; s < g.slots.size(); ++s) {
        const Primitive& p = mesh.primitives[g.slots[s]];
        const uint32_t base = uint32_t(w.positions.size() / 3);
        g.vbase.push_back(base);
        const size_t nv = p.vertex_count();
        for (size_t v = 0; v < nv; ++v) {
            const Vec3 q = xform_point(M, Vec3{p.positions[3 * v], p.positions[3 * v + 1], p.positions[3 * v + 2]}) - O;
            w.positions.insert(w.positions.end(), {float(q.x), float(q.y), float(q.z)});
        }
        g.object.insert(g.object.end(), p.positions.begin(), p.positions.begin() + long(3 * nv));
        if (g.tess && g.all_uv) w.uvs.insert(w.uvs.end(), p.uv0.begin(), p.uv0.begin() + long(2 * nv));
        for (auto& ch : w.channels) {
            const std::vector<float>* src = channel_source(p, ch);
            ch.values.insert(ch.values.end(), src->begin(), src->begin() + long(size_t(ch.components) * nv));
        }
        for (uint32_t i : triangle_indices(p)) w.indices.push_back(base + std::min<uint32_t>(i, uint32_t(nv - 1)));
        w.groups.insert(w.groups.end(), (w.indices.size() / 3) - w.groups.size(), uint32_t(s));
    }
    g.world = w.positions;
    return w;
}

// The displaced work mesh in object space. A point the heightmap did not move gets its input position back
// bit for bit (looked up by its world position: tessellation renumbers the vertices), so untouched snow is
// unchanged in world space whatever the offset. A point whose surrounding surface did not move (no moved
// point on any triangle around it, across welds) keeps the input's normal, so authored hard normals survive;
// elsewhere the welded normal of the displaced surface is used.
void to_object_space(std::vector<float>& P, std::vector<float>& N, const WorkMesh& w, const Gathered& g, const Mat& M,
                     const Mat& inv, const Vec3& O) {
    const size_t V = P.size() / 3;
    std::vector<uint8_t> moved(V, 0);
    for (size_t v = 0; v < V; ++v)
        moved[v] = P[3 * v] != w.positions[3 * v] || P[3 * v + 1] != w.positions[3 * v + 1] || P[3 * v + 2] != w.positions[3 * v + 2];
    std::vector<uint32_t> weld(V);
    weld_positions(weld.data(), w.positions.data(), V);
    std::vector<uint8_t> surface_moved(V, 0);
    for (size_t t = 0; t + 2 < w.indices.size(); t += 3) {
        const uint32_t* c = &w.indices[t];
        if (moved[c[0]] || moved[c[1]] || moved[c[2]])
            for (int k = 0; k < 3; ++k) surface_moved[weld[c[k]]] = 1;
    }
    std::unordered_map<EdgeRates::Key, uint32_t, EdgeRates::Hash> input_at; // world position -> input vertex
    input_at.reserve(g.object.size() / 3);
    if (g.tess) // else the vertices are the input's own: index v is input vertex v
        for (size_t v = 0; v < g.object.size() / 3; ++v) input_at.emplace(EdgeRates::key(&g.world[3 * v], &g.world[3 * v]), uint32_t(v));
    const WorkMesh::Channel* normal = nullptr;
    for (const auto& ch : w.channels)
        if (ch.name == "normal") normal = &ch;
    for (size_t v = 0; v < V; ++v) {
        if (!moved[v]) {
            long src = g.tess ? -1 : long(v);
            if (g.tess) {
                auto it = input_at.find(EdgeRates::key(&w.positions[3 * v], &w.positions[3 * v]));
                if (it != input_at.end()) src = long(it->second);
            }
            if (src >= 0) std::copy_n(&g.object[3 * size_t(src)], 3, &P[3 * v]);
            else {
                const Vec3 q = xform_point(inv, Vec3{P[3 * v], P[3 * v + 1], P[3 * v + 2]} + O);
                P[3 * v] = float(q.x), P[3 * v + 1] = float(q.y), P[3 * v + 2] = float(q.z);
            }
        } else {
            const Vec3 q = xform_point(inv, Vec3{P[3 * v], P[3 * v + 1], P[3 * v + 2]} + O);
            P[3 * v] = float(q.x), P[3 * v + 1] = float(q.y), P[3 * v + 2] = float(q.z);
        }
        Vec3 n{N[3 * v], N[3 * v + 1], N[3 * v + 2]};
        if (normal && !surface_moved[weld[v]]) {
            n = Vec3{normal->values[3 * v], normal->values[3 * v + 1], normal->values[3 * v + 2]};
        } else {
            // Normals transform by the inverse transpose: object normal = Mᵀ · world normal.
            n = Vec3{M[0] * n.x + M[1] * n.y + M[2] * n.z, M[4] * n.x + M[5] * n.y + M[6] * n.z, M[8] * n.x + M[9] * n.y + M[10] * n.z};
        }
        const double l = norm(n);
        n = l > 0 && std::isfinite(l) ? n * (1.0 / l) : Vec3{0, 1, 0};
        N[3 * v] = float(n.x), N[3 * v + 1] = float(n.y), N[3 * v + 2] = float(n.z);
    }
}

// Same vertices: positions and normals replaced in place.
void write_in_place(Mesh& mesh, const Gathered& g, const std::vector<float>& P, const std::vector<float>& N, StampReport& rep) {
    for (size_t s = 0; s < g.slots.size(); ++s) {
        Primitive& p = mesh.primitives[g.slots[s]];
        const size_t nv = p.vertex_count();
        std::copy(P.begin() + long(3 * g.vbase[s]), P.begin() + long(3 * (g.vbase[s] + nv)), p.positions.begin());
        p.normals.assign(N.begin() + long(3 * g.vbase[s]), N.begin() + long(3 * (g.vbase[s] + nv)));
        if (!p.tangents.empty()) {
            p.tangents.clear();
            rep.warnings.push_back("mesh '" + mesh.name + "': tangents dropped (they no longer match the displaced normals)");
        }
        rep.triangles_out += p.triangle_count();
    }
}

// Tessellated: each primitive slot rebuilt from the work-mesh triangles of its group, with its material.
void rebuild_primitives(Mesh& mesh, const Gathered& g, const WorkMesh& w, const std::vector<float>& P, const std::vector<float>& N,
                        StampReport& rep) {
    const size_t V = P.size() / 3;
    bool dropped_tangents = false, dropped_attr = false;
    for (size_t s = 0; s < g.slots.size(); ++s) {
        Primitive& p = mesh.primitives[g.slots[s]];
        Primitive q;
        q.mode = PrimitiveMode::triangles;
        q.material = p.material;
        dropped_tangents = dropped_tangents || !p.tangents.empty();
        dropped_attr = dropped_attr || (!g.all_uv && !p.uv0.empty()) || (!g.all_uv1 && !p.uv1.empty()) || (!g.all_col && !p.colors.empty()) ||
                       p.custom.size() > g.customs.size() || !p.joints.empty();
        std::vector<uint32_t> local(V, UINT32_MAX);
        for (size_t t = 0; t < w.groups.size(); ++t) {
            if (w.groups[t] != s) continue;
            for (int c = 0; c < 3; ++c) {
                const uint32_t v = w.indices[3 * t + size_t(c)];
                if (local[v] == UINT32_MAX) {
                    local[v] = uint32_t(q.positions.size() / 3);
                    q.positions.insert(q.positions.end(), {P[3 * size_t(v)], P[3 * size_t(v) + 1], P[3 * size_t(v) + 2]});
                    q.normals.insert(q.normals.end(), {N[3 * size_t(v)], N[3 * size_t(v) + 1], N[3 * size_t(v) + 2]});
                    if (!w.uvs.empty()) q.uv0.insert(q.uv0.end(), {w.uvs[2 * size_t(v)], w.uvs[2 * size_t(v) + 1]});
                    for (const auto& ch : w.channels) {
                        if (ch.name == "normal") continue; // written above
                        std::vector<float>* dst = ch.name == "uv1" ? &q.uv1 : ch.name == "color" ? &q.colors : nullptr;
                        if (!dst) {
                            CustomAttribute* a = nullptr;
                            for (auto& d : q.custom)
                                if (d.name == ch.name) a = &d;
                            if (!a) {
                                q.custom.push_back({ch.name, ch.components, {}});
                                a = &q.custom.back();
                            }
                            dst = &a->values;
                        }
                        const float* src = &ch.values[size_t(ch.components) * v];
                        dst->insert(dst->end(), src, src + ch.components);
                    }
                }
                q.indices.push_back(local[v]);
            }
        }
        rep.triangles_out += q.indices.size() / 3;
        p = std::move(q);
    }
    if (dropped_tangents) rep.warnings.push_back("mesh '" + mesh.name + "': tangents dropped (they no longer match the displaced normals)");
    if (dropped_attr)
        rep.warnings.push_back("mesh '" + mesh.name + "': attributes not present on every primitive (or skin data) were dropped");
}

// What the displacement reads of the snow field once it has taken every stamp: the field itself (its carve,
// rim and ray-cast tree) is freed before the ground is displaced, the command's memory peak (bench memory).
struct SettledSnow {
    Heightmap heightmap, ground;
    size_t overhangs = 0;
};

// Deforms one mesh drawn with world matrix M; the field works relative to the world point O.
Status deform_mesh(Scene& scene, int mesh_index, const Mat& M, const Vec3& O, bool skinned, const SettledSnow& field,
                   const StampOptions& o, StampReport& rep) {
    Mesh& mesh = scene.meshes[size_t(mesh_index)];
    Mat inv;
    if (!invert_affine(M, inv)) {
        rep.warnings.push_back("mesh '" + mesh.name + "' has a singular transform; not deformed");
        return Status::success();
    }
    Gathered g = survey_mesh(mesh, skinned, o, rep);
    if (g.slots.empty()) return Status::success();
    WorkMesh w = gather_world(mesh, g, M, O);
    rep.triangles_in += w.indices.size() / 3;

    const Heightmap& hm = field.heightmap;
    if (g.tess) {
        const auto t0 = Clock::now();
        Status s = tessellate_ground(w, hm, o, rep);
        if (!s.ok()) return Status::error(s.code, "tessellation of mesh '" + mesh.name + "' failed: " + s.message);
        rep.tessellate_seconds += seconds_since(t0);
    }

    // Displace in the field's frame, welded.
    const auto t1 = Clock::now();
    std::vector<float> P(w.positions.size()), N(w.positions.size());
    {
        // Freed before the mesh is rebuilt: its per-face and per-point arrays (the incremental runtime's) were
        // the largest part of the command's peak memory (`furrow bench memory`).
        DisplacedGround dg;
        DisplaceOptions dopt;
        dopt.along_up = o.along_up;
        dopt.top_only = field.overhangs > 0;
        dopt.keep_face_terms = false; // one displace_all, no update()
        Status s = dg.prepare(w.positions.data(), w.positions.size() / 3, w.indices.data(), w.indices.size(), hm.frame, dopt, &field.ground);
        if (!s.ok()) return s;
        dg.displace_all(hm, P.data(), N.data());
        rep.welded_points += dg.welded_count();
    }
    {
        std::vector<uint32_t> remap(w.positions.size() / 3); // points that actually moved, for the report
        weld_positions(remap.data(), w.positions.data(), remap.size());
        for (size_t v = 0; v < remap.size(); ++v)
            if (remap[v] == v && (P[3 * v] != w.positions[3 * v] || P[3 * v + 1] != w.positions[3 * v + 1] || P[3 * v + 2] != w.positions[3 * v + 2]))
                ++rep.displaced_points;
    }
    rep.displace_seconds += seconds_since(t1);

    to_object_space(P, N, w, g, M, inv, O);
    if (g.tess) rebuild_primitives(mesh, g, w, P, N, rep);
    else write_in_place(mesh, g, P, N, rep);
    rep.meshes += 1;
    rep.primitives += g.slots.size();
    return Status::success();
}

// The ground's triangle primitives, checked before anything changes: finite coordinates within 1e30 units,
// indices in range.
Status check_ground(const Scene& scene) {
    // scene_triangles reads an index out of range as a degenerate corner, which is right for a heightmap of the
    // ground, but the meshes are then written back with their own indices: such a ground came out of an ok
    // stamp still naming vertices that do not exist (found by fuzz_stamp). Refused, as render_scene does.
    for (int n : scene.drawn_nodes()) {
        const int m = scene.nodes[size_t(n)].mesh;
        if (m < 0 || size_t(m) >= scene.meshes.size()) continue;
        for (size_t k = 0; k < scene.meshes[size_t(m)].primitives.size(); ++k) {
            const Primitive& p = scene.meshes[size_t(m)].primitives[k];
            if (p.mode != PrimitiveMode::triangles) continue;
            // Every vertex of the ground is displaced, used by a triangle or not (DisplacedGround::prepare).
            // Coordinates near float's limit (3.4e38) overflow once the ground is tessellated and displaced
            // (a fuzz_stamp ground at 7.9e37 came out with infinite positions): beyond 1e30 units is refused.
            for (float x : p.positions)
                if (!std::isfinite(x))
                    return Status::error(StatusCode::invalid_input, "mesh " + std::to_string(m) + " primitive " + std::to_string(k) +
                                                                        ": a vertex position is not finite");
                else if (std::abs(x) > 1e30f)
                    return Status::error(StatusCode::invalid_input, "mesh " + std::to_string(m) + " primitive " + std::to_string(k) +
                                                                        ": a vertex coordinate is beyond 1e30 units");
            for (uint32_t i : p.indices)
                if (i >= p.vertex_count())
                    return Status::error(StatusCode::invalid_input, "mesh " + std::to_string(m) + " primitive " + std::to_string(k) +
                                                                        ": index " + std::to_string(i) + " is out of range (" +
                                                                        std::to_string(p.vertex_count()) + " vertices)");
        }
    }
    return Status::success();
}

} // namespace

Status stamp_scene(Scene& scene, const ColliderSet& colliders, const StampOptions& o, StampReport* report, Heightmap* heightmap_out) {
    return kernel::no_throw("stamping the scene", [&]() -> Status {
        StampReport rep;
        auto bad = [](const std::string& m) { return Status::error(StatusCode::invalid_argument, m); };
        if (!(o.max_error >= 0) || !std::isfinite(o.max_error)) return bad("max error must be a finite number >= 0");
        if (o.max_rate < 1 || o.max_rate > 4096) return bad("max rate must be in 1..4096");
        if (o.time && !std::isfinite(*o.time)) return bad("time must be finite");
        if (o.camera) {
            if (!(o.camera->fov_degrees > 0 && o.camera->fov_degrees < 180)) return bad("camera field of view must be in (0, 180)");
            if (o.camera->viewport_height < 1) return bad("camera viewport height must be >= 1");
            if (!(o.camera->pixel_error > 0) || !std::isfinite(o.camera->pixel_error)) return bad("pixel error must be > 0");
        }
        if (Status st = check_ground(scene); !st.ok()) return st;
        const auto t0 = Clock::now();
        std::vector<float> gp;
        std::vector<uint32_t> gi;
        // Everything below works relative to the ground's origin O (ground_origin): float32 positions keep
        // their precision at 1e5..1e7 m, and the world-space inputs (colliders, camera, base map) move with it.
        const std::array<double, 3> origin = ground_origin(scene);
        const Vec3 O = d3(origin);
        scene_triangles(gp, gi, scene, origin);
        if (gi.empty()) return Status::error(StatusCode::invalid_input, "the ground has no triangles");
        const ColliderSet local = shifted(colliders, O);
        StampOptions lo = o;
        if (lo.camera) lo.camera->eye = arr(d3(lo.camera->eye) - O);
        Heightmap base;
        if (o.base) {
            base = *o.base;
            base.frame.origin = arr(d3(base.frame.origin) - O);
            lo.base = &base;
        }
        SnowOptions so = o.snow;
        so.up = colliders.up;
        SnowField field;
        Status s = field.create(gp.data(), gp.size() / 3, gi.data(), gi.size(), so);
        if (!s.ok()) return s;
        rep.frame = field.frame();
        rep.frame.origin = arr(d3(rep.frame.origin) + O);
        rep.overhang_triangles = field.overhang_triangles();
        if (rep.overhang_triangles)
            rep.warnings.push_back(std::to_string(rep.overhang_triangles) +
                                   " ground triangles face away from up (overhangs or undersides): the snow follows the top surface "
                                   "only, and points below it are not displaced");
        if (lo.base) {
            s = field.set_base(*lo.base);
            if (!s.ok()) return s;
        }
        double T = 0;
        for (const Collider& c : colliders.colliders)
            for (double t : c.time) T = std::max(T, t);
        if (o.time) T = *o.time;
        field.set_time(T);
        s = field.add_colliders(local, &rep.stats);
        if (!s.ok()) return s;
        field.update();
        rep.removed_volume = field.removed_volume();
        rep.raised_volume = field.raised_volume();
        const Heightmap& hm = field.heightmap();
        bool changed = false;
        for (float v : hm.values) {
            rep.max_depth = std::max(rep.max_depth, double(-v));
            rep.max_rim = std::max(rep.max_rim, double(v));
            changed = changed || v != 0.0f;
        }
        if (rep.stats.missed_rays)
            rep.warnings.push_back(std::to_string(rep.stats.missed_rays) + " contact rays found no ground below their collider");
        rep.stamp_seconds = seconds_since(t0);
        if (heightmap_out) {
            *heightmap_out = hm;
            heightmap_out->frame.origin = arr(d3(hm.frame.origin) + O);
        }
        rep.changed = changed;
        if (changed) {
            const SettledSnow settled{field.heightmap(), field.ground(), field.overhang_triangles()};
            field = SnowField(); // hm is not read past here
            const auto world = scene.world_matrices();
            // Each drawing node gets its own mesh (copied from the undeformed original), then each is deformed.
            std::vector<int> mesh_user(scene.meshes.size(), -1);
            std::vector<std::pair<int, int>> work; // node, mesh
            const size_t originals = scene.meshes.size();
            for (int n : scene.drawn_nodes()) {
                Node& node = scene.nodes[size_t(n)];
                if (node.mesh < 0 || size_t(node.mesh) >= originals) continue;
                int m = node.mesh;
                if (mesh_user[size_t(m)] >= 0) {
                    scene.meshes.push_back(scene.meshes[size_t(m)]);
                    m = int(scene.meshes.size() - 1);
                    node.mesh = m;
                    rep.warnings.push_back("mesh '" + scene.meshes[size_t(m)].name + "' is drawn by several nodes: copied for node '" +
                                           node.name + "'");
                } else {
                    mesh_user[size_t(m)] = n;
                }
                work.push_back({n, m});
            }
            for (const auto& [n, m] : work) {
                s = deform_mesh(scene, m, scene.mesh_placement(n, world), O, scene.nodes[size_t(n)].skin >= 0, settled, lo, rep);
                if (!s.ok()) return s;
            }
        }
        if (report) *report = std::move(rep);
        return Status::success();
    });
}

Status stamp_files(Scene& out, const std::string& ground_path, const std::string& colliders_path, const StampOptions& o,
                   StampReport* report) {
    return kernel::no_throw("stamping the scene", [&]() -> Status {
        Scene scene;
        Status s = load_scene(scene, ground_path);
        if (!s.ok()) return Status::error(s.code, ground_path + ": " + s.message);
        ColliderSet set;
        s = load_colliders(set, colliders_path);
        if (!s.ok()) return Status::error(s.code, colliders_path + ": " + s.message);
        s = stamp_scene(scene, set, o, report);
        if (!s.ok()) return s;
        out = std::move(scene);
        return Status::success();
    });
}

} // namespace furrow

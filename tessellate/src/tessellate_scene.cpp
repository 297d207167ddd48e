// Tessellating the meshes of a glTF scene, keeping the rest of the scene.
//
// All triangle-mode primitives of one mesh are tessellated as ONE surface (each face remembers its
// primitive as a face group), then the result is split back into the primitives: a mesh cut into
// primitives by material is one surface to a modeller, and tessellating the pieces apart would open cracks
// along their shared borders. Attribute values are never shared across primitives, so each output vertex
// belongs to exactly one primitive.
//
// View criteria are in world space, so each mesh gets the placements of the nodes that draw it
// (Scene::mesh_placement: glTF ignores the node transform of a skinned mesh and places it by its joints).
#include "tessellate_internal.h"
#include <furrow_kernel/no_throw.h>
#include <furrow_kernel/huge_pages.h>

#include <algorithm>
#include <map>
#include <string>

namespace furrow {

using namespace tessellate_detail;

namespace {

// Every placement of one mesh among the nodes the scene draws (Scene::mesh_placement: the bind pose for a
// skinned mesh).
std::vector<std::array<double, 16>> mesh_instances(const Scene& scene, size_t mesh, const std::vector<int>& drawn,
                                                   const std::vector<std::array<double, 16>>& world) {
    std::vector<std::array<double, 16>> out;
    for (int n : drawn)
        if (scene.nodes[size_t(n)].mesh == int(mesh)) out.push_back(scene.mesh_placement(n, world));
    return out;
}

// One mesh's triangle primitives merged into plain arrays.
struct Merged {
    std::vector<size_t> prims; // primitive indices in the mesh
    std::vector<float> positions, uv0, uv1, colors, weights;
    std::vector<uint16_t> joints;
    std::vector<uint32_t> indices, face_sizes, face_groups;
    std::vector<std::pair<std::string, int>> custom_keys;
    std::vector<std::vector<float>> custom;
    size_t targets = 0;
    std::vector<std::vector<float>> target_pos, target_nrm; // per target, 3 per vertex (empty if none had them)
    bool any_uv0 = false, any_uv1 = false, any_colors = false, any_skin = false;
    bool dropped_tangents = false;
};

Merged merge(const Mesh& mesh) {
    Merged g;
    for (size_t i = 0; i < mesh.primitives.size(); ++i) {
        const Primitive& p = mesh.primitives[i];
        if (p.mode != PrimitiveMode::triangles || p.positions.empty()) continue;
        g.prims.push_back(i);
        g.any_uv0 |= !p.uv0.empty();
        g.any_uv1 |= !p.uv1.empty();
        g.any_colors |= !p.colors.empty();
        g.any_skin |= !p.joints.empty() && !p.weights.empty();
        g.targets = std::max(g.targets, p.targets.size());
        for (const auto& c : p.custom) {
            std::pair<std::string, int> key{c.name, c.components};
            if (std::find(g.custom_keys.begin(), g.custom_keys.end(), key) == g.custom_keys.end()) g.custom_keys.push_back(key);
        }
    }
    g.custom.resize(g.custom_keys.size());
    g.target_pos.resize(g.targets);
    g.target_nrm.resize(g.targets);
    std::vector<bool> any_tpos(g.targets, false), any_tnrm(g.targets, false);
    for (size_t i : g.prims)
        for (size_t t = 0; t < mesh.primitives[i].targets.size(); ++t) {
            any_tpos[t] = any_tpos[t] || !mesh.primitives[i].targets[t].position_deltas.empty();
            any_tnrm[t] = any_tnrm[t] || !mesh.primitives[i].targets[t].normal_deltas.empty();
        }
    for (size_t slot = 0; slot < g.prims.size(); ++slot) {
        const Primitive& p = mesh.primitives[g.prims[slot]];
        const size_t n = p.vertex_count(), base = g.positions.size() / 3;
        g.positions.insert(g.positions.end(), p.positions.begin(), p.positions.begin() + long(n * 3));
        auto append = [&](std::vector<float>& dst, const std::vector<float>& src, size_t comps, bool any,
                          std::initializer_list<float> fill) {
            if (!any) return;
            if (src.size() >= n * comps) {
                dst.insert(dst.end(), src.begin(), src.begin() + long(n * comps));
            } else {
                for (size_t v = 0; v < n; ++v) dst.insert(dst.end(), fill);
            }
        };
        append(g.uv0, p.uv0, 2, g.any_uv0, {0.f, 0.f});
        append(g.uv1, p.uv1, 2, g.any_uv1, {0.f, 0.f});
        append(g.colors, p.colors, 4, g.any_colors, {1.f, 1.f, 1.f, 1.f});
        if (g.any_skin) {
            if (p.joints.size() >= n * 4 && p.weights.size() >= n * 4) {
                g.joints.insert(g.joints.end(), p.joints.begin(), p.joints.begin() + long(n * 4));
                g.weights.insert(g.weights.end(), p.weights.begin(), p.weights.begin() + long(n * 4));
            } else {
                for (size_t v = 0; v < n; ++v) {
                    g.joints.insert(g.joints.end(), {0, 0, 0, 0});
                    g.weights.insert(g.weights.end(), {1.f, 0.f, 0.f, 0.f});
                }
            }
        }
        for (size_t k = 0; k < g.custom_keys.size(); ++k) {
            const CustomAttribute* found = nullptr;
            for (const auto& c : p.custom)
                if (c.name == g.custom_keys[k].first && c.components == g.custom_keys[k].second) found = &c;
            const size_t comps = size_t(g.custom_keys[k].second);
            if (found && found->values.size() >= n * comps)
                g.custom[k].insert(g.custom[k].end(), found->values.begin(), found->values.begin() + long(n * comps));
            else
                g.custom[k].insert(g.custom[k].end(), n * comps, 0.0f);
        }
        for (size_t t = 0; t < g.targets; ++t) {
            const MorphTarget* mt = t < p.targets.size() ? &p.targets[t] : nullptr;
            if (any_tpos[t]) {
                if (mt && mt->position_deltas.size() >= n * 3)
                    g.target_pos[t].insert(g.target_pos[t].end(), mt->position_deltas.begin(), mt->position_deltas.begin() + long(n * 3));
                else
                    g.target_pos[t].insert(g.target_pos[t].end(), n * 3, 0.0f);
            }
            if (any_tnrm[t]) {
                if (mt && mt->normal_deltas.size() >= n * 3)
                    g.target_nrm[t].insert(g.target_nrm[t].end(), mt->normal_deltas.begin(), mt->normal_deltas.begin() + long(n * 3));
                else
                    g.target_nrm[t].insert(g.target_nrm[t].end(), n * 3, 0.0f);
            }
            if (mt && !mt->tangent_deltas.empty()) g.dropped_tangents = true;
        }
        if (!p.tangents.empty()) g.dropped_tangents = true;
        const size_t faces = p.face_count();
        if (p.indices.empty()) { // non-indexed triangles
            for (size_t v = 0; v + 2 < n; v += 3)
                for (size_t k = 0; k < 3; ++k) g.indices.push_back(uint32_t(base + v + k));
            for (size_t f = 0; f < n / 3; ++f) {
                g.face_sizes.push_back(3);
                g.face_groups.push_back(uint32_t(slot));
            }
            continue;
        }
        for (uint32_t i : p.indices) g.indices.push_back(uint32_t(base + i));
        for (size_t f = 0; f < faces; ++f) {
            g.face_sizes.push_back(p.face_sizes.empty() ? 3u : p.face_sizes[f]);
            g.face_groups.push_back(uint32_t(slot));
        }
    }
    return g;
}

TessellateInput input_of(const Merged& g) {
    TessellateInput in;
    in.positions = g.positions.data();
    in.vertex_count = g.positions.size() / 3;
    in.indices = g.indices.data();
    in.index_count = g.indices.size();
    in.face_sizes = g.face_sizes.data();
    in.face_count = g.face_sizes.size();
    in.face_groups = g.face_groups.data();
    if (g.any_uv0) in.uvs = g.uv0.data();
    if (g.any_uv1) in.attributes.push_back({g.uv1.data(), 2});
    if (g.any_colors) in.attributes.push_back({g.colors.data(), 4});
    for (size_t k = 0; k < g.custom.size(); ++k) in.attributes.push_back({g.custom[k].data(), g.custom_keys[k].second});
    for (size_t t = 0; t < g.targets; ++t) {
        if (!g.target_pos[t].empty()) in.vertex_data.push_back({g.target_pos[t].data(), 3});
        if (!g.target_nrm[t].empty()) in.vertex_data.push_back({g.target_nrm[t].data(), 3});
    }
    if (g.any_skin) {
        in.joints = g.joints.data();
        in.weights = g.weights.data();
    }
    return in;
}

template <class T>
void release(std::vector<T>& v) {
    std::vector<T>().swap(v);
}

// Splits the tessellation back into the merged primitives.
void split(Mesh& mesh, const Merged& g, TessellateOutput& t) {
    const size_t V = t.positions.size() / 3;
    for (size_t slot = 0; slot < g.prims.size(); ++slot) {
        Primitive& dst = mesh.primitives[g.prims[slot]];
        const Primitive src = dst; // what the primitive had decides what it keeps
        // Large outputs on huge pages (furrow_kernel/huge_pages.h); with one primitive, room for all of it.
        std::vector<uint32_t> remap, used, indices;
        kernel::assign_huge(remap, V, none);
        if (g.prims.size() == 1) {
            kernel::reserve_huge(used, V);
            kernel::reserve_huge(indices, t.indices.size());
        }
        for (size_t tri = 0; tri < t.triangle_faces.size(); ++tri) {
            if (g.face_groups[t.triangle_faces[tri]] != slot) continue;
            for (int k = 0; k < 3; ++k) {
                const uint32_t v = t.indices[tri * 3 + size_t(k)];
                if (remap[v] == none) {
                    remap[v] = uint32_t(used.size());
                    used.push_back(v);
                }
                indices.push_back(remap[v]);
            }
        }
        // The last primitive releases each of the output's arrays as soon as it has gathered it: holding them
        // all until the end held the tessellation twice at the command's peak memory.
        const bool last = slot + 1 == g.prims.size();
        if (last) {
            release(t.triangle_faces);
            release(t.indices);
        }
        auto gather = [&](std::vector<float>& from, size_t comps) {
            std::vector<float> r;
            kernel::assign_huge(r, used.size() * comps);
            for (size_t i = 0; i < used.size(); ++i) std::copy_n(&from[size_t(used[i]) * comps], comps, &r[i * comps]);
            if (last) release(from);
            return r;
        };
        dst.positions = gather(t.positions, 3);
        dst.normals = gather(t.normals, 3);
        dst.tangents.clear();
        dst.indices = std::move(indices);
        dst.face_sizes.clear();
        size_t attr = 0;
        dst.uv0 = g.any_uv0 && !src.uv0.empty() ? gather(t.uvs, 2) : std::vector<float>{};
        if (g.any_uv1) {
            dst.uv1 = src.uv1.empty() ? std::vector<float>{} : gather(t.attributes[attr], 2);
            ++attr;
        }
        if (g.any_colors) {
            dst.colors = src.colors.empty() ? std::vector<float>{} : gather(t.attributes[attr], 4);
            ++attr;
        }
        std::vector<CustomAttribute> custom;
        for (size_t k = 0; k < g.custom_keys.size(); ++k, ++attr)
            for (const auto& c : src.custom)
                if (c.name == g.custom_keys[k].first && c.components == g.custom_keys[k].second)
                    custom.push_back({c.name, c.components, gather(t.attributes[attr], size_t(c.components))});
        dst.custom = std::move(custom);
        if (g.any_skin && !src.joints.empty() && !src.weights.empty()) {
            dst.joints.resize(used.size() * 4);
            dst.weights.resize(used.size() * 4);
            for (size_t i = 0; i < used.size(); ++i) {
                std::copy_n(&t.joints[size_t(used[i]) * 4], 4, &dst.joints[i * 4]);
                std::copy_n(&t.weights[size_t(used[i]) * 4], 4, &dst.weights[i * 4]);
            }
        } else {
            dst.joints.clear();
            dst.weights.clear();
        }
        size_t vd = 0;
        dst.targets.resize(g.targets); // glTF: every primitive of a mesh has the same number of targets
        for (size_t k = 0; k < g.targets; ++k) {
            const MorphTarget* mt = k < src.targets.size() ? &src.targets[k] : nullptr;
            MorphTarget& out = dst.targets[k];
            out = MorphTarget{};
            if (!g.target_pos[k].empty()) {
                if (mt && !mt->position_deltas.empty()) out.position_deltas = gather(t.vertex_data[vd], 3);
                ++vd;
            }
            if (!g.target_nrm[k].empty()) {
                if (mt && !mt->normal_deltas.empty()) out.normal_deltas = gather(t.vertex_data[vd], 3);
                ++vd;
            }
            // A target that only moved tangents keeps a (zero) position so that it stays a valid target.
            if (out.position_deltas.empty() && out.normal_deltas.empty()) out.position_deltas.assign(used.size() * 3, 0.0f);
        }
    }
}

void add_counters(TessellateStats& a, const TessellateStats& b, bool first) {
    a.input_faces += b.input_faces;
    a.faces += b.faces;
    a.dropped_faces += b.dropped_faces;
    a.flipped_faces += b.flipped_faces;
    a.linear_faces += b.linear_faces;
    a.non_manifold_edges += b.non_manifold_edges;
    a.inconsistent_edges += b.inconsistent_edges;
    a.valence2_vertices += b.valence2_vertices;
    a.failed_faces += b.failed_faces;
    a.split_vertices += b.split_vertices;
    a.crease_edges += b.crease_edges;
    a.mean_rate = (a.mean_rate * double(a.edges) + b.mean_rate * double(b.edges)) / double(std::max<size_t>(1, a.edges + b.edges));
    a.edges += b.edges;
    a.min_rate = first ? b.min_rate : std::min(a.min_rate, b.min_rate);
    a.max_rate = first ? b.max_rate : std::max(a.max_rate, b.max_rate);
    a.rate_scale = first ? b.rate_scale : std::min(a.rate_scale, b.rate_scale);
    a.vertices += b.vertices;
    a.triangles += b.triangles;
    a.prepare_seconds += b.prepare_seconds;
    a.rate_seconds += b.rate_seconds;
    a.evaluate_seconds += b.evaluate_seconds;
}

} // namespace

Status tessellate_scene(Scene& scene, const TessellateOptions& options, SceneTessellateReport* report) {
    SceneTessellateReport local;
    SceneTessellateReport& rep = report ? *report : local;
    rep = SceneTessellateReport{};
    if (Status s = validate_rates(options.rates); !s.ok()) return s;
    // Checked here too: prepare() checks them only for meshes that have triangles, so a scene without any
    // returned ok for any options at all (found by fuzz_tessellate).
    if (Status s = check_surface_options(options.surface); !s.ok()) return s;
    // A triangle primitive with faces but no positions has nothing to tessellate and is left out of the merge
    // below, so it came back unchanged with indices naming vertices that do not exist (found by
    // fuzz_tessellate): refuse it as the index out of range that it is.
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi)
        for (size_t pi = 0; pi < scene.meshes[mi].primitives.size(); ++pi) {
            const Primitive& p = scene.meshes[mi].primitives[pi];
            if (p.mode == PrimitiveMode::triangles && p.positions.empty() && !p.indices.empty())
                return Status::error(StatusCode::invalid_input, "mesh " + std::to_string(mi) + " primitive " + std::to_string(pi) +
                                                                    ": faces but no vertices (index out of range)");
        }
    const auto world = scene.world_matrices();
    const std::vector<int> drawn = scene.drawn_nodes();
    struct Job {
        size_t mesh;
        Merged merged;
        Tessellator tess;
        RateOptions rates;
        size_t count = 0;
        TessellateOutput out;
    };
    std::vector<std::unique_ptr<Job>> jobs;
    const Status done = kernel::no_throw("tessellating the scene", [&]() -> Status {
        for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
            auto job = std::make_unique<Job>();
            job->mesh = mi;
            job->merged = merge(scene.meshes[mi]);
            if (job->merged.prims.empty()) continue;
            TessellateInput in = input_of(job->merged);
            for (size_t i : job->merged.prims) rep.triangles_in += scene.meshes[mi].primitives[i].triangle_count();
            const std::string where = "mesh " + std::to_string(mi) +
                                      (scene.meshes[mi].name.empty() ? "" : " \"" + scene.meshes[mi].name + "\"");
            if (Status s = job->tess.prepare(in, options.surface); !s.ok())
                return Status::error(s.code, where + ": " + s.message);
            job->rates = options.rates;
            job->rates.instances = mesh_instances(scene, mi, drawn, world);
            job->rates.max_triangles = 0;
            if (options.rates.max_triangles > 0 || options.triangle_budget > 0)
                if (Status s = job->tess.count_triangles(job->count, job->rates); !s.ok())
                    return Status::error(s.code, where + ": " + s.message);
            jobs.push_back(std::move(job));
        }
        if (options.rates.max_triangles == 0 && options.triangle_budget > 0) {
            size_t total = 0;
            for (const auto& j : jobs) total += j->count;
            if (total > options.triangle_budget)
                return Status::error(StatusCode::invalid_argument,
                                     "the rates would make about " + std::to_string(total) + " triangles, over the budget of " +
                                         std::to_string(options.triangle_budget) +
                                         " (--max-triangles N scales the rates down to fit N)");
        }
        if (options.rates.max_triangles > 0) {
            size_t total = 0;
            for (const auto& j : jobs) total += j->count;
            if (total > options.rates.max_triangles)
                for (auto& j : jobs)
                    j->rates.max_triangles = std::max<size_t>(
                        1, size_t(double(options.rates.max_triangles) * double(j->count) / double(total)));
        }
        // Every mesh is tessellated before the scene changes, so an error leaves the scene as it was.
        for (auto& j : jobs) {
            const std::string where = "mesh " + std::to_string(j->mesh) +
                                      (scene.meshes[j->mesh].name.empty() ? "" : " \"" + scene.meshes[j->mesh].name + "\"");
            if (Status s = j->tess.tessellate(j->out, j->rates, false); !s.ok())
                return Status::error(s.code, where + ": " + s.message);
        }
        bool first = true;
        for (auto& j : jobs) {
            const std::string where = "mesh " + std::to_string(j->mesh) +
                                      (scene.meshes[j->mesh].name.empty() ? "" : " \"" + scene.meshes[j->mesh].name + "\"");
            split(scene.meshes[j->mesh], j->merged, j->out);
            ++rep.meshes;
            rep.primitives += j->merged.prims.size();
            rep.triangles_out += j->out.stats.triangles;
            for (const auto& w : j->out.stats.warnings) rep.warnings.push_back(where + ": " + w);
            if (j->merged.dropped_tangents)
                rep.warnings.push_back(where + ": tangents dropped (they do not follow the new surface; recompute them)");
            add_counters(rep.totals, j->out.stats, first);
            first = false;
            j->out = TessellateOutput{};
        }
        return Status::success();
    });
    if (!done.ok()) return done;
    rep.totals.warnings = rep.warnings;
    return Status::success();
}

} // namespace furrow

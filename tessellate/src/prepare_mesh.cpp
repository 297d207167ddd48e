// Preparing a polygon mesh for crack-free tessellation: weld, repair, classify.
//
// The sharing scheme is the one of OpenSubdiv's Bfr tutorial 2.2 (shared points on base vertices and edges,
// evaluated once) and of DiagSplit (M. Fisher, K. Fatahalian, S. Boulos, K. Akeley, W. R. Mark, P. Hanrahan,
// "DiagSplit: parallel, crack-free, adaptive tessellation for micropolygon rendering", ACM TOG 28(5), 2009):
// one integer rate per edge. What this file adds is the topology those two need to be well defined on real
// meshes (definitions as in T. Ju, "Fixing geometric errors on polygonal models: a survey", 2009):
//   - positions are welded, so UV seams do not become cracks; attributes become face-varying *values*
//     (one per distinct attribute vector at a welded position), split only where they really differ;
//   - polygons that visit a welded vertex twice are split there, what has no area left is dropped;
//   - faces on edges with more than two faces or with opposite orientations are kept out of the refiner and
//     tessellated linearly; faces around interior vertices of valence 2 stay in it, evaluated without the
//     surface cache (OpenSubdiv 3.5.0 may share their patches wrongly: PR 1353);
//   - a *point* (shared tessellation vertex) exists per welded position and edge-connected fan of faces, so
//     bowtie vertices split into one point per fan and every edge's two ends are the same points for all of
//     its faces; the refiner gets the fans of the smooth faces only, so it never sees a non-manifold vertex;
//   - normal *sectors* around each point are separated by creases and non-manifold edges.
// Every classification is a sort or a union-find over corners in index order: deterministic, O(n log n).
#include "tessellate_internal.h"

#include <furrow_kernel/disjoint_sets.h>
#include <furrow_kernel/welded_ids.h>

#include <algorithm>
#include <numbers>
#include <cstring>
#include <numeric>
#include <string>

namespace furrow::tessellate_detail {
namespace {

using kernel::DisjointSets;

// The leading 32-bit word of a key (the keys below lead with a welded position or point index, < n).
uint32_t leading_word(uint64_t k) { return uint32_t(k >> 32); }
uint32_t leading_word(const std::array<uint32_t, 3>& k) { return k[0]; }

// Indices 0..n-1 ordered by key(i), ties by index. The (key, index) records are first placed by a counting
// sort on the key's leading word (a welded position or point index: a few corners each), then each run of
// one leading word is sorted: the order of std::sort over all records, in linear time (the full sort was
// 8 % of a rate-4 tessellation of the 32k-quad cube sphere, prepare included). Falls back to the full sort
// when the leading words are not small indices.
template <class Key, class KeyOf>
std::vector<uint32_t> order_by(size_t n, KeyOf key_of) {
    std::vector<std::pair<Key, uint32_t>> records(n);
    uint32_t top = 0;
    for (size_t i = 0; i < n; ++i) {
        records[i] = {key_of(uint32_t(i)), uint32_t(i)};
        top = std::max(top, leading_word(records[i].first));
    }
    if (size_t(top) > 2 * n + 1024) {
        std::sort(records.begin(), records.end());
    } else {
        std::vector<uint32_t> start(size_t(top) + 2, 0);
        for (const auto& r : records) ++start[size_t(leading_word(r.first)) + 1];
        for (size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
        std::vector<std::pair<Key, uint32_t>> placed(n);
        std::vector<uint32_t> next(start.begin(), start.end() - 1);
        for (const auto& r : records) placed[next[leading_word(r.first)]++] = r; // index order kept per run
        for (size_t b = 0; b + 1 < start.size(); ++b)
            if (start[b + 1] - start[b] > 1) std::sort(placed.begin() + start[b], placed.begin() + start[b + 1]);
        records.swap(placed);
    }
    std::vector<uint32_t> order(n);
    for (size_t i = 0; i < n; ++i) order[i] = records[i].second;
    return order;
}

uint64_t pack(uint32_t hi, uint32_t lo) { return (uint64_t(hi) << 32) | lo; }

uint32_t float_bits(float f) {
    if (f == 0.0f) f = 0.0f; // -0 and +0 are the same value
    uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return u;
}

std::string str(size_t n) { return std::to_string(n); }

Status check_options(const SurfaceOptions& o) {
    if (int(o.scheme) < 0 || int(o.scheme) > 2) return Status::error(StatusCode::invalid_argument, "unknown scheme");
    if (int(o.boundary) < 0 || int(o.boundary) > 1)
        return Status::error(StatusCode::invalid_argument, "unknown boundary interpolation");
    if (int(o.uv_interpolation) < 0 || int(o.uv_interpolation) > 5)
        return Status::error(StatusCode::invalid_argument, "unknown UV interpolation");
    if (!(o.crease_angle_degrees >= 0.0) || !std::isfinite(o.crease_angle_degrees))
        return Status::error(StatusCode::invalid_argument, "crease angle must be a finite angle >= 0 degrees");
    if (o.accuracy < 1 || o.accuracy > 10)
        return Status::error(StatusCode::invalid_argument,
                             "accuracy must be 1..10, got " + std::to_string(o.accuracy));
    if (!(o.weld_tolerance >= 0.0) || !std::isfinite(o.weld_tolerance))
        return Status::error(StatusCode::invalid_argument, "weld tolerance must be finite and >= 0");
    return Status::success();
}

Status check_input(const TessellateInput& in, const SurfaceOptions& o) {
    if (in.vertex_count && !in.positions) return Status::error(StatusCode::invalid_input, "no positions");
    if (in.index_count && !in.indices) return Status::error(StatusCode::invalid_input, "no indices");
    if (in.vertex_count > size_t(0x7fffffff)) return Status::error(StatusCode::out_of_memory, "too many vertices");
    if (in.face_sizes) {
        size_t sum = 0;
        for (size_t f = 0; f < in.face_count; ++f) sum += in.face_sizes[f];
        if (sum != in.index_count)
            return Status::error(StatusCode::invalid_input, "face sizes add up to " + str(sum) + " corners but there are " +
                                                                str(in.index_count) + " indices");
    } else if (in.index_count % 3) {
        return Status::error(StatusCode::invalid_input,
                             str(in.index_count) + " indices do not make whole triangles (give face sizes)");
    }
    if (in.index_count > size_t(0x7fffffff)) return Status::error(StatusCode::out_of_memory, "too many indices");
    // Every position finite (the common case): the indices need only their range checked.
    bool finite = true;
    for (size_t k = 0; k < in.vertex_count * 3; ++k) finite = finite && std::isfinite(in.positions[k]);
    for (size_t i = 0; i < in.index_count; ++i) {
        uint32_t v = in.indices[i];
        if (v >= in.vertex_count)
            return Status::error(StatusCode::invalid_input, "index " + str(i) + " refers to vertex " + str(v) +
                                                                " but there are " + str(in.vertex_count) + " vertices");
        const float* p = in.positions + size_t(v) * 3;
        if (!finite && (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])))
            return Status::error(StatusCode::invalid_input, "vertex " + str(v) + " has a non-finite position");
    }
    if (o.scheme == SubdivisionScheme::loop && in.face_sizes) {
        for (size_t f = 0; f < in.face_count; ++f)
            if (in.face_sizes[f] != 3)
                return Status::error(StatusCode::unsupported, "loop subdivision needs triangles; face " + str(f) + " has " +
                                                                  str(in.face_sizes[f]) + " corners (use catmark)");
    }
    int k = in.uvs ? 2 : 0;
    for (const auto& a : in.attributes) {
        if (a.components < 1 || a.components > 16)
            return Status::error(StatusCode::invalid_argument, "attribute components must be 1..16");
        if (!a.values && in.vertex_count) return Status::error(StatusCode::invalid_input, "attribute without values");
        k += a.components;
    }
    if (k > 64) return Status::error(StatusCode::invalid_argument, "more than 64 attribute floats per vertex");
    int w = 3;
    for (const auto& a : in.vertex_data) {
        if (a.components < 1 || a.components > 16)
            return Status::error(StatusCode::invalid_argument, "vertex data components must be 1..16");
        if (!a.values && in.vertex_count) return Status::error(StatusCode::invalid_input, "vertex data without values");
        w += a.components;
    }
    if (w > 256) return Status::error(StatusCode::invalid_argument, "more than 253 vertex data floats per vertex");
    if (bool(in.joints) != bool(in.weights))
        return Status::error(StatusCode::invalid_input, "joints and weights must be given together");
    return Status::success();
}

// Splits a polygon (welded ids with their corners) at its first repeated vertex, recursively; pieces of fewer
// than 3 corners have no area and are dropped.
void split_polygon(std::vector<std::vector<uint32_t>>& pieces, std::vector<uint32_t> corners,
                   const std::vector<uint32_t>& welded_of_corner) {
    auto w = [&](uint32_t c) { return welded_of_corner[c]; };
    std::vector<std::vector<uint32_t>> stack{std::move(corners)};
    while (!stack.empty()) {
        std::vector<uint32_t> poly = std::move(stack.back());
        stack.pop_back();
        // Consecutive duplicates (cyclically) only shorten the polygon.
        std::vector<uint32_t> clean;
        for (uint32_t c : poly)
            if (clean.empty() || w(clean.back()) != w(c)) clean.push_back(c);
        while (clean.size() > 1 && w(clean.front()) == w(clean.back())) clean.pop_back();
        if (clean.size() < 3) continue;
        size_t i = 0, j = 0;
        bool repeated = false;
        for (i = 0; i < clean.size() && !repeated; ++i)
            for (j = i + 1; j < clean.size(); ++j)
                if (w(clean[i]) == w(clean[j])) {
                    repeated = true;
                    break;
                }
        if (!repeated) {
            pieces.push_back(std::move(clean));
            continue;
        }
        --i; // the loop incremented it once more
        std::vector<uint32_t> a(clean.begin() + long(i), clean.begin() + long(j));
        std::vector<uint32_t> b(clean.begin() + long(j), clean.end());
        b.insert(b.end(), clean.begin(), clean.begin() + long(i));
        // Processed in order a, b (stack: push b first).
        stack.push_back(std::move(b));
        stack.push_back(std::move(a));
    }
}

// The corners ordered by edge key (lower end, upper end), ties by index: order_by's order, by a counting pass
// over the lower ends (a few corners each, placed in index order) and an insertion sort of each run by the
// upper end that moves a corner only past strictly greater ones (the order_by records, twice the size, cost
// more than the sorting here). `welded`: the welded positions, above every end.
std::vector<uint32_t> corners_by_edge(const std::vector<uint64_t>& keys, size_t welded) {
    const size_t C = keys.size();
    if (welded > 2 * C + 1024) return order_by<uint64_t>(C, [&](uint32_t c) { return keys[c]; });
    std::vector<uint32_t> begin(welded + 1, 0), order(C);
    for (uint64_t k : keys) ++begin[leading_word(k) + 1];
    for (size_t v = 0; v < welded; ++v) begin[v + 1] += begin[v];
    std::vector<uint32_t> next(begin.begin(), begin.end() - 1);
    for (uint32_t c = 0; c < C; ++c) order[next[leading_word(keys[c])]++] = c;
    for (size_t v = 0; v < welded; ++v) {
        const uint32_t b = begin[v], e = begin[v + 1];
        if (e - b > 32) { // a vertex of high valence: no quadratic insertion
            std::stable_sort(order.begin() + b, order.begin() + e, [&](uint32_t x, uint32_t y) { return keys[x] < keys[y]; });
            continue;
        }
        for (uint32_t i = b + 1; i < e; ++i) {
            const uint32_t c = order[i];
            uint32_t j = i;
            for (; j > b && keys[order[j - 1]] > keys[c]; --j) order[j] = order[j - 1];
            order[j] = c;
        }
    }
    return order;
}

// Edges of the welded mesh: sides (corners whose outgoing edge it is) grouped by sorted endpoint pair.
void build_edges(PreparedMesh& m) {
    const size_t C = m.corner_input.size();
    std::vector<uint64_t> keys(C);
    for (uint32_t c = 0; c < C; ++c) {
        const uint32_t a = m.corner_welded[c], b = m.corner_welded[m.next_corner(c)];
        keys[c] = pack(std::min(a, b), std::max(a, b));
    }
    const std::vector<uint32_t> half = corners_by_edge(keys, m.welded_input.size());
    auto ekey = [&](uint32_t c) { return keys[c]; };
    m.edge_side_begin.assign(1, 0);
    m.edge_side_begin.reserve(C / 2 + 2); // (closed manifold meshes: exactly)
    m.side_corner.clear();
    m.side_corner.reserve(C);
    m.corner_edge.assign(C, none);
    m.corner_side.assign(C, none);
    for (size_t i = 0; i < C; ++i) {
        if (i && ekey(half[i]) != ekey(half[i - 1])) m.edge_side_begin.push_back(uint32_t(i));
        m.side_corner.push_back(half[i]);
    }
    if (C) m.edge_side_begin.push_back(uint32_t(C));
    const size_t E = m.edge_side_begin.size() - 1;
    for (size_t e = 0; e < E; ++e)
        for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s) {
            m.corner_edge[m.side_corner[s]] = uint32_t(e);
            m.corner_side[m.side_corner[s]] = s;
        }
}

// Consistent orientation per connected component (through edges with two faces), by a breadth-first walk
// from each component's lowest face; the orientation most of the component's faces already have is kept.
// Components that cannot be oriented (Moebius-like) are left alone: their inconsistent edges are reported.
// Returns the number of faces flipped (their corner order reversed, corner 0 kept).
size_t orient_faces(PreparedMesh& m) {
    const size_t F = m.face_count();
    const size_t E = m.edge_side_begin.size() - 1;
    // Already consistent (the common case): every edge between two faces is traversed in opposite
    // directions, so the walk below would keep every face as it is.
    bool consistent = true;
    for (size_t e = 0; e < E && consistent; ++e) {
        if (m.edge_side_begin[e + 1] - m.edge_side_begin[e] != 2) continue;
        const uint32_t c1 = m.side_corner[m.edge_side_begin[e]], c2 = m.side_corner[m.edge_side_begin[e] + 1];
        consistent = m.corner_face[c1] == m.corner_face[c2] || m.corner_welded[c1] != m.corner_welded[c2];
    }
    if (consistent) return 0;
    std::vector<int8_t> flip(F, -1);
    std::vector<uint32_t> queue, component;
    std::vector<uint8_t> to_flip(F, 0);
    size_t flipped = 0;
    for (size_t seed = 0; seed < F; ++seed) {
        if (flip[seed] >= 0) continue;
        flip[seed] = 0;
        queue.assign(1, uint32_t(seed));
        component.clear();
        bool orientable = true;
        for (size_t qi = 0; qi < queue.size(); ++qi) {
            const uint32_t f = queue[qi];
            component.push_back(f);
            for (uint32_t c = m.face_offset[f]; c < m.face_offset[f + 1]; ++c) {
                const uint32_t e = m.corner_edge[c];
                if (e >= E || m.edge_side_begin[e + 1] - m.edge_side_begin[e] != 2) continue;
                const uint32_t s0 = m.side_corner[m.edge_side_begin[e]], s1 = m.side_corner[m.edge_side_begin[e] + 1];
                const uint32_t other = s0 == c ? s1 : s0;
                const uint32_t g = m.corner_face[other];
                if (g == f) continue;
                // Same direction along the edge: the two faces disagree as they stand.
                const bool same = m.corner_welded[c] == m.corner_welded[other];
                const int8_t want = int8_t(flip[f] ^ int8_t(same));
                if (flip[g] < 0) {
                    flip[g] = want;
                    queue.push_back(g);
                } else if (flip[g] != want) {
                    orientable = false;
                }
            }
        }
        if (!orientable) continue;
        size_t n = 0;
        for (uint32_t f : component) n += size_t(flip[f]);
        const bool invert = 2 * n > component.size();
        for (uint32_t f : component) {
            to_flip[f] = uint8_t(flip[f] != int8_t(invert));
            flipped += to_flip[f];
        }
    }
    if (!flipped) return 0;
    for (size_t f = 0; f < F; ++f) {
        if (!to_flip[f]) continue;
        std::reverse(m.corner_input.begin() + m.face_offset[f] + 1, m.corner_input.begin() + m.face_offset[f + 1]);
        std::reverse(m.corner_welded.begin() + m.face_offset[f] + 1, m.corner_welded.begin() + m.face_offset[f + 1]);
    }
    return flipped;
}

uint32_t sides(const PreparedMesh& m, size_t e) { return m.edge_side_begin[e + 1] - m.edge_side_begin[e]; }

// ---- weld
// Fills welded_input, W and welded_data; returns the welded id of every input vertex.
std::vector<uint32_t> weld(PreparedMesh& m, const TessellateInput& in, const SurfaceOptions& o) {
    const size_t nv = in.vertex_count;
    std::vector<uint32_t> remap(nv);
    if (nv) weld_positions(remap.data(), in.positions, nv, 3, o.weld_tolerance);
    kernel::WeldedIds welded = kernel::welded_ids(remap.data(), nv);
    std::vector<uint32_t> welded_of = std::move(welded.of_vertex);
    m.welded_input = std::move(welded.first);
    m.W = 3;
    for (const auto& a : in.vertex_data) {
        m.vertex_data_components.push_back(a.components);
        m.W += a.components;
    }
    m.welded_data.resize(m.welded_input.size() * size_t(m.W));
    for (size_t w = 0; w < m.welded_input.size(); ++w) {
        const size_t v = m.welded_input[w];
        float* d = &m.welded_data[w * size_t(m.W)];
        std::copy(in.positions + v * 3, in.positions + v * 3 + 3, d);
        int k = 3;
        for (const auto& a : in.vertex_data) {
            std::copy(a.values + v * size_t(a.components), a.values + (v + 1) * size_t(a.components), d + k);
            k += a.components;
        }
    }
    return welded_of;
}

// ---- faces: repair
// Fills the faces and their corners, face_group_of with each face's group; returns the number of input
// polygons split into several faces.
size_t repair_faces(PreparedMesh& m, std::vector<uint32_t>& face_group_of, const TessellateInput& in,
                    const std::vector<uint32_t>& welded_of) {
    TessellateStats& st = m.stats;
    const size_t nf_in = in.face_sizes ? in.face_count : in.index_count / 3;
    st.input_faces = nf_in;
    std::vector<uint32_t> welded_of_index(in.index_count);
    for (size_t i = 0; i < in.index_count; ++i) welded_of_index[i] = welded_of[in.indices[i]];
    m.face_offset.reserve(nf_in + 1);
    m.face_source.reserve(nf_in);
    face_group_of.reserve(nf_in);
    m.corner_input.reserve(in.index_count);
    m.corner_welded.reserve(in.index_count);
    m.corner_face.reserve(in.index_count);
    m.face_offset.push_back(0);
    size_t split_polygons = 0;
    size_t first = 0;
    std::vector<std::vector<uint32_t>> pieces;
    for (size_t f = 0; f < nf_in; ++f) {
        const size_t n = in.face_sizes ? in.face_sizes[f] : 3;
        // The common case, no welded vertex twice: no repair, no allocation.
        bool distinct = n >= 3;
        for (size_t i = 0; i < n && distinct && n <= 16; ++i)
            for (size_t j = i + 1; j < n; ++j)
                if (welded_of_index[first + i] == welded_of_index[first + j]) {
                    distinct = false;
                    break;
                }
        if (distinct && n <= 16) {
            for (size_t i = first; i < first + n; ++i) {
                m.corner_input.push_back(in.indices[i]);
                m.corner_welded.push_back(welded_of_index[i]);
                m.corner_face.push_back(uint32_t(m.face_source.size()));
            }
            m.face_source.push_back(uint32_t(f));
            face_group_of.push_back(in.face_groups ? in.face_groups[f] : 0u);
            m.face_offset.push_back(uint32_t(m.corner_input.size()));
            first += n;
            continue;
        }
        std::vector<uint32_t> corners(n);
        std::iota(corners.begin(), corners.end(), uint32_t(first));
        first += n;
        pieces.clear();
        split_polygon(pieces, std::move(corners), welded_of_index);
        if (pieces.empty()) ++st.dropped_faces;
        if (pieces.size() > 1) ++split_polygons;
        for (const auto& piece : pieces) {
            for (uint32_t idx : piece) {
                m.corner_input.push_back(in.indices[idx]);
                m.corner_welded.push_back(welded_of_index[idx]);
                m.corner_face.push_back(uint32_t(m.face_source.size()));
            }
            m.face_source.push_back(uint32_t(f));
            face_group_of.push_back(in.face_groups ? in.face_groups[f] : 0u);
            m.face_offset.push_back(uint32_t(m.corner_input.size()));
        }
    }
    return split_polygons;
}

// The attribute vector (uvs, then the attribute arrays) of input vertex v.
void attr_vector(const TessellateInput& in, size_t v, float* out) {
    int k = 0;
    if (in.uvs) {
        out[k++] = in.uvs[v * 2];
        out[k++] = in.uvs[v * 2 + 1];
    }
    for (const auto& a : in.attributes)
        for (int c = 0; c < a.components; ++c) out[k++] = a.values[v * size_t(a.components) + size_t(c)];
}

// Sets has_uv, has_skin, K and attribute_components, and returns the attribute classes below.
// Attribute class of each input vertex: equal attribute vectors (bitwise) and skins share a class.
std::vector<uint32_t> attribute_classes(PreparedMesh& m, const TessellateInput& in) {
    const size_t nv = in.vertex_count;
    m.has_uv = in.uvs != nullptr;
    m.has_skin = in.joints != nullptr;
    m.K = in.uvs ? 2 : 0;
    for (const auto& a : in.attributes) {
        m.attribute_components.push_back(a.components);
        m.K += a.components;
    }
    const int K = m.K;
    std::vector<uint32_t> attr_class(nv, 0);
    if (K > 0 || m.has_skin) {
        const size_t key_len = size_t(K) + (m.has_skin ? 8 : 0);
        std::vector<uint32_t> keys(nv * key_len);
        std::vector<float> tmp(static_cast<size_t>(K));
        for (size_t v = 0; v < nv; ++v) {
            uint32_t* key = &keys[v * key_len];
            attr_vector(in, v, tmp.data());
            for (int k = 0; k < K; ++k) key[k] = float_bits(tmp[size_t(k)]);
            if (m.has_skin)
                for (int j = 0; j < 4; ++j) {
                    key[K + j] = in.joints[v * 4 + size_t(j)];
                    key[K + 4 + j] = float_bits(in.weights[v * 4 + size_t(j)]);
                }
        }
        // Sorted by a hash of the key, equal keys compared in full: equal vectors end up adjacent.
        std::vector<uint64_t> hash(nv);
        for (size_t v = 0; v < nv; ++v) {
            uint64_t h = 1469598103934665603ull;
            for (size_t k = 0; k < key_len; ++k) h = (h ^ keys[v * key_len + k]) * 1099511628211ull;
            hash[v] = h;
        }
        std::vector<uint32_t> order(nv);
        std::iota(order.begin(), order.end(), 0u);
        std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
            if (hash[a] != hash[b]) return hash[a] < hash[b];
            int c = std::memcmp(&keys[a * key_len], &keys[b * key_len], key_len * sizeof(uint32_t));
            return c != 0 ? c < 0 : a < b;
        });
        uint32_t cls = 0;
        for (size_t i = 0; i < nv; ++i) {
            if (i && std::memcmp(&keys[order[i] * key_len], &keys[order[i - 1] * key_len], key_len * sizeof(uint32_t)))
                ++cls;
            attr_class[order[i]] = cls;
        }
    }
    return attr_class;
}

// Values: distinct (welded position, face group, attribute class) over the corners.
void attribute_values(PreparedMesh& m, const TessellateInput& in, const std::vector<uint32_t>& face_group_of,
                      const std::vector<uint32_t>& attr_class) {
    const size_t C = m.corner_input.size();
    m.corner_value.assign(C, 0);
    if (m.K == 0 && !m.has_skin && !in.face_groups) {
        // No attributes, one group: the key is the welded position alone, so the values are the welded
        // positions that have corners, numbered in order (what the sort below gives, without it).
        std::vector<uint32_t> rank(m.welded_input.size(), 0);
        for (size_t c = 0; c < C; ++c) rank[m.corner_welded[c]] = 1;
        uint32_t next = 0;
        for (uint32_t& r : rank) r = r ? next++ : none;
        for (size_t c = 0; c < C; ++c) m.corner_value[c] = rank[m.corner_welded[c]];
        return;
    }
    auto key = [&](uint32_t c) {
        return std::array<uint32_t, 3>{m.corner_welded[c], face_group_of[m.corner_face[c]], attr_class[m.corner_input[c]]};
    };
    const std::vector<uint32_t> order = order_by<std::array<uint32_t, 3>>(C, key);
    uint32_t value = 0;
    std::vector<float> tmp(static_cast<size_t>(m.K));
    for (size_t i = 0; i < C; ++i) {
        const uint32_t c = order[i];
        if (i && key(c) != key(order[i - 1])) ++value;
        if (i == 0 || key(c) != key(order[i - 1])) {
            const size_t v = m.corner_input[c];
            attr_vector(in, v, tmp.data());
            m.value_attrs.insert(m.value_attrs.end(), tmp.begin(), tmp.end());
            if (m.has_skin) {
                m.value_joints.insert(m.value_joints.end(), in.joints + v * 4, in.joints + v * 4 + 4);
                m.value_weights.insert(m.value_weights.end(), in.weights + v * 4, in.weights + v * 4 + 4);
            }
        }
        m.corner_value[c] = value;
    }
}

// Edges with more than two sides (1) or two sides in the same direction (2) send their faces to face_linear;
// returns the mark of every edge.
std::vector<uint8_t> bad_edges(PreparedMesh& m) {
    TessellateStats& st = m.stats;
    const size_t E = m.edge_side_begin.size() - 1;
    auto consistent = [&](size_t e) { // for two sides: they traverse the edge in opposite directions
        uint32_t c1 = m.side_corner[m.edge_side_begin[e]], c2 = m.side_corner[m.edge_side_begin[e] + 1];
        return m.corner_welded[c1] == m.corner_welded[m.next_corner(c2)];
    };
    std::vector<uint8_t> bad_edge(E, 0);
    for (size_t e = 0; e < E; ++e) {
        if (sides(m, e) > 2) {
            bad_edge[e] = 1;
            ++st.non_manifold_edges;
        } else if (sides(m, e) == 2 && !consistent(e)) {
            bad_edge[e] = 2;
            ++st.inconsistent_edges;
        }
        if (bad_edge[e])
            for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s)
                m.face_linear[m.corner_face[m.side_corner[s]]] = 1;
    }
    return bad_edge;
}

// ---- fans of the smooth faces (the refiner's vertices). Interior vertices of valence 2 (two faces sharing
// both edges at a vertex: the control hull folds there) stay in the refiner. OpenSubdiv 3.5.0's Bfr gives
// their faces the right limit surface (against 9 levels of uniform refinement, test
// tessellate_reference.Valence2VerticesAreOnTheLimitSurface), but may share such a face's
// irregular patch wrongly through its surface cache (fixed in 3.6, PR 1353): those faces are evaluated
// without the cache (face_uncached). The other 3.5.0 bugs there need a semi-sharp edge (PR 1301), which
// furrow never makes, or a valence-2 dart, one infinitely sharp edge at the vertex (PR 1336), which its
// creases cannot make: both edges of a valence-2 vertex lie between the same two faces, so the crease
// angle marks both or neither. A crease at any corner of such a face still makes 3.5.0's builder read
// out of bounds: build_surfaces takes those faces out of Bfr (keep_valence2_faces_off_creases).
// Returns the fan (a corner) of every corner of a smooth face, none for the others.
std::vector<uint32_t> smooth_fans(PreparedMesh& m, const std::vector<uint8_t>& bad_edge) {
    const size_t C = m.corner_input.size(), E = m.edge_side_begin.size() - 1;
    std::vector<uint32_t> smooth_class(C, none);
    m.face_uncached.assign(m.face_count(), 0);
    DisjointSets ds(C);
    std::vector<uint32_t> join_sites;
    for (size_t e = 0; e < E; ++e) {
        if (sides(m, e) != 2 || bad_edge[e]) continue;
        uint32_t c1 = m.side_corner[m.edge_side_begin[e]], c2 = m.side_corner[m.edge_side_begin[e] + 1];
        if (m.face_linear[m.corner_face[c1]] || m.face_linear[m.corner_face[c2]]) continue;
        ds.unite(c1, m.next_corner(c2));
        ds.unite(m.next_corner(c1), c2);
        join_sites.push_back(c1);
        join_sites.push_back(m.next_corner(c1));
    }
    std::vector<uint32_t> corners_in(C, 0), joins_in(C, 0);
    for (uint32_t c = 0; c < C; ++c)
        if (!m.face_linear[m.corner_face[c]]) ++corners_in[ds.find(c)];
    for (uint32_t c : join_sites) ++joins_in[ds.find(c)];
    for (uint32_t c = 0; c < C; ++c) {
        if (m.face_linear[m.corner_face[c]]) continue;
        const uint32_t r = ds.find(c);
        smooth_class[c] = r;
        if (corners_in[r] == 2 && joins_in[r] == 2) {
            m.face_uncached[m.corner_face[c]] = 1;
            if (r == c) ++m.stats.valence2_vertices;
        }
    }
    return smooth_class;
}

// Refiner vertices numbered by their first corner.
void number_refiner_vertices(PreparedMesh& m, const std::vector<uint32_t>& smooth_class) {
    const size_t C = m.corner_input.size();
    std::vector<uint32_t> id(C, none);
    uint32_t next = 0;
    m.corner_refiner_vertex.assign(C, none);
    for (uint32_t c = 0; c < C; ++c) {
        if (smooth_class[c] == none) continue;
        uint32_t& r = id[smooth_class[c]];
        if (r == none) {
            r = next++;
            m.refiner_vertex_welded.push_back(m.corner_welded[c]);
        }
        m.corner_refiner_vertex[c] = r;
    }
}

// ---- points: welded positions split into edge-connected fans of all faces
// Also the edges' end points.
void split_points(PreparedMesh& m) {
    const size_t C = m.corner_input.size(), E = m.edge_side_begin.size() - 1;
    DisjointSets ds(C);
    for (size_t e = 0; e < E; ++e) {
        if (sides(m, e) < 2) continue;
        const uint32_t c0 = m.side_corner[m.edge_side_begin[e]];
        for (uint32_t s = m.edge_side_begin[e] + 1; s < m.edge_side_begin[e + 1]; ++s) {
            const uint32_t c = m.side_corner[s];
            if (m.corner_welded[c] == m.corner_welded[c0]) {
                ds.unite(c, c0);
                ds.unite(m.next_corner(c), m.next_corner(c0));
            } else {
                ds.unite(c, m.next_corner(c0));
                ds.unite(m.next_corner(c), c0);
            }
        }
    }
    std::vector<uint32_t> id(C, none);
    std::vector<uint32_t> points_of_welded(m.welded_input.size(), 0);
    m.point_welded.reserve(m.welded_input.size()); // (a point per welded position, but at bowties)
    m.corner_point.assign(C, none);
    for (uint32_t c = 0; c < C; ++c) {
        uint32_t& p = id[ds.find(c)];
        if (p == none) {
            p = uint32_t(m.point_welded.size());
            m.point_welded.push_back(m.corner_welded[c]);
            ++points_of_welded[m.corner_welded[c]];
        }
        m.corner_point[c] = p;
    }
    for (uint32_t n : points_of_welded) m.stats.split_vertices += n > 1;
    m.edges.resize(E);
    for (size_t e = 0; e < E; ++e) {
        const uint32_t c0 = m.side_corner[m.edge_side_begin[e]];
        uint32_t a = m.corner_point[c0], b = m.corner_point[m.next_corner(c0)];
        m.edges[e] = {std::min(a, b), std::max(a, b)};
    }
}

// ---- creases, seams, normal sectors
// edge_split and edge_crease of every edge.
void creases_and_seams(PreparedMesh& m, const std::vector<uint8_t>& bad_edge) {
    const SurfaceOptions& o = m.options;
    const size_t F = m.face_count(), E = m.edge_side_begin.size() - 1;
    const bool creases = o.crease_angle_degrees < 180.0;
    std::vector<std::array<double, 3>> face_normal(creases ? F : 0); // only the crease test reads them
    std::vector<const float*> pts;
    for (size_t f = 0; f < face_normal.size(); ++f) {
        pts.clear();
        for (uint32_t c = m.face_offset[f]; c < m.face_offset[f + 1]; ++c)
            pts.push_back(&m.welded_data[size_t(m.corner_welded[c]) * size_t(m.W)]);
        face_normal[f] = newell_normal(pts.data(), pts.size());
    }
    const double cos_crease = std::cos(o.crease_angle_degrees * std::numbers::pi / 180.0);
    m.edge_split.assign(E, 0);
    m.edge_crease.assign(E, 0);
    for (size_t e = 0; e < E; ++e) {
        if (sides(m, e) == 1) continue;
        if (bad_edge[e]) {
            m.edge_split[e] = 3;
            continue;
        }
        const uint32_t c1 = m.side_corner[m.edge_side_begin[e]], c2 = m.side_corner[m.edge_side_begin[e] + 1];
        if (creases) {
            const auto& n1 = face_normal[m.corner_face[c1]];
            const auto& n2 = face_normal[m.corner_face[c2]];
            double l = length3(n1) * length3(n2);
            if (l > 0 && (n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2]) / l < cos_crease) {
                m.edge_split[e] |= 2;
                m.edge_crease[e] = 1;
                ++m.stats.crease_edges;
            }
        }
        if (m.corner_value[c1] != m.corner_value[m.next_corner(c2)] || m.corner_value[m.next_corner(c1)] != m.corner_value[c2])
            m.edge_split[e] |= 1;
    }
}

// The normal sector of every corner, as its root corner: corners joined across edges that are no crease.
std::vector<uint32_t> sector_roots(const PreparedMesh& m) {
    const size_t C = m.corner_input.size(), E = m.edge_side_begin.size() - 1;
    std::vector<uint32_t> sector_root(C);
    DisjointSets ds(C);
    for (size_t e = 0; e < E; ++e) {
        if (sides(m, e) != 2 || (m.edge_split[e] & 2)) continue;
        uint32_t c1 = m.side_corner[m.edge_side_begin[e]], c2 = m.side_corner[m.edge_side_begin[e] + 1];
        ds.unite(c1, m.next_corner(c2));
        ds.unite(m.next_corner(c1), c2);
    }
    for (uint32_t c = 0; c < C; ++c) sector_root[c] = ds.find(c);
    return sector_root;
}

// ---- groups: output vertices at points, one per (point, value, sector)
// The common case first: every point's corners have one value and one sector (no seam, crease or
// non-manifold fan through it). Then the sorts of build_groups give one group and one sector per point, in
// point order, and each point's corners in index order: the same arrays, from one counting pass. False (and
// nothing written) if some point has more than one group.
bool build_groups_per_point(PreparedMesh& m, const std::vector<uint32_t>& sector_root) {
    const size_t C = m.corner_input.size(), P = m.point_welded.size();
    std::vector<uint32_t> first(P, none), start(P + 1, 0);
    for (uint32_t c = 0; c < C; ++c) {
        const uint32_t p = m.corner_point[c];
        if (first[p] == none) first[p] = c;
        else if (m.corner_value[c] != m.corner_value[first[p]] || sector_root[c] != sector_root[first[p]]) return false;
        ++start[p + 1];
    }
    for (size_t p = 0; p < P; ++p) start[p + 1] += start[p];
    m.corner_group = m.corner_point;
    m.point_group_begin.resize(P + 1);
    std::iota(m.point_group_begin.begin(), m.point_group_begin.end(), 0u);
    m.group_point.resize(P);
    std::iota(m.group_point.begin(), m.group_point.end(), 0u);
    m.group_sector = m.group_point;
    m.group_value.resize(P);
    for (size_t p = 0; p < P; ++p) m.group_value[p] = m.corner_value[first[p]];
    m.group_attr_end.resize(P);
    std::iota(m.group_attr_end.begin(), m.group_attr_end.end(), 1u);
    m.sector_begin = start;
    m.sector_corners.resize(C);
    for (uint32_t c = 0; c < C; ++c) m.sector_corners[start[m.corner_point[c]]++] = c;
    return true;
}

void build_groups(PreparedMesh& m, const std::vector<uint32_t>& sector_root) {
    if (build_groups_per_point(m, sector_root)) return;
    const size_t C = m.corner_input.size(), P = m.point_welded.size();
    auto key = [&](uint32_t c) {
        return std::array<uint32_t, 3>{m.corner_point[c], m.corner_value[c], sector_root[c]};
    };
    const std::vector<uint32_t> order = order_by<std::array<uint32_t, 3>>(C, key);
    m.corner_group.assign(C, none);
    m.point_group_begin.assign(P + 1, 0);
    for (size_t i = 0; i < C; ++i) {
        const uint32_t c = order[i];
        if (i == 0 || key(c) != key(order[i - 1])) {
            m.group_point.push_back(m.corner_point[c]);
            m.group_value.push_back(m.corner_value[c]);
            m.group_sector.push_back(sector_root[c]); // a corner for now, a sector index below
            ++m.point_group_begin[m.corner_point[c] + 1];
        }
        m.corner_group[c] = uint32_t(m.group_value.size() - 1);
    }
    for (size_t p = 0; p < P; ++p) m.point_group_begin[p + 1] += m.point_group_begin[p];
    const size_t G = m.group_value.size();
    m.group_attr_end.assign(G, 0);
    for (size_t g = G; g-- > 0;) {
        const bool same_next = g + 1 < G && m.group_point[g + 1] == m.group_point[g] &&
                               m.group_value[g + 1] == m.group_value[g];
        m.group_attr_end[g] = same_next ? m.group_attr_end[g + 1] : uint32_t(g + 1);
    }
    // Sectors: runs of (point, sector root) over the corners.
    auto skey = [&](uint32_t c) { return pack(m.corner_point[c], sector_root[c]); };
    const std::vector<uint32_t> sorder = order_by<uint64_t>(C, skey);
    std::vector<uint32_t> sector_of_root(C, none);
    for (size_t i = 0; i < C; ++i) {
        const uint32_t c = sorder[i];
        if (i == 0 || skey(c) != skey(sorder[i - 1])) {
            sector_of_root[sector_root[c]] = uint32_t(m.sector_begin.size());
            m.sector_begin.push_back(uint32_t(i));
        }
        m.sector_corners.push_back(c);
    }
    m.sector_begin.push_back(uint32_t(C));
    for (auto& s : m.group_sector) s = sector_of_root[s];
}

// ---- bounding box
void bounding_box(PreparedMesh& m) {
    bool any = false;
    for (uint32_t w : m.corner_welded) {
        const float* p = &m.welded_data[size_t(w) * size_t(m.W)];
        for (int k = 0; k < 3; ++k) {
            m.bbox_min[k] = any ? std::min(m.bbox_min[k], double(p[k])) : double(p[k]);
            m.bbox_max[k] = any ? std::max(m.bbox_max[k], double(p[k])) : double(p[k]);
        }
        any = true;
    }
}

} // namespace

Status check_surface_options(const SurfaceOptions& options) { return check_options(options); }

Status prepare_mesh(PreparedMesh& m, const TessellateInput& in, const SurfaceOptions& o) {
    if (Status s = check_options(o); !s.ok()) return s;
    if (Status s = check_input(in, o); !s.ok()) return s;
    m = PreparedMesh{};
    m.options = o;
    m.scheme = o.scheme == SubdivisionScheme::loop       ? osd::Sdc::SCHEME_LOOP
               : o.scheme == SubdivisionScheme::bilinear ? osd::Sdc::SCHEME_BILINEAR
                                                         : osd::Sdc::SCHEME_CATMARK;
    TessellateStats& st = m.stats;
    m.input_vertex_count = in.vertex_count;

    const std::vector<uint32_t> welded_of = weld(m, in, o);

    std::vector<uint32_t> face_group_of;
    const size_t split_polygons = repair_faces(m, face_group_of, in, welded_of);
    st.faces = m.face_count();
    if (o.refuse_bad_topology && st.dropped_faces)
        return Status::error(StatusCode::invalid_input, str(st.dropped_faces) + " degenerate faces (a repeated vertex)");
    if (o.refuse_bad_topology && split_polygons)
        return Status::error(StatusCode::invalid_input, str(split_polygons) + " faces that visit a vertex twice");
    m.face_linear.assign(m.face_count(), 0);
    build_edges(m);
    st.flipped_faces = orient_faces(m);
    if (st.flipped_faces && o.refuse_bad_topology)
        return Status::error(StatusCode::invalid_input, str(st.flipped_faces) + " faces oriented against their neighbours");

    // ---- attribute values
    const std::vector<uint32_t> attr_class = attribute_classes(m, in);
    attribute_values(m, in, face_group_of, attr_class);

    // ---- edges over welded positions (again if faces were flipped)
    if (st.flipped_faces) build_edges(m);
    st.edges = m.edge_side_begin.size() - 1;
    const std::vector<uint8_t> bad_edge = bad_edges(m);
    if (o.refuse_bad_topology) {
        if (st.non_manifold_edges)
            return Status::error(StatusCode::invalid_input, str(st.non_manifold_edges) + " non-manifold edges");
        if (st.inconsistent_edges)
            return Status::error(StatusCode::invalid_input,
                                 str(st.inconsistent_edges) + " edges with inconsistently oriented faces");
    }

    number_refiner_vertices(m, smooth_fans(m, bad_edge));
    split_points(m);
    creases_and_seams(m, bad_edge);
    build_groups(m, sector_roots(m));
    bounding_box(m);
    return Status::success();
}

} // namespace furrow::tessellate_detail

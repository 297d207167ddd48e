// Crack-free evaluation of a Bfr tessellation with shared points.
//
// Reference: OpenSubdiv 3.5, Bfr tutorial 2.2 ("tessellate watertight"): Tessellation lists the boundary
// coordinates first, vertex 0, the points of edge 0, vertex 1, ...; each point on a base vertex or edge is
// evaluated once by one face and the neighbours reuse it, walking the edge in reverse
// (TransformFacetCoordIndices remaps the facets). Rates alone leave floating-point gaps (OpenSubdiv issue
// 1316): shared points are what makes the output watertight.
//
// Here the sharing is made deterministic and parallel: every point has an owner decided beforehand (the
// first smooth face around it, see build_surfaces.cpp), the output index of every point is known from prefix
// sums over the rates before anything is evaluated, and each face writes only what it owns. Smooth faces
// run first; faces tessellated linearly run second, interpolating the (already evaluated) limit positions of
// their corners, so a fallback face stays attached to its smooth neighbours.
//
// Normals at shared points: where the limit surface is smooth across the point (an edge that is no crease, a
// normal sector, between regular B-spline patches only: choose_normal_owners in build_surfaces.cpp), every
// face has the same normal there, so the owner's evaluation serves all of them and the other faces skip it
// (at rate 4 about a third of all evaluations were such repeats). Elsewhere (creases, sector boundaries,
// faces tessellated linearly, irregular patches) every face evaluates its own normal and they are averaged
// per normal sector, which gives split normals across creases. Where the owner finds no tangent plane (vanishing derivatives: the control polygon's
// normal is the fallback, and it differs per face), the point is marked and every face evaluates it in a
// second, small pass, as at a crease.
//
// Regular interior faces (a B-spline patch of 16 control points, no boundary: Bfr::Surface::IsRegular(),
// OpenSubdiv "Bfr Overview", regular patches) all evaluate the same basis weights at the same tessellation
// coordinates, since the coordinates depend on the rates only. The weights of P, Du, Dv are computed once per
// rate signature and thread (Surface::EvaluateStencil, which calls the same Far basis as Surface::Evaluate)
// and the 16 patch points are combined here in Bfr's order (points::Combine3: the first point's product, then
// the others' added in turn, no fused multiply-add: -ffp-contract=off in CMakeLists.txt), which gives the same
// bits as Surface::Evaluate. `furrow -j 1 bench tessellate --blender-only --repeat 5` (32k-quad cube sphere,
// prepare + tessellate, three interleaved rounds against the binary before this path): rate 8 239-286 ->
// 132-142 ms, rate 4 84-95 -> 56-60 ms (Blender level 2: 191-244 ms, level 3: 688-786 ms in the same runs).
// With positions alone, a face combines all its coordinates at once, several per vector (limit_blocks), and
// normalises their normals there too, with the same operations per lane.
//
// The tessellation pattern itself (Bfr::Tessellation's coordinates and triangles) is a function of the face
// size and the rates, so it is cached per signature and thread too (Pattern), and the triangles' corners are
// mapped to output vertices here as TransformFacetCoordIndices does.
#include "tessellate_internal.h"
#include <furrow_kernel/huge_pages.h>

#include <opensubdiv/bfr/tessellation.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>

namespace furrow::tessellate_detail {
namespace {

void normalise(float* n) {
    double l = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
    if (l > 0 && std::isfinite(l)) {
        n[0] = float(n[0] / l);
        n[1] = float(n[1] / l);
        n[2] = float(n[2] / l);
    } else {
        n[0] = n[1] = n[2] = 0.0f;
    }
}

bool is_zero(const float* n) { return n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f; }

// Per-thread buffers, reused from face to face.
struct Scratch {
    std::vector<int> rates, bidx;
    std::vector<float> patch_v, patch_a, P, Du, Dv, w;
    std::vector<float> limit; // regular interior faces, positions alone: P and unit normal of every coordinate
    std::vector<const float*> corner_data, control;
};

// ---- regular interior faces: basis weights cached per rate signature
int limit_lanes();
constexpr int regular_weights = 3 * regular_points; // per coordinate: P, Du, Dv

// The weights of every coordinate of one tessellation (one rate signature) of a regular interior patch.
struct RegularWeights {
    std::vector<int> rates;
    std::vector<float> w; // per coordinate: 16 of P, 16 of Du, 16 of Dv
    // The same per block of limit_lanes() coordinates, transposed: per weight (16 of P, 16 of Du, 16 of Dv),
    // the block's coordinates side by side (0 past the last coordinate), for limit_blocks.
    std::vector<float> blocks;
};

// The tessellation of one signature (face size and rates): Bfr::Tessellation's coordinates and triangles,
// which depend on the parameterisation (the scheme and the face size) and the rates alone, so one face
// computes them for all faces of its signature (a face of the cube sphere at rate 4 built its Tessellation,
// copied out its coordinates and triangles and remapped them through TransformFacetCoordIndices: 10 % of the
// evaluation).
struct Pattern {
    int n = 0;
    std::vector<int> rates;
    int ncoords = 0, nb = 0, nfacets = 0;
    std::vector<float> coords; // (u, v) of every coordinate, the boundary's first
    std::vector<int> facets;   // triangles: 3 coordinate indices each

    void build(const osd::Bfr::Parameterization& param, int size, const std::vector<int>& face_rates) {
        osd::Bfr::Tessellation t(param, int(face_rates.size()), face_rates.data(),
                                 osd::Bfr::Tessellation::Options().SetFacetSize(3));
        n = size;
        rates = face_rates;
        ncoords = t.GetNumCoords();
        nb = t.GetNumBoundaryCoords();
        nfacets = t.GetNumFacets();
        coords.resize(size_t(ncoords) * 2);
        t.GetCoords(coords.data());
        facets.resize(size_t(nfacets) * 3);
        t.GetFacets(facets.data());
    }
};

// One thread's cache of patterns and regular weights (functions of the signature alone: which thread computed
// them changes no bit). A handful of signatures at uniform rates; bounded for adaptive rates, where the rest
// are computed per face.
struct FaceCache {
    static constexpr size_t max_entries = 64;
    std::vector<RegularWeights> entries;
    std::vector<std::unique_ptr<Pattern>> patterns; // (stable addresses)
    Pattern spare; // the last pattern asked for once the cache is full
};
using FaceCaches = tbb::enumerable_thread_specific<FaceCache>;

// The pattern of face f's signature (its rates in `rates`, from face_rates); valid until the next call.
const Pattern& pattern_for(FaceCache& cache, const osd::Bfr::Parameterization& param, int n, const std::vector<int>& rates) {
    for (const auto& p : cache.patterns)
        if (p->n == n && p->rates == rates) return *p;
    Pattern* p = &cache.spare;
    if (cache.patterns.size() < FaceCache::max_entries) p = cache.patterns.emplace_back(std::make_unique<Pattern>()).get();
    p->build(param, n, rates);
    return *p;
}

// The cached weights for this face's rates, null if there are none yet.
const RegularWeights* cached_weights(const FaceCache& cache, const std::vector<int>& rates) {
    for (const RegularWeights& e : cache.entries)
        if (e.rates == rates) return &e;
    return nullptr;
}

// The weights for this face's rates, computed from its surface if new; null if the cache is full.
const RegularWeights* regular_weights_for(FaceCache& cache, const Surface& s, const std::vector<int>& rates,
                                 const std::vector<float>& coords, int ncoords) {
    if (const RegularWeights* e = cached_weights(cache, rates)) return e;
    if (cache.entries.size() >= FaceCache::max_entries) return nullptr;
    RegularWeights e{rates, std::vector<float>(size_t(ncoords) * regular_weights), {}};
    for (int i = 0; i < ncoords; ++i) {
        float* w = &e.w[size_t(i) * regular_weights];
        s.EvaluateStencil(&coords[size_t(i) * 2], w, w + regular_points, w + 2 * regular_points);
    }
    const size_t L = size_t(limit_lanes());
    e.blocks.assign((size_t(ncoords) + L - 1) / L * regular_weights * L, 0.0f);
    for (size_t i = 0; i < size_t(ncoords); ++i)
        for (size_t k = 0; k < regular_weights; ++k)
            e.blocks[(i / L * regular_weights + k) * L + i % L] = e.w[i * regular_weights + k];
    cache.entries.push_back(std::move(e));
    return &cache.entries.back();
}

// P, Du, Dv from 16 patch points of any width, as Bfr's points::Combine3 sums them.
void combine3(const float* w, const float* pts, int n, float* P, float* Du, float* Dv) {
    const float *wp = w, *wu = w + regular_points, *wv = w + 2 * regular_points;
    for (int j = 0; j < n; ++j) {
        P[j] = wp[0] * pts[j];
        Du[j] = wu[0] * pts[j];
        Dv[j] = wv[0] * pts[j];
    }
    for (int i = 1; i < regular_points; ++i) {
        const float* src = pts + size_t(i) * size_t(n);
        for (int j = 0; j < n; ++j) {
            P[j] += wp[i] * src[j];
            Du[j] += wu[i] * src[j];
            Dv[j] += wv[i] * src[j];
        }
    }
}

// Positions alone (3 floats): P and the unit normal of every coordinate of the face at once, L coordinates
// side by side in the lanes of a vector (GCC vector extensions). Each lane does the float products and sums
// of Combine3, in its order (the weight times the point, then added to the running sum), then the cross
// product and normalise() above, in double as there: the same bits. One coordinate at a time, the sums were
// 3 chains of 16 dependent additions and the normal a chain of square root and divisions, each waiting on
// the latency of the last; L coordinates are 9 (then 3) independent chains of L lanes each.
// The padding coordinates of the last block have zero weights and are never read.
// weights: RegularWeights::blocks; out, per block of L: x, y, z of P, then of the normal (6 x L floats).
template <int L>
struct Lanes; // L floats, L ints, L doubles (GCC takes no vector size that depends on a template argument)
template <>
struct Lanes<4> {
    typedef float F __attribute__((vector_size(16)));
    typedef int32_t I __attribute__((vector_size(16)));
    typedef double D __attribute__((vector_size(32)));
};
template <>
struct Lanes<16> {
    typedef float F __attribute__((vector_size(64)));
    typedef int32_t I __attribute__((vector_size(64)));
    typedef double D __attribute__((vector_size(128)));
};

template <int L>
[[gnu::always_inline]] inline void limit_blocks_of(const float* weights, size_t nblocks, const float* pts, float* out) {
    using F = typename Lanes<L>::F;
    using I = typename Lanes<L>::I;
    using D = typename Lanes<L>::D;
    for (size_t b = 0; b < nblocks; ++b, weights += regular_weights * L, out += 6 * L) {
        F acc[9];
        F w;
        for (int k = 0; k < 3; ++k) {
            std::memcpy(&w, weights + k * regular_points * L, sizeof w);
            for (int d = 0; d < 3; ++d) acc[k * 3 + d] = w * pts[d];
        }
        for (int i = 1; i < regular_points; ++i) {
            const float* src = pts + size_t(i) * 3;
            for (int k = 0; k < 3; ++k) {
                std::memcpy(&w, weights + (k * regular_points + i) * L, sizeof w);
                for (int d = 0; d < 3; ++d) acc[k * 3 + d] += w * src[d];
            }
        }
        const F *u = acc + 3, *v = acc + 6;
        const D n[3] = {__builtin_convertvector(u[1] * v[2] - u[2] * v[1], D),
                        __builtin_convertvector(u[2] * v[0] - u[0] * v[2], D),
                        __builtin_convertvector(u[0] * v[1] - u[1] * v[0], D)};
        const D s = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        D l;
        for (int j = 0; j < L; ++j) l[j] = std::sqrt(s[j]);
        const I ok = __builtin_convertvector((l > 0.0) & (l <= std::numeric_limits<double>::max()), I); // -1 or 0
        for (int d = 0; d < 3; ++d) {
            std::memcpy(out + d * L, &acc[d], sizeof(F));
            const F q = (F)((I)__builtin_convertvector(n[d] / l, F) & ok);
            std::memcpy(out + (3 + d) * L, &q, sizeof(F));
        }
    }
}

#if defined(__x86_64__) && defined(__GNUC__)
// 16 lanes where the processor has AVX-512 (chosen at run time: the build targets baseline x86-64).
[[gnu::target("avx512f")]] void limit_blocks16(const float* weights, size_t nblocks, const float* pts, float* out) {
    limit_blocks_of<16>(weights, nblocks, pts, out);
}
#endif
void limit_blocks4(const float* weights, size_t nblocks, const float* pts, float* out) {
    limit_blocks_of<4>(weights, nblocks, pts, out);
}

// The lanes of limit_blocks on this processor (which changes no bit: each lane computes alone).
int limit_lanes() {
#if defined(__x86_64__) && defined(__GNUC__)
    static const int lanes = __builtin_cpu_supports("avx512f") ? 16 : 4;
    return lanes;
#else
    return 4;
#endif
}

void limit_blocks(const float* weights, size_t nblocks, const float* pts, float* out) {
#if defined(__x86_64__) && defined(__GNUC__)
    if (limit_lanes() == 16) return limit_blocks16(weights, nblocks, pts, out);
#endif
    limit_blocks4(weights, nblocks, pts, out);
}

// P alone (face-varying data), as Bfr's points::Combine1 sums them.
void combine1(const float* wp, const float* pts, int n, float* P) {
    for (int j = 0; j < n; ++j) P[j] = wp[0] * pts[j];
    for (int i = 1; i < regular_points; ++i) {
        const float* src = pts + size_t(i) * size_t(n);
        for (int j = 0; j < n; ++j) P[j] += wp[i] * src[j];
    }
}

// A working array of floats left uninitialised (no zero-fill pass): only for arrays whose every element that
// is read was written first.
struct UninitialisedFloats {
    kernel::HugeBytes bytes;
    bool allocate(size_t n) {
        bytes = kernel::allocate_huge_bytes(n * sizeof(float));
        return bytes != nullptr;
    }
    float& operator[](size_t i) { return reinterpret_cast<float*>(bytes.get())[i]; }
    const float& operator[](size_t i) const { return reinterpret_cast<const float*>(bytes.get())[i]; }
};

struct Layout {
    std::vector<uint32_t> face_interior, face_out, face_tri; // per face: interior count, first interior output, first triangle
    std::vector<uint32_t> edge_out;                          // unsplit edges: first output of their points
    std::vector<uint32_t> side_out;                          // split edges: first output per side
    std::vector<uint32_t> side_slot;                         // every side: first normal slot
    size_t vertices = 0, triangles = 0, slots = 0;
};

// The working state of one evaluate_tessellation: what the faces read, and the buffers they write.
struct Evaluation {
    const PreparedMesh& m;
    const std::vector<int>& rates;
    TessellateOutput& out;
    const bool keep_parameters;
    const int W, K;
    Layout L;
    std::vector<float> data, attrs;                // W and K floats per output vertex
    // Normals each face evaluates at its boundary points: all of them where they are averaged, the owner's
    // where they are shared (the only one read there).
    UninitialisedFloats corner_normal, side_normal;
    // Shared normals whose owner fell back to its control polygon: every face evaluates them (second pass).
    std::vector<uint8_t> sector_fallback, edge_fallback;
    FaceCaches face_cache;
};

// Output indices and normal slots of everything, from prefix sums over the rates.
Status plan_layout(Layout& L, FaceCaches& caches, const PreparedMesh& m, const std::vector<int>& rates) {
    const size_t F = m.face_count(), E = m.edges.size();
    L.face_interior.resize(F);
    std::vector<uint32_t> face_facets(F);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, F, 512), [&](const tbb::blocked_range<size_t>& range) {
        std::vector<int> r;
        FaceCache& cache = caches.local();
        for (size_t f = range.begin(); f != range.end(); ++f) {
            face_rates(m, f, rates, r);
            const Pattern& p = pattern_for(cache, m.parameterization(f), int(m.face_size(f)), r);
            L.face_interior[f] = uint32_t(p.ncoords - p.nb);
            face_facets[f] = uint32_t(p.nfacets);
        }
    });
    size_t cursor = m.group_value.size(), slots = 0, tris = 0;
    L.edge_out.assign(E, none);
    L.side_out.assign(m.side_corner.size(), none);
    L.side_slot.assign(m.side_corner.size(), 0);
    for (size_t e = 0; e < E; ++e) {
        const size_t n = size_t(rates[e] - 1);
        if (!m.edge_split[e]) {
            L.edge_out[e] = uint32_t(cursor);
            cursor += n;
        }
        for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s) {
            if (m.edge_split[e]) {
                L.side_out[s] = uint32_t(cursor);
                cursor += n;
            }
            L.side_slot[s] = uint32_t(slots);
            slots += n;
        }
        if (cursor > 0xfffffff0u) return Status::error(StatusCode::out_of_memory, "more than 4 billion output vertices");
    }
    L.face_out.resize(F);
    L.face_tri.resize(F);
    for (size_t f = 0; f < F; ++f) {
        L.face_out[f] = uint32_t(cursor);
        cursor += L.face_interior[f];
        L.face_tri[f] = uint32_t(tris);
        tris += face_facets[f];
        if (cursor > 0xfffffff0u || tris * 3 > 0xfffffff0u)
            return Status::error(StatusCode::out_of_memory, "more than 4 billion output indices or vertices");
    }
    L.vertices = cursor;
    L.triangles = tris;
    L.slots = slots;
    return Status::success();
}

// The output arrays and the working buffers at their sizes, zeroed (but the normal slots); the large ones on
// huge pages (their first-touch page faults were the largest fixed cost: furrow_kernel/huge_pages.h).
[[nodiscard]] Status allocate(Evaluation& ev) {
    using kernel::assign_huge;
    const PreparedMesh& m = ev.m;
    TessellateOutput& out = ev.out;
    const size_t V = ev.L.vertices, tris = ev.L.triangles;
    assign_huge(ev.data, V * size_t(ev.W));
    assign_huge(ev.attrs, V * size_t(ev.K));
    assign_huge(out.normals, V * 3);
    if (m.has_skin) {
        assign_huge(out.joints, V * 4);
        assign_huge(out.weights, V * 4);
    }
    assign_huge(out.indices, tris * 3);
    assign_huge(out.triangle_faces, tris);
    out.triangle_patches.clear();
    out.triangle_coords.clear();
    if (ev.keep_parameters) {
        assign_huge(out.triangle_patches, tris);
        assign_huge(out.triangle_coords, tris * 6);
    }
    if (!ev.corner_normal.allocate(m.corner_input.size() * 3) || !ev.side_normal.allocate(ev.L.slots * 3))
        return Status::error(StatusCode::out_of_memory, "cannot allocate the normal slots");
    ev.sector_fallback.assign(m.sector_normal_owner.size(), 0);
    ev.edge_fallback.assign(m.edges.size(), 0);
    return Status::success();
}

// One face being evaluated: its tessellation, and what its points are evaluated from (the patch points of
// its surfaces, or its corners for a face tessellated linearly).
struct FaceEvaluation {
    Evaluation& ev;
    const PreparedMesh& m;
    const Layout& L;
    const int W, K;
    const size_t f;
    const bool smooth;
    Surface &vtx, &fvar;
    Scratch& x;
    FaceCache& cache;
    const uint32_t c0;
    const int n;
    const osd::Bfr::Parameterization param;
    const int nr;
    const Pattern& pat;
    const int ncoords, nb;
    float face_normal[3] = {0, 0, 1};
    // Regular interior surfaces: the cached weights of every coordinate (null: Bfr evaluates).
    const float* vtx_weights = nullptr;
    const float* fvar_weights = nullptr;
    bool has_limit = false; // x.limit holds P and the normal of every coordinate (limit_blocks)
    bool vtx_ready;         // vtx is this face's surface (else made when needed: prepare_smooth)

    // vtx_ready false: vtx was not made for a face build_surfaces found regular interior.
    FaceEvaluation(Evaluation& ev, size_t f, bool smooth, bool limit_corners, Surface& vtx, Surface& fvar, Scratch& x,
                   bool vtx_ready = true);
    void prepare_smooth();
    void control_normal(float* nrm);
    bool eval_point(int i, float* nrm);
    void eval_attrs(int i, size_t o);
    void write_data(size_t o) {
        float* dst = &ev.data[o * size_t(W)];
        if (W == 3) // positions alone: no library call for 12 bytes
            dst[0] = x.P[0], dst[1] = x.P[1], dst[2] = x.P[2];
        else
            std::copy(x.P.begin(), x.P.end(), dst);
    }
    void boundary();
    void fallback_normals();
    void interior();
    void triangles();
};

FaceEvaluation::FaceEvaluation(Evaluation& ev, size_t f, bool smooth, bool limit_corners, Surface& vtx, Surface& fvar,
                               Scratch& x, bool vtx_ready)
    : ev(ev), m(ev.m), L(ev.L), W(ev.W), K(ev.K), f(f), smooth(smooth), vtx(vtx), fvar(fvar), x(x),
      cache(ev.face_cache.local()), c0(m.face_offset[f]), n(int(m.face_size(f))), param(m.parameterization(f)),
      nr(face_rates(m, f, ev.rates, x.rates)), pat(pattern_for(cache, param, n, x.rates)), ncoords(pat.ncoords),
      nb(pat.nb), vtx_ready(vtx_ready) {
    x.bidx.resize(size_t(nb));
    x.P.resize(size_t(W));
    x.Du.resize(size_t(W));
    x.Dv.resize(size_t(W));
    x.w.resize(size_t(n));
    x.corner_data.resize(size_t(n));
    if (smooth) {
        prepare_smooth();
    } else {
        for (int k = 0; k < n; ++k) {
            const uint32_t c = c0 + uint32_t(k), p = m.corner_point[c];
            x.corner_data[size_t(k)] = limit_corners && m.smooth(m.corner_face[m.point_owner[p]])
                                           ? &ev.data[size_t(m.point_group_begin[p]) * size_t(W)]
                                           : &m.welded_data[size_t(m.corner_welded[c]) * size_t(W)];
        }
        auto nn = newell_normal(x.corner_data.data(), size_t(n));
        face_normal[0] = float(nn[0]);
        face_normal[1] = float(nn[1]);
        face_normal[2] = float(nn[2]);
        normalise(face_normal);
    }
}

// Patch points and cached weights of a smooth face. A regular interior face (build_surfaces) comes without
// its vertex surface (vtx_ready false): its patch points are its control points, and the surface is made
// here only if Bfr must evaluate it (a full cache) or its signature's weights are new.
void FaceEvaluation::prepare_smooth() {
    auto make_surface = [&] {
        if (!vtx_ready) vtx_ready = m.factory_of(f).InitVertexSurface(m.face_refiner[f], &vtx);
        return vtx_ready; // (it was made once in build_surfaces: a failure here would be a bug)
    };
    const bool known = !vtx_ready;
    if (known) {
        x.patch_v.resize(size_t(regular_points) * size_t(W));
        const uint32_t* control = &m.regular_control[f * regular_points];
        if (W == 3) // positions alone: no library call for 12 bytes
            for (size_t i = 0; i < size_t(regular_points); ++i)
                for (size_t d = 0; d < 3; ++d) x.patch_v[i * 3 + d] = m.refiner_data[size_t(control[i]) * 3 + d];
        else
            for (size_t i = 0; i < size_t(regular_points); ++i)
                std::copy_n(&m.refiner_data[size_t(control[i]) * size_t(W)], W, &x.patch_v[i * size_t(W)]);
    } else {
        x.patch_v.resize(size_t(vtx.GetNumPatchPoints()) * size_t(W));
        vtx.PreparePatchPoints(m.refiner_data.data(), W, x.patch_v.data(), W);
    }
    if (K > 0) {
        x.patch_a.resize(size_t(fvar.GetNumPatchPoints()) * size_t(K));
        fvar.PreparePatchPoints(m.refiner_fvar.data(), K, x.patch_a.data(), K);
    }
    // (Pointers into the entries' own arrays: those stay put when the cache grows.)
    const RegularWeights* rw = nullptr;
    if (known) {
        rw = cached_weights(cache, x.rates);
        if (!rw && make_surface()) rw = regular_weights_for(cache, vtx, x.rates, pat.coords, ncoords);
    } else if (regular_interior(vtx, param)) {
        rw = regular_weights_for(cache, vtx, x.rates, pat.coords, ncoords);
    }
    if (rw) {
        vtx_weights = rw->w.data();
        if (W == 3) {
            const size_t nblocks = rw->blocks.size() / (regular_weights * size_t(limit_lanes()));
            x.limit.resize(nblocks * 6 * size_t(limit_lanes()));
            limit_blocks(rw->blocks.data(), nblocks, x.patch_v.data(), x.limit.data());
            has_limit = true;
        }
    } else {
        make_surface(); // Bfr evaluates
    }
    if (K > 0 && regular_interior(fvar, param))
        if (const RegularWeights* fw = regular_weights_for(cache, fvar, x.rates, pat.coords, ncoords)) fvar_weights = fw->w.data();
}

// The control polygon's normal: the fallback where the surface's derivatives vanish.
void FaceEvaluation::control_normal(float* nrm) {
    x.control.resize(size_t(n));
    for (int k = 0; k < n; ++k)
        x.control[size_t(k)] = &m.welded_data[size_t(m.corner_welded[c0 + uint32_t(k)]) * size_t(W)];
    auto nn = newell_normal(x.control.data(), size_t(n));
    nrm[0] = float(nn[0]);
    nrm[1] = float(nn[1]);
    nrm[2] = float(nn[2]);
    normalise(nrm);
}

// Position (+ vertex data) and unit normal at coordinate i; true if the normal is the control polygon's (no
// tangent plane).
bool FaceEvaluation::eval_point(int i, float* nrm) {
    std::vector<float>&P = x.P, &Du = x.Du, &Dv = x.Dv, &w = x.w;
    const float* uv = &pat.coords[size_t(i) * 2];
    if (smooth) {
        if (has_limit) {
            const int L = limit_lanes();
            const float* b = &x.limit[size_t(i / L) * 6 * size_t(L) + size_t(i % L)];
            for (int d = 0; d < 3; ++d) P[size_t(d)] = b[d * L], nrm[d] = b[(3 + d) * L];
            if (!is_zero(nrm)) return false;
            control_normal(nrm);
            return true;
        } else if (vtx_weights) {
            combine3(vtx_weights + size_t(i) * regular_weights, x.patch_v.data(), W, P.data(), Du.data(), Dv.data());
        } else {
            vtx.Evaluate(uv, x.patch_v.data(), W, P.data(), Du.data(), Dv.data());
        }
        nrm[0] = Du[1] * Dv[2] - Du[2] * Dv[1];
        nrm[1] = Du[2] * Dv[0] - Du[0] * Dv[2];
        nrm[2] = Du[0] * Dv[1] - Du[1] * Dv[0];
        normalise(nrm);
        if (!is_zero(nrm)) return false;
        control_normal(nrm);
        return true;
    } else {
        linear_weights(param, uv, w.data());
        std::fill(P.begin(), P.end(), 0.0f);
        for (int k = 0; k < n; ++k)
            for (int j = 0; j < W; ++j) P[size_t(j)] += w[size_t(k)] * x.corner_data[size_t(k)][j];
        std::copy(face_normal, face_normal + 3, nrm);
    }
    return false;
}

void FaceEvaluation::eval_attrs(int i, size_t o) {
    std::vector<float>& w = x.w;
    const float* uv = &pat.coords[size_t(i) * 2];
    if (K > 0) {
        float* a = &ev.attrs[o * size_t(K)];
        if (smooth && fvar_weights) {
            combine1(fvar_weights + size_t(i) * regular_weights, x.patch_a.data(), K, a);
        } else if (smooth) {
            fvar.Evaluate(uv, x.patch_a.data(), K, a);
        } else {
            linear_weights(param, uv, w.data());
            std::fill(a, a + K, 0.0f);
            for (int k = 0; k < n; ++k) {
                const float* v = &m.value_attrs[size_t(m.corner_value[c0 + uint32_t(k)]) * size_t(K)];
                for (int j = 0; j < K; ++j) a[j] += w[size_t(k)] * v[j];
            }
        }
    }
    if (m.has_skin) {
        linear_weights(param, uv, w.data());
        SkinAccumulator acc;
        for (int k = 0; k < n; ++k) {
            const size_t v = m.corner_value[c0 + uint32_t(k)];
            acc.add(&m.value_joints[v * 4], &m.value_weights[v * 4], w[size_t(k)]);
        }
        acc.finish(&ev.out.joints[o * 4], &ev.out.weights[o * 4]);
    }
}

// The corners and the edge points: data and attributes written by their owners; normals into the face's own
// slots, where they are not shared or the face is the one that evaluates the shared normal; bidx, the output
// index of every boundary coordinate.
void FaceEvaluation::boundary() {
    std::vector<int>& bidx = x.bidx;
    const int* fr = x.rates.data();
    int b = 0;
    for (int k = 0; k < n; ++k) {
        const uint32_t c = c0 + uint32_t(k), g = m.corner_group[c], p = m.corner_point[c];
        const uint32_t sector = m.group_sector[g], normal_owner = m.sector_normal_owner[sector];
        if (m.point_owner[p] == c || normal_owner == none || normal_owner == c) {
            const bool fallback = eval_point(b, &ev.corner_normal[size_t(c) * 3]);
            if (fallback && normal_owner == c) ev.sector_fallback[sector] = 1;
        }
        if (m.point_owner[p] == c)
            for (uint32_t q = m.point_group_begin[p]; q < m.point_group_begin[p + 1]; ++q) write_data(q);
        if (m.group_attr_owner[g] == c && K > 0) {
            // Groups of one (point, value) differ only by normal sector: one evaluation for all of them.
            eval_attrs(b, g);
            for (uint32_t q = m.point_group_begin[p]; q < m.point_group_begin[p + 1]; ++q)
                if (q != g && m.group_value[q] == m.group_value[g])
                    std::copy_n(&ev.attrs[size_t(g) * size_t(K)], K, &ev.attrs[size_t(q) * size_t(K)]);
        }
        bidx[size_t(b++)] = int(g);
        const uint32_t e = m.corner_edge[c], s = m.corner_side[c];
        const int np = fr[k] - 1;
        if (np <= 0) continue;
        const bool forward = p == m.edges[e][0];
        const bool split = m.edge_split[e] != 0, owner = m.edge_owner[e] == s, shared = m.edge_normal_shared[e] != 0;
        for (int j = 0; j < np; ++j) {
            const uint32_t q = uint32_t(forward ? j : np - 1 - j);
            const uint32_t o = split ? L.side_out[s] + q : L.edge_out[e] + q;
            if (owner && shared) {
                // Straight into the output (average_edge_normals normalises it there): the slots of a shared
                // edge stay untouched, unless the owner falls back (then every side fills its own).
                if (eval_point(b + j, &ev.out.normals[size_t(o) * 3])) ev.edge_fallback[e] = 1;
            } else if (!shared) {
                eval_point(b + j, &ev.side_normal[(size_t(L.side_slot[s]) + q) * 3]);
            }
            if (owner) {
                if (split) {
                    for (uint32_t t = m.edge_side_begin[e]; t < m.edge_side_begin[e + 1]; ++t) write_data(L.side_out[t] + q);
                } else {
                    write_data(L.edge_out[e] + q);
                }
            }
            if (split || owner) eval_attrs(b + j, o);
            bidx[size_t(b + j)] = int(o);
        }
        b += np;
    }
}

// Second pass, for a face at a shared point whose owner fell back to the control polygon: this face's own
// normal at each such corner and edge point, into its slots (to be averaged like a crease's).
void FaceEvaluation::fallback_normals() {
    const int* fr = x.rates.data();
    int b = 0;
    for (int k = 0; k < n; ++k) {
        const uint32_t c = c0 + uint32_t(k), e = m.corner_edge[c], s = m.corner_side[c];
        if (ev.sector_fallback[m.group_sector[m.corner_group[c]]])
            eval_point(b, &ev.corner_normal[size_t(c) * 3]);
        ++b;
        const int np = fr[k] - 1;
        if (np <= 0) continue;
        const bool forward = m.corner_point[c] == m.edges[e][0];
        for (int j = 0; ev.edge_fallback[e] && j < np; ++j) {
            const uint32_t q = uint32_t(forward ? j : np - 1 - j);
            eval_point(b + j, &ev.side_normal[(size_t(L.side_slot[s]) + q) * 3]);
        }
        b += np;
    }
}

// The interior points, all the face's own (a normal left zero, with no tangent plane nor polygon normal,
// becomes +z, as average_group_normals and average_edge_normals do for the shared points).
void FaceEvaluation::interior() {
    const uint32_t interior = L.face_out[f];
    float* N = ev.out.normals.data();
    for (int i = nb; i < ncoords; ++i) {
        const size_t o = interior + uint32_t(i - nb);
        eval_point(i, &N[o * 3]);
        if (is_zero(&N[o * 3])) N[o * 3 + 2] = 1.0f;
        write_data(o);
        eval_attrs(i, o);
    }
}

// The face's triangles, with their patch coordinates if kept. Their corners are mapped to output vertices as
// Bfr's Tessellation::TransformFacetCoordIndices does: a boundary coordinate to its shared point (bidx), an
// interior one to the face's own interior outputs.
void FaceEvaluation::triangles() {
    TessellateOutput& out = ev.out;
    const std::vector<float>& coords = pat.coords;
    const uint32_t interior = L.face_out[f];
    const int nfacets = pat.nfacets;
    const int* facets = pat.facets.data();
    const size_t t0 = L.face_tri[f];
    if (ev.keep_parameters)
        for (int t = 0; t < nfacets; ++t) {
            out.triangle_patches[t0 + size_t(t)] = uint32_t(f);
            for (int k = 0; k < 3; ++k) {
                const int local = facets[size_t(t) * 3 + size_t(k)];
                out.triangle_coords[(t0 + size_t(t)) * 6 + size_t(k) * 2] = coords[size_t(local) * 2];
                out.triangle_coords[(t0 + size_t(t)) * 6 + size_t(k) * 2 + 1] = coords[size_t(local) * 2 + 1];
            }
        }
    const uint32_t source = m.face_source[f];
    const int* bidx = x.bidx.data();
    uint32_t* indices = &out.indices[t0 * 3];
    for (int t = 0; t < nfacets; ++t) {
        out.triangle_faces[t0 + size_t(t)] = source;
        for (int k = 0; k < 3; ++k) {
            const int local = facets[size_t(t) * 3 + size_t(k)];
            indices[size_t(t) * 3 + size_t(k)] = local < nb ? uint32_t(bidx[local]) : interior + uint32_t(local - nb);
        }
    }
}

// limit_corners: linear faces read their corners' limit positions (only once all smooth faces are done).
void process(Evaluation& ev, size_t f, bool smooth, bool limit_corners, Surface& vtx, Surface& fvar, Scratch& x,
             bool vtx_ready = true) {
    FaceEvaluation face(ev, f, smooth, limit_corners, vtx, fvar, x, vtx_ready);
    face.boundary();
    face.interior();
    face.triangles();
}

// The faces around shared normals whose owner fell back to the control polygon (none on most meshes), in
// face order; each evaluates its own normals there (all these faces are smooth: shared normals need it).
void evaluate_fallback_normals(Evaluation& ev) {
    const PreparedMesh& m = ev.m;
    std::vector<uint32_t> faces;
    for (size_t s = 0; s < ev.sector_fallback.size(); ++s)
        if (ev.sector_fallback[s])
            for (uint32_t i = m.sector_begin[s]; i < m.sector_begin[s + 1]; ++i) faces.push_back(m.corner_face[m.sector_corners[i]]);
    for (size_t e = 0; e < ev.edge_fallback.size(); ++e)
        if (ev.edge_fallback[e])
            for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s) faces.push_back(m.corner_face[m.side_corner[s]]);
    if (faces.empty()) return;
    std::sort(faces.begin(), faces.end());
    faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, faces.size(), 16), [&](const tbb::blocked_range<size_t>& range) {
        Surface vtx, fvar;
        Scratch scratch;
        for (size_t i = range.begin(); i != range.end(); ++i) {
            const size_t f = faces[i];
            bool ok = m.factory_of(f).InitVertexSurface(m.face_refiner[f], &vtx); // as in evaluate_faces
            if (ok && ev.K > 0) ok = m.factory_of(f).InitFaceVaryingSurface(m.face_refiner[f], &fvar);
            FaceEvaluation face(ev, f, ok, false, vtx, fvar, scratch);
            face.fallback_normals();
        }
    });
}

// Smooth faces first, then the faces tessellated linearly.
void evaluate_faces(Evaluation& ev) {
    const PreparedMesh& m = ev.m;
    const size_t F = m.face_count();
    const int K = ev.K;
    for (int pass = 0; pass < 2; ++pass) {
        const bool smooth_pass = pass == 0;
        tbb::parallel_for(tbb::blocked_range<size_t>(0, F, 16), [&](const tbb::blocked_range<size_t>& range) {
            Surface vtx, fvar;
            Scratch scratch;
            for (size_t f = range.begin(); f != range.end(); ++f) {
                if (m.smooth(f) != smooth_pass) continue;
                if (smooth_pass) {
                    // Surfaces were checked in build_surfaces; a failure here would be a bug, but it must not
                    // become a crash or a crack: such a face would keep its (already shared) boundary points.
                    // Regular interior faces need no vertex surface for most of them (prepare_smooth).
                    const bool made = !m.face_regular_interior[f];
                    bool ok = !made || m.factory_of(f).InitVertexSurface(m.face_refiner[f], &vtx);
                    if (ok && K > 0) ok = m.factory_of(f).InitFaceVaryingSurface(m.face_refiner[f], &fvar);
                    process(ev, f, ok, false, vtx, fvar, scratch, made);
                } else {
                    process(ev, f, false, true, vtx, fvar, scratch);
                }
            }
        });
    }
}

// Per sector (groups), with the skin of each group's value: the normal owner's, or the average of the corners'.
void average_group_normals(Evaluation& ev) {
    const PreparedMesh& m = ev.m;
    TessellateOutput& out = ev.out;
    const UninitialisedFloats& corner_normal = ev.corner_normal;
    float* N = out.normals.data();
    const size_t G = m.group_value.size();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, G, 1024), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t g = range.begin(); g != range.end(); ++g) {
            const uint32_t s = m.group_sector[g], owner = m.sector_normal_owner[s];
            float sum[3] = {0, 0, 0};
            if (owner != none && !ev.sector_fallback[s])
                std::copy_n(&corner_normal[size_t(owner) * 3], 3, sum);
            else
                for (uint32_t i = m.sector_begin[s]; i < m.sector_begin[s + 1]; ++i)
                    for (int k = 0; k < 3; ++k) sum[k] += corner_normal[size_t(m.sector_corners[i]) * 3 + size_t(k)];
            normalise(sum);
            if (is_zero(sum)) std::copy_n(&corner_normal[size_t(m.sector_corners[m.sector_begin[s]]) * 3], 3, sum);
            if (is_zero(sum)) sum[2] = 1.0f;
            std::copy_n(sum, 3, &N[g * 3]);
            if (m.has_skin) {
                const size_t v = m.group_value[g];
                SkinAccumulator acc;
                acc.add(&m.value_joints[v * 4], &m.value_weights[v * 4], 1.0f);
                acc.finish(&out.joints[g * 4], &out.weights[g * 4]);
            }
        }
    });
}

// Across the edges that are no crease: the owner side's normals where they are shared (in the output
// already), else the sides' normals averaged (the same for every side of a seam).
void average_edge_normals(Evaluation& ev) {
    const PreparedMesh& m = ev.m;
    const Layout& L = ev.L;
    const std::vector<int>& rates = ev.rates;
    const UninitialisedFloats& side_normal = ev.side_normal;
    float* N = ev.out.normals.data();
    const size_t E = m.edges.size();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, E, 1024), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t e = range.begin(); e != range.end(); ++e) {
            const int np = rates[e] - 1;
            for (int q = 0; q < np; ++q) {
                auto slot = [&](uint32_t s) { return &side_normal[(size_t(L.side_slot[s]) + size_t(q)) * 3]; };
                if (m.edge_split[e] & 2) {
                    for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s) {
                        float* dst = &N[(size_t(L.side_out[s]) + size_t(q)) * 3];
                        std::copy_n(slot(s), 3, dst);
                        if (is_zero(dst)) dst[2] = 1.0f;
                    }
                    continue;
                }
                float sum[3] = {0, 0, 0};
                const float* first = slot(m.edge_side_begin[e]);
                if (m.edge_normal_shared[e] && !ev.edge_fallback[e]) {
                    // The owner's normal, written where its side's vertex is (boundary()).
                    const uint32_t s = m.edge_owner[e];
                    first = &N[(size_t(m.edge_split[e] ? L.side_out[s] : L.edge_out[e]) + size_t(q)) * 3];
                    std::copy_n(first, 3, sum);
                } else {
                    for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s)
                        for (int k = 0; k < 3; ++k) sum[k] += slot(s)[k];
                }
                normalise(sum);
                if (is_zero(sum)) std::copy_n(first, 3, sum);
                if (is_zero(sum)) sum[2] = 1.0f;
                if (m.edge_split[e]) {
                    for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s)
                        std::copy_n(sum, 3, &N[(size_t(L.side_out[s]) + size_t(q)) * 3]);
                } else {
                    std::copy_n(sum, 3, &N[(size_t(L.edge_out[e]) + size_t(q)) * 3]);
                }
            }
        }
    });
}

// ---- de-interleave
void deinterleave(Evaluation& ev) {
    const PreparedMesh& m = ev.m;
    TessellateOutput& out = ev.out;
    const std::vector<float>&data = ev.data, &attrs = ev.attrs;
    const size_t V = ev.L.vertices;
    const int W = ev.W, K = ev.K;
    if (W == 3) {
        out.positions = std::move(ev.data); // positions only: already laid out as the output (no copy)
    } else {
        kernel::assign_huge(out.positions, V * 3);
        for (size_t v = 0; v < V; ++v) std::copy_n(&data[v * size_t(W)], 3, &out.positions[v * 3]);
    }
    out.vertex_data.assign(m.vertex_data_components.size(), {});
    int offset = 3;
    for (size_t a = 0; a < m.vertex_data_components.size(); ++a) {
        const int nc = m.vertex_data_components[a];
        kernel::assign_huge(out.vertex_data[a], V * size_t(nc));
        for (size_t v = 0; v < V; ++v)
            std::copy_n(&data[v * size_t(W) + size_t(offset)], nc, &out.vertex_data[a][v * size_t(nc)]);
        offset += nc;
    }
    offset = 0;
    out.uvs.clear();
    if (m.has_uv) {
        kernel::assign_huge(out.uvs, V * 2);
        for (size_t v = 0; v < V; ++v) std::copy_n(&attrs[v * size_t(K)], 2, &out.uvs[v * 2]);
        offset = 2;
    }
    out.attributes.assign(m.attribute_components.size(), {});
    for (size_t a = 0; a < m.attribute_components.size(); ++a) {
        const int nc = m.attribute_components[a];
        kernel::assign_huge(out.attributes[a], V * size_t(nc));
        for (size_t v = 0; v < V; ++v)
            std::copy_n(&attrs[v * size_t(K) + size_t(offset)], nc, &out.attributes[a][v * size_t(nc)]);
        offset += nc;
    }
}

} // namespace

Status evaluate_tessellation(TessellateOutput& out, const PreparedMesh& m, const std::vector<int>& rates,
                             bool keep_parameters) {
    Evaluation ev{m, rates, out, keep_parameters, m.W, m.K, {}, {}, {}, {}, {}, {}, {}, {}};
    if (Status s = plan_layout(ev.L, ev.face_cache, m, rates); !s.ok()) return s;
    if (Status s = allocate(ev); !s.ok()) return s;
    evaluate_faces(ev);
    evaluate_fallback_normals(ev);

    // ---- normals at shared points: averaged per sector (groups) and across non-crease edges
    average_group_normals(ev);
    average_edge_normals(ev);
    const size_t V = ev.L.vertices;

    deinterleave(ev);
    out.stats.vertices = V;
    out.stats.triangles = ev.L.triangles;
    return Status::success();
}

} // namespace furrow::tessellate_detail

// Displacement of a ground mesh by the heightmap, once or incrementally, with normals on welded positions.
//
// References: displacement p −= n·depth as in Blender's Dynamic Paint displace canvas and the seed technique
// (tessellated ground, vertex offset along the normal); angle-weighted normals: G. Thürmer, C. A. Wüthrich,
// "Computing Vertex Normals from Polygonal Facets", JGT 3(1), 1998. Crack-freedom needs every copy of a
// position (UV seams split vertices) to move by exactly the same vector: the displacement and the normal are
// computed once per welded point and copied to every vertex of that position (OpenSubdiv issue 168: displace
// shared points once, never per face). An incremental update moves the points whose bilinear footprint meets
// the dirty rectangle and renormalises every point of the faces around them, which is exactly the set whose
// angle-weighted normal can change. Each face's part of a normal, and which faces are degenerate, are the
// kernel's (furrow_kernel/angle_weighted_normal.h), as in compute_vertex_normals.
// Cost per point. Each face's terms (unit normal, three corner angles) are computed once per face, not once
// per corner, several faces to a vector register (furrow_kernel/face_terms.h: 8 with AVX-512, the same
// bits). On one thread a full pass adds them to their corners in one pass over the faces, a block at a time
// (none is kept); on more, each point gathers its own from all the faces' terms (the same sums in the same
// order). An update keeps every face's terms, computed by its first call, and recomputes only those it
// moves. prepare() puts every array in one block (Arena, below; on huge pages from 32 MiB), which a later
// prepare() of the same object takes over when the new mesh fits: on this project's VM a fresh 4 KiB page
// costs ~20 us, and prepare used to spend most of its time in page faults (`bench stamp` §5, 394k
// vertices: 392-624 ms, 17x the 99k mesh's). The update's indexes (faces per point, points per tile) and
// the faces' terms are built on the first update(): a one-shot displacement needs none of them; nor are
// the arrays it writes whole filled first. `furrow -j 1 bench stamp --section 5`, 394k vertices,
// prepare + displace_all: 83-92 + 37-41 ms before the vector terms, the one-pass sums, the late
// indexes and the unfilled arrays; 37.7-38.7 + 21.1-21.4 ms after (2026-11-27); 25.9-26.2 + 16.9-17.7 ms
// once the face terms sat in the block (size_terms), were built for their instruction set (face_terms.h),
// derived their third angle (face_term), and the checks, triangle copy and texel coordinates each took one
// vectorisable pass (later that day); 25.0 + 16.5-16.6 ms once a one-thread full pass kept no face terms.
// An update skips the points whose position comes out bit-identical (a dirty tile is rarely dirty
// everywhere): their faces, normals and buffer entries are already those a full pass writes. The points
// and faces to redo are found in one cheap sweep, collected in index order from their marks (so the
// arrays are walked forwards: with a 6 cm rim, `bench stamp` section 4 at -j 1, 7.0-7.4 ms a frame against
// 9.4-10.4 in the order they were found), and recomputed in parallel; the result bytes do not depend on the
// thread count. (Numbering the points by heightmap tile and the faces by their lowest point, for
// locality, made an update 5-10 % faster and prepare() 30 % slower, 82 -> 107 ms at 394k points: not kept.
// Measured again once the update had become load-bound: the points alone numbered by tile, with the same bits,
// and each point's rest, direction and texel in one 64-byte line, gave no faster update; deform/README.md.)
#include "deform_internal.h"

#include <furrow_kernel/angle_weighted_normal.h>
#include <furrow_kernel/face_terms.h>
#include <furrow_kernel/huge_pages.h>
#include <furrow_kernel/welded_ids.h>
#include <furrow_kernel/no_throw.h>
#include <furrow_kernel/threads.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <utility>
#include <cstdlib>
#include <new>

namespace furrow {

using namespace deform_detail;

namespace {

// One face's part of its corners' normals (the kernel's FaceTerm: unit normal, the angle at each corner).
// Cached per face, so that a full pass computes each face once rather than once per corner, and an
// incremental update recomputes only the faces around the points it moves; a point's normal then sums the
// cached terms of its faces in the same (CSR) order either way, so both give the same bits.
using kernel::FaceTerm;

// Every array of a prepared ground comes from one block (Arena), advised for huge pages from 32 MiB, sized in
// prepare() once the welded point and triangle counts are known. The cost is page faults, not bytes: on this project's
// 2-core VM a first touch of a fresh 4 KiB page costs ~20 us (a zero-filled 2 MiB vector: 9 ms; 38 MiB: 170 ms,
// against 12 ms with huge pages), and prepare() used to fault in ~20 separately allocated arrays, most below
// kernel::assign_huge's 4 MiB threshold or with 4 KiB-paged ends. A vector that outgrows the block, or is made
// without it, gets its own kernel::allocate_huge_bytes block.
constexpr size_t kHugeArenaFrom = size_t(32) << 20;
struct Arena {
    kernel::HugeBytes block;
    uint8_t* base = nullptr; // the block's range, kept when the block moves on to a new Arena (see owns)
    size_t size = 0, used = 0;
    static size_t padded(size_t bytes) { return (bytes + 63) & ~size_t(63); }
    // A block of `bytes`: `old`'s when it is that large but not twice as large (a re-prepare: its pages are
    // already mapped, no fault; a much smaller mesh does not keep a large block), else a new one. The arrays
    // of `old` keep pointing into the block until they are destroyed; they free nothing (owns() uses base).
    void adopt(Arena* old, size_t bytes) {
        if (old && old->block && old->size >= bytes && old->size / 2 <= bytes) {
            block = std::move(old->block);
            size = old->size;
        } else {
            // Huge pages for a large block only: on the stamp command's ground (a 26 MB block) they raised the
            // command's peak by 1.2-1.6 MiB (/usr/bin/time), to the edge of `furrow bench memory`'s rule; the
            // 394k-point ground of `bench stamp` section 5 (a block of about 70 MB) keeps them. A smaller
            // block, written whole below, is mapped in one call instead.
            block = bytes >= kHugeArenaFrom ? kernel::allocate_huge_bytes(bytes) : kernel::allocate_prefaulted_bytes(bytes);
            size = block ? bytes : 0; // no block: each array allocates its own
        }
        base = block.get();
    }
    void* take(size_t bytes) {
        if (!base || used + bytes > size) return nullptr;
        void* p = base + used;
        used += padded(bytes);
        return p;
    }
    bool owns(const void* p) const {
        const auto* b = static_cast<const uint8_t*>(p);
        return base && b >= base && b < base + size;
    }
};
template <class T>
struct ArenaAlloc {
    using value_type = T;
    using propagate_on_container_copy_assignment = std::true_type;
    using propagate_on_container_move_assignment = std::true_type;
    using propagate_on_container_swap = std::true_type;
    Arena* arena = nullptr;
    ArenaAlloc() = default;
    explicit ArenaAlloc(Arena* a) : arena(a) {}
    template <class U>
    ArenaAlloc(const ArenaAlloc<U>& o) : arena(o.arena) {}
    T* allocate(size_t n) {
        if (void* p = arena ? arena->take(n * sizeof(T)) : nullptr) return static_cast<T*>(p);
        void* p = kernel::allocate_huge_bytes(n * sizeof(T)).release();
        if (!p) throw std::bad_alloc();
        return static_cast<T*>(p);
    }
    void deallocate(T* p, size_t) {
        if (!(arena && arena->owns(p))) std::free(p); // inside the block: freed with it
    }
    // Without a value, an element is default-initialised: no fill for the arrays prepare() writes whole
    // (a fill of the face terms alone was 5 ms of a 40 ms prepare at 394k points).
    template <class U>
    void construct(U* p) {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... A>
    void construct(U* p, A&&... a) {
        ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
    }
    template <class U>
    bool operator==(const ArenaAlloc<U>& o) const { return arena == o.arena; }
};
template <class T>
using Array = std::vector<T, ArenaAlloc<T>>;
using FaceTerms = Array<FaceTerm>; // 48 bytes per triangle
using Doubles = Array<double>;     // per point: 24 bytes a vector
using Indices = Array<uint32_t>;

// Compressed rows (CSR) by counting sort: off[r] .. off[r + 1] holds, in increasing order, the items i < n
// with row_of(i) == r, stored as item(i). off itself is the fill cursor, shifted back after (no scratch array).
// also(at, i), if given, runs as item i is stored at position `at` (face_index's ring beside each incidence).
struct NoAlso {
    void operator()(size_t, size_t) const {}
};
template <class RowOf, class Item, class Also = NoAlso>
void bucket(Indices& off, Indices& items, size_t rows, size_t n, RowOf row_of, Item item, Also also = {}) {
    std::fill(off.begin(), off.end(), 0u);
    for (size_t i = 0; i < n; ++i) ++off[size_t(row_of(i)) + 1];
    for (size_t r = 0; r < rows; ++r) off[r + 1] += off[r];
    for (size_t i = 0; i < n; ++i) {
        const uint32_t at = off[row_of(i)]++;
        items[at] = item(i);
        also(size_t(at), i);
    }
    for (size_t r = rows; r > 0; --r) off[r] = off[r - 1];
    off[0] = 0;
}

FaceTerm face_term(const double* P, const uint32_t* t) {
    return kernel::face_term(kernel::point_at(P, t[0]), kernel::point_at(P, t[1]), kernel::point_at(P, t[2]));
}

// A point's normal from the sum of its faces' terms: the sum over its length, or zero (no face with an
// area). One division and three products (not three divisions), in both passes (gather_normal,
// scattered_normals: the same bits).
inline void unit_or_zero(double* o, const kernel::Vec3& sum) {
    const double l = kernel::norm(sum), inverse = 1.0 / l;
    o[0] = l > 0 ? sum.x * inverse : 0.0, o[1] = l > 0 ? sum.y * inverse : 0.0, o[2] = l > 0 ? sum.z * inverse : 0.0;
}

// Angle-weighted normal (Thürmer & Wüthrich) of welded point v from the terms of its faces: `term(f)` is the
// cached term, or (without a cache) the term computed again, with the same bits. A point's incidences are
// corners (3 × face + corner, see Impl::faces): the corner is known without reading the face's indices (a
// cache miss per face on the per-frame path).
template <class Term>
void gather_normal(double* o, uint32_t v, const Term& term, const Indices& off, const Indices& corners) {
    kernel::Vec3 sum;
    for (uint32_t k = off[v]; k < off[size_t(v) + 1]; ++k) {
        const uint32_t f = corners[k] / 3;
        const uint32_t c = corners[k] % 3;
        decltype(auto) ft = term(f); // a reference into the cache, or a fresh term
        if (ft.angle[c] < 0) continue;
        sum = sum + ft.angle[c] * kernel::Vec3{ft.unit[0], ft.unit[1], ft.unit[2]};
    }
    unit_or_zero(o, sum);
}

using kernel::one_thread;

// All points' normals on one thread, in one streaming pass over the faces: each block's terms, then each
// term added to its three corners' sums. A point's row of `faces` lists its corners in increasing order
// (bucket() is stable), so adding in face order sums each point's terms in gather_normal's order: the same
// bits, without the per-point walk through the index (a second read of every term, 48 bytes a face).
void scattered_normals(double* normals, const double* P, const Indices& tri, size_t points) {
    std::fill(normals, normals + 3 * points, 0.0);
    constexpr size_t kBlock = 512;
    FaceTerm t[kBlock]; // this block's terms only (in cache; none is kept)
    const size_t T = tri.size() / 3;
    for (size_t f0 = 0; f0 < T; f0 += kBlock) {
        const size_t n = std::min(kBlock, T - f0);
        kernel::face_terms(t, P, tri.data() + 3 * f0, 0, nullptr, n);
        for (size_t k = 0; k < n; ++k) {
            if (t[k].angle[0] < 0) continue; // degenerate: every angle is < 0
            for (int c = 0; c < 3; ++c) {
                double* o = normals + 3 * size_t(tri[3 * (f0 + k) + size_t(c)]);
                const kernel::Vec3 sum = kernel::Vec3{o[0], o[1], o[2]} +
                                         t[k].angle[c] * kernel::Vec3{t[k].unit[0], t[k].unit[1], t[k].unit[2]};
                o[0] = sum.x, o[1] = sum.y, o[2] = sum.z;
            }
        }
    }
    for (size_t p = 0; p < points; ++p) {
        double* o = normals + 3 * p;
        unit_or_zero(o, kernel::Vec3{o[0], o[1], o[2]});
    }
}

// Every face's term over positions P, in parallel (terms sized to the faces).
void every_face_term(FaceTerms& terms, const double* P, const Indices& tri) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, terms.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
        kernel::face_terms(terms.data(), P, tri.data(), r.begin(), nullptr, r.size());
    });
}

// All faces' terms, then all points' normals, each point gathering its own (in parallel; the terms as
// scattered_normals adds them, the same bits). With `keep` false (a one-shot displacement) no term is kept:
// each point computes its faces' terms itself (each face three times), and the 48 bytes per triangle of the
// cache, the largest array of a `furrow stamp`, are never allocated.
void gathered_normals(double* normals, FaceTerms& terms, bool keep, const double* P, const Indices& tri, const Indices& off,
                      const Indices& faces) {
    if (!keep) {
        auto fresh = [&](uint32_t f) { return face_term(P, &tri[3 * size_t(f)]); };
        tbb::parallel_for(tbb::blocked_range<size_t>(0, off.size() - 1, 1024), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t v = r.begin(); v != r.end(); ++v) gather_normal(normals + 3 * v, uint32_t(v), fresh, off, faces);
        });
        return;
    }
    every_face_term(terms, P, tri);
    auto cached = [&](uint32_t f) -> const FaceTerm& { return terms[f]; };
    tbb::parallel_for(tbb::blocked_range<size_t>(0, off.size() - 1, 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t v = r.begin(); v != r.end(); ++v) gather_normal(normals + 3 * v, uint32_t(v), cached, off, faces);
    });
}

} // namespace

struct DisplacedGround::Impl {
    Arena arena;                          // first: the arrays below live in it, and are destroyed before it
    HeightmapFrame frame;
    DisplaceOptions opt;
    size_t vertex_count = 0;
    Indices copy_off, copies;             // welded point -> its vertices (CSR)
    Doubles rest;                         // undeformed position per point
    Doubles dir;                          // displacement direction per point (unit)
    Doubles texel;                        // (ti, tj) per point
    std::vector<uint8_t> movable;         // top_only: on the top surface
    Indices tris;                         // welded, non-degenerate
    Indices face_off, faces;              // point -> incident corners, 3 × triangle + corner (CSR); see face_index()
    Doubles cur, nrm;                     // current displaced positions and normals per point
    // Points bucketed by kTile x kTile-texel tiles of their footprint's lower corner.
    int tiles_x = 0, tiles_y = 0;
    Indices tile_off, tile_pts;           // see tile_index()
    Indices ring;                         // per incidence k of `faces`: its face's other two corners at 2k, 2k + 1
    bool face_indexed = false, tile_indexed = false; // built (face_index, tile_index; ring: when two entries an incidence)
    FaceTerms terms;                      // per triangle, of the current positions when terms_current
    bool terms_current = false;           // (else the next update() computes them all first)
    bool cur_unset = false;               // cur not yet written: it stands for rest (see settle_cur)
    Array<uint64_t> mark, face_mark;      // update()'s scratch: a bit per point and per triangle (27 + 55 KB at
                                          // 221k points: in cache, unlike a word each, 2.6 MB)
    std::vector<uint32_t> moved;          // points under the dirty rectangles
    std::vector<uint32_t> redo_faces, redo_points; // the faces and points an update recomputes
    std::vector<uint8_t> shifted;         // per moved point: its position changed
    // 8 texels: the dirty rectangles come in 16-texel tiles, often smaller; 16-texel buckets made points_under
    // test 4 points for each it kept (`bench stamp` section 4, no rim, -j 1: 0.23 ms a frame, 0.155 at 8 and at 4).
    static constexpr int kTile = 8;

    // The update's indexes, each built when first needed: the faces around each point (update() and the
    // parallel normals read it) and the points of each texel tile (update()). A one-shot displacement on one
    // thread reads neither (`bench stamp` section 5, 394k points: 17 ms of a 73 ms prepare).
    // With `with_ring` (update()'s), each incidence also lists its face's other two corners (`ring`, written in
    // the same counting sort, where the triangles are read in order): the update marks a shifted point's
    // neighbours from that contiguous row instead of reading each face's corners at scattered places
    // (`bench stamp` section 4 at -j 1, with a 6 cm rim: the sweep 40-41 -> 25-26 ns a moved point). At 394k
    // points it adds 2-3 ms to the first update (24.7-24.9 -> 26.8-27.7 ms, section 5) and 24 bytes a
    // triangle, counted in the block only when face terms are kept (an update is expected).
    void face_index(bool with_ring = false) {
        if (face_indexed && (!with_ring || ring.size() == 2 * faces.size())) return;
        const size_t points = rest.size() / 3, T = tris.size() / 3;
        if (with_ring) ring = Indices(6 * T, ArenaAlloc<uint32_t>(&arena)); // (written whole below)
        auto ring_of = [&](size_t at, size_t c) {
            const size_t f = c - c % 3;
            ring[2 * at] = tris[f + (c + 1) % 3], ring[2 * at + 1] = tris[f + (c + 2) % 3];
        };
        if (face_indexed) {
            for (size_t k = 0; k < 3 * T; ++k) ring_of(k, faces[k]);
        } else {
            face_off = Indices(points + 1, ArenaAlloc<uint32_t>(&arena)); // (bucket writes both whole)
            faces = Indices(3 * T, ArenaAlloc<uint32_t>(&arena));
            auto row = [&](size_t c) { return tris[c]; };
            auto item = [](size_t c) { return uint32_t(c); };
            if (with_ring) bucket(face_off, faces, points, 3 * T, row, item, ring_of);
            else bucket(face_off, faces, points, 3 * T, row, item);
        }
        face_indexed = true;
    }
    void tile_index() {
        if (tile_indexed) return;
        const size_t points = rest.size() / 3, tiles = size_t(tiles_x) * size_t(tiles_y);
        tile_off = Indices(tiles + 1, ArenaAlloc<uint32_t>(&arena));
        tile_pts = Indices(points, ArenaAlloc<uint32_t>(&arena));
        auto tile_of_point = [this](size_t p) {
            return uint32_t(tile_of(texel[2 * p + 1], tiles_y) * tiles_x + tile_of(texel[2 * p], tiles_x));
        };
        bucket(tile_off, tile_pts, tiles, points, tile_of_point, [](size_t p) { return uint32_t(p); });
        tile_indexed = true;
    }
    // The face terms' array, one per triangle, in the block (room for it was counted in prepare()), unfilled:
    // its caller writes it whole. A default-constructed array has no arena: sized by resize(), the 38 MB of a
    // 394k-point ground came from a fresh mapping at every prepare(), 19 huge-page faults (a prepare loop at
    // 394k points: 43.5-43.8 -> 39.0-39.7 ms once in the block).
    void size_terms() {
        if (terms.size() != tris.size() / 3) terms = FaceTerms(tris.size() / 3, ArenaAlloc<FaceTerm>(&arena));
    }
    // Every point's angle-weighted normal over positions P (rest or current): in one pass over the faces on
    // one thread, gathered per point in parallel on more (the same bits). The gather computes every face's
    // term first and keeps them if asked; the one-thread pass keeps none: the first update() computes them
    // (terms_current). A one-shot prepare + displace_all never reads them, and writing 48 bytes a face took
    // it from 42.7-45.7 to 47.2-47.6 ms (`bench stamp` section 5, 394k points, -j 1, two noisy runs).
    void normals(double* out, const double* P) {
        terms_current = false;
        if (!opt.keep_face_terms) FaceTerms().swap(terms);
        if (one_thread()) return scattered_normals(out, P, tris, rest.size() / 3);
        face_index();
        if (opt.keep_face_terms) size_terms();
        gathered_normals(out, terms, opt.keep_face_terms, P, tris, face_off, faces);
        terms_current = opt.keep_face_terms;
    }

    // Clamped before the conversion: a vertex no triangle uses may lie far off the grid, with a texel
    // coordinate beyond int (undefined behaviour, found by fuzz_stamp). The result is unchanged.
    int tile_of(double t, int tiles) const {
        return std::clamp(int(std::floor(std::clamp(t, -1.0, double(tiles) * kTile))) / kTile, 0, tiles - 1);
    }

    void write(uint32_t p, float* pos, float* nor) const {
        for (uint32_t k = copy_off[p]; k < copy_off[size_t(p) + 1]; ++k) {
            const size_t v = copies[k];
            for (int d = 0; d < 3; ++d) {
                pos[3 * v + size_t(d)] = float(cur[3 * size_t(p) + size_t(d)]);
                nor[3 * v + size_t(d)] = float(nrm[3 * size_t(p) + size_t(d)]);
            }
        }
    }
    // What displace(p) reads: an update's points are scattered over these arrays, each a cache miss (fetched 8
    // points ahead: `bench stamp` section 4, no rim, -j 1, 0.32-0.37 -> 0.21-0.27 ms a frame).
    void prefetch_point(uint32_t p) const {
        __builtin_prefetch(&texel[2 * size_t(p)]);
        __builtin_prefetch(&rest[3 * size_t(p)]);
        __builtin_prefetch(&dir[3 * size_t(p)]);
        __builtin_prefetch(&cur[3 * size_t(p)], 1);
    }
    // cur as prepare() leaves it: the rest positions, copied only when an update() needs them (displace_all
    // writes every point's without reading it first). Copying at prepare() was a pass of 24 bytes a point
    // that a one-shot prepare + displace_all overwrote unread.
    void settle_cur() {
        if (!cur_unset) return;
        std::copy(rest.begin(), rest.end(), cur.begin());
        cur_unset = false;
    }
    // Returns whether the position changed (`fresh`: cur holds nothing yet, and is written without a look).
    template <bool fresh = false>
    bool displace(uint32_t p, const Heightmap& h) {
        double d = 0;
        // Heightmap::sample's arithmetic, inlined (the call, with two libm floors, was about 5 % of a full
        // pass: bench stamp section 5 at 394k points, displace 37.7 -> 35.1-36.0 ms).
        if (movable.empty() || movable[p]) d = sample_split(h, split_texel(texel[2 * size_t(p)], texel[2 * size_t(p) + 1]));
        bool changed = false;
        for (int k = 0; k < 3; ++k) {
            double& c = cur[3 * size_t(p) + size_t(k)];
            const double v = rest[3 * size_t(p) + size_t(k)] + dir[3 * size_t(p) + size_t(k)] * d;
            if constexpr (!fresh) changed = changed || std::bit_cast<uint64_t>(v) != std::bit_cast<uint64_t>(c); // -0 vs 0 too
            c = v;
        }
        return changed;
    }
    void fix_normal(uint32_t p) {
        double* o = &nrm[3 * size_t(p)];
        if (o[0] == 0 && o[1] == 0 && o[2] == 0) o[0] = frame.up[0], o[1] = frame.up[1], o[2] = frame.up[2];
    }
};

DisplacedGround::DisplacedGround() : impl_(std::make_unique<Impl>()) {}
DisplacedGround::~DisplacedGround() = default;
DisplacedGround::DisplacedGround(DisplacedGround&&) noexcept = default;
DisplacedGround& DisplacedGround::operator=(DisplacedGround&&) noexcept = default;

size_t DisplacedGround::vertex_count() const { return impl_->vertex_count; }
size_t DisplacedGround::welded_count() const { return impl_->rest.size() / 3; }

Status DisplacedGround::prepare(const float* positions, size_t vertex_count, const uint32_t* indices, size_t index_count,
                                const HeightmapFrame& frame, const DisplaceOptions& opt, const Heightmap* ground) {
    return kernel::no_throw("preparing the ground", [&]() -> Status {
        if (!(frame.texel > 0) || frame.width <= 0 || frame.height <= 0)
            return Status::error(StatusCode::invalid_argument, "the heightmap frame is empty");
        if (index_count % 3) return Status::error(StatusCode::invalid_input, "indices are not triangles");
        // Both checks as one reduction each, without an early exit, which the compiler vectorises (two early-exit
        // loops were 3.8 ms of a 59 ms prepare at 394k points). An OR of comparisons, not a maximum: baseline
        // x86-64 (SSE2) has no unsigned 32-bit maximum, but compares (0.65 -> 0.33 ms for 2.4 M indices).
        if (vertex_count <= UINT32_MAX) {
            const uint32_t n = uint32_t(vertex_count);
            uint32_t out_of_range = 0;
            for (size_t k = 0; k < index_count; ++k) out_of_range |= uint32_t(indices[k] >= n);
            if (out_of_range) return Status::error(StatusCode::invalid_input, "an index is out of range");
        }
        // Every vertex is displaced and bucketed by texel, including those no triangle uses: a NaN among them
        // reached an int conversion (undefined behaviour, found by fuzz_stamp). Not finite: all exponent bits set.
        uint32_t not_finite = 0;
        for (size_t k = 0; k < 3 * vertex_count; ++k) not_finite |= uint32_t((std::bit_cast<uint32_t>(positions[k]) & 0x7f800000u) == 0x7f800000u);
        if (not_finite) return Status::error(StatusCode::invalid_input, "a vertex position is not finite");
        auto m = std::make_unique<Impl>(), empty = std::make_unique<Impl>();
        m->frame = frame;
        m->opt = opt;
        m->vertex_count = vertex_count;
        // vertex -> welded point, numbered in order of first appearance, in one array (welded_ids' two were
        // three temporary allocations, one of them grown by doubling).
        std::vector<uint32_t> remap(vertex_count);
        weld_positions(remap.data(), positions, vertex_count);
        const size_t points = kernel::number_welded_in_place(remap.data(), vertex_count);
        // The block holds room for every triangle (F); the degenerate ones' room stays unused (see below).
        const size_t F = index_count / 3;
        if (3 * F > size_t(UINT32_MAX)) return Status::error(StatusCode::invalid_input, "more than 1.4 billion triangles");
        m->tiles_x = (frame.width + Impl::kTile - 1) / Impl::kTile + 1;
        m->tiles_y = (frame.height + Impl::kTile - 1) / Impl::kTile + 1;
        const size_t tiles = size_t(m->tiles_x) * size_t(m->tiles_y);
        const bool terms = opt.keep_face_terms;
        // One block for every array below (see Arena); the terms only when kept.
        const size_t bytes = 4 * Arena::padded(24 * points) + Arena::padded(16 * points) + 2 * Arena::padded(4 * (points + 1)) +
                        Arena::padded(4 * points) + Arena::padded(4 * vertex_count) + 2 * Arena::padded(12 * F) +
                        Arena::padded(4 * (tiles + 1)) +
                        Arena::padded(8 * ((points + 63) / 64)) + Arena::padded(8 * ((F + 63) / 64)) +
                        (terms ? Arena::padded(sizeof(FaceTerm) * F) + Arena::padded(24 * F) : 0);
        {
            // The old state goes now (a failure past this point, out of memory, leaves the ground empty): its
            // arrays point into the block this one may take over.
            std::unique_ptr<Impl> old = std::exchange(impl_, std::move(empty));
            m->arena.adopt(old ? &old->arena : nullptr, bytes);
        }
        auto array = [&]<class T>(Array<T>& v, size_t n, const T& value) { v = Array<T>(n, value, ArenaAlloc<T>(&m->arena)); };
        auto unfilled = [&]<class T>(Array<T>& v, size_t n) { v = Array<T>(n, ArenaAlloc<T>(&m->arena)); }; // written whole next
        unfilled(m->rest, 3 * points);
        for (size_t v = 0; v < vertex_count; ++v)
            for (int d = 0; d < 3; ++d) m->rest[3 * size_t(remap[v]) + size_t(d)] = positions[3 * v + size_t(d)];
        unfilled(m->copy_off, points + 1);
        unfilled(m->copies, vertex_count);
        bucket(m->copy_off, m->copies, points, vertex_count, [&](size_t v) { return remap[v]; }, [](size_t v) { return uint32_t(v); });
        // Triangles on welded points, in one pass: each is written, and kept (T grows) when its three points
        // differ; degenerate ones carry no normal and no neighbourhood. (Counting them first, then copying,
        // read every index and its remap entry twice: 1.7 ms of 3.4 at 394k points.)
        unfilled(m->tris, 3 * F);
        size_t T = 0;
        for (size_t t = 0; t < F; ++t) {
            const uint32_t a = remap[indices[3 * t]], b = remap[indices[3 * t + 1]], c = remap[indices[3 * t + 2]];
            m->tris[3 * T] = a, m->tris[3 * T + 1] = b, m->tris[3 * T + 2] = c;
            T += a != b && b != c && c != a;
        }
        m->tris.resize(3 * T);
        // (The face terms are allocated where they are first computed and kept: a gathered normals() on more
        // than one thread, or the first update(); the block holds room for them.)
        // Undeformed normals give the displacement direction.
        unfilled(m->dir, 3 * points);
        if (opt.along_up) {
            for (size_t p = 0; p < points; ++p)
                for (int d = 0; d < 3; ++d) m->dir[3 * p + size_t(d)] = frame.up[size_t(d)];
        } else {
            // (Terms kept here, on more threads, are the current positions' too: cur starts as rest.)
            m->normals(m->dir.data(), m->rest.data());
            for (size_t p = 0; p < points; ++p) {
                double* o = &m->dir[3 * p];
                if (o[0] == 0 && o[1] == 0 && o[2] == 0) o[0] = frame.up[0], o[1] = frame.up[1], o[2] = frame.up[2];
            }
        }
        unfilled(m->texel, 2 * points);
        const double inverse = frame.texel > 0 ? 1.0 / frame.texel : 0.0;
        for (size_t p = 0; p < points; ++p) {
            const auto t = texel_of(frame, inverse, &m->rest[3 * p]);
            m->texel[2 * p] = t[0], m->texel[2 * p + 1] = t[1];
        }
        if (opt.top_only && ground) {
            const double tol = opt.top_tolerance > 0 ? opt.top_tolerance : 2 * frame.texel;
            m->movable.assign(points, 1);
            for (size_t p = 0; p < points; ++p) {
                // On the grid before rounding to int, for the same reason as tile_of (same texels as before).
                const double ti = m->texel[2 * p], tj = m->texel[2 * p + 1];
                if (!(ti > -0.5 && tj > -0.5 && ti < ground->frame.width - 0.5 && tj < ground->frame.height - 0.5)) continue;
                const int i = int(std::lround(ti)), j = int(std::lround(tj));
                const float g = ground->at(i, j);
                const double w = dot(Vec3{m->rest[3 * p], m->rest[3 * p + 1], m->rest[3 * p + 2]}, d3(frame.up));
                if (!std::isnan(g) && w < double(g) - tol) m->movable[p] = 0;
            }
        }
        // Both written before they are read: cur by displace_all or settle_cur, a point's normal where it is
        // computed (a fill of the two was 2.2-2.4 ms of a 33 ms prepare at 394k points).
        unfilled(m->cur, 3 * points);
        m->cur_unset = true;
        unfilled(m->nrm, 3 * points);
        array(m->mark, (points + 63) / 64, uint64_t(0));
        array(m->face_mark, (T + 63) / 64, uint64_t(0));
        impl_ = std::move(m);
        return Status::success();
    });
}

size_t DisplacedGround::displace_all(const Heightmap& h, float* pos, float* nor) {
    Impl& m = *impl_;
    const size_t P = m.rest.size() / 3;
    if (m.cur_unset) tbb::parallel_for(size_t(0), P, [&](size_t p) { m.displace<true>(uint32_t(p), h); });
    else tbb::parallel_for(size_t(0), P, [&](size_t p) { m.displace(uint32_t(p), h); });
    m.cur_unset = false;
    m.normals(m.nrm.data(), m.cur.data());
    tbb::parallel_for(size_t(0), P, [&](size_t p) {
        m.fix_normal(uint32_t(p));
        m.write(uint32_t(p), pos, nor);
    });
    return P;
}

size_t DisplacedGround::update(const Heightmap& h, const TexelRect& dirty, float* pos, float* nor) {
    return update(h, std::vector<TexelRect>{dirty}, pos, nor);
}

// The marked items in increasing order: the update then walks its arrays forwards, a cache line shared by
// neighbouring items read once.
static void marked(std::vector<uint32_t>& out, const Array<uint64_t>& marks) {
    out.clear();
    for (size_t w = 0; w < marks.size(); ++w)
        for (uint64_t b = marks[w]; b; b &= b - 1) out.push_back(uint32_t(64 * w + size_t(std::countr_zero(b))));
}

// The welded points whose bilinear footprint meets a dirty rectangle, each once. A point at (ti, tj) reads
// texels floor(ti) .. floor(ti) + 1: it is affected when ti is in (x0 − 1, x1), and it lies in the tile of
// floor(ti), so only the tiles from floor((x0 − 1) / T) to (x1 − 1) / T are scanned; points of tiles wholly
// inside the rectangle's span need no test.
static void points_under(DisplacedGround::Impl& m, const std::vector<TexelRect>& rects) {
    constexpr int T = DisplacedGround::Impl::kTile;
    for (const TexelRect& dirty : rects) {
        if (dirty.empty()) continue;
        auto first = [](int x0) { return x0 >= 1 ? (x0 - 1) / T : 0; };
        const int tx0 = std::clamp(first(dirty.x0), 0, m.tiles_x - 1), tx1 = std::clamp((dirty.x1 - 1) / T, 0, m.tiles_x - 1);
        const int ty0 = std::clamp(first(dirty.y0), 0, m.tiles_y - 1), ty1 = std::clamp((dirty.y1 - 1) / T, 0, m.tiles_y - 1);
        for (int ty = ty0; ty <= ty1; ++ty)
            for (int tx = tx0; tx <= tx1; ++tx) {
                const size_t t = size_t(ty) * size_t(m.tiles_x) + size_t(tx);
                // Inside: every point of an inner tile has floor(ti) in [tx·T, tx·T + T − 1], within [x0, x1 − 1].
                const bool inside = tx * T >= dirty.x0 && tx * T + T <= dirty.x1 && ty * T >= dirty.y0 && ty * T + T <= dirty.y1 &&
                                    tx + 1 < m.tiles_x && ty + 1 < m.tiles_y && tx > 0 && ty > 0;
                for (uint32_t k = m.tile_off[t]; k < m.tile_off[t + 1]; ++k) {
                    const uint32_t p = m.tile_pts[k];
                    uint64_t& word = m.mark[p / 64];
                    const uint64_t bit = uint64_t(1) << (p % 64);
                    if (word & bit) continue;
                    const double ti = m.texel[2 * size_t(p)], tj = m.texel[2 * size_t(p) + 1];
                    if (inside || (ti > double(dirty.x0) - 1 && ti < dirty.x1 && tj > double(dirty.y0) - 1 && tj < dirty.y1))
                        word |= bit;
                }
            }
    }
}

// The phases' clock, read only when the caller asked for stats.
namespace {
struct PhaseClock {
    using clock = std::chrono::steady_clock;
    DisplaceUpdateStats* stats;
    clock::time_point last = stats ? clock::now() : clock::time_point{};
    void lap(double DisplaceUpdateStats::*phase) {
        if (!stats) return;
        const clock::time_point now = clock::now();
        stats->*phase = std::chrono::duration<double>(now - last).count();
        last = now;
    }
};
} // namespace

size_t DisplacedGround::update(const Heightmap& h, const std::vector<TexelRect>& rects, float* pos, float* nor,
                               DisplaceUpdateStats* stats) {
    Impl& m = *impl_;
    if (stats) *stats = DisplaceUpdateStats{};
    if (m.rest.empty()) return 0;
    m.face_index(true);
    m.tile_index();
    m.settle_cur();
    if (!m.terms_current) { // the first update after a prepare or a one-thread displace_all
        m.size_terms();
        every_face_term(m.terms, m.cur.data(), m.tris);
        m.terms_current = true;
    }
    PhaseClock phase{stats};
    std::fill(m.mark.begin(), m.mark.end(), 0); // a bit a point: 27 KB at 221k points, cleared in microseconds
    std::fill(m.face_mark.begin(), m.face_mark.end(), 0);
    points_under(m, rects);
    marked(m.moved, m.mark);
    phase.lap(&DisplaceUpdateStats::search_seconds);
    if (m.moved.empty()) return 0;
    // Re-displaced; a point whose position came out bit-identical (its texels did not change: a dirty tile is
    // rarely dirty everywhere) changes no face, and is already in the buffers.
    // The faces around a shifted point change; every corner of such a face gets a new normal (the point's own
    // and its faces' other corners, listed in `ring` beside each incidence). Found with plain bit marks:
    // claiming them in parallel chunks took an atomic or per face and per point, which cost more than the
    // faces' own arithmetic (`bench stamp` section 4, no rim: 1.35 ms of claims for 14k faces, 2/3 of it the
    // locked or). On one thread each shifted point is marked as soon as it is displaced (its rows are then
    // in cache); on more, in one sweep after. The faces' terms and the points' normals are then computed in
    // parallel; each is a function of positions alone, so the bytes do not depend on the thread count.
    std::fill(m.mark.begin(), m.mark.end(), 0);
    auto mark_around = [&m](uint32_t p) {
        auto set_mark = [](Array<uint64_t>& marks, uint32_t i) { marks[i / 64] |= uint64_t(1) << (i % 64); };
        const uint32_t k0 = m.face_off[p], k1 = m.face_off[size_t(p) + 1];
        set_mark(m.mark, p); // (a point without faces too)
        for (uint32_t k = k0; k < k1; ++k) set_mark(m.face_mark, m.faces[k] / 3);
        for (uint32_t k = 2 * k0; k < 2 * k1; ++k) set_mark(m.mark, m.ring[k]);
    };
    m.shifted.resize(m.moved.size());
    if (one_thread()) {
        for (size_t k = 0; k < m.moved.size(); ++k) {
            if (k + 8 < m.moved.size()) m.prefetch_point(m.moved[k + 8]);
            m.shifted[k] = m.displace(m.moved[k], h);
            if (m.shifted[k]) mark_around(m.moved[k]);
        }
        phase.lap(&DisplaceUpdateStats::displace_seconds);
    } else {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, m.moved.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t k = r.begin(); k != r.end(); ++k) {
                if (k + 8 < r.end()) m.prefetch_point(m.moved[k + 8]);
                m.shifted[k] = m.displace(m.moved[k], h);
            }
        });
        phase.lap(&DisplaceUpdateStats::displace_seconds);
        for (size_t i = 0; i < m.moved.size(); ++i)
            if (m.shifted[i]) mark_around(m.moved[i]);
    }
    marked(m.redo_faces, m.face_mark);
    marked(m.redo_points, m.mark);
    phase.lap(&DisplaceUpdateStats::sweep_seconds);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, m.redo_faces.size(), 512), [&](const tbb::blocked_range<size_t>& r) {
        kernel::face_terms(m.terms.data(), m.cur.data(), m.tris.data(), 0, m.redo_faces.data() + r.begin(), r.size());
    });
    phase.lap(&DisplaceUpdateStats::terms_seconds);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, m.redo_points.size(), 512), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
            const uint32_t p = m.redo_points[k];
            gather_normal(&m.nrm[3 * size_t(p)], p, [&](uint32_t f) -> const FaceTerm& { return m.terms[f]; }, m.face_off, m.faces);
            m.fix_normal(p);
            m.write(p, pos, nor);
        }
    });
    phase.lap(&DisplaceUpdateStats::normals_seconds);
    if (stats) {
        stats->moved = m.moved.size();
        stats->shifted = size_t(std::count(m.shifted.begin(), m.shifted.end(), uint8_t(1)));
        stats->faces = m.redo_faces.size();
        stats->normals = m.redo_points.size();
    }
    return m.moved.size();
}

} // namespace furrow

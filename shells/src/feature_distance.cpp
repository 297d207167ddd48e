// Ray casts and point-to-mesh distances on an axis-aligned bounding-box tree.
//
// Reference: P. Alliez, S. Tayeb, C. Wormser, "3D Fast Intersection and Distance Computation", CGAL User
// and Reference Manual (AABB Tree package), 5.5. The tree is built once per call and then queried from
// several threads: both query kinds are const on a built tree (the distance accelerator is built up front,
// before the parallel loop, because CGAL builds it lazily otherwise).
//
// The only CGAL file of furrow::shells (its headers dominate compile time).
#include "shells_internal.h"

#include <furrow/shells.h>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/box_intersection_d.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace furrow {
namespace {

// Constructions (ray hit points, closest points) are all this file needs, and it needs them fast: the
// results only scale an offset by a safety fraction, so double rounding is harmless.
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using Ray = Kernel::Ray_3;
using Triangle = Kernel::Triangle_3;
using Iterator = std::vector<Triangle>::const_iterator;
using Primitive3 = CGAL::AABB_triangle_primitive<Kernel, Iterator>;
using Traits = CGAL::AABB_traits<Kernel, Primitive3>;
using Tree = CGAL::AABB_tree<Traits>;

// The pair decision of CGAL Polygon_mesh_processing::self_intersections (as in furrow::mesh's check),
// with adjacency read from vertex ids.
using Exact = CGAL::Exact_predicates_inexact_constructions_kernel;
bool pair_intersects(const std::vector<Exact::Point_3>& pts, const std::array<uint32_t, 3>& a, const std::array<uint32_t, 3>& b) {
    int shared = 0, ia = -1, ib = -1;
    bool in_b[3] = {false, false, false};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (a[i] == b[j]) {
                if (shared == 0) ia = i, ib = j;
                ++shared;
                in_b[i] = true;
            }
    if (shared >= 3) return false;
    if (shared == 2) {
        int u = -1, v = -1, apex = -1;
        for (int i = 0; i < 3; ++i) {
            if (!in_b[i]) apex = i;
            else if (u < 0) u = i;
            else v = i;
        }
        uint32_t apex_b = b[0];
        for (int j = 0; j < 3; ++j)
            if (b[j] != a[u] && b[j] != a[v]) apex_b = b[j];
        const auto &pu = pts[a[u]], &pv = pts[a[v]], &pa = pts[a[apex]], &pb = pts[apex_b];
        return CGAL::coplanar(pu, pv, pa, pb) && CGAL::coplanar_orientation(pu, pv, pa, pb) == CGAL::POSITIVE;
    }
    const Exact::Triangle_3 ta(pts[a[0]], pts[a[1]], pts[a[2]]), tb(pts[b[0]], pts[b[1]], pts[b[2]]);
    if (shared == 1) {
        const Exact::Segment_3 opposite_a(pts[a[(ia + 1) % 3]], pts[a[(ia + 2) % 3]]);
        const Exact::Segment_3 opposite_b(pts[b[(ib + 1) % 3]], pts[b[(ib + 2) % 3]]);
        return CGAL::do_intersect(ta, opposite_b) || CGAL::do_intersect(tb, opposite_a);
    }
    return CGAL::do_intersect(ta, tb);
}

} // namespace

namespace detail {

size_t crossing_vertices(uint8_t* hit, const std::vector<double>& base, const std::vector<double>& shell,
                         const std::vector<uint8_t>& moving, const std::vector<std::array<uint32_t, 3>>& triangles,
                         const std::vector<uint8_t>* changed) {
    const size_t W = moving.size();
    // Points: base vertices 0..W-1, then a shell copy W + v for every vertex that moves.
    std::vector<Exact::Point_3> pts;
    pts.reserve(2 * W);
    for (size_t v = 0; v < W; ++v) pts.emplace_back(base[3 * v], base[3 * v + 1], base[3 * v + 2]);
    std::vector<uint32_t> shell_id(W);
    for (size_t v = 0; v < W; ++v) {
        if (moving[v]) {
            shell_id[v] = uint32_t(pts.size());
            pts.emplace_back(shell[3 * v], shell[3 * v + 1], shell[3 * v + 2]);
        } else {
            shell_id[v] = uint32_t(v);
        }
    }
    // Triangles: the base ones (0..T-1) and the moving shell ones (T + f).
    std::vector<std::array<uint32_t, 3>> tris;
    std::vector<uint32_t> source; // shell triangle -> base face, base triangles: UINT32_MAX
    for (const auto& t : triangles) {
        tris.push_back(t);
        source.push_back(UINT32_MAX);
    }
    for (size_t f = 0; f < triangles.size(); ++f) {
        const auto& t = triangles[f];
        if (!moving[t[0]] && !moving[t[1]] && !moving[t[2]]) continue;
        tris.push_back({shell_id[t[0]], shell_id[t[1]], shell_id[t[2]]});
        source.push_back(uint32_t(f));
    }
    using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, size_t, CGAL::Box_intersection_d::ID_FROM_BOX_ADDRESS>;
    std::vector<Box> boxes;
    boxes.reserve(tris.size());
    for (size_t i = 0; i < tris.size(); ++i) {
        const auto& t = tris[i];
        if (CGAL::collinear(pts[t[0]], pts[t[1]], pts[t[2]])) continue;
        boxes.emplace_back(pts[t[0]].bbox() + pts[t[1]].bbox() + pts[t[2]].bbox(), i);
    }
    // Only pairs with a shell triangle are of interest: the shell boxes (or, after a repair, those around
    // changed vertices) against all boxes, so that the many overlapping base-base neighbours are never
    // enumerated.
    std::vector<const Box*> bases, shells, touched;
    for (const Box& b : boxes) {
        const uint32_t f = source[b.info()];
        if (f == UINT32_MAX) {
            bases.push_back(&b);
            continue;
        }
        shells.push_back(&b);
        if (!changed || (*changed)[triangles[f][0]] || (*changed)[triangles[f][1]] || (*changed)[triangles[f][2]])
            touched.push_back(&b);
    }
    if (touched.empty()) return 0;
    std::vector<std::pair<size_t, size_t>> candidates;
    auto report = [&](const Box* x, const Box* y) {
        if (x->info() != y->info()) candidates.emplace_back(std::min(x->info(), y->info()), std::max(x->info(), y->info()));
    };
    // Shell against base, and shell against shell; the base's own overlapping neighbours are never
    // enumerated. After a repair only the shell triangles around changed vertices are tested.
    CGAL::box_intersection_d<CGAL::Sequential_tag>(touched.begin(), touched.end(), bases.begin(), bases.end(), report);
    if (changed)
        CGAL::box_intersection_d<CGAL::Sequential_tag>(touched.begin(), touched.end(), shells.begin(), shells.end(), report);
    else
        CGAL::box_self_intersection_d<CGAL::Sequential_tag>(shells.begin(), shells.end(), report);
    std::sort(candidates.begin(), candidates.end()); // a fixed order, whatever order the boxes came in
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
    std::vector<uint8_t> crossing(candidates.size(), 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, candidates.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i)
            crossing[i] = pair_intersects(pts, tris[candidates[i].first], tris[candidates[i].second]);
    });
    size_t count = 0;
    for (size_t i = 0; i < candidates.size(); ++i) {
        if (!crossing[i]) continue;
        ++count;
        for (size_t t : {candidates[i].first, candidates[i].second})
            if (source[t] != UINT32_MAX)
                for (uint32_t v : triangles[source[t]]) hit[v] = 1;
    }
    return count;
}


void free_distances(double* out, const std::vector<double>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                    const uint32_t* query_vertex, const double* dirs, size_t query_count) {
    const double inf = std::numeric_limits<double>::infinity();
    if (triangles.empty()) {
        std::fill(out, out + query_count, inf);
        return;
    }
    std::vector<Triangle> tris;
    tris.reserve(triangles.size());
    auto pt = [&](uint32_t v) { return Point(points[3 * size_t(v)], points[3 * size_t(v) + 1], points[3 * size_t(v) + 2]); };
    for (const auto& t : triangles) tris.emplace_back(pt(t[0]), pt(t[1]), pt(t[2]));
    Tree tree(tris.begin(), tris.end());
    tree.build();
    const Iterator first = tris.begin();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, query_count, 256), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t q = r.begin(); q != r.end(); ++q) {
            const uint32_t v = query_vertex[q];
            const Vector d(dirs[3 * q], dirs[3 * q + 1], dirs[3 * q + 2]);
            if (!(d.squared_length() > 0)) {
                out[q] = inf;
                continue;
            }
            const Point origin = pt(v);
            // Faces around the vertex touch the ray at its origin; they are the surface being offset, not
            // an obstacle in front of it.
            auto skip = [&](const Iterator& id) {
                const auto& t = triangles[size_t(id - first)];
                return t[0] == v || t[1] == v || t[2] == v;
            };
            double best = inf;
            try {
                auto hit = tree.first_intersection(Ray(origin, d), skip);
                if (hit) {
                    if (const Point* p = boost::get<Point>(&hit->first)) {
                        best = std::sqrt(CGAL::squared_distance(origin, *p));
                    } else if (const auto* s = boost::get<Kernel::Segment_3>(&hit->first)) {
                        // The ray runs inside a coplanar face: its nearer end is where it is blocked.
                        best = std::sqrt(std::min(CGAL::squared_distance(origin, s->source()),
                                                  CGAL::squared_distance(origin, s->target())));
                    } else {
                        best = 0;
                    }
                }
            } catch (...) {
                best = 0; // a failed construction: be safe, treat the vertex as blocked
            }
            out[q] = best;
        }
    });
}

void owned_lengths(double* out, const std::vector<double>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                   const uint32_t* ring_start, const uint32_t* ring_faces, const uint32_t* query_vertex, const double* dirs,
                   const double* lengths, double ratio, size_t query_count) {
    if (triangles.empty()) {
        std::copy(lengths, lengths + query_count, out);
        return;
    }
    std::vector<Triangle> tris;
    tris.reserve(triangles.size());
    auto pt = [&](uint32_t v) { return Point(points[3 * size_t(v)], points[3 * size_t(v) + 1], points[3 * size_t(v) + 2]); };
    for (const auto& t : triangles) tris.emplace_back(pt(t[0]), pt(t[1]), pt(t[2]));
    Tree tree(tris.begin(), tris.end());
    tree.build();
    tree.accelerate_distance_queries();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, query_count, 128), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t q = r.begin(); q != r.end(); ++q) {
            const uint32_t v = query_vertex[q];
            const Point p = pt(v);
            const Vector d(dirs[3 * q], dirs[3 * q + 1], dirs[3 * q + 2]);
            auto owned = [&](double t) {
                const Point x = p + t * d;
                double own = std::numeric_limits<double>::infinity();
                for (uint32_t i = ring_start[v]; i < ring_start[v + 1]; ++i)
                    own = std::min(own, CGAL::squared_distance(x, tris[ring_faces[i]]));
                const double all = tree.squared_distance(x);
                return all >= ratio * ratio * own;
            };
            const double h = lengths[q];
            if (!(h > 0) || owned(h)) {
                out[q] = h;
                continue;
            }
            // Ownership is lost once along the ray and (in practice) not regained: bisect the boundary.
            double lo = 0, hi = h;
            for (int i = 0; i < 12; ++i) { // 1/4096 of the length
                const double mid = 0.5 * (lo + hi);
                (owned(mid) ? lo : hi) = mid;
            }
            out[q] = lo;
        }
    });
}

void bend_limits(double* out, const std::vector<double>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
                 const uint32_t* ring_start, const uint32_t* ring_faces, const uint32_t* query_vertex,
                 const double* straight, const double* bent, double clearance, size_t query_count) {
    if (triangles.empty()) {
        std::fill(out, out + query_count, 1.0);
        return;
    }
    std::vector<Triangle> tris;
    tris.reserve(triangles.size());
    auto pt = [&](uint32_t v) { return Point(points[3 * size_t(v)], points[3 * size_t(v) + 1], points[3 * size_t(v) + 2]); };
    for (const auto& t : triangles) tris.emplace_back(pt(t[0]), pt(t[1]), pt(t[2]));
    Tree tree(tris.begin(), tris.end());
    tree.build();
    tree.accelerate_distance_queries();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, query_count, 64), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<uint32_t> faces, verts, next;
        for (size_t q = r.begin(); q != r.end(); ++q) {
            const uint32_t v = query_vertex[q];
            const Point p = pt(v);
            const Vector a(straight[3 * q], straight[3 * q + 1], straight[3 * q + 2]);
            const Vector b(bent[3 * q], bent[3 * q + 1], bent[3 * q + 2]);
            // The neighbourhood the bent tip may still belong to: rings of faces around v, as many as the
            // bend is long in edges (at most 6), grown in a fixed order.
            double edge = 0;
            int edges = 0;
            for (uint32_t i = ring_start[v]; i < ring_start[v + 1]; ++i)
                for (uint32_t u : triangles[ring_faces[i]])
                    if (u != v) edge += std::sqrt(CGAL::squared_distance(p, pt(u))), ++edges;
            edge = edges ? edge / edges : 0;
            const double bend = std::sqrt((b - a).squared_length());
            const int rings = edge > 0 ? std::min(6, 1 + int(std::ceil(bend / edge))) : 1;
            faces.clear();
            verts.assign(1, v);
            for (int k = 0; k < rings; ++k) {
                next.clear();
                for (uint32_t u : verts)
                    for (uint32_t i = ring_start[u]; i < ring_start[u + 1]; ++i) {
                        const uint32_t f = ring_faces[i];
                        if (std::find(faces.begin(), faces.end(), f) != faces.end()) continue;
                        faces.push_back(f);
                        for (uint32_t w : triangles[f]) next.push_back(w);
                    }
                verts.swap(next);
            }
            const double need = clearance * clearance * tree.squared_distance(p + a);
            // The tip keeps its clearance, does not pass through the surface on the way (a tip pushed
            // through a thin wall can be far from the mesh again on the other side), and stays nearer to its
            // own neighbourhood than to any other part of the surface.
            auto ok = [&](double sigma) {
                const Point tip = p + a + sigma * (b - a);
                const double all = tree.squared_distance(tip);
                if (all < need || tree.do_intersect(Kernel::Segment_3(p + a, tip))) return false;
                double own = std::numeric_limits<double>::infinity();
                for (uint32_t f : faces) own = std::min(own, CGAL::squared_distance(tip, tris[f]));
                return all >= 0.98 * 0.98 * own;
            };
            if (ok(1.0)) {
                out[q] = 1.0;
                continue;
            }
            double lo = 0, hi = 1;
            for (int i = 0; i < 10; ++i) {
                const double mid = 0.5 * (lo + hi);
                (ok(mid) ? lo : hi) = mid;
            }
            out[q] = lo;
        }
    });
}

} // namespace detail

void distances_to_mesh(double* out, const float* points, size_t point_count, const float* positions, size_t vertex_count,
                       const uint32_t* indices, size_t index_count) {
    std::vector<Triangle> tris;
    tris.reserve(index_count / 3);
    auto pt = [&](uint32_t v) { return Point(positions[3 * size_t(v)], positions[3 * size_t(v) + 1], positions[3 * size_t(v) + 2]); };
    for (size_t t = 0; t + 3 <= index_count; t += 3) {
        if (indices[t] >= vertex_count || indices[t + 1] >= vertex_count || indices[t + 2] >= vertex_count) continue;
        Triangle tri(pt(indices[t]), pt(indices[t + 1]), pt(indices[t + 2]));
        if (!tri.is_degenerate()) tris.push_back(tri);
    }
    if (tris.empty()) {
        std::fill(out, out + point_count, std::numeric_limits<double>::infinity());
        return;
    }
    Tree tree(tris.begin(), tris.end());
    tree.build();
    tree.accelerate_distance_queries();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, point_count, 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i)
            out[i] = std::sqrt(tree.squared_distance(Point(points[3 * i], points[3 * i + 1], points[3 * i + 2])));
    });
}

} // namespace furrow

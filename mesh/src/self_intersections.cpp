// Self-intersecting triangle pairs.
//
// Reference: CGAL Polygon Mesh Processing, `CGAL::Polygon_mesh_processing::self_intersections`
// (S. Loriot, J. Tournois, I. O. Yaz, M. Rouxel-Labbé et al., CGAL User and Reference Manual, 5.5), which
// filters candidate pairs with box intersection (Zomorodian & Edelsbrunner, "Fast software for box
// intersections", SoCG 2000) and decides each pair with exact predicates.
//
// That function needs a halfedge graph, and a CGAL::Surface_mesh cannot hold non-manifold edges or
// vertices: exactly the meshes `furrow check` is most often asked about. So when the welded triangles do not
// all fit into a Surface_mesh, the same decision procedure is applied to the soup, with adjacency read from
// the welded vertex indices instead of from halfedges (kernel::triangles_intersect, which the shells'
// intersection test shares). On a manifold mesh both agree pair for pair.
//
// This is the only file of furrow::mesh that includes CGAL headers (they dominate compile time).
#include "self_intersections.h"

#include <furrow_kernel/triangle_pair_intersection.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/box_intersection_d.h>
#include <boost/iterator/function_output_iterator.hpp>

#include <exception>
#include <iterator>

namespace furrow::mesh_detail {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;

// A counting output iterator: only the number of pairs is reported, and CGAL reports a collinear face
// as the pair (f, f), which is a degenerate face rather than an intersection.
template <class Pair>
struct PairCounter {
    long long* count;
    void operator()(const Pair& p) const {
        if (p.first != p.second) ++*count;
    }
};

long long count_on_surface_mesh(const std::vector<Point>& points,
                                const std::vector<std::array<uint32_t, 3>>& triangles, bool& refused) {
    refused = false;
    Mesh mesh;
    mesh.reserve(Mesh::size_type(points.size()), Mesh::size_type(3 * triangles.size() / 2),
                 Mesh::size_type(triangles.size()));
    for (const Point& p : points) mesh.add_vertex(p);
    for (const auto& t : triangles) {
        Mesh::Face_index f = mesh.add_face(Mesh::Vertex_index(t[0]), Mesh::Vertex_index(t[1]),
                                           Mesh::Vertex_index(t[2]));
        if (f == Mesh::null_face()) {
            refused = true;
            return -1;
        }
    }
    long long count = 0;
    using Pair = std::pair<Mesh::Face_index, Mesh::Face_index>;
    CGAL::Polygon_mesh_processing::self_intersections<CGAL::Sequential_tag>(
        mesh, boost::make_function_output_iterator(PairCounter<Pair>{&count}));
    return count;
}

long long count_on_soup(const std::vector<Point>& points, const std::vector<std::array<uint32_t, 3>>& triangles) {
    using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, size_t,
                                                          CGAL::Box_intersection_d::ID_FROM_BOX_ADDRESS>;
    std::vector<Box> boxes;
    boxes.reserve(triangles.size());
    for (size_t i = 0; i < triangles.size(); ++i) {
        const auto& t = triangles[i];
        const Point &p = points[t[0]], &q = points[t[1]], &r = points[t[2]];
        if (CGAL::collinear(p, q, r)) continue; // degenerate, not an intersection (as in CGAL)
        boxes.emplace_back(p.bbox() + q.bbox() + r.bbox(), i);
    }
    // Pointers, as in PMP: box_self_intersection_d copies its input, and the ids come from addresses.
    std::vector<const Box*> box_ptrs;
    box_ptrs.reserve(boxes.size());
    for (const Box& b : boxes) box_ptrs.push_back(&b);
    long long count = 0;
    auto callback = [&](const Box* x, const Box* y) {
        if (kernel::triangles_intersect(points, triangles[x->info()], triangles[y->info()])) ++count;
    };
    CGAL::box_self_intersection_d<CGAL::Sequential_tag>(box_ptrs.begin(), box_ptrs.end(), callback);
    return count;
}

} // namespace

long long count_self_intersections(const std::vector<double>& xyz,
                                   const std::vector<std::array<uint32_t, 3>>& triangles,
                                   SelfIntersectionMethod method) {
    // CGAL signals violated preconditions with exceptions; the library promises none, so any of them
    // becomes "not computed".
    try {
        const size_t n = xyz.size() / 3;
        for (const auto& t : triangles)
            if (t[0] >= n || t[1] >= n || t[2] >= n || t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) return -1;
        std::vector<Point> points;
        points.reserve(n);
        for (size_t i = 0; i < n; ++i) points.emplace_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
        if (method != SelfIntersectionMethod::soup) {
            bool refused = false;
            long long count = count_on_surface_mesh(points, triangles, refused);
            if (!refused || method == SelfIntersectionMethod::surface_mesh) return count;
        }
        return count_on_soup(points, triangles);
    } catch (...) {
        return -1;
    }
}

} // namespace furrow::mesh_detail

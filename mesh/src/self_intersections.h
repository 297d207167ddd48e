// Private to furrow::mesh: self-intersection count for check_primitive, kept apart so that only
// self_intersections.cpp pays for the CGAL headers.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace furrow::mesh_detail {

enum class SelfIntersectionMethod {
    automatic,    // surface_mesh when every triangle fits a manifold Surface_mesh, soup otherwise
    surface_mesh, // CGAL::Polygon_mesh_processing::self_intersections on a CGAL::Surface_mesh
    soup,         // the same predicates on the triangle soup (non-manifold input)
};

// Number of intersecting triangle pairs. `points` holds xyz per vertex (finite); `triangles` index them
// and must already be welded (shared vertices have one index), with three distinct indices each. Pairs
// that share an edge count only if they overlap in their common plane; pairs that share a vertex count if
// they meet anywhere else (CGAL's definition). Returns -1 if the computation could not be done (CGAL
// refused the input, or `surface_mesh` was forced on a non-manifold soup).
long long count_self_intersections(const std::vector<double>& points,
                                   const std::vector<std::array<uint32_t, 3>>& triangles,
                                   SelfIntersectionMethod method = SelfIntersectionMethod::automatic);

} // namespace furrow::mesh_detail

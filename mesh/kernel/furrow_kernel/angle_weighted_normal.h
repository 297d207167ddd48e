// furrow's private geometry kernel: what one triangle contributes to angle-weighted vertex normals, and the
// one rule for which triangles contribute nothing, in one place. Shared because mesh (compute_vertex_normals),
// shells (the fur frame's extrusion direction) and deform (the displaced ground's normals, recomputed
// incrementally) must weigh the same faces: before they shared this rule, the displaced ground weighted
// near-zero-area faces that compute_vertex_normals and the fur frame ignored. Not installed and not part of
// any public header (see affine.h).
//
// References: G. Thürmer, C. A. Wüthrich, "Computing Vertex Normals from Polygonal Facets", JGT 3(1), 1998
// (each face normal weighted by the face's interior angle at the vertex, so that the result does not depend
// on how a surface is triangulated); J. A. Bærentzen, H. Aanæs, "Signed Distance Computation Using the Angle
// Weighted Pseudonormal", IEEE TVCG 11(3), 2005.
//
// Degenerate faces. A triangle whose area is at most kDegenerateAreaRelative × (its longest edge)² has no
// normal: |e1 × e2| is then at most about 200 double roundings of (longest edge)², the order of its own
// rounding error, so its direction is noise, and at its obtuse corner it would weigh nearly pi. The
// threshold is relative to the face's own edges, not to the mesh's size: a face is judged the same however
// large the rest of the mesh is (an incremental update sees only the faces around the points it moves), and
// the threshold scales with the face. The constant is CheckOptions::zero_area_relative's default,
// measured against the face instead of the bounding-box diagonal, so every face ignored here is one that
// `furrow check` reports as zero-area (no edge is longer than the diagonal). Faces with a non-finite corner
// are degenerate too; callers drop faces with a repeated (welded) vertex before asking.
#pragma once

#include "vec3.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace furrow::kernel {

inline constexpr double kDegenerateAreaRelative = 1e-14;

struct FaceNormal {
    Vec3 unit;              // unit normal, right-handed over the corners p0 -> p1 -> p2
    double double_area = 0; // |(p1 - p0) × (p2 - p0)|, twice the area
};

// The normal of triangle (p0, p1, p2), or nothing when the triangle is degenerate (see above).
inline std::optional<FaceNormal> face_normal(Vec3 p0, Vec3 p1, Vec3 p2) {
    const Vec3 n = cross(p1 - p0, p2 - p0);
    const double double_area = norm(n);
    const double longest2 = std::max({dot(p1 - p0, p1 - p0), dot(p2 - p0, p2 - p0), dot(p2 - p1, p2 - p1)});
    if (!std::isfinite(double_area) || !(double_area > 2.0 * kDegenerateAreaRelative * longest2)) return std::nullopt;
    return FaceNormal{{n.x / double_area, n.y / double_area, n.z / double_area}, double_area};
}

// The interior angle at p of a non-degenerate triangle (p, q, r) of the given double area: atan2 of
// |e1 × e2| (the same at every corner) and e1 · e2 stays accurate near 0 and pi, where acos of a normalised
// dot product loses half its digits.
inline double corner_angle(Vec3 p, Vec3 q, Vec3 r, double double_area) { return std::atan2(double_area, dot(q - p, r - p)); }

} // namespace furrow::kernel

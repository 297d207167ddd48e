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

// One face's part of its corners' normals: the unit normal and the interior angle at each corner (face_term,
// below; many at once: face_terms.h).
struct FaceTerm {
    double unit[3];
    double angle[3]; // < 0: degenerate (face_normal gives nothing), contributes nothing
    // A degenerate face's term. (No default member values: an array of terms that a pass overwrites whole is
    // allocated without a fill, 5 ms for the 786k faces of `bench stamp` section 5.)
    static constexpr FaceTerm none() { return {{0, 0, 0}, {-1, -1, -1}}; }
};

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
    const double inverse = 1.0 / double_area; // one division, not three (as in face_term)
    return FaceNormal{{n.x * inverse, n.y * inverse, n.z * inverse}, double_area};
}

inline constexpr double kPi = 3.14159265358979323846;

// The interior angle at p of a non-degenerate triangle (p, q, r) of the given double area (corner_angle_of:
// the same from the double area and x = (q − p) · (r − p)): the angle of
// (e1 · e2, |e1 × e2|), with |e1 × e2| the same at every corner, stays accurate near 0 and pi, where acos of a
// normalised dot product loses half its digits.
//
// The arctangent is Cephes' (S. L. Moshier, Cephes Math Library, atan.c): the ratio reduced to |t| <= 0.66 by
// the identities atan(x) = pi/2 - atan(1/x) and pi/4 + atan((x - 1)/(x + 1)), then t + t³ P(t²)/Q(t²), a (4, 5)
// rational approximation. It replaces libm's atan2 (there: ~29 ns a call, 45 % of the displaced ground's
// re-displacement; here ~21 ns, inlined, no special cases: y > 0 and a finite x are all a corner can give).
// Against std::atan2 over 20 M random corners (1e-9 .. 1e9 in y and x): at most 4.4e-16 rad (2 ulp of pi)
// apart; test compute_vertex_normals.CornerAngleIsLibmAtan2WithinTwoUlp.
inline double corner_angle_of(double double_area, double x) {
    constexpr double P[5] = {-8.750608600031904122785e-1, -1.615753718733365076637e1, -7.500855792314704667340e1,
                             -1.228866684490136173410e2, -6.485021904942025371773e1};
    constexpr double Q[5] = {2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
                             4.853903996359136964868e2, 1.945506571482613964425e2}; // leading 1 implied
    constexpr double more_bits = 6.123233995736765886130e-17;                       // pi/2 - double(pi/2)
    constexpr double tan_3pi_8 = 2.41421356237309504880, pi = 3.14159265358979323846;
    const double y = double_area, a = std::abs(x);
    double base = 0, t = 0, extra = 0; // atan(y / a) = base + atan(t) + extra
    if (y > tan_3pi_8 * a) base = pi / 2, t = -a / y, extra = more_bits;
    else if (y <= 0.66 * a) t = y / a;
    else base = pi / 4, t = (y - a) / (y + a), extra = 0.5 * more_bits;
    const double z = t * t;
    const double num = (((P[0] * z + P[1]) * z + P[2]) * z + P[3]) * z + P[4];
    const double den = ((((z + Q[0]) * z + Q[1]) * z + Q[2]) * z + Q[3]) * z + Q[4];
    const double angle = base + ((t + t * (z * num / den)) + extra);
    return x >= 0 ? angle : pi - angle;
}
inline double corner_angle(Vec3 p, Vec3 q, Vec3 r, double double_area) { return corner_angle_of(double_area, dot(q - p, r - p)); }

// The term of triangle (p0, p1, p2): its face_normal and its three corner angles, or FaceTerm::none() when
// it is degenerate. This is the one definition of a face's part of an angle-weighted normal: every caller
// (compute_vertex_normals, the fur frame, the displaced ground) and the batched face_terms (face_terms.h,
// each lane the same operations in the same order, so the same bits) compute it so.
// Two corners get corner_angle; the third, the corner opposite the longest edge (the largest angle, at least
// pi/3), is pi minus the other two: one arctangent (two divisions and two polynomials) fewer a face. The
// subtraction loses nothing that matters: the derived angle is at least pi/3, so its absolute error, a few
// roundings of pi, stays a few ulp of itself (test compute_vertex_normals.DerivedCornerIsAtan2WithinFourUlp).
// Edges as the batched code forms them: a = p1 − p0, b = p2 − p0, c = p2 − p1.
inline FaceTerm face_term(Vec3 p0, Vec3 p1, Vec3 p2) {
    const auto face = face_normal(p0, p1, p2);
    if (!face) return FaceTerm::none();
    const Vec3 a = p1 - p0, b = p2 - p0, c = p2 - p1;
    const double la = dot(a, a), lb = dot(b, b), lc = dot(c, c);
    // The corner opposite the longest edge (the first longest of a, b, c): a faces p2, b p1, c p0.
    const int derived = la >= lb && la >= lc ? 2 : lb >= lc ? 1 : 0;
    const double x[3] = {dot(a, b), dot(c, -a), dot(-b, -c)}; // each corner's edges' dot product
    FaceTerm f;
    f.unit[0] = face->unit.x, f.unit[1] = face->unit.y, f.unit[2] = face->unit.z;
    const int first = derived == 0 ? 1 : 0, second = derived == 2 ? 1 : 2;
    f.angle[first] = corner_angle_of(face->double_area, x[first]);
    f.angle[second] = corner_angle_of(face->double_area, x[second]);
    f.angle[derived] = (kPi - f.angle[first]) - f.angle[second];
    return f;
}

} // namespace furrow::kernel

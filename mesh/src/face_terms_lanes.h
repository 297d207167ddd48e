// The batched face terms (furrow_kernel/face_terms.h) as templates over the lane count L: face_term of
// angle_weighted_normal.h written over GCC vector types, one triangle per lane. The scalar function's
// branches become selects: every lane computes each candidate and keeps the one the scalar code would
// compute, through the same operations (the arctangent's reduced argument is one division of selected
// operands, as the scalar branch divides them), so the bits are the scalar's. No fused multiply-add
// (-ffp-contract=off in CMakeLists.txt): the AVX-512 and AVX2 code would otherwise fuse what the scalar
// code rounds twice.
// Private to mesh/src. Each width is compiled in its own translation unit with its instruction set
// (face_terms.cpp: 2 lanes, baseline; face_terms_avx2.cpp: 4; face_terms_avx512.cpp: 8), so everything here
// is in an unnamed namespace: each unit keeps its own copies, and the linker cannot hand the baseline code an
// AVX-512 instance of a shared inline function (nor is any std:: template called here, for that reason).
// Compiled whole with -mavx512f, the 8-lane code took 10.2 ns a face, against 12.9 as a [[gnu::target]]
// function in the baseline unit (800k nearby triangles, the project's AVX-512 machine); the clamp of the last
// block's index is std::min's own test, b < a ? b : a: written a < b ? a : b, GCC 12 made the loop 14.8 ns.
#pragma once

#include <furrow_kernel/angle_weighted_normal.h>
#include <furrow_kernel/face_terms.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace furrow::kernel {
namespace {

template <int L>
struct Lanes {
    typedef double D __attribute__((vector_size(8 * L)));
    typedef int64_t M __attribute__((vector_size(8 * L)));
};

template <int L>
using D = typename Lanes<L>::D;

// corner_angle for L corners: y the double area, x the dot product of the corner's edges.
template <int L>
[[gnu::always_inline]] inline D<L> corner_angles(D<L> y, D<L> x) {
    constexpr double P[5] = {-8.750608600031904122785e-1, -1.615753718733365076637e1, -7.500855792314704667340e1,
                             -1.228866684490136173410e2, -6.485021904942025371773e1};
    constexpr double Q[5] = {2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
                             4.853903996359136964868e2, 1.945506571482613964425e2};
    constexpr double more_bits = 6.123233995736765886130e-17;
    constexpr double tan_3pi_8 = 2.41421356237309504880, pi = 3.14159265358979323846;
    using M = typename Lanes<L>::M;
    const D<L> zero = {}, a = (D<L>)((M)x & std::numeric_limits<int64_t>::max()); // std::abs (-0 gives +0)
    const auto steep = y > tan_3pi_8 * a, shallow = y <= 0.66 * a;
    // t = -a / y, y / a or (y - a) / (y + a): one division of the operands the scalar branch divides.
    const D<L> num_t = steep ? -a : (shallow ? y : y - a), den_t = steep ? y : (shallow ? a : y + a);
    const D<L> base = steep ? zero + pi / 2 : (shallow ? zero : zero + pi / 4);
    const D<L> extra = steep ? zero + more_bits : (shallow ? zero : zero + 0.5 * more_bits);
    const D<L> t = num_t / den_t, z = t * t;
    const D<L> num = (((P[0] * z + P[1]) * z + P[2]) * z + P[3]) * z + P[4];
    const D<L> den = ((((z + Q[0]) * z + Q[1]) * z + Q[2]) * z + Q[3]) * z + Q[4];
    const D<L> angle = base + ((t + t * (z * num / den)) + extra);
    return x >= zero ? angle : pi - angle;
}

// Square roots of L lanes: one vector instruction (-fno-math-errno: no errno call to keep per lane),
// correctly rounded as std::sqrt is.
template <int L>
[[gnu::always_inline]] inline D<L> roots(D<L> s) {
    for (int j = 0; j < L; ++j) s[j] = std::sqrt(s[j]);
    return s;
}

// The triangles of items k0 .. k0 + L − 1 (the last repeated past `count`), written for the items < count.
// (GCC 12 warns that lanes set one at a time may be read uninitialised; every lane is set first.)
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
template <int L, class FaceOf>
[[gnu::always_inline]] inline void block(FaceTerm* out, const double* P, const uint32_t* tris, FaceOf face_of, size_t k0, size_t count) {
    D<L> x[3] = {}, y[3] = {}, z[3] = {};
    size_t f[L];
    for (int j = 0; j < L; ++j) {
        f[j] = face_of(count - 1 < k0 + size_t(j) ? count - 1 : k0 + size_t(j)); // std::min's test (see the opening comment)
        const uint32_t* t = tris + 3 * f[j];
        for (int c = 0; c < 3; ++c) {
            const double* p = P + 3 * size_t(t[c]);
            x[c][j] = p[0], y[c][j] = p[1], z[c][j] = p[2];
        }
    }
    // face_normal: n = (p1 − p0) × (p2 − p0) as GLM forms it, its length, the longest edge squared.
    const D<L> ax = x[1] - x[0], ay = y[1] - y[0], az = z[1] - z[0];
    const D<L> bx = x[2] - x[0], by = y[2] - y[0], bz = z[2] - z[0];
    const D<L> cx = x[2] - x[1], cy = y[2] - y[1], cz = z[2] - z[1];
    const D<L> nx = ay * bz - by * az, ny = az * bx - bz * ax, nz = ax * by - bx * ay;
    const D<L> area = roots<L>(nx * nx + ny * ny + nz * nz);
    const D<L> la = ax * ax + ay * ay + az * az;
    D<L> longest2 = la;
    const D<L> b2 = bx * bx + by * by + bz * bz, c2 = cx * cx + cy * cy + cz * cz;
    longest2 = longest2 < b2 ? b2 : longest2; // std::max({...}): the first largest
    longest2 = longest2 < c2 ? c2 : longest2;
    // Comparisons feed selects directly: a comparison kept as a mask value (a & b of two) is lowered lane by
    // lane with AVX-512F alone (a scalar compare per lane: 20 instead of 13 ns a face).
    const D<L> zero = {}, limit = 2.0 * kDegenerateAreaRelative * longest2;
    const D<L> inverse = 1.0 / area, ux = nx * inverse, uy = ny * inverse, uz = nz * inverse;
    // Each corner's edges' dot product: at p0 (edges to p1, p2), p1 (to p2, p0), p2 (to p0, p1); p0 − p1 is
    // −(p1 − p0) exactly.
    const D<L> dot0 = ax * bx + ay * by + az * bz;
    const D<L> dot1 = cx * -ax + cy * -ay + cz * -az;   // (p2 − p1) · (p0 − p1)
    const D<L> dot2 = -bx * -cx + -by * -cy + -bz * -cz; // (p0 − p2) · (p1 − p2)
    // face_term's corners: the one opposite the first longest edge is derived (a = p1 − p0 faces p2, b faces
    // p1, c faces p0), the lower of the other two is `first`. p2's when |a|² >= max(|b|², |c|²); p0's when
    // |c|² > max(|a|², |b|²) (the scalar tests, for finite lengths; a face with a NaN is degenerate).
    const D<L> max_bc = b2 < c2 ? c2 : b2, max_ab = la < b2 ? b2 : la;
    const D<L> first = corner_angles<L>(area, c2 > max_ab ? dot1 : dot0);
    const D<L> second = corner_angles<L>(area, la >= max_bc ? dot1 : dot2);
    const D<L> third = (kPi - first) - second;
    D<L> angle[3] = {c2 > max_ab ? third : first, c2 > max_ab ? first : (la >= max_bc ? second : third), la >= max_bc ? third : second};
    // A degenerate face (face_normal's test: a finite area above the limit) gets FaceTerm::none(). A non-finite
    // area is taken as 0 first, which no limit (>= 0, or NaN) is below.
    const D<L> finite_area = area <= std::numeric_limits<double>::max() ? area : zero;
    for (auto& a : angle) a = finite_area > limit ? a : zero - 1;
    const D<L> unit[3] = {finite_area > limit ? ux : zero, finite_area > limit ? uy : zero, finite_area > limit ? uz : zero};
    for (int j = 0; j < L && k0 + size_t(j) < count; ++j) {
        FaceTerm& o = out[f[j]];
        for (int c = 0; c < 3; ++c) o.unit[c] = unit[c][j], o.angle[c] = angle[c][j];
    }
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

template <int L>
[[gnu::always_inline]] inline void terms_of(FaceTerm* out, const double* P, const uint32_t* tris, size_t first, const uint32_t* faces, size_t count) {
    if (faces) {
        for (size_t k = 0; k < count; k += L) block<L>(out, P, tris, [faces](size_t i) { return size_t(faces[i]); }, k, count);
    } else {
        for (size_t k = 0; k < count; k += L) block<L>(out, P, tris, [first](size_t i) { return first + i; }, k, count);
    }
}

} // namespace
} // namespace furrow::kernel

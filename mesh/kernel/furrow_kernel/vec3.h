// furrow's private geometry kernel: the double-precision 3-vector the geometry code computes in, in one
// place. Shared because mesh (checks, normals), shells (the fur frame) and the kernel's normal rule
// (angle_weighted_normal.h) each carried the same small struct and operators. Positions arrive as float and
// are promoted, so that cross products and angles keep their digits. Not installed and not part of any
// public header (see affine.h).
#pragma once

#include <cmath>
#include <cstddef>

namespace furrow::kernel {

struct Vec3 {
    double x = 0, y = 0, z = 0;
};

inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double norm(Vec3 a) { return std::sqrt(dot(a, a)); }
inline bool finite(Vec3 a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }

// Point v of xyz triples (float or double), promoted to double.
template <class T>
Vec3 point_at(const T* xyz, size_t v) {
    return {double(xyz[3 * v]), double(xyz[3 * v + 1]), double(xyz[3 * v + 2])};
}

} // namespace furrow::kernel

// furrow's private geometry kernel: the double-precision 3-vector the geometry code computes in, in one
// place. The type is GLM's dvec3 (GLM is the project's vector library; every module links it through the
// kernel, see furrow_add_library), so that no module carries its own small struct and operators: mesh
// (checks, normals, shapes), shells (the fur frame), deform (colliders, heightmap frame) and render all
// compute in this one type. Positions arrive as float and are promoted, so that cross products and angles keep
// their digits. Not installed and not part of any public header (see affine.h).
//
// The helpers below are named for what the geometry code says (dot, cross, norm); dot and cross forward to
// GLM. norm is written out as sqrt(dot) rather than glm::length so that every module measures a length the
// same way, bit for bit, as before the move to GLM.
#pragma once

// Zero-initialised vectors (GLM leaves them uninitialised by default) and plain x/y/z members. Defined here,
// before the first GLM include of any furrow translation unit: only the kernel includes GLM.
#ifndef GLM_FORCE_CTOR_INIT
#define GLM_FORCE_CTOR_INIT
#endif
#ifndef GLM_FORCE_XYZW_ONLY
#define GLM_FORCE_XYZW_ONLY
#endif
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cmath>
#include <cstddef>

namespace furrow::kernel {

using Vec3 = glm::dvec3;

inline double dot(const Vec3& a, const Vec3& b) { return glm::dot(a, b); }
inline Vec3 cross(const Vec3& a, const Vec3& b) { return glm::cross(a, b); }
inline double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }
inline bool finite(const Vec3& a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }

// Point v of xyz triples (float or double), promoted to double.
template <class T>
Vec3 point_at(const T* xyz, size_t v) {
    return {double(xyz[3 * v]), double(xyz[3 * v + 1]), double(xyz[3 * v + 2])};
}

// Between the kernel's vector and the std::array<double, 3> of the public headers (Scene, colliders, frames).
inline Vec3 vec3_of(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }
inline std::array<double, 3> array_of(const Vec3& a) { return {a.x, a.y, a.z}; }

} // namespace furrow::kernel

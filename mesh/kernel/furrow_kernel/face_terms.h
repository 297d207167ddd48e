// furrow's private geometry kernel: the angle-weighted normal terms of many triangles at once, several
// triangles to a vector register. Each lane computes what face_term computes for one triangle
// (angle_weighted_normal.h), the same operations in the same order, and IEEE arithmetic rounds a
// lane as it rounds a scalar, so the terms are the same bits whichever width runs (tested against the scalar
// functions, degenerate and sliver faces included). The width is chosen at run time: 8 lanes with AVX-512,
// 4 with AVX2, else 2 (SSE2); the build targets baseline x86-64. Implemented in mesh/src/face_terms_lanes.h,
// built once per width (face_terms.cpp, face_terms_avx2.cpp, face_terms_avx512.cpp).
//
// Why: one face at a time, a triangle's terms (a square root, five divisions, two arctangent polynomials) are
// latency-bound. The displaced snow ground recomputes them for every face in a full pass and for the faces
// around each moved point in an update (deform/src/displaced_ground.cpp); they were its largest cost. 800k
// triangles of nearby points, one thread, on the project's AVX-512 machine: 40 ns a face scalar, 18-19 ns at
// 2 lanes, 15-17 at 4, 13-14 at 8 (2026-11-27); 9.9 at 8 once built for AVX-512 in their own unit with the
// third angle derived (later that day). They are not bound by the divisions (made products, the same 13 ns):
// gathering each lane's three points and storing the terms is most of the cost.
#pragma once

#include "angle_weighted_normal.h" // FaceTerm, face_term

#include <cstddef>
#include <cstdint>

namespace furrow::kernel {

// The terms of `count` triangles of `tris` (three point indices each) over points P (xyz triples): with
// `faces` null, triangles first .. first + count − 1 into out[first ..]; else triangles faces[0 .. count − 1]
// into out[faces[k]]. `lanes` 0 picks the widest this processor runs; 2, 4 or 8 force one (tests; a width
// the processor lacks falls back to 2).
void face_terms(FaceTerm* out, const double* P, const uint32_t* tris, size_t first, const uint32_t* faces, size_t count,
                int lanes = 0);

// The widest lane count face_terms runs here.
int face_term_lanes();

} // namespace furrow::kernel

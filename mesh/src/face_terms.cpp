// Angle-weighted normal terms of many triangles at once (furrow_kernel/face_terms.h): the 2-lane build
// (baseline x86-64: SSE2) and the choice of width at run time. The terms themselves: face_terms_lanes.h.
#include "face_terms_lanes.h"

namespace furrow::kernel {

#if FURROW_FACE_TERMS_X86
// In face_terms_avx512.cpp and face_terms_avx2.cpp, each compiled for its instruction set.
void face_terms_8(FaceTerm* out, const double* P, const uint32_t* tris, size_t first, const uint32_t* faces, size_t count);
void face_terms_4(FaceTerm* out, const double* P, const uint32_t* tris, size_t first, const uint32_t* faces, size_t count);
#endif

int face_term_lanes() {
#if FURROW_FACE_TERMS_X86
    static const int lanes = __builtin_cpu_supports("avx512f") ? 8 : __builtin_cpu_supports("avx2") ? 4 : 2;
    return lanes;
#else
    return 2;
#endif
}

void face_terms(FaceTerm* out, const double* P, const uint32_t* tris, size_t first, const uint32_t* faces, size_t count, int lanes) {
    if (count == 0) return;
    const int best = face_term_lanes();
    if (lanes <= 0 || lanes > best) lanes = best;
#if FURROW_FACE_TERMS_X86
    if (lanes == 8) return face_terms_8(out, P, tris, first, faces, count);
    if (lanes == 4) return face_terms_4(out, P, tris, first, faces, count);
#endif
    terms_of<2>(out, P, tris, first, faces, count);
}

} // namespace furrow::kernel

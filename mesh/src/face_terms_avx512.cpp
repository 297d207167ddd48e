// The 8-lane face terms (face_terms_lanes.h), compiled for AVX-512F (mesh/CMakeLists.txt); called only where
// the processor has it (face_terms.cpp checks at run time).
#include "face_terms_lanes.h"

namespace furrow::kernel {

void face_terms_8(FaceTerm* out, const double* P, const uint32_t* tris, size_t first, const uint32_t* faces, size_t count) {
    terms_of<8>(out, P, tris, first, faces, count);
}

} // namespace furrow::kernel

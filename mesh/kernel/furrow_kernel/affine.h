// furrow's private geometry kernel: what every module needs of 4×4 matrices, in one place. Not installed and
// not part of any public header (every furrow target includes mesh/kernel privately; see furrow_add_library).
// Matrices are double, column-major, as glTF stores them (element (row r, column c) at [4c + r]).
#pragma once

#include <array>
#include <cstddef>

namespace furrow::kernel {

using Mat4 = std::array<double, 16>;

inline constexpr Mat4 kIdentity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

// a × b.
inline Mat4 multiply(const Mat4& a, const Mat4& b) {
    Mat4 r{};
    for (size_t c = 0; c < 4; ++c)
        for (size_t row = 0; row < 4; ++row) {
            double s = 0;
            for (size_t k = 0; k < 4; ++k) s += a[k * 4 + row] * b[c * 4 + k];
            r[c * 4 + row] = s;
        }
    return r;
}

// Determinant of the linear (upper-left 3×3) part: < 0 for a mirroring transform.
inline double det3(const Mat4& m) {
    return m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) + m[8] * (m[1] * m[6] - m[5] * m[2]);
}

// m × (p, 1), p three doubles.
inline std::array<double, 3> transform_point(const Mat4& m, const double* p) {
    return {m[0] * p[0] + m[4] * p[1] + m[8] * p[2] + m[12], m[1] * p[0] + m[5] * p[1] + m[9] * p[2] + m[13],
            m[2] * p[0] + m[6] * p[1] + m[10] * p[2] + m[14]};
}
inline std::array<double, 3> transform_point(const Mat4& m, const std::array<double, 3>& p) { return transform_point(m, p.data()); }

// m × (v, 0): a direction or a difference of points, v three doubles.
inline std::array<double, 3> transform_vector(const Mat4& m, const double* v) {
    return {m[0] * v[0] + m[4] * v[1] + m[8] * v[2], m[1] * v[0] + m[5] * v[1] + m[9] * v[2],
            m[2] * v[0] + m[6] * v[1] + m[10] * v[2]};
}

} // namespace furrow::kernel

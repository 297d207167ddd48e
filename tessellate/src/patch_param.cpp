// The parametric layout of a face as OpenSubdiv's Bfr::Parameterization defines it, seen as a linear patch.
//
// Reference: OpenSubdiv 3.5, bfr/parameterization.h. Quads are the unit square, Loop triangles the unit
// triangle; any other face is split into quadrilateral sub-faces, one per corner, laid out as separate tiles:
// the sub-face of corner i spans [0, 1/2]^2 of its tile (unnormalised), with its u axis along edge i (the
// edge midpoint at u = 1/2) and its v axis along edge i-1 (reversed). Neighbouring tiles therefore meet along
// u = 1/2 of tile i and v = 1/2 of tile i+1, and tile i+1's (s, t) continues tile i's chart at (1 - t, s):
// a rotation by a quarter turn, which lets a triangle that straddles two sub-faces (Bfr's tessellations do,
// near the face centre) be interpolated in one chart.
//
// The linear patch is what fallback faces and skin weights use: barycentric on triangles, bilinear on quads,
// bilinear per sub-face otherwise with edge midpoints and the face centre as averages of the corners.
// The polygon normal is Newell's (M. E. Newell; see F. S. Hill, "Computer Graphics", 1990): robust for
// non-planar and non-convex polygons.
#include "tessellate_internal.h"

#include <algorithm>

namespace furrow::tessellate_detail {

using osd::Bfr::Parameterization;

void linear_weights(const Parameterization& p, const float uv[2], float* w) {
    const int n = p.GetFaceSize();
    const float u = uv[0], v = uv[1];
    switch (p.GetType()) {
    case Parameterization::TRI:
        w[0] = 1.0f - u - v;
        w[1] = u;
        w[2] = v;
        return;
    case Parameterization::QUAD:
        w[0] = (1 - u) * (1 - v);
        w[1] = u * (1 - v);
        w[2] = u * v;
        w[3] = (1 - u) * v;
        return;
    case Parameterization::QUAD_SUBFACES: {
        for (int i = 0; i < n; ++i) w[i] = 0.0f;
        float st[2];
        const int i = p.ConvertCoordToNormalizedSubFace(uv, st);
        const float s = std::clamp(st[0], 0.0f, 1.0f), t = std::clamp(st[1], 0.0f, 1.0f);
        const int next = (i + 1) % n, prev = (i + n - 1) % n;
        w[i] += (1 - s) * (1 - t);
        w[i] += 0.5f * s * (1 - t);
        w[next] += 0.5f * s * (1 - t);
        w[i] += 0.5f * (1 - s) * t;
        w[prev] += 0.5f * (1 - s) * t;
        for (int k = 0; k < n; ++k) w[k] += s * t / float(n);
        return;
    }
    }
}

std::array<double, 3> newell_normal(const float* const* c, size_t n) {
    std::array<double, 3> r{0, 0, 0};
    for (size_t i = 0; i < n; ++i) {
        const float* a = c[i];
        const float* b = c[(i + 1) % n];
        r[0] += (double(a[1]) - b[1]) * (double(a[2]) + b[2]);
        r[1] += (double(a[2]) - b[2]) * (double(a[0]) + b[0]);
        r[2] += (double(a[0]) - b[0]) * (double(a[1]) + b[1]);
    }
    return r;
}

bool common_chart(const Parameterization& p, const float in[6], float chart[6], int& tile) {
    if (!p.HasSubFaces()) {
        std::copy(in, in + 6, chart);
        tile = 0;
        return true;
    }
    const int n = p.GetFaceSize();
    int sub[3];
    float local[6];
    bool centre[3];
    tile = -1;
    for (int k = 0; k < 3; ++k) {
        sub[k] = p.ConvertCoordToSubFace(in + 2 * k, local + 2 * k);
        centre[k] = std::abs(local[2 * k] - 0.5f) < 1e-5f && std::abs(local[2 * k + 1] - 0.5f) < 1e-5f;
        if (!centre[k] && tile < 0) tile = sub[k];
    }
    if (tile < 0) return false;
    for (int k = 0; k < 3; ++k) {
        const float s = local[2 * k], t = local[2 * k + 1];
        float* out = chart + 2 * k;
        if (centre[k]) {
            out[0] = out[1] = 0.5f;
        } else if (sub[k] == tile) {
            out[0] = s;
            out[1] = t;
        } else if (sub[k] == (tile + 1) % n) {
            out[0] = 1.0f - t;
            out[1] = s;
        } else if (sub[k] == (tile + n - 1) % n) {
            out[0] = t;
            out[1] = 1.0f - s;
        } else {
            return false;
        }
    }
    return true;
}

void chart_to_coord(const Parameterization& p, int tile, const float chart[2], float uv[2]) {
    if (!p.HasSubFaces()) {
        uv[0] = chart[0];
        uv[1] = chart[1];
        return;
    }
    const int n = p.GetFaceSize();
    const float x = chart[0], y = chart[1];
    float local[2];
    int sub = tile;
    if (x <= 0.5f && y <= 0.5f) {
        local[0] = x;
        local[1] = y;
    } else if (x > 0.5f && y <= 0.5f) {
        sub = (tile + 1) % n;
        local[0] = y;
        local[1] = 1.0f - x;
    } else if (y > 0.5f && x <= 0.5f) {
        sub = (tile + n - 1) % n;
        local[0] = 1.0f - y;
        local[1] = x;
    } else {
        local[0] = local[1] = 0.5f;
    }
    p.ConvertSubFaceToCoord(sub, local, uv);
}

} // namespace furrow::tessellate_detail

// Blending glTF skins (4 joints + 4 weights per vertex) at tessellation points.
//
// A skin is a sparse vector over joints, so it is blended as one: the linear weights of the face corners
// (see patch_param.cpp) scale each corner's weights, equal joints add up, and the 4 largest are kept and
// renormalised to sum 1 — glTF allows 4 influences per set and requires normalised weights (glTF 2.0,
// "Skinned Mesh Attributes"). Ties are broken by joint index so the result does not depend on input order.
#include "tessellate_internal.h"

#include <algorithm>
#include <numeric>

namespace furrow::tessellate_detail {

void SkinAccumulator::add(const uint16_t* joints, const float* weights, float w) {
    for (int j = 0; j < 4; ++j) {
        const float x = weights[j] * w;
        if (!(x > 0.0f)) continue;
        int k = 0;
        while (k < n && joint[size_t(k)] != joints[j]) ++k;
        if (k == n) {
            if (n == int(joint.size())) continue; // 4 corners x 4 joints of an n-gon can overflow; drop the rest
            joint[size_t(n)] = joints[j];
            weight[size_t(n)] = 0.0f;
            ++n;
        }
        weight[size_t(k)] += x;
    }
}

void SkinAccumulator::finish(uint16_t* joints_out, float* weights_out) const {
    std::array<int, 16> order;
    std::iota(order.begin(), order.begin() + n, 0);
    std::sort(order.begin(), order.begin() + n, [&](int a, int b) {
        return weight[size_t(a)] != weight[size_t(b)] ? weight[size_t(a)] > weight[size_t(b)]
                                                      : joint[size_t(a)] < joint[size_t(b)];
    });
    const int keep = std::min(n, 4);
    float sum = 0.0f;
    for (int i = 0; i < keep; ++i) sum += weight[size_t(order[size_t(i)])];
    for (int i = 0; i < 4; ++i) {
        if (i < keep && sum > 0.0f) {
            joints_out[i] = joint[size_t(order[size_t(i)])];
            weights_out[i] = weight[size_t(order[size_t(i)])] / sum;
        } else {
            joints_out[i] = 0;
            weights_out[i] = 0.0f;
        }
    }
    if (keep == 0 || !(sum > 0.0f)) weights_out[0] = 1.0f; // no influence at all: bind to joint 0
}

} // namespace furrow::tessellate_detail

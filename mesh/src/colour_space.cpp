// The sRGB transfer functions (IEC 61966-2-1): glTF stores base colours and colour textures sRGB-encoded,
// and every filter, blend or light computation in furrow happens on linear values.
#include <furrow/mesh.h>

#include <algorithm>
#include <cmath>

namespace furrow {

float srgb_to_linear(float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float linear_to_srgb(float v) {
    if (!(v < 1.0f)) return v >= 1.0f ? 1.0f : 0.0f; // exact white (the formula gives 1 ± 1 ulp); NaN -> 0
    v = std::max(v, 0.0f);
    return v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

} // namespace furrow

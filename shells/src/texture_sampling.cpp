// Bilinear texture sampling with the glTF sampler wrap modes (glTF 2.0 specification, section 3.8.4 and
// the OpenGL ES 3.0 specification, section 3.8.10, for texel-centre conventions), used to read fur masks,
// comb maps and base-colour textures at vertex UVs.
#include "shells_internal.h"

#include <algorithm>
#include <cmath>

namespace furrow::shells_detail {
namespace {

int wrap_index(long long i, int n, int mode) {
    if (mode == 33071) return int(std::clamp<long long>(i, 0, n - 1)); // CLAMP_TO_EDGE
    if (mode == 33648) {                                               // MIRRORED_REPEAT
        long long period = 2LL * n;
        long long m = ((i % period) + period) % period;
        return int(m < n ? m : period - 1 - m);
    }
    return int(((i % n) + n) % n); // REPEAT
}

} // namespace

float sample_bilinear(const ImageF& image, int channel, float u, float v, int wrap_s, int wrap_t) {
    if (image.width <= 0 || image.height <= 0 || channel < 0 || channel >= image.channels) return 0.0f;
    if (!std::isfinite(u) || !std::isfinite(v)) return 0.0f;
    // In double: a UV of 6.0 (BoxTextured) times 4096 texels must still land on the right texel.
    const double x = double(u) * image.width - 0.5, y = double(v) * image.height - 0.5;
    const double fx = std::floor(x), fy = std::floor(y);
    const double ax = x - fx, ay = y - fy;
    const int x0 = wrap_index((long long)fx, image.width, wrap_s), x1 = wrap_index((long long)fx + 1, image.width, wrap_s);
    const int y0 = wrap_index((long long)fy, image.height, wrap_t), y1 = wrap_index((long long)fy + 1, image.height, wrap_t);
    auto at = [&](int xi, int yi) {
        return double(image.pixels[(size_t(yi) * size_t(image.width) + size_t(xi)) * size_t(image.channels) + size_t(channel)]);
    };
    const double top = at(x0, y0) * (1 - ax) + at(x1, y0) * ax;
    const double bottom = at(x0, y1) * (1 - ax) + at(x1, y1) * ax;
    return float(top * (1 - ay) + bottom * ay);
}

} // namespace furrow::shells_detail

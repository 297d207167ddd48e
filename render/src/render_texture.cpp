// Textures of the verification rasterizer, sampled the way a real-time viewer's GPU samples them, so that
// `furrow render` predicts what three.js, Babylon.js or a game engine draws (alpha-tested fur above all,
// whose coverage depends on the mip level).
//
// References:
//   glTF 2.0 specification §3.8.4 (samplers: magFilter, minFilter, wrapS/wrapT as in OpenGL; texel centres at
//     +0.5; an unset filter is the viewer's choice — here three.js's: LINEAR magnification,
//     LINEAR_MIPMAP_LINEAR minification, which is also what most engines default to).
//   OpenGL ES 3.0 specification §3.8.10–3.8.11: the level of detail λ = log2 ρ with
//     ρ = max(|∂(u·w, v·h)/∂x|, |∂(u·w, v·h)/∂y|) per screen pixel, magnification when λ <= c (c = 0.5 for
//     LINEAR magnification with a NEAREST_MIPMAP_* minification, else 0), the nearest level
//     d = ceil(λ + 1/2) − 1 for *_MIPMAP_NEAREST, and the blend of levels ⌊λ⌋ and ⌊λ⌋ + 1 by the fraction of λ
//     for *_MIPMAP_LINEAR; level k has max(1, ⌊w / 2^k⌋) × max(1, ⌊h / 2^k⌋) texels.
//   glGenerateMipmap (what three.js calls for a mip-mapped sampler): each level a box filter of the one above,
//     computed in linear space for sRGB textures and stored in 8 bits per channel (sRGB-encoded colour,
//     linear alpha). The chain is built the same way here, including that quantization, because an alpha
//     test at cutoff c is decided by which side of c the stored 8-bit alpha falls.
//
// Derivatives: a GPU takes finite differences over 2×2 pixel quads; here they are exact, from the
// perspective-correct interpolation (render_raster.cpp), at the output-pixel scale even when supersampling,
// as MSAA does (one shading rate per pixel). The two agree to first order; the small difference is one
// reason the viewer stage compares with a tolerance.
#include "render_internal.h"

#include <algorithm>
#include <cmath>

namespace furrow::render_detail {
namespace {

constexpr int kNearest = 9728, kLinear = 9729;
constexpr int kNearestMipmapNearest = 9984, kLinearMipmapNearest = 9985, kNearestMipmapLinear = 9986,
              kLinearMipmapLinear = 9987;
constexpr int kRepeat = 10497, kClampToEdge = 33071, kMirroredRepeat = 33648;

float quantize_srgb(float linear) { return srgb_to_linear(std::round(linear_to_srgb(linear) * 255.0f) / 255.0f); }
float quantize_linear(float v) { return std::round(std::clamp(v, 0.0f, 1.0f) * 255.0f) / 255.0f; }

// The next level of a glGenerateMipmap chain: each texel the mean of the texels it covers in the level above
// (2×2, or 1×2 / 2×1 / 3-wide where a dimension is 1 or odd), rounded to the 8-bit storage.
MipLevel next_level(const MipLevel& a) {
    MipLevel b;
    b.width = std::max(1, a.width / 2);
    b.height = std::max(1, a.height / 2);
    b.rgba.resize(size_t(b.width) * size_t(b.height) * 4);
    for (int y = 0; y < b.height; ++y) {
        const int y0 = y * a.height / b.height, y1 = std::max(y0 + 1, (y + 1) * a.height / b.height);
        for (int x = 0; x < b.width; ++x) {
            const int x0 = x * a.width / b.width, x1 = std::max(x0 + 1, (x + 1) * a.width / b.width);
            float sum[4] = {0, 0, 0, 0};
            for (int sy = y0; sy < y1; ++sy)
                for (int sx = x0; sx < x1; ++sx)
                    for (int c = 0; c < 4; ++c) sum[c] += a.rgba[4 * (size_t(sy) * size_t(a.width) + size_t(sx)) + size_t(c)];
            const float n = 1.0f / float((y1 - y0) * (x1 - x0));
            float* d = &b.rgba[4 * (size_t(y) * size_t(b.width) + size_t(x))];
            for (int c = 0; c < 3; ++c) d[c] = quantize_srgb(sum[c] * n);
            d[3] = quantize_linear(sum[3] * n);
        }
    }
    return b;
}

// The two texels a coordinate falls between along one axis (the same one twice for nearest), and the weight
// of the second, with the sampler's wrap mode applied.
struct Axis {
    int i0, i1;
    float f;
};
Axis axis(float coord, int n, int mode, bool nearest) {
    double c = coord;
    // Reduce to one period first so the texel indices below stay within one period of the range.
    if (mode == kRepeat) c -= std::abs(c) < 1e9 ? double(fast_floor(c)) : std::floor(c);
    else if (mode == kMirroredRepeat) c -= 2 * (std::abs(c) < 1e9 ? double(fast_floor(c / 2)) : std::floor(c / 2));
    else c = std::clamp(c, -1.0, 2.0); // kClampToEdge: anything beyond one period out reads the edge
    double x = c * n - (nearest ? 0.0 : 0.5);
    int64_t k = fast_floor(x);
    auto fix = [&](int64_t i) {
        if (mode == kRepeat) return int(i < 0 ? i + n : i >= n ? i - n : i);
        if (mode == kMirroredRepeat) {
            i = i < 0 ? -1 - i : i >= 2 * n ? i - 2 * n : i; // [-1, 2n] -> [0, 2n)
            return int(i < n ? i : 2 * n - 1 - i);
        }
        return int(std::clamp<int64_t>(i, 0, n - 1));
    };
    if (nearest) return {fix(k), fix(k), 0.0f};
    return {fix(k), fix(k + 1), float(x - double(k))};
}

// One level, bilinear or nearest, at (u, v) with v = 0 on the top row (glTF).
std::array<float, 4> sample_level(const MipLevel& l, float u, float v, int wrap_s, int wrap_t, bool nearest) {
    Axis ax = axis(u, l.width, wrap_s, nearest), ay = axis(v, l.height, wrap_t, nearest);
    auto texel = [&](int x, int y) { return &l.rgba[4 * (size_t(y) * size_t(l.width) + size_t(x))]; };
    const float *a = texel(ax.i0, ay.i0), *b = texel(ax.i1, ay.i0), *c = texel(ax.i0, ay.i1), *d = texel(ax.i1, ay.i1);
    std::array<float, 4> r;
    for (size_t k = 0; k < 4; ++k) {
        float top = a[k] + ax.f * (b[k] - a[k]), bottom = c[k] + ax.f * (d[k] - c[k]);
        r[k] = top + ay.f * (bottom - top);
    }
    return r;
}

} // namespace

void set_sampler(DecodedTexture& t, int mag_filter, int min_filter, int wrap_s, int wrap_t, bool mipmaps,
                 std::vector<std::string>& warnings, const std::string& name) {
    if (mag_filter != -1 && mag_filter != kNearest && mag_filter != kLinear)
        warnings.push_back(name + ": unknown magFilter " + std::to_string(mag_filter) + "; using LINEAR");
    if (min_filter != -1 && (min_filter < kNearestMipmapNearest || min_filter > kLinearMipmapLinear) &&
        min_filter != kNearest && min_filter != kLinear)
        warnings.push_back(name + ": unknown minFilter " + std::to_string(min_filter) + "; using LINEAR_MIPMAP_LINEAR");
    t.mag_nearest = mag_filter == kNearest;
    switch (min_filter) {
    case kNearest: t.min_nearest = true, t.mip = MipMode::none; break;
    case kLinear: t.min_nearest = false, t.mip = MipMode::none; break;
    case kNearestMipmapNearest: t.min_nearest = true, t.mip = MipMode::nearest; break;
    case kLinearMipmapNearest: t.min_nearest = false, t.mip = MipMode::nearest; break;
    case kNearestMipmapLinear: t.min_nearest = true, t.mip = MipMode::linear; break;
    default: t.min_nearest = false, t.mip = MipMode::linear; break; // LINEAR_MIPMAP_LINEAR, unset, unknown
    }
    // GL's c: with LINEAR magnification and NEAREST_MIPMAP_* minification, λ in (0, 0.5] still magnifies.
    t.mag_threshold = !t.mag_nearest && t.min_nearest && t.mip != MipMode::none ? 0.5f : 0.0f;
    if (!mipmaps) t.mip = MipMode::none;
    t.wrap_s = wrap_s, t.wrap_t = wrap_t;
    for (int wrap : {t.wrap_s, t.wrap_t})
        if (wrap != kRepeat && wrap != kClampToEdge && wrap != kMirroredRepeat) {
            warnings.push_back(name + ": unknown wrap mode " + std::to_string(wrap) + "; using REPEAT");
            t.wrap_s = t.wrap_t = kRepeat;
            break;
        }
    while (t.mip != MipMode::none && (t.levels.back().width > 1 || t.levels.back().height > 1))
        t.levels.push_back(next_level(t.levels.back()));
}

std::array<float, 4> sample_texture(const DecodedTexture& t, float u, float v, float lod) {
    if (!std::isfinite(u) || !std::isfinite(v)) u = v = 0;
    if (!(lod > t.mag_threshold)) // magnification (NaN: no derivative known, the base level)
        return sample_level(t.levels[0], u, v, t.wrap_s, t.wrap_t, t.mag_nearest);
    const int last = int(t.levels.size()) - 1;
    switch (t.mip) {
    case MipMode::none: return sample_level(t.levels[0], u, v, t.wrap_s, t.wrap_t, t.min_nearest);
    case MipMode::nearest: {
        const int d = lod <= 0.5f ? 0 : std::min(last, int(std::ceil(std::min(lod, 64.0f) + 0.5f)) - 1);
        return sample_level(t.levels[size_t(d)], u, v, t.wrap_s, t.wrap_t, t.min_nearest);
    }
    default: {
        const float l = std::min(lod, float(last));
        const int d0 = int(l), d1 = std::min(last, d0 + 1);
        const float f = l - float(d0);
        auto a = sample_level(t.levels[size_t(d0)], u, v, t.wrap_s, t.wrap_t, t.min_nearest);
        if (f == 0 || d1 == d0) return a;
        auto b = sample_level(t.levels[size_t(d1)], u, v, t.wrap_s, t.wrap_t, t.min_nearest);
        for (size_t k = 0; k < 4; ++k) a[k] += f * (b[k] - a[k]);
        return a;
    }
    }
}

} // namespace furrow::render_detail

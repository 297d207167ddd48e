// KHR_mesh_quantization for the writer: positions, normals, tangents, texture coordinates and colours as
// integers, the way gltfpack stores them, so that a viewer uploads them as they are.
//   Positions: one grid per mesh (all its primitives share the node transform that dequantizes them). The
//   grid's origin is the bounding-box minimum computed in double and its step the largest extent divided by
//   2^bits − 1 (gltfpack's -vp N rule). Because the origin goes into a node translation (double in the
//   JSON), a mesh 5e6 m from the origin is stored relative to its own corner: recentring comes first, and
//   the error is at most half a step per axis whatever the distance. Skinned meshes (their node transform is
//   ignored, glTF 2.0 §3.7.3) and meshes with morph targets (their deltas would need the same grid) keep
//   float positions.
//   Unit vectors: normalized int8 (the validator accepts a length within its tolerance for 8-bit vectors);
//   for --compress, the decoded 8-bit octahedral code of the float vector (what the OCTAHEDRAL filter keeps).
//   Texture coordinates: normalized uint16 when every value lies in [0, 1]. Colours (clamped to [0, 1] by the
//   writer): normalized uint8, as gltfpack's default -vc 8.
// Every value is rounded to the nearest integer, so the output is the same bytes at any thread count.
#include "encoding.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <cmath>
#include <limits>

namespace furrow::mesh_detail {

PositionGrid position_grid(const Mesh& mesh, int bits) {
    PositionGrid g;
    std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (const Primitive& p : mesh.primitives) {
        if (!p.targets.empty() || !p.joints.empty()) return g;
        for (size_t i = 0; i + 2 < p.positions.size(); i += 3)
            for (size_t k = 0; k < 3; ++k) {
                const double x = p.positions[i + k];
                if (!std::isfinite(x)) return g; // the writer refuses it
                lo[k] = std::min(lo[k], x);
                hi[k] = std::max(hi[k], x);
            }
    }
    if (!(lo[0] <= hi[0])) return g; // no vertices
    const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    g.quantized = true;
    g.offset = lo;
    // A flat point cloud of one position still needs a non-zero scale (validator: NODE_SCALE_ZERO... and a
    // singular transform); 1 keeps every q at 0.
    // The step a reader uses is a float (the node's scale): the grid uses that float's shortest decimal, so
    // the file carries 9 digits instead of 17 and positions are quantized on the very grid read back.
    // (A step no float holds, below FLT_TRUE_MIN, stays the double.)
    const double step = extent / double((1u << bits) - 1u), short_step = decimal(float(step));
    g.scale = extent > 0 ? (short_step > 0 && std::isfinite(short_step) ? short_step : step) : 1.0;
    return g;
}

double decimal(float f) {
    if (!std::isfinite(f)) return double(f);
    char text[32];
    const auto end = std::to_chars(text, text + sizeof text, f).ptr;
    double d = double(f);
    std::from_chars(text, end, d);
    return d;
}

std::vector<uint16_t> quantize_positions(const std::vector<float>& positions, const PositionGrid& grid) {
    const size_t n = positions.size() / 3;
    std::vector<uint16_t> out(n * 4, 0);
    for (size_t i = 0; i < n; ++i)
        for (size_t k = 0; k < 3; ++k) {
            const double q = std::round((double(positions[i * 3 + k]) - grid.offset[k]) / grid.scale);
            out[i * 4 + k] = uint16_t(std::clamp(q, 0.0, 65535.0));
        }
    return out;
}

std::vector<int8_t> quantize_unit_vectors(const std::vector<float>& v, size_t stride, bool octahedral) {
    const size_t n = v.size() / stride;
    std::vector<int8_t> out(n * 4, 0);
    std::vector<float> xyzw(octahedral ? n * 4 : 0, 0.0f);
    for (size_t i = 0; i < n; ++i) {
        for (size_t k = 0; k < 3; ++k) {
            const double x = std::isfinite(v[i * stride + k]) ? double(v[i * stride + k]) : 0.0;
            out[i * 4 + k] = int8_t(std::clamp(std::round(x * 127.0), -127.0, 127.0));
            if (octahedral) xyzw[i * 4 + k] = float(x);
        }
    }
    if (octahedral) {
        // Rounded on the octahedral grid first, instead of int8 x, y, z rounded again by the filter: the demo
        // fur's largest normal error falls from 1.20 to 1.14 degrees (bench io; gltfpack -cc: 0.98). The
        // filter (meshopt_codec.cpp octahedral()) then writes the code each of these was decoded from.
        std::vector<uint8_t> code(n * 4);
        meshopt_encodeFilterOct(code.data(), n, 4, 8, xyzw.data());
        meshopt_decodeFilterOct(code.data(), n, 4);
        std::memcpy(out.data(), code.data(), code.size());
    }
    for (size_t i = 0; i < n; ++i) out[i * 4 + 3] = stride == 4 ? (v[i * 4 + 3] < 0 ? int8_t(-127) : int8_t(127)) : int8_t(0);
    return out;
}

// Values in [0, 1] as unsigned normalized integers (round to nearest); false if any value is outside.
template <class T>
bool quantize_unorm(std::vector<T>& out, const std::vector<float>& v) {
    constexpr double top = double(std::numeric_limits<T>::max());
    out.resize(v.size());
    for (size_t i = 0; i < v.size(); ++i) {
        if (!(v[i] >= 0.0f && v[i] <= 1.0f)) return false;
        out[i] = T(std::lround(double(v[i]) * top));
    }
    return true;
}

bool quantize_unorm16(std::vector<uint16_t>& out, const std::vector<float>& v) { return quantize_unorm(out, v); }
bool quantize_unorm8(std::vector<uint8_t>& out, const std::vector<float>& v) { return quantize_unorm(out, v); }

} // namespace furrow::mesh_detail

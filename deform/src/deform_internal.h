// Internals of furrow::deform shared between its .cpp files (one algorithm per file).
#pragma once

#include <furrow/deform.h>
#include <furrow_kernel/vec3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace furrow::deform_detail {

// Vectors are the kernel's (furrow_kernel/vec3.h); d3/arr convert from and to the public std::array.
using kernel::Vec3;
using kernel::cross;
using kernel::dot;
using kernel::norm;
inline Vec3 d3(const std::array<double, 3>& a) { return kernel::vec3_of(a); }
inline std::array<double, 3> arr(const Vec3& a) { return kernel::array_of(a); }

constexpr double kInf = std::numeric_limits<double>::infinity();

// HeightmapFrame::to_texel's (i, j) texel coordinates of world point p, inline for the per-point loop of
// DisplacedGround::prepare (an out-of-line call per point was 2.3 ms at 394k points); `inverse` is
// 1 / frame.texel (0 for an empty frame). The same operations, so the same bits, as to_texel.
inline std::array<double, 2> texel_of(const HeightmapFrame& frame, double inverse, const double* p) {
    const Vec3 d = Vec3{p[0], p[1], p[2]} - d3(frame.origin);
    return {dot(d, d3(frame.axis_u)) * inverse, dot(d, d3(frame.axis_v)) * inverse};
}

// double -> int with the value clamped to [lo, hi] first (NaN gives lo). Converting a double outside int's
// range is undefined behaviour, and collider sizes and positions may be anything up to 1e308: texel ranges
// and step counts derived from them go through here (found by fuzz_colliders).
inline int clamped_int(double x, int lo, int hi) { return x >= double(lo) ? (x <= double(hi) ? int(x) : hi) : lo; }
constexpr double kPi = std::numbers::pi;

// A texel coordinate split into its cell and the fraction within it: t = cell + frac exactly (frac = t −
// floor(t) is exact below 2^52). Inline, for the per-point loops (DisplacedGround) and Heightmap::sample.
// Cells are clamped to [−2, 2^31 − 2] first (any finite t: a double outside int's range is undefined
// behaviour); frac is then 0, and sample_split gives what it gives on the unclamped t on any grid narrower
// than 2^31 − 2 texels.
struct SplitTexel {
    int i = 0, j = 0;
    double fi = 0, fj = 0;
};
inline SplitTexel split_texel(double ti, double tj) {
    constexpr double lo = -2.0, hi = 2147483646.0;
    auto one = [&](double t, int& cell, double& frac) {
        if (!(t >= lo && t < hi)) {
            cell = t >= lo ? int(hi) : int(lo), frac = 0;
            return;
        }
        cell = int(t); // toward zero, then down: floor without a libm call (baseline x86-64 has no roundsd)
        cell -= double(cell) > t;
        frac = t - double(cell);
    };
    SplitTexel s;
    one(ti, s.i, s.fi);
    one(tj, s.j, s.fj);
    return s;
}
// Bilinear height at a split coordinate, 0 beyond the grid (one texel of ramp to 0 at the border, as
// Heightmap::sample documents): Heightmap::sample's arithmetic, in one place.
inline double sample_split(const Heightmap& h, const SplitTexel& s) {
    const int w = h.frame.width, hh = h.frame.height;
    if (w <= 0 || hh <= 0 || h.values.size() != size_t(w) * size_t(hh)) return 0.0;
    // t > −1 and t < size, on cell + frac.
    if (!(s.i > -1 || (s.i == -1 && s.fi > 0)) || !(s.j > -1 || (s.j == -1 && s.fj > 0)) || s.i >= w || s.j >= hh) return 0.0;
    auto v = [&](int i, int j) -> double {
        if (i < 0 || j < 0 || i >= w || j >= hh) return 0.0;
        return double(h.values[size_t(j) * size_t(w) + size_t(i)]);
    };
    const double fi = s.fi, fj = s.fj;
    return (v(s.i, s.j) * (1 - fi) + v(s.i + 1, s.j) * fi) * (1 - fj) + (v(s.i, s.j + 1) * (1 - fi) + v(s.i + 1, s.j + 1) * fi) * fj;
}

// The in-plane axes for an up vector: +x/+z for +y up, a stable choice otherwise (axis_v = axis_u × up).
void frame_axes(const std::array<double, 3>& up, std::array<double, 3>& axis_u, std::array<double, 3>& axis_v,
                std::array<double, 3>& unit_up);

// ---- ground_raster.cpp -----------------------------------------------------------------------------------
// Highest ground height along up at every texel centre (NaN where no triangle lies over it): what a ray cast
// down from above sees, by scan conversion instead of one ray per texel. Returns the number of triangles
// facing away from up (overhangs or undersides).
size_t rasterize_ground(float* heights, const HeightmapFrame& frame, const float* positions, size_t vertex_count,
                        const uint32_t* indices, size_t index_count);

// ---- ground_raycast.cpp (the only CGAL file) --------------------------------------------------------------
class GroundRaycaster {
public:
    GroundRaycaster();
    ~GroundRaycaster();
    void build(const float* positions, size_t vertex_count, const uint32_t* indices, size_t index_count);
    // First hit of the ray origin + t·direction (t > 0); NaN when none. Returns the ray parameter t.
    double first_hit(const Vec3& origin, const Vec3& direction) const;
    bool built() const;

private:
    struct Tree;
    std::unique_ptr<Tree> tree_;
};

// ---- collider_stamp.cpp -----------------------------------------------------------------------------------
// Where a stamp is written: the carve layer (min-composited, values <= 0 meaning pressed down), the
// undeformed ground height per texel, and the limits.
struct StampTarget {
    float* carve = nullptr;
    const float* ground = nullptr;
    int width = 0, height = 0;
    double texel = 0;
    double snow_depth = 0; // 0 = unlimited
    bool whole_boxes = false; // tests: rasterise each image stamp's whole bounding box, not its rows' spans
};

// A pose in the heightmap's frame: u, v in metres from the origin along axis_u / axis_v, w along up.
struct LocalPose {
    double u = 0, v = 0, w = 0;
    double heading = 0;     // radians
    double penetration = 0; // image shapes: depth pressed at pixel value 1 (>= 0)
};

struct StampResult {
    TexelRect rect;      // texels written (deepened)
    size_t written = 0;
    double reach = 0;    // half-extent of the footprint (metres), for the rim's window
};

// Rasterises the shape swept from p0 to p1 (p0 == p1: one sample) into target.carve with min-compositing,
// scaled by `decay` (refill). Sphere sweeps are capsules, box sweeps exact for a fixed heading; turning
// shapes and images are sub-stepped finely enough (half a texel at the far corner). Thread-safe: concurrent
// calls composite with atomic min. Sub-steps are capped per path segment (10,000 sweeps, 1e6 image stamps;
// a shape that would need more is resolved more coarsely); `share` is the part of its segment this sweep is
// (refill sub-steps cut a segment into parts), and gets that part of the caps.
StampResult stamp_sweep(const StampTarget& target, const Collider& shape, const LocalPose& p0, const LocalPose& p1,
                        double decay, double share = 1.0);

// Lowest point of the collider below its centre (metres along up), as the contact test uses it.
double collider_bottom_offset(const Collider& shape);
// Highest point above its centre.
double collider_top_offset(const Collider& shape);

// ---- snow_rim.cpp -----------------------------------------------------------------------------------------
// The cosmetic rim ring's builds, narrowest first (snow_rim.cpp): every one gives the same bits.
enum class RingBuild : uint8_t { baseline, avx2, avx512, widest = avx512 };

struct RimInput {
    const float* carve = nullptr;  // current carve layer
    const float* base = nullptr;   // base layer or null (= 0)
    const float* ground = nullptr; // NaN = no ground: never receives a rim
    int width = 0, height = 0;
    double texel = 0;
    double width_m = 0;            // rim reach (metres)
    double gather_m = 0;           // half-width of the largest imprint (metres): how far a rim point looks
    double height_ratio = 0.5;     // cosmetic rim
    bool conserve = false;
    double compaction = 0.3;
    double max_height = 1.0;        // conserve: rim height <= this × the nearby print depth (0 = no limit)
    double max_slope_degrees = 40;  // conserve: steepest rim slope (0 or >= 90 = no limit)
    double max_width_m = 0;         // conserve: how far the rim may widen to keep those limits (>= width_m)
    bool parallel = true;           // false: one thread per window (the caller runs windows in parallel)
    bool full_window = false;       // cosmetic: every step over the whole window (the reference the ring-only
                                    // evaluation must equal byte for byte; tests), not only around `out`
    RingBuild ring_build = RingBuild::widest; // cosmetic: which build of the ring runs (tests ask for narrower ones)
};
// The texels a rim computation owns: the tiles of one connected dirty region. It counts only the imprints
// inside them and writes only them.
struct RimOwner {
    const uint8_t* tiles = nullptr; // per tile, 1 = owned
    int tiles_x = 0, tile = 16;
    TexelRect* changed_box = nullptr; // optional, per tile: grown to hold every texel whose written value differs (in bits)
    size_t tile_of(int i, int j) const { return size_t(j / tile) * size_t(tiles_x) + size_t(i / tile); }
    bool owns(int i, int j) const { return tiles[tile_of(i, j)] != 0; }
};
// Recomputes the rim on the owned texels of `out` (within `window`) from the imprints in the window; with
// conserve, only the imprints on owned texels count and the raised volume written equals their removed volume
// × (1 − compaction). rim is the full-grid layer. Returns the volume (m³) that could not be placed (no
// receiver near any imprint). The sums are exact and in a fixed order, so a cosmetic rim's texel does not
// depend on the window as long as the window holds the texel's rim_reach (below).
double compute_rim(float* rim, const RimInput& in, const TexelRect& window, const RimOwner& owner, const TexelRect& out);

// Gathering radius (texels) of a rim: an imprint's half-width (gather_m) plus the rim's width, halved (the
// sums are smoothed twice), so that a rim point sees the volume it carries. At most kRimMaxGather: a fixed
// cap (not the window's size), so that every window gathers alike; it also keeps the exact sums in range
// and i + n + 1 from overflowing for a collider of 1e30 m.
constexpr int kRimMaxGather = 64;
inline int rim_gather_radius(double width_m, double gather_m, double texel) {
    return std::max(2, clamped_int(std::ceil((width_m + gather_m) / texel / 2), 0, kRimMaxGather));
}
// How far (texels, Chebyshev) a cosmetic rim texel depends on the carve: the blur (2), and the farther of
// the gathered sums (2n) and the distance to the nearest imprint (the rim's width + half a texel).
// How far (texels, Chebyshev) from its nearest imprint a texel can be on the ridge: the width + half a texel.
inline int rim_profile_radius(double width_m, double texel) { return clamped_int(std::ceil(width_m / texel + 0.5), 0, 1 << 20); }
inline int rim_reach(double width_m, double gather_m, double texel) {
    return 2 + std::max(2 * rim_gather_radius(width_m, gather_m, texel), rim_profile_radius(width_m, texel));
}

// ---- heightmap_io.cpp -------------------------------------------------------------------------------------
// (public save_heightmap / load_heightmap)

// ---- ground_detail_rates.cpp ------------------------------------------------------------------------------
struct DetailRateOptions {
    double max_error = 0;                 // metres
    double min_spacing = 0;               // metres
    int max_rate = 64;
    std::optional<StampCamera> camera;
};
// Tessellation rate per triangle of a world-space mesh: the segments its longest edge needs so that linear
// interpolation of the heightmap over it deviates by at most max_error (from the heightmap's curvature inside
// the triangle's footprint); 1 where the heightmap is flat there.
void triangle_detail_rates(std::vector<int>& rates, const Heightmap& heightmap, const float* positions,
                           const uint32_t* indices, size_t triangle_count, const DetailRateOptions& options);

// Size of the grid for a ground extent, and the memory guard (bytes per texel of all layers).
constexpr size_t kBytesPerTexel = 28;

} // namespace furrow::deform_detail

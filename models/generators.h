// The generators of furrow's sample assets (models/*): one function per asset, all deterministic — no clock,
// no std::random distributions (their output is implementation-defined), a fixed-seed hash instead — so that
// regenerating gives the same bytes. Used by generate_models.cpp (the program that writes models/) and by
// tests/mesh/test_models.cpp (which regenerates into a temp folder and compares bytes).
#pragma once

#include <furrow/mesh.h>
#include <furrow/shapes.h>
#include <furrow_kernel/atomic_file.h>
#include <furrow_kernel/vec3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

namespace furrow::models {

// ---------------------------------------------------------------------------------------------------------
// Small deterministic helpers
// ---------------------------------------------------------------------------------------------------------

// splitmix64 (Steele, Lea & Flood 2014): a tiny, well-mixed, fully specified generator.
inline uint64_t splitmix64(uint64_t& state) {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// Gradient noise after K. Perlin, "Improving Noise" (SIGGRAPH 2002): quintic fade, 12 edge gradients; the
// permutation is a Fisher-Yates shuffle driven by splitmix64(seed) instead of Perlin's fixed table.
class PerlinNoise {
public:
    explicit PerlinNoise(uint64_t seed) {
        for (int i = 0; i < 256; ++i) perm_[i] = uint8_t(i);
        uint64_t state = seed;
        for (int i = 255; i > 0; --i) std::swap(perm_[i], perm_[splitmix64(state) % uint64_t(i + 1)]);
        for (int i = 0; i < 256; ++i) perm_[256 + i] = perm_[i];
    }

    // In about [-1, 1]; 0 on the integer lattice.
    double operator()(double x, double y, double z) const {
        double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
        int X = int(fx) & 255, Y = int(fy) & 255, Z = int(fz) & 255;
        x -= fx, y -= fy, z -= fz;
        double u = fade(x), v = fade(y), w = fade(z);
        int A = perm_[X] + Y, AA = perm_[A] + Z, AB = perm_[A + 1] + Z;
        int B = perm_[X + 1] + Y, BA = perm_[B] + Z, BB = perm_[B + 1] + Z;
        return lerp(w,
                    lerp(v, lerp(u, grad(perm_[AA], x, y, z), grad(perm_[BA], x - 1, y, z)),
                         lerp(u, grad(perm_[AB], x, y - 1, z), grad(perm_[BB], x - 1, y - 1, z))),
                    lerp(v, lerp(u, grad(perm_[AA + 1], x, y, z - 1), grad(perm_[BA + 1], x - 1, y, z - 1)),
                         lerp(u, grad(perm_[AB + 1], x, y - 1, z - 1), grad(perm_[BB + 1], x - 1, y - 1, z - 1))));
    }

    // Fractional Brownian motion: octaves of noise at lacunarity ~2 (not exactly 2, so that octave lattices
    // do not line up) and gain 1/2, normalised to about [-1, 1].
    double fbm(double x, double y, double z, int octaves) const {
        double sum = 0, amplitude = 1, norm = 0;
        for (int o = 0; o < octaves; ++o) {
            sum += amplitude * (*this)(x, y, z);
            norm += amplitude;
            amplitude *= 0.5;
            x *= 2.03, y *= 2.03, z *= 2.03;
        }
        return sum / norm;
    }

private:
    static double fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
    static double lerp(double t, double a, double b) { return a + t * (b - a); }
    static double grad(int hash, double x, double y, double z) {
        int h = hash & 15;
        double u = h < 8 ? x : y, v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
        return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
    }
    uint8_t perm_[512];
};

inline double smoothstep(double e0, double e1, double x) {
    double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3 - 2 * t);
}
inline double mix(double a, double b, double t) { return a + (b - a) * t; }

using Vec3 = kernel::Vec3; // the kernel's one vector type (GLM's dvec3)
inline Vec3 vec(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }
inline double dist(const Vec3& a, const Vec3& b) { return kernel::norm(a - b); }
inline Vec3 mix(const Vec3& a, const Vec3& b, double t) {
    return {mix(a[0], b[0], t), mix(a[1], b[1], t), mix(a[2], b[2], t)};
}

inline uint8_t to_u8(double x) { return uint8_t(std::lround(std::clamp(x, 0.0, 1.0) * 255.0)); }

// ---------------------------------------------------------------------------------------------------------
// The creature: mesh (furrow::shapes::creature), base-colour texture and fur-length mask painted in its UV
// space from the surface point of every texel, so that both are continuous across the UV seam.
// ---------------------------------------------------------------------------------------------------------
constexpr int creature_segments = 128, creature_rings = 64; // 16128 triangles
constexpr int creature_texture_width = 512, creature_texture_height = 256;

// The surface point under every texel centre, row-major, top row (v = 0) first.
inline std::vector<shapes::SurfacePoint> creature_texel_points(int width, int height) {
    std::vector<shapes::SurfacePoint> points(size_t(width) * size_t(height));
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            points[size_t(y) * size_t(width) + size_t(x)] =
                shapes::creature_surface(float((x + 0.5) / width), float((y + 0.5) / height));
    return points;
}

// Region weights of a surface point, shared by the colour and the fur-length painting.
struct CreatureRegions {
    double nose = 0, eye = 0, glint = 0; // 1 inside
    double eye_ring = 0;                 // 1 at the eye edge, fading out over 2.5 cm
    double muzzle = 0, face = 0, belly = 0, back = 0, paw = 0, ear_tip = 0, tail = 0, tail_tip = 0;
};

inline CreatureRegions creature_regions(const shapes::SurfacePoint& s) {
    const shapes::CreatureLandmarks& L = shapes::creature_landmarks();
    const Vec3 p = vec(s.position), n = vec(s.normal);
    CreatureRegions r;
    const Vec3 nose_centre{L.nose_tip[0], L.nose_tip[1], L.nose_tip[2] - L.nose_radius};
    r.nose = 1 - smoothstep(L.nose_radius + 0.002, L.nose_radius + 0.008, dist(p, nose_centre));
    for (const auto& e : {L.eye_left, L.eye_right}) {
        const Vec3 c = vec(e);
        double d = dist(p, c);
        // The eye is the visible cap of its sphere (points at ~eye_radius from the centre, a little more where
        // the smooth union fills the crease) plus a 3 mm margin.
        r.eye = std::max(r.eye, 1 - smoothstep(L.eye_radius + 0.003, L.eye_radius + 0.008, d));
        r.eye_ring = std::max(r.eye_ring, 1 - smoothstep(L.eye_radius + 0.008, L.eye_radius + 0.03, d));
        // A highlight up and toward the outside, as if lit from above-front.
        const Vec3 g{c[0] + (c[0] > 0 ? 0.012 : -0.012), c[1] + 0.016, c[2] + 0.028};
        r.glint = std::max(r.glint, 1 - smoothstep(0.007, 0.010, dist(p, g)));
    }
    const Vec3 head = vec(L.head_centre);
    const Vec3 muzzle_centre{L.nose_tip[0], L.nose_tip[1] - 0.04, L.nose_tip[2] - 0.09};
    r.muzzle = 1 - smoothstep(0.09, 0.14, dist(p, muzzle_centre));
    r.face = smoothstep(0.02, 0.14, p[2] - head[2]) * (1 - smoothstep(L.head_radius, L.head_radius + 0.06, dist(p, head)));
    r.belly = smoothstep(-0.15, -0.55, n[1]) * smoothstep(0.10, 0.16, p[1]);
    r.back = smoothstep(0.15, 0.75, n[1]) * (1 - r.face);
    for (const auto& w : L.paws) r.paw = std::max(r.paw, 1 - smoothstep(0.11, 0.17, dist(p, vec(w))));
    for (const auto& t : L.ear_tips) r.ear_tip = std::max(r.ear_tip, 1 - smoothstep(0.05, 0.10, dist(p, vec(t))));
    const Vec3 tail = vec(L.tail_centre);
    r.tail = 1 - smoothstep(0.10, 0.16, dist(p, tail));
    r.tail_tip = 1 - smoothstep(0.05, 0.08, dist(p, Vec3{tail[0], tail[1] + 0.03, tail[2] - 0.09}));
    return r;
}

// Base colour (sRGB-encoded, as glTF baseColorTexture expects): a ginger tabby with cream belly, muzzle
// and tail tip, dark socks and ear tips, a dark nose and dark eyes with a highlight.
inline std::vector<uint8_t> creature_albedo_rgba8(const std::vector<shapes::SurfacePoint>& points) {
    const PerlinNoise noise(0xF0220001);
    const Vec3 ginger{0.80, 0.45, 0.18}, stripe{0.52, 0.24, 0.08}, cream{0.96, 0.89, 0.76},
        sock{0.26, 0.16, 0.10}, nose{0.16, 0.08, 0.08}, eye{0.03, 0.025, 0.02}, glint{0.95, 0.95, 0.95};
    std::vector<uint8_t> rgba(points.size() * 4);
    for (size_t i = 0; i < points.size(); ++i) {
        const Vec3 p = vec(points[i].position);
        const CreatureRegions r = creature_regions(points[i]);
        // Tabby stripes: bands across the body (along z), wobbled by noise, on the back and flanks only.
        double wobble = noise.fbm(p[0] * 4, p[1] * 4, p[2] * 4, 3);
        double band = 0.5 + 0.5 * std::sin(2 * std::numbers::pi * (p[2] * 6.5 + 0.8 * wobble));
        Vec3 c = mix(ginger, stripe, 0.6 * smoothstep(0.55, 0.85, band) * smoothstep(0.3, 0.9, r.back + 0.4));
        c = mix(c, cream, std::max({r.belly, r.muzzle, r.tail_tip}));
        c = mix(c, sock, std::max(r.paw, r.ear_tip));
        // Fur mottling: +-12 % brightness from higher-frequency noise on the 3D position (seam-free).
        double mottle = 1 + 0.12 * noise.fbm(p[0] * 14 + 17, p[1] * 14, p[2] * 14, 4);
        c = {c[0] * mottle, c[1] * mottle, c[2] * mottle};
        c = mix(c, nose, r.nose);
        c = mix(c, eye, r.eye);
        c = mix(c, glint, r.glint * r.eye);
        for (int k = 0; k < 3; ++k) rgba[i * 4 + size_t(k)] = to_u8(c[size_t(k)]);
        rgba[i * 4 + 3] = 255;
    }
    return rgba;
}

// Fur length in [0, 1] (linear, 8-bit grey): long on the back and tail, medium on the flanks and belly,
// short on the face, paws and ear tips, zero on the nose and the eyes.
inline ImageF creature_fur_mask(const std::vector<shapes::SurfacePoint>& points, int width, int height) {
    ImageF mask;
    mask.width = width, mask.height = height, mask.channels = 1;
    mask.pixels.resize(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
        const CreatureRegions r = creature_regions(points[i]);
        double length = 0.7;
        length = mix(length, 0.55, r.belly);
        length = mix(length, 1.0, r.back);
        length = mix(length, 1.0, r.tail);
        length = mix(length, 0.3, r.face);
        length = mix(length, 0.2, r.muzzle);
        length = mix(length, 0.25, r.paw);
        length = mix(length, 0.2, r.ear_tip);
        length = mix(length, 0.1, r.eye_ring); // short lashes around the eyes
        length *= (1 - r.nose) * (1 - r.eye);
        // Quantise here, so that the 8-bit file and the in-memory mask are the same numbers.
        mask.pixels[i] = float(to_u8(length)) / 255.0f;
    }
    return mask;
}

inline Scene creature_scene(std::vector<uint8_t> albedo_png) {
    Primitive body = shapes::creature(creature_segments, creature_rings);
    body.material = 0;
    Scene scene = make_scene(std::move(body), "creature");
    scene.nodes[0].name = "creature";
    Material fur;
    fur.name = "creature_fur";
    fur.base_color_texture.texture = 0;
    fur.metallic = 0.0f;
    fur.roughness = 0.9f;
    scene.materials.push_back(fur);
    Sampler sampler;
    sampler.mag_filter = 9729; // LINEAR
    sampler.min_filter = 9987; // LINEAR_MIPMAP_LINEAR
    sampler.wrap_s = 10497;    // REPEAT: u wraps across the seam, where both sides are the same fur
    sampler.wrap_t = 33071;    // CLAMP_TO_EDGE: v ends at the poles
    scene.samplers.push_back(sampler);
    scene.textures.push_back({0, 0});
    Image image;
    image.name = "creature_albedo";
    image.mime_type = "image/png";
    image.encoded = std::move(albedo_png);
    scene.images.push_back(std::move(image));
    return scene;
}

// ---------------------------------------------------------------------------------------------------------
// Ground: a 20 m × 20 m snow patch, 64 × 64 cells, gentle hills from Perlin fBm (heights within about ±0.4 m).
// ---------------------------------------------------------------------------------------------------------
constexpr float ground_size = 20.0f;
constexpr int ground_cells = 64;

inline double ground_height(double x, double z) {
    static const PerlinNoise noise(0xF0220002);
    // Wavelength ~8 m for the hills; the third coordinate is off the lattice so that the origin is not 0.
    return 0.9 * noise.fbm(x / 8.0, z / 8.0, 0.37, 3);
}

inline Primitive ground_primitive();

// Height of the ground mesh itself (not of the noise) under (x, z): the triangle of grid cell (i, j) that
// contains the point, interpolated linearly — what a ray cast down onto ground.glb hits. Colliders are
// placed with it so that their contact with the mesh is exactly as designed.
inline double ground_surface_height(double x, double z) {
    static const Primitive g = ground_primitive();
    const int n = ground_cells;
    double fx = (x / ground_size + 0.5) * n, fz = (z / ground_size + 0.5) * n;
    int i = std::clamp(int(std::floor(fx)), 0, n - 1), j = std::clamp(int(std::floor(fz)), 0, n - 1);
    fx -= i, fz -= j;
    auto h = [&](int a, int b) { return double(g.positions[(size_t(b) * size_t(n + 1) + size_t(a)) * 3 + 1]); };
    double ha = h(i, j), hb = h(i, j + 1), hc = h(i + 1, j + 1), hd = h(i + 1, j);
    // shapes::grid splits each cell along (i, j)-(i+1, j+1): [a, b, c] holds fz >= fx, [a, c, d] the rest.
    return fz >= fx ? ha + fz * (hb - ha) + fx * (hc - hb) : ha + fx * (hd - ha) + fz * (hc - hd);
}

inline Primitive ground_primitive() {
    Primitive g = shapes::grid(ground_size, ground_size, ground_cells, ground_cells);
    for (size_t i = 0; i < g.vertex_count(); ++i) {
        double x = g.positions[i * 3], z = g.positions[i * 3 + 2];
        g.positions[i * 3 + 1] = float(ground_height(x, z));
        // Normal of the height field from central differences: n ~ (-dh/dx, 1, -dh/dz).
        const double h = 1e-3;
        double dx = (ground_height(x + h, z) - ground_height(x - h, z)) / (2 * h);
        double dz = (ground_height(x, z + h) - ground_height(x, z - h)) / (2 * h);
        double len = std::sqrt(dx * dx + 1 + dz * dz);
        g.normals[i * 3] = float(-dx / len);
        g.normals[i * 3 + 1] = float(1 / len);
        g.normals[i * 3 + 2] = float(-dz / len);
    }
    g.material = 0;
    return g;
}

inline Scene ground_scene() {
    Scene scene = make_scene(ground_primitive(), "ground");
    scene.nodes[0].name = "ground";
    Material snow;
    snow.name = "snow";
    snow.base_color = {0.90f, 0.93f, 0.97f, 1.0f}; // linear; slightly blue-white
    snow.metallic = 0.0f;
    snow.roughness = 0.85f;
    scene.materials.push_back(snow);
    return scene;
}

// ---------------------------------------------------------------------------------------------------------
// Footprint brush: a boot sole, 8-bit grey, value = imprint depth / collider depth (white = deepest).
// The image spans the collider's `size` [across, along]; the toe is at the top row (v = 0), which points
// along the collider's heading. Symmetric left/right, so it serves both feet.
// ---------------------------------------------------------------------------------------------------------
constexpr int footprint_width = 128, footprint_height = 320;
constexpr double footprint_size_x = 0.12, footprint_size_z = 0.30; // metres

inline ImageF footprint_brush() {
    ImageF img;
    img.width = footprint_width, img.height = footprint_height, img.channels = 1;
    img.pixels.resize(size_t(footprint_width) * footprint_height);
    // 2D signed distance of the sole outline (metres; x across, y from the toe end): forefoot ellipse, heel
    // ellipse and a waist between them, smoothly united.
    auto ellipse = [](double x, double y, double cx, double cy, double rx, double ry) {
        double k0 = std::hypot((x - cx) / rx, (y - cy) / ry), k1 = std::hypot((x - cx) / (rx * rx), (y - cy) / (ry * ry));
        return k1 > 0 ? k0 * (k0 - 1) / k1 : -std::min(rx, ry);
    };
    auto smin = [](double a, double b, double k) {
        double h = std::max(k - std::abs(a - b), 0.0) / k;
        return std::min(a, b) - h * h * k * 0.25;
    };
    for (int j = 0; j < footprint_height; ++j)
        for (int i = 0; i < footprint_width; ++i) {
            double x = ((i + 0.5) / footprint_width - 0.5) * footprint_size_x;
            double y = (j + 0.5) / footprint_height * footprint_size_z;
            double forefoot = ellipse(x, y, 0, 0.095, 0.053, 0.085);
            double heel = ellipse(x, y, 0, 0.240, 0.044, 0.048);
            double waist = ellipse(x, y, 0, 0.170, 0.036, 0.070);
            double d = smin(smin(forefoot, heel, 0.02), waist, 0.03);
            double inside = 1 - smoothstep(-0.003, 0.002, d); // soft 5 mm edge
            // Tread: chevron lugs across the sole (deeper) and a shallower arch between heel and ball.
            double chevron = std::fmod(y * 55.0 + std::abs(x) * 30.0, 1.0);
            double lug = smoothstep(0.35, 0.45, chevron) * (1 - smoothstep(0.75, 0.85, chevron));
            double arch = smoothstep(0.16, 0.185, y) * (1 - smoothstep(0.185, 0.21, y));
            double depth = (0.82 + 0.18 * lug) * (1 - 0.25 * arch);
            img.pixels[size_t(j) * footprint_width + size_t(i)] = float(to_u8(inside * depth)) / 255.0f;
        }
    return img;
}

// ---------------------------------------------------------------------------------------------------------
// Colliders (schema in deform/README.md): a walking trail of footprints, a rolling ball, a dropped crate and a
// dragged log, all placed on the ground mesh (ground_surface_height).
// ---------------------------------------------------------------------------------------------------------
inline std::string fmt(double v) {
    v = std::round(v * 1e4) / 1e4 + 0.0; // 4 decimals, no "-0"
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4f", v);
    std::string s = buf;
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
    return s;
}
inline std::string fmt3(double x, double y, double z) { return "[" + fmt(x) + ", " + fmt(y) + ", " + fmt(z) + "]"; }

struct Footstep {
    double x, y, z, heading_degrees;
    bool left;
};

// A walker crossing the patch on a gentle S-curve: steps every 0.7 m along the curve, feet 0.11 m to each
// side of it, alternating left/right, each print turned to the walking direction (heading: degrees about
// +y, 0 = toward +z, 90 = toward +x).
inline std::vector<Footstep> footsteps() {
    auto curve = [](double s) { return std::array<double, 2>{-7.5 + s, -2.0 + 2.2 * std::sin(s * 0.33)}; };
    std::vector<Footstep> steps;
    double s = 0;
    for (int k = 0; k < 20; ++k) {
        auto c = curve(s);
        auto a = curve(s - 0.01), b = curve(s + 0.01);
        double tx = b[0] - a[0], tz = b[1] - a[1], tl = std::hypot(tx, tz);
        tx /= tl, tz /= tl;
        bool left = k % 2 == 0;
        // Left of the walking direction (t) seen from above with y up is (tz, -tx).
        double side = left ? 0.11 : -0.11;
        double x = c[0] + tz * side, z = c[1] - tx * side;
        steps.push_back({x, ground_surface_height(x, z), z, std::atan2(tx, tz) * 180.0 / std::numbers::pi, left});
        // Advance ~0.7 m of arc length in small increments.
        for (double walked = 0; walked < 0.7;) {
            auto p = curve(s), q = curve(s + 0.01);
            walked += std::hypot(q[0] - p[0], q[1] - p[1]);
            s += 0.01;
        }
    }
    return steps;
}

inline std::string colliders_json() {
    std::string j = "{\n  \"up\": [0, 1, 0],\n  \"colliders\": [\n";
    // Footprints: one image collider per step (a one-point path: the print does not slide).
    for (const Footstep& f : footsteps()) {
        j += "    {\"shape\": \"image\", \"image\": \"footprint.png\", \"size\": [" + fmt(footprint_size_x) + ", " + fmt(footprint_size_z) +
             "], \"depth\": 0.06, \"heading\": [" + fmt(f.heading_degrees) + "], \"path\": [" + fmt3(f.x, f.y, f.z) + "]},\n";
    }
    // A ball of radius 0.35 m rolling across, sunk 0.12 m into the snow, sampled every 0.5 m.
    {
        const double r = 0.35, sink = 0.12;
        j += "    {\"shape\": \"sphere\", \"radius\": " + fmt(r) + ", \"path\": [";
        for (int k = 0; k <= 16; ++k) {
            double x = 2.0 + 0.3 * k, z = -7.0 + 0.35 * k + 0.6 * std::sin(k * 0.4);
            j += (k ? ", " : "") + fmt3(x, ground_surface_height(x, z) + r - sink, z);
        }
        j += "]},\n";
    }
    // A crate resting on the snow, turned 30 degrees, pressed 0.08 m in.
    {
        const double x = -4.0, z = 4.5, sy = 0.4;
        j += "    {\"shape\": \"box\", \"size\": [0.6, " + fmt(sy) +
             ", 0.6], \"heading\": [30], \"path\": [" + fmt3(x, ground_surface_height(x, z) + sy / 2 - 0.08, z) + "]},\n";
    }
    // A log (capsule) dragged over 3 m, lying across its path (oriented by the path direction), 0.05 m in.
    {
        const double r = 0.12;
        j += "    {\"shape\": \"capsule\", \"radius\": " + fmt(r) + ", \"length\": 1.0, \"path\": [";
        for (int k = 0; k <= 6; ++k) {
            double x = 4.0 + 0.1 * k, z = 3.0 + 0.5 * k;
            j += (k ? ", " : "") + fmt3(x, ground_surface_height(x, z) + r - 0.05, z);
        }
        j += "]}\n";
    }
    j += "  ]\n}\n";
    return j;
}

// Where the demo puts things and looks from (metres, y up). The creature stands on the snow beside the trail.
inline std::array<double, 3> creature_position() { return {-3.0, ground_surface_height(-3.0, 1.5), 1.5}; }

// The combined scene: the creature walking toward +x (heading 90°), standing with its paws 3.5 cm deep in the
// snow, and the prints of its last steps behind it. Paw centres in the creature's own frame are those of
// shapes::creature (front ±0.25, +0.28; back ±0.25, −0.32; the sole at y = 0); each print is a ball of the
// paw's size (r 0.1 m) pressed 3.5 cm in. A walk moves diagonal pairs together: front-left with back-right,
// then front-right with back-left, half a stride (0.35 m) apart.
constexpr double creature_heading_degrees = 90, creature_sink = 0.035, creature_stride = 0.7;
inline std::string creature_trail_json() {
    const auto c = creature_position();
    const double h = creature_heading_degrees * std::numbers::pi / 180, r = 0.1;
    const double fx = std::sin(h), fz = std::cos(h); // forward
    const double lx = std::cos(h), lz = -std::sin(h); // the creature's local +x (its left) in world x, z
    const double paw_x[4] = {0.25, -0.25, 0.25, -0.25}, paw_z[4] = {0.28, 0.28, -0.32, -0.32};
    const double phase[4] = {0, 0.5, 0.5, 0}; // fraction of a stride each paw is behind the body's last step
    std::string j = "{\"up\": [0, 1, 0], \"colliders\": [";
    bool first = true;
    for (int step = 0; step < 6; ++step)
        for (int k = 0; k < 4; ++k) {
            const double back = (step + phase[k]) * creature_stride;
            const double x = c[0] + paw_x[k] * lx + (paw_z[k] - back) * fx, z = c[2] + paw_x[k] * lz + (paw_z[k] - back) * fz;
            j += std::string(first ? "" : ",") + "\n        {\"shape\": \"sphere\", \"radius\": " + fmt(r) + ", \"path\": [" +
                 fmt3(x, ground_surface_height(x, z) + r - creature_sink, z) + "]}";
            first = false;
        }
    return j + "]}";
}

inline std::string scene_json() {
    auto c = creature_position();
    std::string j = "{\n";
    j += "  \"creature\": {\"model\": \"creature.glb\", \"fur_mask\": \"creature_fur_mask.png\", \"position\": " +
         fmt3(c[0], c[1], c[2]) + ",\n";
    j += "               \"camera\": {\"eye\": [1.6, 1.1, 2.2], \"target\": [0, 0.45, 0], \"fov\": 40}},\n";
    j += "  \"snow\": {\"ground\": \"ground.glb\", \"colliders\": \"colliders.json\",\n";
    j += "           \"camera\": {\"eye\": [0, 9, 14], \"target\": [0, 0, 0], \"fov\": 45}},\n";
    // A low camera at one corner of the ground: near hills get fine triangles, the far side stays coarse.
    j += "  \"terrain\": {\"ground\": \"ground.glb\", \"scheme\": \"catmark\", \"screen_error\": 2, \"max_rate\": 8,\n";
    j += "              \"camera\": {\"eye\": [-9, 3, 9], \"target\": [1, -0.5, -1], \"fov\": 50}},\n";
    // The combined scene: the furred creature in the stamped snow with its own trail; the camera ahead of it
    // and to its right, looking back along the trail.
    j += "  \"scene\": {\"position\": " + fmt3(c[0], c[1] - creature_sink, c[2]) + ", \"heading\": " + fmt(creature_heading_degrees) +
         ",\n            \"camera\": {\"eye\": " + fmt3(c[0] + 2.4, c[1] + 1.2, c[2] - 1.7) + ", \"target\": " +
         fmt3(c[0] - 0.9, c[1] + 0.3, c[2]) + ", \"fov\": 45},\n            \"trail\": " + creature_trail_json() + "}\n";
    j += "}\n";
    return j;
}

// ---------------------------------------------------------------------------------------------------------
// Everything
// ---------------------------------------------------------------------------------------------------------
// Written as save_scene and save_png write the other assets (furrow_kernel/atomic_file.h): all or nothing, so
// an interrupted run never leaves a half-written asset in models/.
inline Status write_text_file(const std::filesystem::path& path, const std::string& text) {
    return kernel::atomic_write(path.string(), text.data(), text.size());
}

// The files generate_all() writes, in order.
inline std::vector<std::string> model_files() {
    return {"creature.glb", "creature_fur_mask.png", "ground.glb", "footprint.png", "colliders.json", "scene.json"};
}

// Writes every asset of model_files() into `dir` (which must exist).
inline Status generate_all(const std::filesystem::path& dir) {
    const auto points = creature_texel_points(creature_texture_width, creature_texture_height);
    const auto albedo = creature_albedo_rgba8(points);
    // The generator's own vertex order (no meshoptimizer reordering): the committed files stay as they were.
    SaveOptions as_generated;
    as_generated.optimize = false;
    Status st = save_scene(creature_scene(encode_png_rgba8(albedo.data(), creature_texture_width, creature_texture_height)),
                           (dir / "creature.glb").string(), as_generated);
    if (st.ok()) st = save_png(creature_fur_mask(points, creature_texture_width, creature_texture_height),
                               (dir / "creature_fur_mask.png").string());
    if (st.ok()) st = save_scene(ground_scene(), (dir / "ground.glb").string(), as_generated);
    if (st.ok()) st = save_png(footprint_brush(), (dir / "footprint.png").string());
    if (st.ok()) st = write_text_file(dir / "colliders.json", colliders_json());
    if (st.ok()) st = write_text_file(dir / "scene.json", scene_json());
    return st;
}

} // namespace furrow::models

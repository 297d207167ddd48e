// Procedural shapes (see furrow/shapes.h for the exact layouts and counts).
//
// All geometry is computed in double and rounded once to float, and every vertex that must coincide with
// another (UV seams, poles) is computed from the same integer grid coordinate, never from an angle that
// merely should be equal (sin(2*pi) != sin(0) in floating point) — that is what makes the shapes close
// under exact welding.
#include <furrow/shapes.h>
#include <furrow_kernel/vec3.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_map>

namespace furrow::shapes {
namespace {

constexpr double pi = std::numbers::pi;
constexpr int max_grid = 16384;

using V3 = kernel::Vec3; // component-wise a * b and a / b are GLM's
using kernel::dot;
double length(V3 a) { return kernel::norm(a); }
V3 normalize(V3 a) {
    double l = length(a);
    return l > 0 ? a * (1.0 / l) : V3{0, 1, 0};
}

void push3(std::vector<float>& out, V3 v) {
    out.push_back(float(v.x));
    out.push_back(float(v.y));
    out.push_back(float(v.z));
}
void push2(std::vector<float>& out, double u, double v) {
    out.push_back(float(u));
    out.push_back(float(v));
}
void push_tri(std::vector<uint32_t>& out, size_t a, size_t b, size_t c) {
    out.push_back(uint32_t(a));
    out.push_back(uint32_t(b));
    out.push_back(uint32_t(c));
}

void reserve(Primitive& p, size_t vertices, size_t indices, bool uv) {
    p.positions.reserve(vertices * 3);
    p.normals.reserve(vertices * 3);
    if (uv) p.uv0.reserve(vertices * 2);
    p.indices.reserve(indices);
}

// Unit direction of uv_sphere's grid point (i, j): azimuth from i % segments so that the seam column
// repeats column 0 bit for bit; the poles exactly on ±y (sin(pi) is not 0 in floating point).
V3 sphere_direction(int i, int segments, int j, int rings) {
    if (j <= 0) return {0, 1, 0};
    if (j >= rings) return {0, -1, 0};
    double theta = pi * double(j) / double(rings);
    double phi = 2.0 * pi * double(i % segments) / double(segments);
    double s = std::sin(theta);
    return {-s * std::sin(phi), std::cos(theta), -s * std::cos(phi)};
}

// uv_sphere's topology and UVs with a caller-supplied placement of each grid point, so that creature()
// shares them exactly. place(i, j) appends the position and normal of grid point (i, j).
template <class Place>
Primitive lat_long_mesh(int segments, int rings, Place&& place) {
    segments = std::clamp(segments, 3, max_grid);
    rings = std::clamp(rings, 2, max_grid);
    const size_t S = size_t(segments), row = S + 1;
    const size_t vertex_count = (size_t(rings) - 1) * row + 2 * S;
    const size_t triangle_count = 2 * S * (size_t(rings) - 1);

    Primitive p;
    reserve(p, vertex_count, triangle_count * 3, true);
    // Top pole: one copy per segment, u at the middle of the segment so the cap triangle is not sheared.
    for (size_t i = 0; i < S; ++i) {
        place(int(i), 0, p);
        push2(p.uv0, (double(i) + 0.5) / double(S), 0.0);
    }
    for (int j = 1; j < rings; ++j)
        for (size_t i = 0; i <= S; ++i) {
            place(int(i), j, p);
            push2(p.uv0, double(i) / double(S), double(j) / double(rings));
        }
    for (size_t i = 0; i < S; ++i) {
        place(int(i), rings, p);
        push2(p.uv0, (double(i) + 0.5) / double(S), 1.0);
    }

    auto ring = [&](int j, size_t i) { return S + size_t(j - 1) * row + i; };
    const size_t bottom = S + (size_t(rings) - 1) * row;
    // Cell (i, j) between rings j and j+1: a = (i, j), b = (i, j+1), c = (i+1, j+1), d = (i+1, j);
    // [a, b, c] and [a, c, d] are counter-clockwise from outside (b is south of a, d east of a).
    for (size_t i = 0; i < S; ++i) push_tri(p.indices, i, ring(1, i), ring(1, i + 1));
    for (int j = 1; j + 1 < rings; ++j)
        for (size_t i = 0; i < S; ++i) {
            size_t a = ring(j, i), b = ring(j + 1, i), c = ring(j + 1, i + 1), d = ring(j, i + 1);
            push_tri(p.indices, a, b, c);
            push_tri(p.indices, a, c, d);
        }
    for (size_t i = 0; i < S; ++i) push_tri(p.indices, ring(rings - 1, i), bottom + i, ring(rings - 1, i + 1));
    return p;
}

} // namespace

// ---------------------------------------------------------------------------------------------------------
Primitive uv_sphere(float radius, int segments, int rings) {
    const int S = std::clamp(segments, 3, max_grid), R = std::clamp(rings, 2, max_grid);
    return lat_long_mesh(S, R, [&](int i, int j, Primitive& p) {
        V3 d = sphere_direction(i, S, j, R);
        push3(p.positions, d * double(radius));
        push3(p.normals, d);
    });
}

// ---------------------------------------------------------------------------------------------------------
Primitive icosphere(float radius, int subdivisions) {
    subdivisions = std::clamp(subdivisions, 0, 9);
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    std::vector<V3> dirs = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                            {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    for (V3& d : dirs) d = normalize(d);
    std::vector<uint32_t> faces = {0, 11, 5, 0, 5, 1,  0, 1, 7,  0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4,
                                   11, 10, 2, 10, 7, 6, 7, 1, 8, 3, 9, 4,  3, 4, 2,   3, 2, 6, 3, 6, 8,
                                   3, 8, 9, 4, 9, 5,  2, 4, 11, 6, 2, 10, 8, 6, 7,   9, 8, 1};

    // 4:1 split per level; each edge's midpoint is created once (keyed by its sorted vertex pair), in face
    // order, so the numbering is deterministic.
    for (int level = 0; level < subdivisions; ++level) {
        std::unordered_map<uint64_t, uint32_t> midpoints;
        midpoints.reserve(faces.size() / 2 * 3 / 2 + 1);
        auto midpoint = [&](uint32_t a, uint32_t b) {
            uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
            auto [it, inserted] = midpoints.try_emplace(key, uint32_t(dirs.size()));
            if (inserted) dirs.push_back(normalize(dirs[a] + dirs[b]));
            return it->second;
        };
        std::vector<uint32_t> next;
        next.reserve(faces.size() * 4);
        for (size_t f = 0; f < faces.size(); f += 3) {
            uint32_t a = faces[f], b = faces[f + 1], c = faces[f + 2];
            uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
            next.insert(next.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
        }
        faces.swap(next);
    }

    Primitive p;
    reserve(p, dirs.size(), faces.size(), false);
    for (const V3& d : dirs) {
        push3(p.positions, d * double(radius));
        push3(p.normals, d);
    }
    p.indices = std::move(faces);
    return p;
}

// ---------------------------------------------------------------------------------------------------------
namespace {
Primitive grid_vertices(float size_x, float size_z, int nx, int nz) {
    Primitive p;
    const size_t X = size_t(nx), Z = size_t(nz);
    reserve(p, (X + 1) * (Z + 1), 0, true);
    for (size_t j = 0; j <= Z; ++j)
        for (size_t i = 0; i <= X; ++i) {
            double u = double(i) / double(X), v = double(j) / double(Z);
            push3(p.positions, {double(size_x) * (u - 0.5), 0.0, double(size_z) * (v - 0.5)});
            push3(p.normals, {0, 1, 0});
            push2(p.uv0, u, v);
        }
    return p;
}
} // namespace

Primitive grid(float size_x, float size_z, int nx, int nz) {
    nx = std::clamp(nx, 1, max_grid);
    nz = std::clamp(nz, 1, max_grid);
    Primitive p = grid_vertices(size_x, size_z, nx, nz);
    const size_t X = size_t(nx), Z = size_t(nz), row = X + 1;
    p.indices.reserve(X * Z * 6);
    for (size_t j = 0; j < Z; ++j)
        for (size_t i = 0; i < X; ++i) {
            size_t a = j * row + i, b = a + row, c = b + 1, d = a + 1;
            push_tri(p.indices, a, b, c);
            push_tri(p.indices, a, c, d);
        }
    return p;
}

Primitive quad_grid(float size_x, float size_z, int nx, int nz) {
    nx = std::clamp(nx, 1, max_grid);
    nz = std::clamp(nz, 1, max_grid);
    Primitive p = grid_vertices(size_x, size_z, nx, nz);
    const size_t X = size_t(nx), Z = size_t(nz), row = X + 1;
    p.indices.reserve(X * Z * 4);
    for (size_t j = 0; j < Z; ++j)
        for (size_t i = 0; i < X; ++i) {
            size_t a = j * row + i, b = a + row, c = b + 1, d = a + 1;
            p.indices.insert(p.indices.end(), {uint32_t(a), uint32_t(b), uint32_t(c), uint32_t(d)});
        }
    p.face_sizes.assign(X * Z, 4);
    return p;
}

// ---------------------------------------------------------------------------------------------------------
Primitive box(float size_x, float size_y, float size_z, bool split_faces) {
    // Per face: outward normal n, the viewer's right r and down d seen from outside. Corner (u, v) is at
    // n + r*(2u - 1) + d*(2v - 1) in half-size units; r × d = -n, so corners (0,0), (0,1), (1,1), (1,0) run
    // counter-clockwise seen from outside.
    struct Face {
        V3 n, r, d;
    };
    static const Face faces[6] = {
        {{1, 0, 0}, {0, 0, -1}, {0, -1, 0}},  // +x
        {{-1, 0, 0}, {0, 0, 1}, {0, -1, 0}},  // -x
        {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}},    // +y: top edge of the image at -z
        {{0, -1, 0}, {1, 0, 0}, {0, 0, -1}},  // -y: top edge of the image at +z
        {{0, 0, 1}, {1, 0, 0}, {0, -1, 0}},   // +z
        {{0, 0, -1}, {-1, 0, 0}, {0, -1, 0}}, // -z
    };
    static const int corner_uv[4][2] = {{0, 0}, {0, 1}, {1, 1}, {1, 0}};
    const V3 half{double(size_x) * 0.5, double(size_y) * 0.5, double(size_z) * 0.5};

    Primitive p;
    if (split_faces) {
        reserve(p, 24, 36, true);
        for (const Face& f : faces) {
            size_t base = p.vertex_count();
            for (const auto& c : corner_uv) {
                V3 s = f.n + f.r * double(2 * c[0] - 1) + f.d * double(2 * c[1] - 1);
                push3(p.positions, s * half);
                push3(p.normals, f.n);
                push2(p.uv0, c[0], c[1]);
            }
            push_tri(p.indices, base, base + 1, base + 2);
            push_tri(p.indices, base, base + 2, base + 3);
        }
        return p;
    }
    reserve(p, 8, 36, false);
    for (int i = 0; i < 8; ++i) {
        V3 s{(i & 1) ? 1.0 : -1.0, (i & 2) ? 1.0 : -1.0, (i & 4) ? 1.0 : -1.0};
        push3(p.positions, s * half);
        push3(p.normals, normalize(s));
    }
    for (const Face& f : faces) {
        uint32_t id[4];
        for (int k = 0; k < 4; ++k) {
            V3 s = f.n + f.r * double(2 * corner_uv[k][0] - 1) + f.d * double(2 * corner_uv[k][1] - 1);
            id[k] = uint32_t((s.x > 0 ? 1 : 0) | (s.y > 0 ? 2 : 0) | (s.z > 0 ? 4 : 0));
        }
        push_tri(p.indices, id[0], id[1], id[2]);
        push_tri(p.indices, id[0], id[2], id[3]);
    }
    return p;
}

// ---------------------------------------------------------------------------------------------------------
Primitive torus(float major_radius, float minor_radius, int segments, int sides) {
    segments = std::clamp(segments, 3, max_grid);
    sides = std::clamp(sides, 3, max_grid);
    const size_t S = size_t(segments), T = size_t(sides), row = S + 1;
    Primitive p;
    reserve(p, row * (T + 1), S * T * 6, true);
    for (size_t j = 0; j <= T; ++j) {
        double psi = 2.0 * pi * double(j % T) / double(T);
        for (size_t i = 0; i <= S; ++i) {
            double phi = 2.0 * pi * double(i % S) / double(S);
            V3 out{-std::sin(phi), 0.0, -std::cos(phi)};
            // Going down from the outer equator: v grows downward seen from outside, as on uv_sphere.
            V3 n = out * std::cos(psi) + V3{0, -std::sin(psi), 0};
            push3(p.positions, out * double(major_radius) + n * double(minor_radius));
            push3(p.normals, n);
            push2(p.uv0, double(i) / double(S), double(j) / double(T));
        }
    }
    for (size_t j = 0; j < T; ++j)
        for (size_t i = 0; i < S; ++i) {
            size_t a = j * row + i, b = a + row, c = b + 1, d = a + 1;
            push_tri(p.indices, a, b, c);
            push_tri(p.indices, a, c, d);
        }
    return p;
}

// ---------------------------------------------------------------------------------------------------------
// The creature. Signed-distance primitives and the polynomial smooth minimum follow I. Quilez,
// "distance functions" and "smooth minimum" (iquilezles.org/articles); the ellipsoid is his bounded
// approximation, which is enough here because only the sign and the gradient direction are used.
namespace {

double sd_sphere(V3 p, V3 c, double r) { return length(p - c) - r; }

double sd_ellipsoid(V3 p, V3 c, V3 radii) {
    V3 q = p - c;
    double k0 = length(q / radii);
    double k1 = length(q / (radii * radii));
    if (k1 == 0) return -std::min({radii.x, radii.y, radii.z});
    return k0 * (k0 - 1.0) / k1;
}

double sign_of(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

// A capsule whose radius goes linearly from r1 at a to r2 at b.
double sd_round_cone(V3 p, V3 a, V3 b, double r1, double r2) {
    V3 ba = b - a;
    double l2 = dot(ba, ba), rr = r1 - r2, a2 = l2 - rr * rr, il2 = 1.0 / l2;
    V3 pa = p - a;
    double y = dot(pa, ba), z = y - l2;
    V3 xv = pa * l2 - ba * y;
    double x2 = dot(xv, xv), y2 = y * y * l2, z2 = z * z * l2;
    double k = sign_of(rr) * rr * rr * x2;
    if (sign_of(z) * a2 * z2 > k) return std::sqrt(x2 + z2) * il2 - r2;
    if (sign_of(y) * a2 * y2 < k) return std::sqrt(x2 + y2) * il2 - r1;
    return (std::sqrt(x2 * a2 * il2) + y * rr) * il2 - r1;
}

double smin(double a, double b, double k) {
    double h = std::max(k - std::abs(a - b), 0.0) / k;
    return std::min(a, b) - h * h * k * 0.25;
}

std::array<float, 3> to_f3(V3 v) { return {float(v.x), float(v.y), float(v.z)}; }

// The layout, in metres. Parts that stick out (legs, ears, tail, snout) lie along rays from `centre` so
// that the union stays star-shaped from it and the radial sampling sees every part.
struct Layout {
    V3 centre{0, 0.45, -0.02};
    V3 body{0, 0.45, -0.04}, body_radii{0.36, 0.32, 0.44};
    V3 head{0, 0.68, 0.33};
    double head_r = 0.24;
    V3 snout{0, 0.615, 0.53}, snout_radii{0.115, 0.09, 0.10};
    V3 nose{0, 0.64, 0.615};
    double nose_r = 0.042;
    V3 eye[2];
    double eye_r = 0.036;
    V3 ear_base[2], ear_tip[2];
    double ear_r1 = 0.075, ear_r2 = 0.028;
    V3 paw[4], leg_top[4];
    V3 paw_radii{0.10, 0.075, 0.12};
    double leg_r1 = 0.115, leg_r2 = 0.085;
    V3 tail{0, 0.62, -0.50};
    double tail_r = 0.11;

    Layout() {
        for (int s = 0; s < 2; ++s) {
            double side = s == 0 ? 1.0 : -1.0; // left = +x (the creature's own left when it faces +z)
            // Eyes sit on the head sphere, slightly sunk so that they bulge by about half their radius.
            eye[s] = head + normalize(V3{side * 0.40, 0.30, 0.86}) * (head_r - 0.018);
            // Ears: base on the head, pointing away from the centre (tilted up a little for the look).
            ear_base[s] = head + normalize(V3{side * 0.50, 0.82, -0.10}) * (head_r - 0.02);
            V3 dir = normalize(normalize(ear_base[s] - centre) + V3{side * 0.15, 0.35, -0.25});
            ear_tip[s] = ear_base[s] + dir * 0.17;
        }
        // Paws: front left, front right, back left, back right; legs run from inside the body to the paw
        // along the ray from the centre (splayed like a plush toy).
        const double px[4] = {0.25, -0.25, 0.25, -0.25}, pz[4] = {0.28, 0.28, -0.32, -0.32};
        for (int k = 0; k < 4; ++k) {
            paw[k] = {px[k], paw_radii.y + 0.015, pz[k]}; // the smooth unions bulge the sole ~1.5 cm down
            leg_top[k] = centre + normalize(paw[k] - centre) * 0.18;
        }
    }

    double distance(V3 p) const {
        double d = sd_ellipsoid(p, body, body_radii);
        d = smin(d, sd_sphere(p, head, head_r), 0.12);
        d = smin(d, sd_ellipsoid(p, snout, snout_radii), 0.06);
        d = smin(d, sd_sphere(p, nose, nose_r), 0.02);
        for (int s = 0; s < 2; ++s) {
            d = smin(d, sd_sphere(p, eye[s], eye_r), 0.01);
            d = smin(d, sd_round_cone(p, ear_base[s], ear_tip[s], ear_r1, ear_r2), 0.05);
        }
        for (int k = 0; k < 4; ++k) {
            d = smin(d, sd_round_cone(p, leg_top[k], paw[k], leg_r1, leg_r2), 0.08);
            d = smin(d, sd_ellipsoid(p, paw[k] + V3{0, 0, 0.02}, paw_radii), 0.04);
        }
        d = smin(d, sd_sphere(p, tail, tail_r), 0.08);
        return d;
    }

    // Distance along `dir` from the centre to the last exit of the surface: march inward from outside the
    // bounding sphere with steps of half the distance estimate (the estimate stays close to the true
    // distance, so no part is stepped over), then bisect the bracket.
    double radial_extent(V3 dir) const {
        double outside = 1.2; // beyond every part
        for (double t = outside; t > 0;) {
            double f = distance(centre + dir * t);
            if (f < 0) {
                double inside = t;
                for (int it = 0; it < 30; ++it) {
                    double mid = 0.5 * (inside + outside);
                    (distance(centre + dir * mid) < 0 ? inside : outside) = mid;
                }
                return 0.5 * (inside + outside);
            }
            outside = t;
            t -= std::clamp(0.5 * f, 0.002, 0.1);
        }
        return 0.01; // not reached: the centre is inside the body
    }

    V3 gradient_normal(V3 p) const {
        const double h = 1e-5;
        V3 g{distance(p + V3{h, 0, 0}) - distance(p - V3{h, 0, 0}),
             distance(p + V3{0, h, 0}) - distance(p - V3{0, h, 0}),
             distance(p + V3{0, 0, h}) - distance(p - V3{0, 0, h})};
        return normalize(g);
    }
};

const Layout& layout() {
    static const Layout l;
    return l;
}

} // namespace

Primitive creature(int segments, int rings) {
    const Layout& l = layout();
    const int S = std::clamp(segments, 3, max_grid), R = std::clamp(rings, 2, max_grid);
    return lat_long_mesh(S, R, [&](int i, int j, Primitive& p) {
        V3 d = sphere_direction(i, S, j, R);
        V3 x = l.centre + d * l.radial_extent(d);
        push3(p.positions, x);
        push3(p.normals, l.gradient_normal(x));
    });
}

SurfacePoint creature_surface(float u, float v) {
    const Layout& l = layout();
    double theta = pi * std::clamp(double(v), 0.0, 1.0), phi = 2.0 * pi * double(u);
    V3 d = v <= 0 ? V3{0, 1, 0}
                  : v >= 1 ? V3{0, -1, 0}
                           : V3{-std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
    V3 x = l.centre + d * l.radial_extent(d);
    return {to_f3(x), to_f3(l.gradient_normal(x))};
}

const CreatureLandmarks& creature_landmarks() {
    static const CreatureLandmarks marks = [] {
        const Layout& l = layout();
        CreatureLandmarks m{};
        m.nose_tip = to_f3(l.nose + V3{0, 0, l.nose_r});
        m.nose_radius = float(l.nose_r);
        m.eye_left = to_f3(l.eye[0]);
        m.eye_right = to_f3(l.eye[1]);
        m.eye_radius = float(l.eye_r);
        for (int k = 0; k < 4; ++k) m.paws[k] = to_f3(l.paw[k]);
        m.paw_radius = float(l.paw_radii.z);
        m.ear_tips = {to_f3(l.ear_tip[0]), to_f3(l.ear_tip[1])};
        m.head_centre = to_f3(l.head);
        m.head_radius = float(l.head_r);
        m.tail_centre = to_f3(l.tail);
        m.centre = to_f3(l.centre);
        return m;
    }();
    return marks;
}

} // namespace furrow::shapes

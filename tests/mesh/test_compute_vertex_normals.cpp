#include <furrow/mesh.h>
#include <furrow_kernel/angle_weighted_normal.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

using furrow::compute_vertex_normals;

namespace {

// Unit cube [0,1]^3 with one copy of each corner per face (24 vertices, like a glTF cube with per-face
// normals/UVs), triangulated with every face split along the diagonal from its first corner.
struct SplitCube {
    std::vector<float> positions;
    std::vector<uint32_t> indices;
    SplitCube() {
        const int faces[6][4][3] = {
            {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}}, // z = 0, outward -z
            {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}, // z = 1
            {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}}, // y = 0
            {{0, 1, 0}, {0, 1, 1}, {1, 1, 1}, {1, 1, 0}}, // y = 1
            {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {0, 1, 0}}, // x = 0
            {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}}, // x = 1
        };
        for (const auto& f : faces) {
            uint32_t base = uint32_t(positions.size() / 3);
            for (const auto& c : f)
                for (int k = 0; k < 3; ++k) positions.push_back(float(c[k]));
            indices.insert(indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
        }
    }
};

std::array<float, 3> normal_of(const std::vector<float>& normals, size_t v) {
    return {normals[3 * v], normals[3 * v + 1], normals[3 * v + 2]};
}

} // namespace

// Every corner of a cube gets the diagonal direction: three faces with 90° each at the corner. The split
// diagonals give some corners two triangles of one face (45° + 45°) and others one (90°): angle weighting
// makes that irrelevant, and all copies of a corner get bit-identical normals.
TEST(compute_vertex_normals, CubeCornersAreDiagonalAndCopiesAgree) {
    SplitCube cube;
    const size_t n = cube.positions.size() / 3;
    std::vector<float> normals(3 * n, 7.0f);
    compute_vertex_normals(normals.data(), cube.positions.data(), n, cube.indices.data(), cube.indices.size());
    const float s = float(1.0 / std::sqrt(3.0));
    for (size_t v = 0; v < n; ++v) {
        std::array<float, 3> expect;
        for (int k = 0; k < 3; ++k) expect[k] = cube.positions[3 * v + k] > 0.5f ? s : -s;
        auto got = normal_of(normals, v);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(got[k], expect[k], 1e-6) << "vertex " << v;
        for (size_t w = 0; w < v; ++w) {
            if (cube.positions[3 * w] == cube.positions[3 * v] && cube.positions[3 * w + 1] == cube.positions[3 * v + 1] &&
                cube.positions[3 * w + 2] == cube.positions[3 * v + 2]) {
                EXPECT_EQ(normal_of(normals, w), got) << "copies " << w << " and " << v;
            }
        }
    }
}

// A fan of many thin triangles in one plane must not outvote a single triangle in another plane: at the
// apex of a "roof" (two planes at 90°, each spanning 90° around the vertex) the normal bisects the planes
// however finely one side is triangulated.
TEST(compute_vertex_normals, AngleWeightingIgnoresTriangulation) {
    std::vector<float> p = {0, 0, 0}; // apex, vertex 0
    std::vector<uint32_t> idx;
    // Side A in the plane z = 0 (normal +z), quarter disc from +x to +y, split into 8 triangles.
    const int slices = 8;
    for (int i = 0; i <= slices; ++i) {
        double a = (3.14159265358979 / 2) * i / slices;
        p.insert(p.end(), {float(std::cos(a)), float(std::sin(a)), 0.0f});
    }
    for (int i = 0; i < slices; ++i) idx.insert(idx.end(), {0u, uint32_t(1 + i), uint32_t(2 + i)});
    // Side B in the plane x = 0 (normal +x), one triangle spanning 90°: from +y to +z.
    const uint32_t b = uint32_t(p.size() / 3);
    p.insert(p.end(), {0, 1, 0, 0, 0, 1});
    idx.insert(idx.end(), {0u, b, b + 1});
    std::vector<float> normals(p.size());
    compute_vertex_normals(normals.data(), p.data(), p.size() / 3, idx.data(), idx.size());
    const float h = float(1.0 / std::sqrt(2.0));
    EXPECT_NEAR(normals[0], h, 1e-6);
    EXPECT_NEAR(normals[1], 0.0, 1e-6);
    EXPECT_NEAR(normals[2], h, 1e-6);
}

// Degenerate faces contribute nothing: a repeated vertex, three collinear points, and a face with an
// index out of range leave the normals exactly as they were.
TEST(compute_vertex_normals, DegenerateFacesContributeNothing) {
    std::vector<float> p = {0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0};
    std::vector<uint32_t> clean = {0, 1, 2};
    std::vector<uint32_t> dirty = {0, 1, 2, /*repeated*/ 0, 0, 1, /*collinear*/ 0, 1, 3, /*out of range*/ 0, 1, 99};
    std::vector<float> a(12), b(12);
    compute_vertex_normals(a.data(), p.data(), 4, clean.data(), clean.size());
    compute_vertex_normals(b.data(), p.data(), 4, dirty.data(), dirty.size());
    EXPECT_EQ(a, b);
    EXPECT_EQ(normal_of(a, 0), (std::array<float, 3>{0, 0, 1}));
}

// A vertex that no valid face uses gets (0,0,0): the caller chooses the fallback.
TEST(compute_vertex_normals, UnusedVertexIsZero) {
    std::vector<float> p = {0, 0, 0, 1, 0, 0, 0, 1, 0, 9, 9, 9};
    std::vector<uint32_t> idx = {0, 1, 2};
    std::vector<float> normals(12, 5.0f);
    compute_vertex_normals(normals.data(), p.data(), 4, idx.data(), idx.size());
    EXPECT_EQ(normal_of(normals, 3), (std::array<float, 3>{0, 0, 0}));
}

// NaN positions make their faces degenerate instead of spreading NaN into neighbouring normals.
TEST(compute_vertex_normals, NaNPositionDoesNotSpread) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::vector<float> p = {0, 0, 0, 1, 0, 0, 0, 1, 0, nan, 0, 0};
    std::vector<uint32_t> idx = {0, 1, 2, 0, 3, 1};
    std::vector<float> normals(12);
    compute_vertex_normals(normals.data(), p.data(), 4, idx.data(), idx.size());
    for (float x : normals) EXPECT_TRUE(std::isfinite(x));
    EXPECT_EQ(normal_of(normals, 0), (std::array<float, 3>{0, 0, 1}));
}

// The kernel's corner angle (a Cephes arctangent, not libm's atan2; angle_weighted_normal.h) against
// std::atan2 of the same (|e1 x e2|, e1 . e2): within 2 ulp of pi over corners from needle-thin to nearly
// flat, on both sides of a right angle, at scales from 1e-9 to 1e9, and on the reduction's boundaries.
TEST(compute_vertex_normals, CornerAngleIsLibmAtan2WithinTwoUlp) {
    using furrow::kernel::Vec3;
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> U(-1, 1), E(-9, 9);
    const double bound = 2 * std::numeric_limits<double>::epsilon() * 3.14159265358979323846 / 2; // 2 ulp of pi
    double worst = 0;
    size_t differ = 0, n = 0;
    auto check = [&](Vec3 q, Vec3 r) {
        const Vec3 p{0, 0, 0};
        const double area = furrow::kernel::norm(furrow::kernel::cross(q, r));
        if (!(area > 0)) return;
        const double want = std::atan2(area, furrow::kernel::dot(q, r));
        const double got = furrow::kernel::corner_angle(p, q, r, area);
        worst = std::max(worst, std::abs(got - want));
        differ += got != want;
        ++n;
    };
    for (int i = 0; i < 1000000; ++i) {
        const double s = std::pow(10.0, E(rng));
        check({s * U(rng), s * U(rng), s * U(rng)}, {s * U(rng), s * U(rng), s * U(rng)});
    }
    // Angles at and around the reduction's boundaries: atan(0.66), 45 degrees, atan(tan(3 pi / 8)) from each side.
    for (double deg = 0.001; deg < 180; deg += 0.0137) {
        const double th = deg * 3.14159265358979323846 / 180;
        check({1, 0, 0}, {std::cos(th), std::sin(th), 0});
    }
    for (double ratio : {0.66, std::nextafter(0.66, 1.0), 1.0, 2.41421356237309504880, std::nextafter(2.41421356237309504880, 3.0)}) {
        check({1, 0, 0}, {1, ratio, 0});
        check({1, 0, 0}, {-1, ratio, 0});
    }
    EXPECT_LE(worst, bound) << "over " << n << " corners";
    EXPECT_GT(n, 990000u);
    std::printf("corner_angle vs std::atan2: %zu corners, %zu differ, at most %.3g rad\n", n, differ, worst);
}

// The kernel's face term (angle_weighted_normal.h) derives the angle at the corner opposite the longest edge
// as pi minus the other two: against std::atan2 of each corner's own (|e1 x e2|, e1 . e2), every angle of
// random, needle and nearly flat triangles at scales from 1e-9 to 1e9 stays within 4 ulp of pi, and the three
// sum to pi.
TEST(compute_vertex_normals, DerivedCornerIsAtan2WithinFourUlp) {
    using furrow::kernel::Vec3;
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> U(-1, 1), E(-9, 9);
    std::uniform_int_distribution<int> kind(0, 3);
    const double bound = 4 * std::numeric_limits<double>::epsilon() * 3.14159265358979323846 / 2; // 4 ulp of pi
    double worst = 0;
    size_t n = 0;
    for (int i = 0; i < 300000; ++i) {
        const double s = std::pow(10.0, E(rng));
        Vec3 p[3] = {{s * U(rng), s * U(rng), s * U(rng)}, {s * U(rng), s * U(rng), s * U(rng)}, {s * U(rng), s * U(rng), s * U(rng)}};
        const double t = std::pow(10.0, -8 * std::abs(U(rng)));
        if (kind(rng) == 1) p[2] = p[0] + (0.5 + 0.4 * U(rng)) * (p[1] - p[0]) + t * s * Vec3{U(rng), U(rng), U(rng)}; // near-flat
        if (kind(rng) == 2) p[2] = p[0] + t * (p[2] - p[0]);                                                        // needle
        const furrow::kernel::FaceTerm f = furrow::kernel::face_term(p[0], p[1], p[2]);
        if (f.angle[0] < 0) continue;
        const double area = furrow::kernel::norm(furrow::kernel::cross(p[1] - p[0], p[2] - p[0]));
        for (int c = 0; c < 3; ++c) {
            const double want = std::atan2(area, furrow::kernel::dot(p[(c + 1) % 3] - p[c], p[(c + 2) % 3] - p[c]));
            worst = std::max(worst, std::abs(f.angle[c] - want));
        }
        EXPECT_NEAR(f.angle[0] + f.angle[1] + f.angle[2], 3.14159265358979323846, bound);
        ++n;
    }
    EXPECT_LE(worst, bound) << "over " << n << " triangles";
    EXPECT_GT(n, 250000u);
    std::printf("face_term vs std::atan2: %zu triangles, at most %.3g rad\n", n, worst);
}

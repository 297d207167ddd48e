// furrow::shapes: counts exactly as documented in shapes.h, unit normals, UVs in [0,1], closed and
// consistently oriented after exact welding (measured here with an independent edge map, and cross-checked
// with check_primitive), outward winding (positive signed volume), determinism.
#include <furrow/shapes.h>

#include "test_support.h"

#include <array>
#include <cmath>
#include <map>
#include <numbers>

using namespace furrow;

namespace {

constexpr double pi = std::numbers::pi;

// Topology over positions welded by exact value (-0 == +0), independent of the library's weld/check code.
struct Topology {
    size_t welded = 0;
    size_t edges = 0;              // undirected, welded
    size_t boundary_edges = 0;     // used by one face
    size_t non_manifold_edges = 0; // used by more than two faces
    size_t inconsistent_edges = 0; // a directed edge used twice (neighbours disagree on orientation)
    size_t degenerate_faces = 0;   // a welded vertex repeated in a triangle
    double signed_volume = 0;      // > 0: faces wind counter-clockwise seen from outside
    long euler() const { return long(welded) - long(edges) + long(faces); }
    size_t faces = 0;
};

Topology topology(const Primitive& p) {
    Topology t;
    std::map<std::array<float, 3>, uint32_t> ids;
    std::vector<uint32_t> remap(p.vertex_count());
    for (size_t i = 0; i < p.vertex_count(); ++i) {
        std::array<float, 3> key{p.positions[i * 3] + 0.0f, p.positions[i * 3 + 1] + 0.0f, p.positions[i * 3 + 2] + 0.0f};
        remap[i] = ids.try_emplace(key, uint32_t(ids.size())).first->second;
    }
    t.welded = ids.size();
    std::map<std::pair<uint32_t, uint32_t>, int> directed;
    auto add_triangle = [&](uint32_t a, uint32_t b, uint32_t c) {
        const float *pa = &p.positions[a * 3], *pb = &p.positions[b * 3], *pc = &p.positions[c * 3];
        t.signed_volume += (double(pa[0]) * (double(pb[1]) * pc[2] - double(pb[2]) * pc[1]) -
                            double(pa[1]) * (double(pb[0]) * pc[2] - double(pb[2]) * pc[0]) +
                            double(pa[2]) * (double(pb[0]) * pc[1] - double(pb[1]) * pc[0])) / 6.0;
        uint32_t w[3] = {remap[a], remap[b], remap[c]};
        if (w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) ++t.degenerate_faces;
    };
    // Faces (polygons kept as such for the edge map; fan-triangulated for the volume).
    size_t offset = 0;
    const size_t face_count = p.face_count();
    for (size_t f = 0; f < face_count; ++f) {
        size_t n = p.face_sizes.empty() ? 3 : p.face_sizes[f];
        for (size_t k = 0; k < n; ++k) ++directed[{remap[p.indices[offset + k]], remap[p.indices[offset + (k + 1) % n]]}];
        for (size_t k = 1; k + 1 < n; ++k) add_triangle(p.indices[offset], p.indices[offset + k], p.indices[offset + k + 1]);
        offset += n;
    }
    t.faces = face_count;
    for (const auto& [e, count] : directed) {
        auto reverse = directed.find({e.second, e.first});
        int back = reverse == directed.end() ? 0 : reverse->second;
        if (count > 1) ++t.inconsistent_edges;
        if (e.first < e.second || back == 0) { // count each undirected edge once
            ++t.edges;
            if (count + back == 1) ++t.boundary_edges;
            if (count + back > 2) ++t.non_manifold_edges;
        }
    }
    return t;
}

void expect_closed_manifold(const Primitive& p, long euler) {
    Topology t = topology(p);
    EXPECT_EQ(t.boundary_edges, 0u);
    EXPECT_EQ(t.non_manifold_edges, 0u);
    EXPECT_EQ(t.inconsistent_edges, 0u);
    EXPECT_EQ(t.degenerate_faces, 0u);
    EXPECT_EQ(t.euler(), euler);
    EXPECT_GT(t.signed_volume, 0.0) << "faces must wind counter-clockwise seen from outside";
}

void expect_unit_normals(const Primitive& p) {
    ASSERT_EQ(p.normals.size(), p.positions.size());
    for (size_t i = 0; i < p.vertex_count(); ++i) {
        double len = std::hypot(p.normals[i * 3], p.normals[i * 3 + 1], p.normals[i * 3 + 2]);
        ASSERT_NEAR(len, 1.0, 1e-6) << "vertex " << i;
    }
}

void expect_uv_in_unit_square(const Primitive& p) {
    ASSERT_EQ(p.uv0.size(), p.vertex_count() * 2);
    for (float v : p.uv0) {
        ASSERT_GE(v, 0.0f);
        ASSERT_LE(v, 1.0f);
    }
}

void expect_indices_in_range(const Primitive& p) {
    for (uint32_t i : p.indices) ASSERT_LT(i, p.vertex_count());
}

bool same_bytes(const Primitive& a, const Primitive& b) {
    return a.positions == b.positions && a.normals == b.normals && a.uv0 == b.uv0 && a.indices == b.indices &&
           a.face_sizes == b.face_sizes;
}

} // namespace

// ---------------------------------------------------------------------------------------------------------
TEST(uv_sphere, CountsMatchHeader) {
    for (auto [s, r] : std::vector<std::pair<int, int>>{{3, 2}, {8, 4}, {32, 16}, {33, 17}}) {
        Primitive p = shapes::uv_sphere(1.0f, s, r);
        EXPECT_EQ(p.vertex_count(), size_t((r - 1) * (s + 1) + 2 * s)) << s << "x" << r;
        EXPECT_EQ(p.triangle_count(), size_t(2 * s * (r - 1)));
        EXPECT_EQ(p.indices.size(), p.triangle_count() * 3);
        EXPECT_TRUE(p.face_sizes.empty());
        EXPECT_EQ(p.mode, PrimitiveMode::triangles);
        EXPECT_EQ(p.material, -1);
        EXPECT_EQ(topology(p).welded, size_t((r - 1) * s + 2));
        expect_indices_in_range(p);
    }
}

TEST(uv_sphere, ClosedAfterWeldingWithUnitNormalsAndUvs) {
    Primitive p = shapes::uv_sphere(2.0f, 24, 12);
    expect_closed_manifold(p, 2);
    expect_unit_normals(p);
    expect_uv_in_unit_square(p);
    // Inscribed polyhedron: volume a little under 4/3 pi r^3.
    double v = topology(p).signed_volume, exact = 4.0 / 3.0 * pi * 8.0;
    EXPECT_LT(v, exact);
    EXPECT_GT(v, 0.95 * exact);
    for (size_t i = 0; i < p.vertex_count(); ++i) {
        double r = std::hypot(p.positions[i * 3], p.positions[i * 3 + 1], p.positions[i * 3 + 2]);
        ASSERT_NEAR(r, 2.0, 1e-6);
        for (int k = 0; k < 3; ++k) ASSERT_NEAR(p.normals[i * 3 + k], p.positions[i * 3 + k] / 2.0f, 1e-6);
    }
}

TEST(uv_sphere, SeamAndPolesAreSplitWithBitIdenticalCopies) {
    const int S = 16, R = 8;
    Primitive p = shapes::uv_sphere(1.0f, S, R);
    // Poles: S copies each, at u = (i + 0.5)/S, exactly on the axis.
    for (int i = 0; i < S; ++i) {
        size_t top = size_t(i), bottom = p.vertex_count() - S + size_t(i);
        EXPECT_EQ(p.positions[top * 3 + 0], 0.0f);
        EXPECT_EQ(p.positions[top * 3 + 1], 1.0f);
        EXPECT_EQ(p.positions[bottom * 3 + 1], -1.0f);
        EXPECT_FLOAT_EQ(p.uv0[top * 2], (i + 0.5f) / S);
        EXPECT_EQ(p.uv0[top * 2 + 1], 0.0f);
        EXPECT_EQ(p.uv0[bottom * 2 + 1], 1.0f);
    }
    // Seam: column S repeats column 0 bit for bit, with u = 1 instead of 0; it runs down the back (-z).
    for (int j = 1; j < R; ++j) {
        size_t first = size_t(S + (j - 1) * (S + 1)), last = first + size_t(S);
        for (int k = 0; k < 3; ++k) EXPECT_EQ(p.positions[first * 3 + k], p.positions[last * 3 + k]);
        EXPECT_EQ(p.uv0[first * 2], 0.0f);
        EXPECT_EQ(p.uv0[last * 2], 1.0f);
        EXPECT_FLOAT_EQ(p.uv0[first * 2 + 1], float(j) / R);
        EXPECT_EQ(p.positions[first * 3], 0.0f);
        EXPECT_LT(p.positions[first * 3 + 2], 0.0f);
    }
}

TEST(uv_sphere, TextureIsUnmirroredFromOutside) {
    // On the front (+z, u = 0.5) u must grow toward +x (the viewer's right when looking at it from +z) and v
    // downward.
    const int S = 16, R = 8;
    Primitive p = shapes::uv_sphere(1.0f, S, R);
    size_t row = S + 1, equator = size_t(S + (R / 2 - 1) * int(row));
    size_t front = equator + S / 2, right = front + 1, below = front + row;
    EXPECT_GT(p.positions[front * 3 + 2], 0.99f);
    EXPECT_GT(p.positions[right * 3 + 0], p.positions[front * 3 + 0]);
    EXPECT_LT(p.positions[below * 3 + 1], p.positions[front * 3 + 1]);
    EXPECT_GT(p.uv0[right * 2], p.uv0[front * 2]);
    EXPECT_GT(p.uv0[below * 2 + 1], p.uv0[front * 2 + 1]);
}

TEST(uv_sphere, ArgumentsBelowMinimumAreRaised) {
    EXPECT_TRUE(same_bytes(shapes::uv_sphere(1.0f, 0, -5), shapes::uv_sphere(1.0f, 3, 2)));
    Primitive p = shapes::uv_sphere(1.0f, 1, 1);
    EXPECT_EQ(p.vertex_count(), 10u);
    EXPECT_EQ(p.triangle_count(), 6u);
}

TEST(uv_sphere, Deterministic) { EXPECT_TRUE(same_bytes(shapes::uv_sphere(1.5f, 40, 20), shapes::uv_sphere(1.5f, 40, 20))); }

// ---------------------------------------------------------------------------------------------------------
TEST(icosphere, CountsMatchHeader) {
    for (int s = 0; s <= 4; ++s) {
        Primitive p = shapes::icosphere(1.0f, s);
        size_t pow4 = size_t(1) << (2 * s);
        EXPECT_EQ(p.vertex_count(), 10 * pow4 + 2) << "s = " << s;
        EXPECT_EQ(p.triangle_count(), 20 * pow4);
        EXPECT_TRUE(p.uv0.empty());
        EXPECT_EQ(topology(p).welded, p.vertex_count()) << "an icosphere has no split vertices";
        expect_indices_in_range(p);
    }
}

TEST(icosphere, ClosedUnitNormalsNearUniformEdges) {
    Primitive p = shapes::icosphere(3.0f, 3);
    expect_closed_manifold(p, 2);
    expect_unit_normals(p);
    double shortest = 1e9, longest = 0;
    for (size_t f = 0; f < p.indices.size(); f += 3)
        for (int k = 0; k < 3; ++k) {
            const float *a = &p.positions[p.indices[f + k] * 3], *b = &p.positions[p.indices[f + (k + 1) % 3] * 3];
            double len = std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
            shortest = std::min(shortest, len), longest = std::max(longest, len);
        }
    EXPECT_LT(longest / shortest, 1.35); // geodesic spheres stay within ~1.2 at these levels
    for (size_t i = 0; i < p.vertex_count(); ++i)
        ASSERT_NEAR(std::hypot(p.positions[i * 3], p.positions[i * 3 + 1], p.positions[i * 3 + 2]), 3.0, 1e-5);
}

TEST(icosphere, SubdivisionsClamped) {
    EXPECT_EQ(shapes::icosphere(1.0f, -3).vertex_count(), 12u);
    EXPECT_TRUE(same_bytes(shapes::icosphere(1.0f, 2), shapes::icosphere(1.0f, 2)));
}

// ---------------------------------------------------------------------------------------------------------
TEST(grid, CountsMatchHeader) {
    for (auto [nx, nz] : std::vector<std::pair<int, int>>{{1, 1}, {4, 3}, {64, 64}}) {
        Primitive p = shapes::grid(20.0f, 10.0f, nx, nz);
        EXPECT_EQ(p.vertex_count(), size_t((nx + 1) * (nz + 1)));
        EXPECT_EQ(p.triangle_count(), size_t(2 * nx * nz));
        Topology t = topology(p);
        EXPECT_EQ(t.boundary_edges, size_t(2 * (nx + nz)));
        EXPECT_EQ(t.non_manifold_edges, 0u);
        EXPECT_EQ(t.inconsistent_edges, 0u);
        EXPECT_EQ(t.euler(), 1); // a disk
        expect_indices_in_range(p);
    }
}

TEST(grid, LayoutNormalsUvsAndUpwardWinding) {
    const int nx = 4, nz = 2;
    Primitive p = shapes::grid(8.0f, 2.0f, nx, nz);
    expect_unit_normals(p);
    expect_uv_in_unit_square(p);
    for (size_t i = 0; i < p.vertex_count(); ++i) {
        EXPECT_EQ(p.positions[i * 3 + 1], 0.0f);
        EXPECT_EQ(p.normals[i * 3 + 1], 1.0f);
        // uv is the normalised position: u = x/size_x + 0.5, v = z/size_z + 0.5.
        EXPECT_FLOAT_EQ(p.uv0[i * 2], p.positions[i * 3] / 8.0f + 0.5f);
        EXPECT_FLOAT_EQ(p.uv0[i * 2 + 1], p.positions[i * 3 + 2] / 2.0f + 0.5f);
    }
    // Vertex (i, j) = j*(nx+1) + i.
    EXPECT_EQ(p.positions[0], -4.0f);
    EXPECT_EQ(p.positions[2], -1.0f);
    size_t last = p.vertex_count() - 1;
    EXPECT_EQ(p.positions[last * 3], 4.0f);
    EXPECT_EQ(p.positions[last * 3 + 2], 1.0f);
    EXPECT_EQ(p.positions[1 * 3], -2.0f); // (1, 0)
    // Every triangle faces +y.
    for (size_t f = 0; f < p.indices.size(); f += 3) {
        const float *a = &p.positions[p.indices[f] * 3], *b = &p.positions[p.indices[f + 1] * 3],
                    *c = &p.positions[p.indices[f + 2] * 3];
        double ny = double(c[0] - a[0]) * (b[2] - a[2]) - double(b[0] - a[0]) * (c[2] - a[2]);
        EXPECT_GT(ny, 0.0);
    }
    // First cell: [a, b, c], [a, c, d] with a = (0,0), b = (0,1), c = (1,1), d = (1,0).
    std::vector<uint32_t> first(p.indices.begin(), p.indices.begin() + 6);
    EXPECT_EQ(first, (std::vector<uint32_t>{0, 5, 6, 0, 6, 1}));
}

// ---------------------------------------------------------------------------------------------------------
TEST(quad_grid, CountsMatchHeader) {
    Primitive p = shapes::quad_grid(3.0f, 2.0f, 6, 4);
    EXPECT_EQ(p.vertex_count(), 35u);
    EXPECT_EQ(p.face_count(), 24u);
    EXPECT_EQ(p.face_sizes, std::vector<uint32_t>(24, 4));
    EXPECT_EQ(p.indices.size(), 96u);
    EXPECT_EQ(p.triangle_count(), 48u);
    Topology t = topology(p);
    EXPECT_EQ(t.boundary_edges, 20u);
    EXPECT_EQ(t.inconsistent_edges, 0u);
    EXPECT_EQ(t.euler(), 1);
    EXPECT_GT(t.signed_volume, -1e-12);
}

TEST(quad_grid, TriangulatesToGrid) {
    Primitive q = shapes::quad_grid(5.0f, 7.0f, 9, 5);
    Primitive g = shapes::grid(5.0f, 7.0f, 9, 5);
    EXPECT_EQ(q.positions, g.positions);
    EXPECT_EQ(q.normals, g.normals);
    EXPECT_EQ(q.uv0, g.uv0);
    triangulate(q);
    EXPECT_TRUE(q.face_sizes.empty());
    EXPECT_EQ(q.indices, g.indices);
}

TEST(quad_grid, InteriorVerticesHaveValenceFour) {
    const int nx = 5, nz = 4;
    Primitive p = shapes::quad_grid(1.0f, 1.0f, nx, nz);
    std::vector<int> valence(p.vertex_count(), 0);
    for (size_t f = 0; f < p.face_count(); ++f) // each quad edge a->b counted at a; interior edges twice
        for (int k = 0; k < 4; ++k) ++valence[p.indices[f * 4 + size_t(k)]];
    for (int j = 1; j < nz; ++j)
        for (int i = 1; i < nx; ++i) EXPECT_EQ(valence[size_t(j * (nx + 1) + i)], 4) << i << "," << j;
}

// ---------------------------------------------------------------------------------------------------------
TEST(box, CountsMatchHeader) {
    Primitive split = shapes::box(1.0f, 2.0f, 3.0f);
    EXPECT_EQ(split.vertex_count(), 24u);
    EXPECT_EQ(split.triangle_count(), 12u);
    EXPECT_EQ(topology(split).welded, 8u);
    Primitive welded = shapes::box(1.0f, 2.0f, 3.0f, false);
    EXPECT_EQ(welded.vertex_count(), 8u);
    EXPECT_EQ(welded.triangle_count(), 12u);
    EXPECT_TRUE(welded.uv0.empty());
}

TEST(box, ClosedWithExactVolume) {
    for (bool split : {true, false}) {
        Primitive p = shapes::box(1.0f, 2.0f, 3.0f, split);
        expect_closed_manifold(p, 2);
        expect_unit_normals(p);
        EXPECT_NEAR(topology(p).signed_volume, 6.0, 1e-9);
    }
}

TEST(box, SplitFacesHavePerFaceNormalsAndFullUvs) {
    Primitive p = shapes::box(2.0f, 2.0f, 2.0f);
    expect_uv_in_unit_square(p);
    const float normals[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int f = 0; f < 6; ++f) {
        float umin = 1, umax = 0, vmin = 1, vmax = 0;
        for (int k = 0; k < 4; ++k) {
            size_t v = size_t(f * 4 + k);
            for (int c = 0; c < 3; ++c) {
                EXPECT_EQ(p.normals[v * 3 + c], normals[f][c]) << "face " << f;
                if (normals[f][c] != 0) {
                    EXPECT_EQ(p.positions[v * 3 + c], normals[f][c]); // on its plane
                }
            }
            umin = std::min(umin, p.uv0[v * 2]), umax = std::max(umax, p.uv0[v * 2]);
            vmin = std::min(vmin, p.uv0[v * 2 + 1]), vmax = std::max(vmax, p.uv0[v * 2 + 1]);
        }
        EXPECT_EQ(umin, 0.0f);
        EXPECT_EQ(umax, 1.0f);
        EXPECT_EQ(vmin, 0.0f);
        EXPECT_EQ(vmax, 1.0f);
        // Triangles of the face wind around its normal.
        for (int t = 0; t < 2; ++t) {
            const uint32_t* tri = &p.indices[size_t(f * 6 + t * 3)];
            const float *a = &p.positions[tri[0] * 3], *b = &p.positions[tri[1] * 3], *c = &p.positions[tri[2] * 3];
            float e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
            EXPECT_GT(n[0] * normals[f][0] + n[1] * normals[f][1] + n[2] * normals[f][2], 0.0f);
        }
    }
    // Side faces: v = 0 at the top (+y).
    for (int f : {0, 1, 4, 5})
        for (int k = 0; k < 4; ++k) {
            size_t v = size_t(f * 4 + k);
            EXPECT_EQ(p.uv0[v * 2 + 1], p.positions[v * 3 + 1] > 0 ? 0.0f : 1.0f);
        }
}

TEST(box, WeldedCornerLayout) {
    Primitive p = shapes::box(2.0f, 4.0f, 6.0f, false);
    for (int i = 0; i < 8; ++i) {
        EXPECT_EQ(p.positions[size_t(i) * 3 + 0], (i & 1) ? 1.0f : -1.0f);
        EXPECT_EQ(p.positions[size_t(i) * 3 + 1], (i & 2) ? 2.0f : -2.0f);
        EXPECT_EQ(p.positions[size_t(i) * 3 + 2], (i & 4) ? 3.0f : -3.0f);
        EXPECT_NEAR(p.normals[size_t(i) * 3], ((i & 1) ? 1 : -1) / std::sqrt(3.0), 1e-6);
    }
}

// ---------------------------------------------------------------------------------------------------------
TEST(torus, CountsMatchHeader) {
    for (auto [s, t] : std::vector<std::pair<int, int>>{{3, 3}, {24, 12}, {48, 7}}) {
        Primitive p = shapes::torus(1.0f, 0.25f, s, t);
        EXPECT_EQ(p.vertex_count(), size_t((s + 1) * (t + 1)));
        EXPECT_EQ(p.triangle_count(), size_t(2 * s * t));
        EXPECT_EQ(topology(p).welded, size_t(s * t));
        expect_indices_in_range(p);
    }
}

TEST(torus, ClosedGenusOneWithAnalyticNormals) {
    const double R = 1.0, r = 0.3;
    Primitive p = shapes::torus(float(R), float(r), 48, 24);
    expect_closed_manifold(p, 0);
    expect_unit_normals(p);
    expect_uv_in_unit_square(p);
    double v = topology(p).signed_volume, exact = 2 * pi * pi * R * r * r;
    EXPECT_NEAR(v, exact, 0.02 * exact);
    for (size_t i = 0; i < p.vertex_count(); ++i) {
        // position = tube centre + r * normal, the tube centre on the circle of radius R in y = 0.
        double c[3];
        for (int k = 0; k < 3; ++k) c[k] = p.positions[i * 3 + k] - r * p.normals[i * 3 + k];
        ASSERT_NEAR(c[1], 0.0, 1e-6);
        ASSERT_NEAR(std::hypot(c[0], c[2]), R, 1e-6);
    }
}

TEST(torus, BothSeamsAreBitIdenticalCopies) {
    const int S = 12, T = 6;
    Primitive p = shapes::torus(1.0f, 0.3f, S, T);
    const size_t row = S + 1;
    for (size_t j = 0; j <= size_t(T); ++j)
        for (int k = 0; k < 3; ++k) EXPECT_EQ(p.positions[(j * row) * 3 + k], p.positions[(j * row + S) * 3 + k]);
    for (size_t i = 0; i < row; ++i)
        for (int k = 0; k < 3; ++k) EXPECT_EQ(p.positions[i * 3 + k], p.positions[(T * row + i) * 3 + k]);
}

// ---------------------------------------------------------------------------------------------------------
TEST(creature, CountsMatchHeader) {
    Primitive p = shapes::creature();
    EXPECT_EQ(p.vertex_count(), size_t(63 * 129 + 2 * 128));
    EXPECT_EQ(p.triangle_count(), 16128u);
    EXPECT_GE(p.triangle_count(), 5000u);
    EXPECT_LE(p.triangle_count(), 20000u);
    Primitive small = shapes::creature(20, 10);
    Primitive sphere = shapes::uv_sphere(1.0f, 20, 10);
    EXPECT_EQ(small.vertex_count(), sphere.vertex_count());
    EXPECT_EQ(small.indices, sphere.indices);
    EXPECT_EQ(small.uv0, sphere.uv0);
}

TEST(creature, ClosedManifoldAfterWelding) {
    Primitive p = shapes::creature();
    expect_closed_manifold(p, 2);
    expect_unit_normals(p);
    expect_uv_in_unit_square(p);
    EXPECT_EQ(topology(p).welded, size_t(63 * 128 + 2));
}

TEST(creature, CheckPrimitiveAgrees) {
    Primitive p = shapes::creature();
    CheckReport r = check_primitive(p);
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.boundary_edges, 0u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.degenerate_faces, 0u);
    EXPECT_EQ(r.zero_area_faces, 0u);
    EXPECT_EQ(r.slivers, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_EQ(r.valence2_interior_vertices, 0u);
    EXPECT_EQ(r.welded_vertices, size_t(63 * 128 + 2));
    EXPECT_TRUE(r.has_uv);
}

TEST(creature, StandsOnGroundFacingPlusZ) {
    Primitive p = shapes::creature();
    float lo[3] = {1e9f, 1e9f, 1e9f}, hi[3] = {-1e9f, -1e9f, -1e9f};
    for (size_t i = 0; i < p.positions.size(); ++i)
        lo[i % 3] = std::min(lo[i % 3], p.positions[i]), hi[i % 3] = std::max(hi[i % 3], p.positions[i]);
    EXPECT_NEAR(lo[1], 0.0f, 0.01f);           // paw soles on y = 0
    EXPECT_NEAR(hi[1], 1.05f, 0.1f);           // ear tips
    EXPECT_NEAR(hi[0], -lo[0], 1e-6f);         // symmetric left/right
    EXPECT_GT(hi[2], -lo[2] * 0.9f);           // the nose end reaches about as far as the tail end
    const auto& L = shapes::creature_landmarks();
    EXPECT_NEAR(L.nose_tip[2], hi[2], 0.01f); // the nose is the front-most point
    EXPECT_GT(L.eye_left[0], 0.0f);
    EXPECT_LT(L.eye_right[0], 0.0f);
}

TEST(creature, NormalsPointOutward) {
    Primitive p = shapes::creature();
    const auto& c = shapes::creature_landmarks().centre;
    size_t inward = 0;
    for (size_t i = 0; i < p.vertex_count(); ++i) {
        double d = 0;
        for (int k = 0; k < 3; ++k) d += (p.positions[i * 3 + k] - c[size_t(k)]) * p.normals[i * 3 + k];
        if (d <= 0) ++inward;
    }
    EXPECT_EQ(inward, 0u);
}

TEST(creature, SurfaceFunctionMatchesVertices) {
    const int S = 32, R = 16;
    Primitive p = shapes::creature(S, R);
    for (size_t i = 0; i < p.vertex_count(); i += 7) {
        shapes::SurfacePoint s = shapes::creature_surface(p.uv0[i * 2], p.uv0[i * 2 + 1]);
        for (int k = 0; k < 3; ++k) {
            ASSERT_NEAR(s.position[size_t(k)], p.positions[i * 3 + k], 1e-5) << "vertex " << i;
            ASSERT_NEAR(s.normal[size_t(k)], p.normals[i * 3 + k], 1e-4) << "vertex " << i;
        }
    }
}

TEST(creature, Deterministic) { EXPECT_TRUE(same_bytes(shapes::creature(48, 24), shapes::creature(48, 24))); }

// ---------------------------------------------------------------------------------------------------------
// The library's own checker sees the same topology as the edge map above.
TEST(shapes, CheckPrimitiveAgreesOnEveryShape) {
    struct Case {
        const char* name;
        Primitive primitive;
        size_t welded;
        bool closed;
    };
    std::vector<Case> cases;
    cases.push_back({"uv_sphere", shapes::uv_sphere(1.0f, 24, 12), 11 * 24 + 2, true});
    cases.push_back({"icosphere", shapes::icosphere(1.0f, 2), 162, true});
    cases.push_back({"box split", shapes::box(1.0f, 2.0f, 3.0f, true), 8, true});
    cases.push_back({"box welded", shapes::box(1.0f, 2.0f, 3.0f, false), 8, true});
    cases.push_back({"torus", shapes::torus(1.0f, 0.3f, 24, 12), 24 * 12, true});
    cases.push_back({"grid", shapes::grid(2.0f, 2.0f, 6, 5), 7 * 6, false});
    cases.push_back({"quad_grid", shapes::quad_grid(2.0f, 2.0f, 6, 5), 7 * 6, false});
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        CheckReport r = check_primitive(c.primitive);
        EXPECT_EQ(r.closed, c.closed);
        EXPECT_EQ(r.components, 1u);
        EXPECT_EQ(r.welded_vertices, c.welded);
        EXPECT_EQ(r.duplicate_vertices, c.primitive.vertex_count() - c.welded);
        EXPECT_EQ(r.unreferenced_vertices, 0u);
        EXPECT_EQ(r.non_manifold_edges, 0u);
        EXPECT_EQ(r.non_manifold_vertices, 0u);
        EXPECT_EQ(r.degenerate_faces, 0u);
        EXPECT_EQ(r.zero_area_faces, 0u);
        EXPECT_EQ(r.slivers, 0u);
        EXPECT_EQ(r.inconsistent_edges, 0u);
        EXPECT_EQ(r.nan_values, 0u);
        EXPECT_EQ(r.boundary_edges, c.closed ? 0u : 22u);
        EXPECT_EQ(r.boundary_loops, c.closed ? 0u : 1u);
        EXPECT_EQ(r.has_uv, !c.primitive.uv0.empty());
    }
}

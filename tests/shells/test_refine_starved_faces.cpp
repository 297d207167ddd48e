// Coarse meshes at concave corners (refine_starved_faces.cpp): a cabinet whose shelves are 2 long triangles
// each, every shelf corner where the shelf meets a wall. Clamped to 0 there, the corners once left every
// shelf bald; refined, the fur reaches its length over the shelves.
#include "test_support.h"

#include <furrow/shapes.h>
#include <furrow/shells.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

using namespace furrow;

namespace {

// The inside of a printed bookshelf, as thingi10k's are modelled (normals into the compartments): the two
// side walls and the back are one long quad each over the whole height, and `shelves` slabs of w × d, t
// thick, h apart, each a top (2 triangles: the floor a test measures), an underside and a front edge. Every
// shelf corner lies on a wall's face without being one of its vertices (a T-junction), so the fur there
// would reach into the wall: every shelf vertex clamps to 0.
Primitive cabinet(int shelves, float w, float h, float d, float t) {
    Primitive p;
    auto quad = [&](std::array<float, 3> a, std::array<float, 3> b, std::array<float, 3> c, std::array<float, 3> e) {
        const uint32_t base = uint32_t(p.vertex_count());
        for (const auto& q : {a, b, c, e}) p.positions.insert(p.positions.end(), q.begin(), q.end());
        p.indices.insert(p.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    };
    const float top = float(shelves) * (h + t);
    quad({0, 0, 0}, {0, top, 0}, {0, top, d}, {0, 0, d}); // left wall, normal +x
    quad({w, 0, d}, {w, top, d}, {w, top, 0}, {w, 0, 0}); // right wall, normal −x
    quad({0, 0, 0}, {w, 0, 0}, {w, top, 0}, {0, top, 0}); // back wall, normal +z
    for (int s = 0; s < shelves; ++s) {
        const float y = float(s) * (h + t) + t; // the shelf's top
        quad({0, y, d}, {w, y, d}, {w, y, 0}, {0, y, 0});             // top, normal +y
        quad({0, y - t, 0}, {w, y - t, 0}, {w, y - t, d}, {0, y - t, d}); // underside, normal −y
        quad({0, y - t, d}, {w, y - t, d}, {w, y, d}, {0, y, d});     // front edge, normal +z
    }
    p.normals.assign(p.positions.size(), 0.0f);
    compute_vertex_normals(p.normals.data(), p.positions.data(), p.vertex_count(), p.indices.data(), p.indices.size());
    p.uv0.assign(2 * p.vertex_count(), 0.5f);
    return p;
}

// The fraction of the floors' area over which the fur reaches `fraction` of its requested length (frame
// lengths interpolated over the triangles, sampled on a barycentric grid).
double floor_coverage(const Scene& s, const FurReport& rep, float fraction) {
    double covered = 0, total = 0;
    for (const FurFrame& ff : rep.frames) {
        const auto& P = s.meshes[ff.mesh].primitives[ff.primitive].positions;
        for (size_t t = 0; t + 2 < ff.triangles.size(); t += 3) {
            const uint32_t* c = &ff.triangles[t];
            double e1[3], e2[3];
            for (int k = 0; k < 3; ++k) e1[k] = P[3 * c[1] + k] - P[3 * c[0] + k], e2[k] = P[3 * c[2] + k] - P[3 * c[0] + k];
            const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
            const double area = 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (!(area > 0) || n[1] / (2 * area) < 0.99) continue; // floors face up
            const int N = 12;
            for (int i = 0; i <= N; ++i)
                for (int j = 0; i + j <= N; ++j) {
                    const double b1 = double(i) / N, b2 = double(j) / N, b0 = 1 - b1 - b2;
                    const double len = b0 * ff.frame.length[c[0]] + b1 * ff.frame.length[c[1]] + b2 * ff.frame.length[c[2]];
                    const double req = b0 * ff.frame.requested[c[0]] + b1 * ff.frame.requested[c[1]] + b2 * ff.frame.requested[c[2]];
                    const double w = area / double((N + 1) * (N + 2) / 2);
                    total += w;
                    covered += len >= fraction * req ? w : 0.0;
                }
        }
    }
    return total > 0 ? covered / total : 0.0;
}

} // namespace

TEST(RefineStarvedFaces, FurGrowsOnCoarseShelves) {
    const Scene input = make_scene(cabinet(3, 1.0f, 0.3f, 0.35f, 0.018f), "cabinet");
    FurOptions o;
    o.shells.layers = 8;
    o.shells.length = 0.015;
    o.keep_frames = true;
    // Without refinement: bald shelves.
    Scene coarse = input;
    FurOptions off = o;
    off.refine_starved = false;
    FurReport before;
    ASSERT_TRUE(add_fur_shells(coarse, off, &before).ok());
    const double bald = floor_coverage(coarse, before, 0.8f);
    EXPECT_LT(bald, 0.05);
    // With it (the default).
    Scene s = input;
    FurReport rep;
    ASSERT_TRUE(add_fur_shells(s, o, &rep).ok());
    const double coverage = floor_coverage(s, rep, 0.8f);
    std::printf("shelves: fur >= 0.8 L over %.1f %% of the shelf area (%.1f %% unrefined), %zu faces split, %zu -> %zu base triangles\n",
                100 * coverage, 100 * bald, rep.refined_faces, before.base_triangles, rep.base_triangles);
    if (std::getenv("DEBUG_SHELF")) {
        const FurFrame& ff = rep.frames[0];
        const auto& P = s.meshes[0].primitives[0].positions;
        for (size_t v = 0; v < P.size() / 3; ++v)
            if (std::abs(P[3 * v + 1] - 0.018f) < 1e-4f)
                std::printf("v %zu (%.3f %.3f %.3f) len %.4f req %.4f flags %d dir (%.2f %.2f %.2f)\n", v, P[3 * v], P[3 * v + 1], P[3 * v + 2], ff.frame.length[v],
                            ff.frame.requested[v], ff.frame.flags[v], ff.frame.direction[3 * v], ff.frame.direction[3 * v + 1], ff.frame.direction[3 * v + 2]);
    }
    EXPECT_GE(coverage, 0.9);
    EXPECT_GT(rep.refined_faces, 0u);
    // The base surface is the same surface: every new vertex lies on its original face (the floors stay flat).
    const Primitive& base = s.meshes[0].primitives[0];
    const Primitive& original = input.meshes[0].primitives[0];
    EXPECT_EQ(check_primitive(base).non_manifold_edges, check_primitive(original).non_manifold_edges);
    auto area = [](const Primitive& q) {
        double sum = 0;
        for (size_t t = 0; t + 2 < q.indices.size(); t += 3) {
            const float* a = &q.positions[3 * q.indices[t]];
            const float* b = &q.positions[3 * q.indices[t + 1]];
            const float* c = &q.positions[3 * q.indices[t + 2]];
            const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            sum += 0.5 * std::hypot(e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]);
        }
        return sum;
    };
    EXPECT_NEAR(area(base), area(original), 1e-5 * area(original));
}

// The output-size guard holds after refinement: the refined base's shells stay within max_triangles (once
// the guard judged the coarse base, and the refinement could grow it 100-fold past the limit).
TEST(RefineStarvedFaces, StaysWithinTheTriangleLimit) {
    Scene s = make_scene(cabinet(3, 1.0f, 0.3f, 0.35f, 0.018f), "cabinet");
    FurOptions o;
    o.shells.layers = 8;
    o.shells.length = 0.015;
    o.max_triangles = 8 * 600; // room for 600 base triangles of 8 shells each; the cabinet has 24
    FurReport rep;
    ASSERT_TRUE(add_fur_shells(s, o, &rep).ok());
    EXPECT_GT(rep.refined_faces, 0u);
    EXPECT_LE(rep.base_triangles, 600u);
    EXPECT_LE(rep.shell_triangles, o.max_triangles);
    // And FurOptions::refine_budget bounds it on its own.
    Scene t = make_scene(cabinet(3, 1.0f, 0.3f, 0.35f, 0.018f), "cabinet");
    FurOptions b = o;
    b.max_triangles = 0;
    b.refine_budget = 100;
    FurReport small;
    ASSERT_TRUE(add_fur_shells(t, b, &small).ok());
    EXPECT_LE(small.base_triangles, 8u * 24u + 100u);
    EXPECT_GT(small.refined_faces, 0u);
}

// A fur mask's own edges are not clamps: a grid whose mask drops from 1 to 0 across its middle keeps its
// triangles (once they counted as "uneven" and were split down to twice the fur: the masked creature grew
// from 16k to 75k base triangles and its setup from 60 ms to 3.6 s).
TEST(RefineStarvedFaces, MaskEdgesAreNotRefined) {
    Primitive p = shapes::quad_grid(1, 1, 4, 4);
    ASSERT_EQ(p.uv0.size(), 2 * p.vertex_count());
    Scene s = make_scene(p, "grid");
    FurOptions o;
    o.shells.layers = 4;
    o.shells.length = 0.01;
    o.mask.width = 8, o.mask.height = 1, o.mask.channels = 1;
    o.mask.pixels = {0, 0, 0, 0, 1, 1, 1, 1};
    FurReport rep;
    ASSERT_TRUE(add_fur_shells(s, o, &rep).ok());
    EXPECT_GT(rep.bald_vertices, 0u); // the mask does bald a part
    EXPECT_EQ(rep.refined_faces, 0u);
    EXPECT_EQ(rep.base_triangles, 32u);
}

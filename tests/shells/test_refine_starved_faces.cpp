// Coarse meshes at concave corners (refine_starved_faces.cpp): a cabinet whose shelves are 2 long triangles
// each, every shelf corner where the shelf meets a wall. Clamped to 0 there, the corners once left every
// shelf bald; refined, the fur reaches its length over the shelves.
#include "test_support.h"

#include <furrow/shapes.h>
#include <furrow/shells.h>

#include "shells_internal.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <set>

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

// refine_starved_faces on `base` with a synthetic regrow: every point asks for fur L and keeps
// length_of(its position) (no direction, lean or sag), the frame the callback and the start both get.
struct SyntheticRefinement {
    Primitive p;
    std::vector<uint32_t> tris;
    shells_detail::Refinement refinement;
    size_t regrown = 0;
    Status status;
};
template <class LengthOf>
SyntheticRefinement refine_synthetic(const Primitive& base, double L, LengthOf length_of, size_t budget, double tolerance) {
    SyntheticRefinement r;
    auto frame_of = [&](const Primitive& q, ShellFrame& f) {
        const size_t n = q.vertex_count();
        f = ShellFrame{};
        f.requested.assign(n, float(L));
        f.length.resize(n);
        for (size_t v = 0; v < n; ++v) f.length[v] = float(length_of(&q.positions[3 * v]));
        f.direction.assign(3 * n, 0.0f), f.lean.assign(3 * n, 0.0f), f.sag.assign(3 * n, 0.0f), f.flags.assign(n, 0);
        return Status::success();
    };
    r.tris = base.indices;
    ShellFrame frame;
    (void)frame_of(base, frame);
    r.status = shells_detail::refine_starved_faces(
        base, r.p, r.tris, frame, L,
        [&](const Primitive& q, const std::vector<uint32_t>&, ShellFrame& f) { return ++r.regrown, frame_of(q, f); }, budget, tolerance,
        r.refinement);
    EXPECT_EQ(r.refinement.rounds, r.regrown); // a round is one regrowth
    return r;
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
    EXPECT_GT(rep.refine_rounds, 0u);
    EXPECT_LE(rep.refine_rounds, 16u); // one primitive, at most 16 rounds
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

// Two marked edges of one triangle are both bisected in the same round (refine_starved_faces.cpp,
// bisect_pass): every round regrows the whole frame, and a split that waited for the next round cost one.
// A unit triangle ABC between two flat ones, ADB and BEC, whose longest edges are AB and BC: the fur at D and
// E is short (0.3 of the length asked), so both flat triangles are uneven and their longest edges, longer
// than twice the fur, are marked; ABC holds both. After one round every triangle's longest edge is under
// twice the fur or its corners are even: one regrowth, and the refinement has no T-junction.
TEST(RefineStarvedFaces, TwoMarkedEdgesOfOneTriangleSplitInOneRound) {
    const float h = 0.8660254f; // the unit triangle's height
    Primitive base;
    base.positions = {0, 0, 0,           // A
                      1, 0, 0,           // B
                      0.5f, h, 0,        // C
                      0.5f, -0.3f, 0,    // D, below AB
                      1.0098f, 0.583f, 0}; // E, 0.3 beyond BC's midpoint (0.75, 0.433)
    base.indices = {0, 1, 2, 0, 3, 1, 1, 4, 2};
    const double L = 0.35; // 2L = 0.7: AB and BC (1) are longer, every flat child's edges (at most 0.59) shorter
    auto length_of = [&](const float* x) { // D and E keep 0.3 of the fur
        const bool outer = (x[0] == 0.5f && x[1] == -0.3f) || (x[0] == 1.0098f && x[1] == 0.583f);
        return outer ? 0.3 * L : L;
    };
    const SyntheticRefinement r = refine_synthetic(base, L, length_of, 1000, FurOptions{}.refine_tolerance);
    ASSERT_TRUE(r.status.ok()) << r.status.message;
    EXPECT_EQ(r.regrown, 1u); // (waiting, BC was split a round after AB: 2)
    EXPECT_EQ(r.refinement.faces_split, 4u); // ADB and ABC at AB's midpoint, BEC and ABC's child at BC's
    const std::vector<uint32_t>& tris = r.tris;
    ASSERT_EQ(tris.size(), 3u * 7u);
    // Conforming: an edge held by one triangle only is one of the outline's five (A-D, D-B, B-E, E-C, C-A).
    std::map<std::pair<uint32_t, uint32_t>, int> uses;
    for (size_t t = 0; t < tris.size(); t += 3)
        for (int k = 0; k < 3; ++k) {
            const uint32_t a = tris[t + size_t(k)], b = tris[t + size_t((k + 1) % 3)];
            ++uses[{std::min(a, b), std::max(a, b)}];
        }
    const std::set<std::pair<uint32_t, uint32_t>> outline = {{0, 3}, {1, 3}, {1, 4}, {2, 4}, {0, 2}};
    for (const auto& [edge, n] : uses) {
        EXPECT_LE(n, 2);
        if (n == 1) {
            EXPECT_TRUE(outline.count(edge)) << edge.first << "-" << edge.second << " is a T-junction";
        }
    }
}

// The refinement stops once it has converged (refine_starved_faces.cpp, FurOptions::refine_tolerance): every
// round regrows the whole frame, and rounds that change the fur by less than 0.1 % of what is asked over the
// furred area are not worth one. A 4 x 1 strip whose fur grows only at its two right corners (every other
// point, each midpoint included, is clamped to 0, as in a crevice that stays one) holds uneven triangles at
// every depth, longer than twice the fur; beside it a 100 x 100 floor with all its fur, so that the strip's
// splits move the share of the fur kept by less than 4e-4 a round. Two such rounds in a row end it: 2
// regrowths; with tolerance 0, 15.
TEST(RefineStarvedFaces, StopsOnceRoundsChangeTheFurByTooLittle) {
    Primitive base;
    base.positions = {0, 0, 0, 4, 0, 0, 4, 1, 0, 0, 1, 0,                  // the strip
                      0, 10, 5, 100, 10, 5, 100, 110, 5, 0, 110, 5};     // the floor
    base.indices = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
    const double L = 0.01;
    auto length_of = [&](const float* x) { return x[0] == 4.0f || x[2] == 5.0f ? L : 0.0; };
    auto regrowths = [&](double tolerance) {
        const SyntheticRefinement r = refine_synthetic(base, L, length_of, 100000, tolerance);
        EXPECT_TRUE(r.status.ok()) << r.status.message;
        EXPECT_GT(r.refinement.faces_split, 0u);
        return r.regrown;
    };
    EXPECT_EQ(regrowths(FurOptions{}.refine_tolerance), 2u);
    EXPECT_EQ(regrowths(0.0), 15u);
}

// The tolerance is checked with the other options.
TEST(RefineStarvedFaces, RejectsABadTolerance) {
    for (double bad : {-1e-3, 1.5, std::nan("")}) {
        Scene s = make_scene(cabinet(1, 1.0f, 0.3f, 0.35f, 0.018f), "cabinet");
        FurOptions o;
        o.shells.layers = 4;
        o.shells.length = 0.015;
        o.refine_tolerance = bad;
        EXPECT_EQ(add_fur_shells(s, o).code, StatusCode::invalid_argument) << bad;
        EXPECT_EQ(s.meshes[0].primitives.size(), 1u);
    }
}

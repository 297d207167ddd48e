// compute_shell_frame / shell_positions: no cracks, mask and comb handling, clamps, options, determinism.
#include "shells_test_util.h"

#include <furrow/shapes.h>
#include <furrow/shells.h>
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <cmath>
#include <cstring>

namespace furrow {
namespace {

ShellFrame frame_of(const Primitive& p, const ShellOptions& o, const std::vector<float>& mask = {},
                    const std::vector<float>& comb = {}) {
    Primitive t = p;
    triangulate(t);
    ShellFrame f;
    Status s = compute_shell_frame(f, t.positions.data(), t.vertex_count(), t.indices.data(), t.indices.size(),
                                   mask.empty() ? nullptr : mask.data(), comb.empty() ? nullptr : comb.data(), o);
    EXPECT_TRUE(s.ok()) << s.message;
    return f;
}

TEST(compute_shell_frame, SplitCopiesGetOnePositionPerShell) {
    // Hard edges (split box: per-face normals), UV seams (sphere, torus), and a mask that differs on the
    // two sides of every seam: a per-copy computation would crack on each of them.
    const std::vector<Primitive> shapes_ = {shapes::box(1, 1, 1, true), shapes::uv_sphere(0.5f, 24, 12),
                                            shapes::torus(1.0f, 0.3f, 24, 12)};
    for (const Primitive& p : shapes_) {
        ShellOptions o;
        o.layers = 8;
        o.length = 0.05;
        o.droop = 0.5;
        std::vector<float> mask(p.vertex_count());
        for (size_t v = 0; v < mask.size(); ++v) mask[v] = float((v * 7919) % 101) / 100.0f; // differs per copy
        std::vector<float> comb(3 * p.vertex_count());
        for (size_t v = 0; v < comb.size(); ++v) comb[v] = float((v * 104729) % 17) / 17.0f - 0.5f;
        ShellFrame f = frame_of(p, o, mask, comb);
        EXPECT_EQ(test::cracked_positions(p, f, o.layers), 0u);
        // And the copies really were different before reconciliation: the max rule picked one value.
        std::vector<uint32_t> remap(p.vertex_count());
        weld_positions(remap.data(), p.positions.data(), p.vertex_count());
        for (size_t v = 0; v < p.vertex_count(); ++v) EXPECT_EQ(f.requested[v], f.requested[remap[v]]);
    }
}

TEST(compute_shell_frame, MaskSeamsTakeTheMaximum) {
    Primitive p = shapes::box(2, 2, 2, true); // every corner has 3 copies
    std::vector<float> mask(p.vertex_count(), 0.2f);
    mask[0] = 0.9f; // one copy of one corner
    ShellOptions o;
    o.length = 0.1;
    ShellFrame f = frame_of(p, o, mask);
    std::vector<uint32_t> remap(p.vertex_count());
    weld_positions(remap.data(), p.positions.data(), p.vertex_count());
    for (size_t v = 0; v < p.vertex_count(); ++v) {
        const float want = remap[v] == remap[0] ? 0.09f : 0.02f;
        EXPECT_NEAR(f.requested[v], want, 1e-6) << v;
    }
}

TEST(compute_shell_frame, EvenThicknessPutsShellsAtTheRequestedDistance) {
    // Convex corners (a welded cube): each corner moves by √3·L along (1,1,1)/√3, so every shell face is
    // parallel to its base face at exactly L (the mitered offset), at every layer.
    Primitive cube = shapes::box(1, 1, 1, false);
    ShellOptions o;
    o.length = 0.1;
    ShellFrame f = frame_of(cube, o);
    for (size_t v = 0; v < cube.vertex_count(); ++v) EXPECT_NEAR(f.length[v], 0.1 * std::sqrt(3.0), 1e-6) << v;
    EXPECT_EQ(f.clamped_vertices, 0u);
    for (int layer : {1, o.layers / 2, o.layers}) {
        std::vector<float> shell(cube.positions.size());
        shell_positions(shell.data(), f, cube.positions.data(), cube.vertex_count(), layer, o.layers, 1.0);
        const double want = 0.1 * shell_height_fraction(layer, o.layers, 1.0);
        for (size_t v = 0; v < cube.vertex_count(); ++v)
            for (int axis = 0; axis < 3; ++axis) // the cube spans [-0.5, 0.5]: each face plane moved by L
                EXPECT_NEAR(std::abs(shell[3 * v + size_t(axis)]) - 0.5, want, 1e-6) << v << " axis " << axis;
    }
    // Concave crease (the inner edge of an L): 1/cos(45°), so each wall's shell is L away from that wall.
    Primitive l = test::voxel_surface(8, 8, 3, 0.1f, [](int x, int y, int) { return x < 2 || y < 2; });
    o.length = 0.01; // well below the edge length: no clamp involved
    f = frame_of(l, o);
    size_t checked = 0;
    for (size_t v = 0; v < l.vertex_count(); ++v) {
        const float* p = &l.positions[3 * v];
        if (std::abs(p[0] - 0.2f) < 1e-6f && std::abs(p[1] - 0.2f) < 1e-6f && std::abs(p[2] - 0.1f) < 1e-6f) {
            EXPECT_NEAR(f.length[v], 0.01 * std::sqrt(2.0), 1e-6);
            std::vector<float> top(3 * l.vertex_count());
            shell_positions(top.data(), f, l.positions.data(), l.vertex_count(), o.layers, o.layers, 1.0);
            EXPECT_NEAR(top[3 * v] - 0.2f, 0.01f, 1e-6);
            EXPECT_NEAR(top[3 * v + 1] - 0.2f, 0.01f, 1e-6);
            ++checked;
        }
    }
    EXPECT_EQ(checked, 1u);
}

TEST(compute_shell_frame, ZeroMaskIsBaldAndGradientIsFollowed) {
    Primitive p = shapes::grid(1, 1, 16, 16);
    std::vector<float> mask(p.vertex_count());
    for (size_t v = 0; v < mask.size(); ++v) mask[v] = std::max(0.0f, p.uv0[2 * v] * 2 - 1); // 0 on the left half
    ShellOptions o;
    o.length = 0.05;
    ShellFrame f = frame_of(p, o, mask);
    for (size_t v = 0; v < p.vertex_count(); ++v) {
        const float u = p.uv0[2 * v];
        if (u <= 0.5f) {
            EXPECT_EQ(f.length[v], 0.0f) << v;
        }
        // A flat open sheet: nothing in front, no fold, so the length is exactly L·mask (the boundary's
        // pseudo-normal is still +y on a flat sheet).
        EXPECT_NEAR(f.length[v], 0.05 * mask[v], 1e-6) << v;
        EXPECT_NEAR(f.direction[3 * v + 1], 1.0f, 1e-6);
    }
    EXPECT_EQ(f.clamped_vertices, 0u);
}

TEST(compute_shell_frame, CombAndDroopNeverPushIntoTheSkin) {
    Primitive p = shapes::uv_sphere(1.0f, 32, 16);
    ShellOptions o;
    o.length = 0.05;
    o.droop = 1.0;
    std::vector<float> comb(3 * p.vertex_count(), 0.0f);
    for (size_t v = 0; v < p.vertex_count(); ++v) comb[3 * v] = 1.0f; // comb toward +x everywhere
    ShellFrame f = frame_of(p, o, {}, comb);
    for (size_t v = 0; v < p.vertex_count(); ++v) {
        double dl = 0, ds = 0;
        for (int k = 0; k < 3; ++k) {
            dl += double(f.lean[3 * v + k]) * f.direction[3 * v + k];
            ds += double(f.sag[3 * v + k]) * f.direction[3 * v + k];
        }
        // Never toward the skin (faces' planes are respected too, so a bend may lift a little).
        EXPECT_GE(dl, -1e-6);
        EXPECT_GE(ds, -1e-6);
        EXPECT_LT(dl, 0.2);
        EXPECT_LT(ds, 0.2);
    }
    // The equator's bend points down (gravity along the surface) by droop·17.5°, the poles' vanishes.
    size_t equator = 0;
    for (size_t v = 0; v < p.vertex_count(); ++v)
        if (std::abs(p.positions[3 * v + 1]) < 1e-3) {
            EXPECT_NEAR(f.sag[3 * v + 1], -17.5 * M_PI / 180.0, 0.01);
            ++equator;
        }
    EXPECT_GT(equator, 0u);
}

// Droop bends strands and keeps their length (it used to shift tips sideways by up to 4 L, and the fold clamp
// then cut the creature's fur to a quarter of its length at droop 2). On a sphere at droop 4, the top of the
// range, every strand's polyline through its 16 shells is within 5 % of its length, unclamped, and the
// equator's tips hang down: lowered by at least 0.3 of the length against a straight strand.
TEST(compute_shell_frame, DroopBendsStrandsAndKeepsTheirLength) {
    Primitive p = shapes::uv_sphere(1.0f, 48, 24);
    ShellOptions o;
    o.length = 0.1;
    o.layers = 16;
    o.droop = 4.0;
    ShellFrame f = frame_of(p, o);
    EXPECT_LT(f.clamped_vertices, f.welded_vertices / 20);
    std::vector<std::vector<float>> shells(size_t(o.layers) + 1, p.positions);
    for (int i = 1; i <= o.layers; ++i)
        shell_positions(shells[size_t(i)].data(), f, p.positions.data(), p.vertex_count(), i, o.layers, 1.0);
    size_t kept = 0, equator = 0;
    for (size_t v = 0; v < p.vertex_count(); ++v) {
        double arc = 0;
        for (int i = 1; i <= o.layers; ++i) {
            double d2 = 0;
            for (int k = 0; k < 3; ++k) d2 += std::pow(double(shells[size_t(i)][3 * v + k]) - shells[size_t(i - 1)][3 * v + k], 2);
            arc += std::sqrt(d2);
        }
        kept += std::abs(arc - f.length[v]) <= 0.05 * f.length[v] && f.length[v] >= 0.95 * o.length;
        if (std::abs(p.positions[3 * v + 1]) < 1e-3) {
            ++equator;
            EXPECT_LT(shells.back()[3 * v + 1] - p.positions[3 * v + 1], -0.3 * o.length) << v;
        }
    }
    EXPECT_GE(double(kept), 0.95 * double(p.vertex_count()));
    EXPECT_GT(equator, 0u);
}

TEST(compute_shell_frame, RejectsBadOptions) {
    Primitive p = shapes::box(1, 1, 1, false);
    ShellFrame f;
    auto run = [&](ShellOptions o) {
        return compute_shell_frame(f, p.positions.data(), p.vertex_count(), p.indices.data(), p.indices.size(), nullptr, nullptr, o).code;
    };
    ShellOptions o;
    o.layers = 0;
    EXPECT_EQ(run(o), StatusCode::invalid_argument);
    o.layers = 257;
    EXPECT_EQ(run(o), StatusCode::invalid_argument);
    o = {};
    o.length = -1;
    EXPECT_EQ(run(o), StatusCode::invalid_argument);
    o.length = std::nan("");
    EXPECT_EQ(run(o), StatusCode::invalid_argument);
    o = {};
    o.spacing_power = 0;
    EXPECT_EQ(run(o), StatusCode::invalid_argument);
    std::vector<uint32_t> bad_indices{0, 1, 99};
    EXPECT_EQ(compute_shell_frame(f, p.positions.data(), p.vertex_count(), bad_indices.data(), 3, nullptr, nullptr, {}).code,
              StatusCode::invalid_argument);
}

TEST(compute_shell_frame, IdenticalForAnyThreadCount) {
    Primitive p = shapes::torus(1.0f, 0.8f, 64, 32);
    ShellOptions o;
    o.length = 0.3;
    o.droop = 0.7;
    o.layers = 8;
    ShellFrame a, b;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        a = frame_of(p, o);
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        b = frame_of(p, o);
    }
    EXPECT_EQ(a.length, b.length);
    EXPECT_EQ(a.direction, b.direction);
    EXPECT_EQ(a.sag, b.sag);
    EXPECT_GT(a.clamped_vertices, 0u); // the hole is small for that length: the case is not trivial
}

TEST(shell_height_fraction, LinearAndPower) {
    EXPECT_DOUBLE_EQ(shell_height_fraction(4, 8, 1.0), 0.5);
    EXPECT_DOUBLE_EQ(shell_height_fraction(8, 8, 2.0), 1.0);
    EXPECT_DOUBLE_EQ(shell_height_fraction(4, 8, 2.0), 0.25);
}

} // namespace
} // namespace furrow

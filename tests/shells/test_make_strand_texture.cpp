// Strand density and fin textures: deterministic, tapered, tiling.
#include <furrow/shells.h>
#include <gtest/gtest.h>

namespace furrow {
namespace {

double coverage(const std::vector<uint8_t>& rgba, double at_least) {
    size_t on = 0, n = rgba.size() / 4;
    for (size_t i = 0; i < n; ++i) on += rgba[4 * i + 3] / 255.0 >= at_least;
    return double(on) / double(n);
}

TEST(make_strand_texture, DeterministicPerSeed) {
    StrandTextureOptions o;
    o.size = 64;
    o.strands = 100;
    EXPECT_EQ(make_strand_texture(o), make_strand_texture(o));
    StrandTextureOptions other = o;
    other.seed = 2;
    EXPECT_NE(make_strand_texture(o), make_strand_texture(other));
    EXPECT_EQ(make_strand_texture(o).size(), size_t(64 * 64 * 4));
}

TEST(make_strand_texture, StrandsTaperWithHeight) {
    StrandTextureOptions o;
    auto t = make_strand_texture(o);
    // Each shell higher up shows a thinner slice of every strand.
    double previous = 1.0;
    for (double f : {0.01, 0.2, 0.4, 0.6, 0.8}) {
        double c = coverage(t, f);
        EXPECT_LT(c, previous) << f;
        previous = c;
    }
    EXPECT_GT(coverage(t, 0.01), 0.2);  // dense near the roots
    EXPECT_GT(coverage(t, 0.9), 0.0);   // some tips reach the top shells
    EXPECT_LT(coverage(t, 0.9), 0.02);
}

TEST(make_strand_texture, TilesAcrossTheEdges) {
    // A strand whose axis is near the left edge continues on the right edge.
    StrandTextureOptions o;
    o.size = 32;
    o.strands = 60;
    o.radius = 3;
    o.min_height = 1.0;
    auto t = make_strand_texture(o);
    auto alpha = [&](int x, int y) { return t[4 * (size_t(y) * 32 + size_t(x)) + 3]; };
    // Wrapped neighbours: a texel on the left edge with alpha > 0 has a non-zero texel on the right edge
    // or left edge's neighbours (discs are at least 2 texels wide).
    size_t edge_on = 0, matched = 0;
    for (int y = 0; y < 32; ++y) {
        if (alpha(0, y) > 150) { // within ~1.4 texels of an axis: the disc (radius >= 2.25) crosses the edge
            ++edge_on;
            matched += alpha(31, y) > 0 || (y > 0 && alpha(31, y - 1) > 0) || (y < 31 && alpha(31, y + 1) > 0);
        }
    }
    EXPECT_GT(edge_on, 0u);
    EXPECT_EQ(matched, edge_on);
}

TEST(make_fin_texture, RootsBelowTipsAbove) {
    StrandTextureOptions o;
    o.size = 128;
    auto t = make_fin_texture(o);
    ASSERT_EQ(t.size(), size_t(128 * 64 * 4));
    auto row = [&](int y) {
        size_t on = 0;
        for (int x = 0; x < 128; ++x) on += t[4 * (size_t(y) * 128 + size_t(x)) + 3] > 127;
        return on;
    };
    EXPECT_GT(row(63), row(2));
    EXPECT_GT(row(63), 10u);
}

} // namespace
} // namespace furrow

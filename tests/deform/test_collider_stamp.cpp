// Collider stamps (deform/src/collider_stamp.cpp), internals: an image brush's rows are cut to the brush's
// span in each row, a bound that must never drop a texel the brush writes.
#include "deform_internal.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

using namespace furrow;
using namespace furrow::deform_detail;

// Random brushes (sizes from a texel to a quarter of the grid, every heading including the axis-aligned ones
// where a slab's u coefficient is exactly 0, centres on, near and off the grid, some far from the origin)
// write the same carve bytes and the same result (rectangle, count) with their rows cut as over their whole
// bounding box. Also fails if the cut is too tight by a texel at the brush's rounded edge.
TEST(ColliderStamp, ImageRowSpansWriteWhatTheWholeBoxWrites) {
    const int w = 96, h = 80;
    const double texel = 0.02;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> U01(0.0, 1.0);
    auto image = std::make_shared<ImageF>();
    image->width = 13, image->height = 29, image->channels = 1;
    for (int k = 0; k < image->width * image->height; ++k) image->pixels.push_back(float(0.2 + 0.8 * U01(rng)));
    std::vector<float> ground(size_t(w) * size_t(h));
    for (size_t k = 0; k < ground.size(); ++k) ground[k] = k % 97 == 0 ? NAN : float(0.01 * std::sin(double(k)));
    size_t stamps_writing = 0;
    for (int trial = 0; trial < 400; ++trial) {
        Collider c;
        c.shape = ColliderShape::image;
        c.brush = image;
        c.size = {texel * (1 + 24 * U01(rng)), texel * (1 + 40 * U01(rng)), 0.0};
        c.depth = 0.05;
        const double headings[] = {0.0, 0.5 * std::numbers::pi, std::numbers::pi, 1.5 * std::numbers::pi};
        LocalPose p;
        p.u = (-0.2 + 1.4 * U01(rng)) * (w - 1) * texel, p.v = (-0.2 + 1.4 * U01(rng)) * (h - 1) * texel;
        p.heading = trial % 3 == 0 ? headings[trial % 4] : 2 * std::numbers::pi * U01(rng);
        p.penetration = 0.03;
        SCOPED_TRACE("trial " + std::to_string(trial));
        std::vector<float> cut(ground.size(), 0.0f), whole(ground.size(), 0.0f);
        StampTarget t{cut.data(), ground.data(), w, h, texel, 0.0};
        const StampResult a = stamp_sweep(t, c, p, p, 1.0);
        t.carve = whole.data(), t.whole_boxes = true;
        const StampResult b = stamp_sweep(t, c, p, p, 1.0);
        ASSERT_EQ(std::memcmp(cut.data(), whole.data(), cut.size() * sizeof(float)), 0);
        EXPECT_EQ(a.written, b.written);
        EXPECT_TRUE(a.rect.x0 == b.rect.x0 && a.rect.y0 == b.rect.y0 && a.rect.x1 == b.rect.x1 && a.rect.y1 == b.rect.y1);
        stamps_writing += b.written > 0;
    }
    EXPECT_GT(stamps_writing, 200u); // most brushes reach the grid: the comparison is not vacuous
}

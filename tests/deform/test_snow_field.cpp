// SnowField: analytic imprints, sweeps, compositing, refill, rim volume, dirty rectangles, guards.
#include "deform_test_util.h"
#include "test_support.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <random>

using namespace furrow;
using namespace furrow::test;

namespace {

SnowOptions fine(double texel = 0.01) {
    SnowOptions o;
    o.texel = texel;
    return o;
}

} // namespace

TEST(SnowField, SphereImprintMatchesTheAnalyticCap) {
    const double r = 0.35, p = 0.12;
    for (double texel : {0.02, 0.01}) {
        SnowField f = make_field(flat_ground(4, 1), fine(texel));
        StampStats st;
        ASSERT_TRUE(f.add_collider(sphere(r, {{0.1, r - p, -0.2}}), &st).ok());
        EXPECT_EQ(st.contacts, 1u);
        EXPECT_NEAR(st.deepest, p, 1e-9);
        f.update();
        const Heightmap& h = f.heightmap();
        double worst = 0;
        for (int j = 0; j < h.frame.height; ++j)
            for (int i = 0; i < h.frame.width; ++i) {
                auto xz = texel_xz(h.frame, i, j);
                const double rho = std::hypot(xz[0] - 0.1, xz[1] + 0.2);
                worst = std::max(worst, std::abs(double(h.at(i, j)) - sphere_imprint(r, p, rho)));
            }
        EXPECT_LT(worst, 2e-6) << "texel " << texel; // exact at texel centres, up to float storage
        EXPECT_NEAR(texel_at(h, 0.1, -0.2), -p, 1e-6);
    }
}

TEST(SnowField, BoxImprintIsAFlatRectangle) {
    const double depth = 0.08, heading = 30 * 3.14159265358979 / 180;
    SnowField f = make_field(flat_ground(4, 1), fine(0.01));
    ASSERT_TRUE(f.add_collider(box({0.6, 0.4, 0.8}, 30, {{0.2, 0.2 - depth, 0.1}})).ok());
    f.update();
    const Heightmap& h = f.heightmap();
    size_t inside = 0, outside = 0;
    for (int j = 0; j < h.frame.height; ++j)
        for (int i = 0; i < h.frame.width; ++i) {
            auto xz = texel_xz(h.frame, i, j);
            const double rx = xz[0] - 0.2, rz = xz[1] - 0.1;
            // Local axes: x across = (cos, −sin), z along = (sin, cos) in (x, z).
            const double lx = rx * std::cos(heading) - rz * std::sin(heading), lz = rx * std::sin(heading) + rz * std::cos(heading);
            const double margin = std::min(0.3 - std::abs(lx), 0.4 - std::abs(lz)); // > 0 inside
            const float v = h.at(i, j);
            if (margin > 0.01) {
                ++inside;
                EXPECT_NEAR(v, -depth, 1e-6) << lx << " " << lz;
            } else if (margin < -0.01) {
                ++outside;
                EXPECT_EQ(v, 0.0f) << lx << " " << lz;
            } else {
                EXPECT_TRUE(v <= 0 && v >= -depth - 1e-6); // anti-aliased wall
            }
        }
    EXPECT_GT(inside, 4000u);
    EXPECT_GT(outside, 100000u);
}

TEST(SnowField, CapsuleImprintMatchesItsLowerSurface) {
    // A log lying across its heading (axis along local x = world x for heading 0), pressed p.
    const double r = 0.12, L = 1.0, p = 0.05;
    SnowField f = make_field(flat_ground(4, 1), fine(0.01));
    Collider c = capsule(r, L, {{0, r - p, 0}});
    c.heading = {0};
    ASSERT_TRUE(f.add_collider(c).ok());
    f.update();
    const Heightmap& h = f.heightmap();
    double worst = 0;
    for (int j = 0; j < h.frame.height; ++j)
        for (int i = 0; i < h.frame.width; ++i) {
            auto xz = texel_xz(h.frame, i, j);
            const double ax = std::clamp(xz[0], -L / 2, L / 2); // closest axis point
            const double rho = std::hypot(xz[0] - ax, xz[1]);
            worst = std::max(worst, std::abs(double(h.at(i, j)) - sphere_imprint(r, p, rho)));
        }
    EXPECT_LT(worst, 2e-6);
}

TEST(SnowField, ImagePressesDepthTimesPixelValueTowardTheHeading) {
    // Toe half (top rows) white, heel half black: only the half toward the heading is pressed.
    for (double heading : {0.0, 90.0}) {
        SnowField f = make_field(flat_ground(4, 1), fine(0.01));
        Collider c = image(8, 16, 0.2, 0.4, 0.06, heading, {0, 0, 0}, [](int, int j) { return j < 8 ? 1.0 : 0.0; });
        StampStats st;
        ASSERT_TRUE(f.add_collider(c, &st).ok());
        EXPECT_EQ(st.contacts, 1u);
        f.update();
        const Heightmap& h = f.heightmap();
        const double fx = std::sin(heading * 3.14159265358979 / 180), fz = std::cos(heading * 3.14159265358979 / 180);
        EXPECT_NEAR(texel_at(h, 0.1 * fx, 0.1 * fz), -0.06, 1e-6);  // toe side
        EXPECT_NEAR(texel_at(h, -0.1 * fx, -0.1 * fz), 0.0, 1e-6);  // heel side
        EXPECT_NEAR(texel_at(h, 0.3 * fx, 0.3 * fz), 0.0, 1e-6);    // beyond the print
    }
}

TEST(SnowField, ImageColumnsMapToTheWalkersLeftAndRight) {
    // Column 0 (left of the image) is the walker's left: +x when heading toward +z (glTF: +x is left).
    SnowField f = make_field(flat_ground(4, 1), fine(0.01));
    Collider c = image(8, 8, 0.4, 0.4, 0.05, 0.0, {0, 0, 0}, [](int i, int) { return i < 4 ? 1.0 : 0.0; });
    ASSERT_TRUE(f.add_collider(c).ok());
    f.update();
    EXPECT_NEAR(texel_at(f.heightmap(), 0.1, 0), -0.05, 1e-6);
    EXPECT_NEAR(texel_at(f.heightmap(), -0.1, 0), 0.0, 1e-6);
}

TEST(SnowField, SphereTrailIsContinuousAtTenRadiiSpacing) {
    const double r = 0.1, p = 0.05;
    SnowField f = make_field(flat_ground(6, 3), fine(0.01));
    std::vector<std::array<double, 3>> path;
    for (int k = 0; k < 4; ++k) path.push_back({-1.5 + 10 * r * k, r - p, 0.3 * k}); // diagonal, 10 r apart in x
    ASSERT_TRUE(f.add_collider(sphere(r, path)).ok());
    f.update();
    // Along the centreline between the first and last sample, the depth never returns to 0.
    double shallowest = -1;
    for (int s = 0; s <= 3000; ++s) {
        const double a = s / 3000.0;
        const double x = path[0][0] + a * (path[3][0] - path[0][0]), z = path[0][2] + a * (path[3][2] - path[0][2]);
        shallowest = std::max(shallowest, f.heightmap().sample_world(std::array<double, 3>{x, 0, z}.data()));
    }
    EXPECT_LT(shallowest, -0.9 * p);
}

TEST(SnowField, BoxAndCapsuleTrailsAreContinuous) {
    SnowField f = make_field(flat_ground(6, 3), fine(0.01));
    Collider b = box({0.1, 0.1, 0.1}, 0, {{-2, 0.02, -1}, {0, 0.02, -1}, {2, 0.02, -1}}); // 20 sizes apart, 3 cm in
    Collider c = capsule(0.05, 0.2, {{-2, 0.03, 1}, {0, 0.03, 1}, {2, 0.03, 1}});
    ASSERT_TRUE(f.add_collider(b).ok());
    ASSERT_TRUE(f.add_collider(c).ok());
    f.update();
    for (double x = -2; x <= 2; x += 0.005) {
        EXPECT_NEAR(f.heightmap().sample_world(std::array<double, 3>{x, 0, -1}.data()), -0.03, 1e-6) << x;
        EXPECT_NEAR(f.heightmap().sample_world(std::array<double, 3>{x, 0, 1}.data()), -0.02, 1e-6) << x;
    }
}

TEST(SnowField, SlidingImageIsContinuous) {
    // A brush dragged 2 m between two samples is stamped every half texel: no gaps.
    SnowField f = make_field(flat_ground(4, 1), fine(0.01));
    Collider c = image(4, 4, 0.1, 0.1, 0.03, 90, {-1, 0, 0}, [](int, int) { return 1.0; });
    c.path = {{-1, 0, 0}, {1, 0, 0}};
    ASSERT_TRUE(f.add_collider(c).ok());
    f.update();
    for (double x = -1; x <= 1; x += 0.003) EXPECT_NEAR(f.heightmap().sample_world(std::array<double, 3>{x, 0, 0}.data()), -0.03, 1e-6) << x;
}

TEST(SnowField, TurningBoxSweepsItsCorners) {
    // A box turning 90 degrees in place sweeps a disc of its half-diagonal (minus a half-texel tolerance).
    SnowField f = make_field(flat_ground(4, 1), fine(0.01));
    Collider b = box({0.4, 0.2, 0.4}, 0, {{0, 0.05, 0}, {0, 0.05, 0}});
    b.heading = {0, 90};
    ASSERT_TRUE(f.add_collider(b).ok());
    f.update();
    const double R = 0.2 * std::sqrt(2.0);
    for (double a = 0; a < 6.28; a += 0.05) {
        const double x = 0.9 * R * std::cos(a), z = 0.9 * R * std::sin(a);
        // Only the quadrants the corners pass through: the 0→90 turn covers every angle at the corner radius.
        EXPECT_LT(texel_at(f.heightmap(), x, z), -0.04) << a;
    }
}

TEST(SnowField, MinCompositingIsOrderIndependent) {
    std::vector<Collider> cs = {sphere(0.3, {{-0.5, 0.2, 0}, {0.5, 0.25, 0.2}}), box({0.5, 0.2, 0.5}, 20, {{0.1, 0.05, 0.1}}),
                                capsule(0.1, 0.6, {{0, 0.06, -0.3}, {0.3, 0.04, 0.4}}),
                                image(16, 16, 0.3, 0.3, 0.07, 45, {0.2, 0.0, -0.1}, [](int i, int j) { return (i + j) % 5 / 4.0; })};
    std::vector<int> order = {0, 1, 2, 3};
    std::vector<float> first;
    std::mt19937 rng(7);
    for (int trial = 0; trial < 6; ++trial) {
        SnowOptions o = fine(0.01);
        o.rim_width = 0.1;
        o.conserve_volume = true;
        SnowField f = make_field(flat_ground(4, 2), o);
        if (trial % 2 == 0) {
            ColliderSet set;
            for (int k : order) set.colliders.push_back(cs[size_t(k)]);
            ASSERT_TRUE(f.add_colliders(set).ok());
        } else {
            for (int k : order) ASSERT_TRUE(f.add_collider(cs[size_t(k)]).ok());
        }
        f.update();
        if (first.empty()) first = f.heightmap().values;
        else EXPECT_EQ(f.heightmap().values, first) << "trial " << trial;
        std::shuffle(order.begin(), order.end(), rng);
    }
}

TEST(SnowField, SnowDepthLimitsImprints) {
    SnowOptions o = fine(0.01);
    o.snow_depth = 0.05;
    SnowField f = make_field(flat_ground(4, 1), o);
    ASSERT_TRUE(f.add_collider(sphere(0.3, {{0, 0.1, 0}})).ok()); // 0.2 m deep without the limit
    f.update();
    const auto& v = f.heightmap().values;
    EXPECT_NEAR(*std::min_element(v.begin(), v.end()), -0.05f, 1e-7);
}

TEST(SnowField, RefillIsMonotoneAndRespectsTime) {
    Collider c = sphere(0.2, {{-1, 0.12, 0}, {0, 0.12, 0}, {1, 0.12, 0}});
    c.time = {0, 1, 2};
    std::vector<float> prev;
    for (double T : {0.5, 2.0, 3.0, 5.0, 9.0, 20.0}) {
        SnowOptions o = fine(0.02);
        o.refill_rate = 0.3;
        o.rim_width = 0.1;
        SnowField f = make_field(flat_ground(4, 1), o);
        f.set_time(T);
        ASSERT_TRUE(f.add_collider(c).ok());
        f.update();
        const auto& v = f.heightmap().values;
        if (T < 1) { // the ball has not reached x = 0.5 yet
            EXPECT_EQ(texel_at(f.heightmap(), 0.6, 0), 0.0f);
            EXPECT_LT(texel_at(f.heightmap(), -0.6, 0), -0.05f);
            continue;
        }
        if (!prev.empty()) {
            size_t violations = 0;
            for (size_t k = 0; k < v.size(); ++k)
                if (std::abs(v[k]) > std::abs(prev[k]) * (1 + 1e-6) + 1e-9) ++violations;
            EXPECT_EQ(violations, 0u) << "T = " << T;
        }
        prev = v;
    }
    // Exponential: after 18 s at rate 0.3 the newest part keeps exp(-5.4) of its 8 cm.
    EXPECT_LT(*std::max_element(prev.begin(), prev.end(), [](float a, float b) { return std::abs(a) < std::abs(b); }) * -1.0f,
              float(0.08 * std::exp(-0.3 * 18) * 1.05));
}

TEST(SnowField, SetTimeRefillsAStampedField) {
    SnowOptions o = fine(0.02);
    o.refill_rate = std::log(2.0); // half-life 1 s
    SnowField f = make_field(flat_ground(4, 1), o);
    ASSERT_TRUE(f.add_collider(sphere(0.3, {{0, 0.2, 0}})).ok());
    f.update();
    const float before = texel_at(f.heightmap(), 0, 0);
    f.set_time(1.0);
    const auto changed = f.update();
    EXPECT_FALSE(changed.empty());
    EXPECT_NEAR(texel_at(f.heightmap(), 0, 0), before * 0.5f, 1e-6);
}

TEST(SnowField, RimConservesVolumeWithinOnePercent) {
    for (double compaction : {0.0, 0.3, 0.8}) {
        SnowOptions o = fine(0.01);
        o.rim_width = 0.08;
        o.conserve_volume = true;
        o.compaction = compaction;
        SnowField f = make_field(flat_ground(6, 2), o);
        ColliderSet set;
        set.colliders = {sphere(0.35, {{-2, 0.23, -2}, {-1, 0.25, -1}, {0, 0.22, -1.5}}), box({0.6, 0.4, 0.6}, 30, {{1.5, 0.12, 1.5}}),
                         capsule(0.12, 1.0, {{1, 0.07, -2}, {1.2, 0.07, -1}}),
                         image(32, 64, 0.12, 0.3, 0.06, 60, {-1.5, 0, 1.5}, [](int i, int j) { return (i * j) % 7 / 6.0; })};
        ASSERT_TRUE(f.add_colliders(set).ok());
        f.update();
        const double removed = f.removed_volume(), raised = f.raised_volume();
        EXPECT_GT(removed, 0.01);
        EXPECT_NEAR(raised, removed * (1 - compaction), 0.01 * removed) << "compaction " << compaction;
        // Independent sum over the output heightmap.
        double pos = 0, neg = 0;
        for (float v : f.heightmap().values) (v > 0 ? pos : neg) += double(v) * 0.01 * 0.01;
        EXPECT_NEAR(pos, -neg * (1 - compaction), 0.01 * -neg);
    }
}

TEST(SnowField, CosmeticRimRisesOnlyOutsideImprints) {
    SnowOptions o = fine(0.01);
    o.rim_width = 0.1;
    o.rim_height = 0.5;
    SnowField f = make_field(flat_ground(4, 1), o);
    ASSERT_TRUE(f.add_collider(sphere(0.3, {{0, 0.22, 0}})).ok()); // 8 cm deep, contact radius ~0.21 m
    f.update();
    const Heightmap& h = f.heightmap();
    EXPECT_LT(texel_at(h, 0, 0), -0.07f);
    const float ridge = texel_at(h, 0.26, 0);
    EXPECT_GT(ridge, 0.005f);
    EXPECT_LT(ridge, 0.05f);
    EXPECT_EQ(texel_at(h, 0.5, 0), 0.0f);
}

TEST(SnowField, IncrementalStampsMatchTheBatchAndReportDirtyRectangles) {
    std::vector<Collider> cs;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(-1.5, 1.5);
    for (int k = 0; k < 12; ++k) cs.push_back(sphere(0.1, {{U(rng), 0.07, U(rng)}}));
    SnowOptions o = fine(0.01);
    o.rim_width = 0.05;
    SnowField batch = make_field(flat_ground(4, 1), o), inc = make_field(flat_ground(4, 1), o);
    ColliderSet set;
    set.colliders = cs;
    ASSERT_TRUE(batch.add_colliders(set).ok());
    batch.update();
    inc.update();
    for (const Collider& c : cs) {
        const std::vector<float> before = inc.heightmap().values;
        ColliderPose pose{c.path[0], 0, 0};
        ASSERT_TRUE(inc.stamp(c, pose).ok());
        const std::vector<TexelRect> rects = inc.update();
        const auto& after = inc.heightmap().values;
        const int W = inc.frame().width;
        for (size_t k = 0; k < after.size(); ++k)
            if (after[k] != before[k]) {
                const int i = int(k % size_t(W)), j = int(k / size_t(W));
                bool inside = false;
                for (const TexelRect& r : rects) inside = inside || (i >= r.x0 && i < r.x1 && j >= r.y0 && j < r.y1);
                ASSERT_TRUE(inside) << "changed texel outside the dirty rectangles";
            }
        size_t area = 0;
        for (size_t a = 0; a < rects.size(); ++a) {
            area += size_t(rects[a].x1 - rects[a].x0) * size_t(rects[a].y1 - rects[a].y0);
            for (size_t b = a + 1; b < rects.size(); ++b) { // disjoint
                const TexelRect& p = rects[a];
                const TexelRect& q = rects[b];
                EXPECT_TRUE(p.x1 <= q.x0 || q.x1 <= p.x0 || p.y1 <= q.y0 || q.y1 <= p.y0);
            }
        }
        EXPECT_LT(area, after.size() / 10); // local, not the whole map
    }
    double worst = 0;
    for (size_t k = 0; k < batch.heightmap().values.size(); ++k)
        worst = std::max(worst, double(std::abs(batch.heightmap().values[k] - inc.heightmap().values[k])));
    EXPECT_LT(worst, 1e-4); // imprints identical; cosmetic rims gathered in windows agree closely
}

TEST(SnowField, FarApartStampsGiveSeparateDirtyRectangles) {
    SnowField f = make_field(flat_ground(10, 1), fine(0.02));
    f.update();
    ASSERT_TRUE(f.stamp(sphere(0.2, {}), ColliderPose{{-4, 0.15, -4}, 0, 0}).ok());
    ASSERT_TRUE(f.stamp(sphere(0.2, {}), ColliderPose{{4, 0.15, 4}, 0, 0}).ok());
    const auto rects = f.update();
    ASSERT_EQ(rects.size(), 2u);
    size_t area = 0;
    for (const auto& r : rects) area += size_t(r.x1 - r.x0) * size_t(r.y1 - r.y0);
    EXPECT_LE(area, size_t(2 * 48 * 48));
    EXPECT_TRUE(f.update().empty());
}

TEST(SnowField, ContactRaysFollowAHill) {
    SnowField f = make_field(hill_ground(8, 64), fine(0.02));
    // A sphere resting 5 cm into the hill's side: contact found by the ray, imprint around the centre.
    const double x = 0.8, z = 0.4, r = 0.2, p = 0.05;
    const double g = hill_height(x, z);
    StampStats st;
    ASSERT_TRUE(f.add_collider(sphere(r, {{x, g + r - p, z}}), &st).ok());
    EXPECT_EQ(st.contacts, 1u);
    EXPECT_NEAR(st.deepest, p, 0.003); // the mesh's chord is below the analytic hill by a little
    f.update();
    EXPECT_LT(texel_at(f.heightmap(), x, z), -0.04f);
    double h = 0;
    f.cast_down(&h, std::array<double, 3>{x, 5, z}.data(), 1);
    EXPECT_NEAR(h, g, 0.003);
}

// Collider values may be anything finite: a path point 4e28 m away or a 1e30 m capsule asked for more sweep
// steps and texels than an int holds (undefined behaviour, found by fuzz_colliders). Now the steps are capped
// and the trench still reaches the near end of the path.
// A turning brush with pixels far coarser than the texels still stamps every half texel of its far corner's
// travel: its outline is sharp at the texel scale, and a texel near the corner radius is inside it for a
// short turn only. (Only a brush that holds the whole field inside it steps by its pixels.)
TEST(SnowField, TurningCoarseImageSweepsItsCorners) {
    SnowField f = make_field(flat_ground(4, 1), fine(0.01));
    Collider c = image(2, 2, 0.4, 0.4, 0.05, 0, {0, 0, 0}, [](int, int) { return 1.0; }); // 20 cm pixels
    c.path = {{0, 0, 0}, {0, 0, 0}};
    c.heading = {0, 90};
    ASSERT_TRUE(f.add_collider(c).ok());
    f.update();
    const double R = 0.2 * std::sqrt(2.0);
    for (double a = 0; a < 6.28; a += 0.05) {
        const double x = 0.9 * R * std::cos(a), z = 0.9 * R * std::sin(a);
        EXPECT_LT(texel_at(f.heightmap(), x, z), -0.04) << a;
    }
}

// A brush that holds the whole field inside it steps by half a brush pixel: 3 pixels 1e11 m wide turning
// 2 rad from 1e8 m away took 1e6 full-field stamps (found by fuzz_stamp). Every texel is pressed by the
// brush's value. (The slowness itself is the fuzz regression's: a kept input that takes 5 s fails.)
TEST(SnowField, TurningBrushLargerThanTheFieldStampsAtItsPixelScale) {
    SnowField f = make_field(flat_ground(1, 2), fine(0.05));
    Collider c = image(3, 6, 1.1e11, 1.1e25, 0.05, 0, {0, 0, 0}, [](int, int) { return 1.0; });
    c.path = {{-1e8, 0, -1e8}, {0.5, 0, 0.5}};
    c.heading = {0, 114.6};
    ASSERT_TRUE(f.add_collider(c).ok());
    f.update();
    for (float v : f.heightmap().values) ASSERT_NEAR(v, -0.05, 1e-6);
}

TEST(SnowField, CollidersOfAbsurdSizeOrDistanceStampSafely) {
    SnowOptions o = fine(0.02);
    o.rim_width = 0.1;
    SnowField f = make_field(flat_ground(4, 4), o);
    Collider far = capsule(0.1, 0.5, {{4.4e28, 0.05, 0}, {0.5, 0.05, 0.5}});
    far.heading = {0, 75};
    ASSERT_TRUE(f.add_collider(far).ok());
    ASSERT_TRUE(f.add_collider(sphere(1e30, {{-1, 1e30 + 1, -1}})).ok());
    f.update();
    for (float v : f.heightmap().values) ASSERT_TRUE(std::isfinite(v));
    EXPECT_LT(texel_at(f.heightmap(), 0.5, 0.5), -0.04); // the capsule's end sample, 0.05 deep
    EXPECT_TRUE(std::isfinite(f.removed_volume()));
    EXPECT_TRUE(std::isfinite(f.raised_volume()));
}

// Headings are unwrapped so that a sweep turns the short way; subtracting 360 in a loop never ended for a
// heading of 1e30, where h − 360 == h (found by fuzz_stamp). Both the path and the runtime API.
TEST(SnowField, HugeHeadingsDoNotHang) {
    SnowField f = make_field(flat_ground(4, 4), fine(0.02));
    ASSERT_TRUE(f.add_collider(box({0.4, 0.2, 0.6}, 0, {{-0.5, 0.05, 0}, {0.5, 0.05, 0}})).ok());
    Collider spun = box({0.4, 0.2, 0.6}, 0, {{-0.5, 0.05, 0.8}, {0.5, 0.05, 0.8}});
    spun.heading = {0, 1e30};
    ASSERT_TRUE(f.add_collider(spun).ok());
    ColliderPose from{{0.5, 0.05, -0.8}, -1e300, 0}, to{{-0.5, 0.05, -0.8}, 1e300, 0};
    ASSERT_TRUE(f.stamp(spun, to, &from).ok());
    f.update();
    for (float v : f.heightmap().values) ASSERT_TRUE(std::isfinite(v));
    EXPECT_LT(texel_at(f.heightmap(), 0.5, 0.8), -0.04); // both ends of the spun box pressed in
}

TEST(SnowField, AColliderInTheAirMakesNoContact) {
    SnowField f = make_field(flat_ground(4, 1), fine(0.02));
    StampStats st;
    ColliderSet set;
    set.colliders = {sphere(0.2, {{0, 0.5, 0}, {1, 0.21, 0}}), box({0.3, 0.3, 0.3}, 0, {{0, 0.16, 1}})};
    ASSERT_TRUE(f.add_colliders(set, &st).ok());
    EXPECT_EQ(st.samples, 3u);
    EXPECT_EQ(st.contacts, 0u);
    EXPECT_EQ(st.stamps, 0u);
    f.update();
    for (float v : f.heightmap().values) ASSERT_EQ(v, 0.0f);
}

TEST(SnowField, MemoryGuardRefusesHugeHeightmaps) {
    SnowOptions o;
    o.texel = 1e-4; // 20 m / 0.1 mm = 200001² texels
    Primitive g = flat_ground(20, 1);
    SnowField f;
    Status s = f.create(g.positions.data(), g.vertex_count(), g.indices.data(), g.indices.size(), o);
    EXPECT_EQ(s.code, StatusCode::out_of_memory);
    EXPECT_NE(s.message.find("MiB"), std::string::npos) << s.message;
    EXPECT_NE(s.message.find("--texel"), std::string::npos) << s.message;
}

TEST(SnowField, RejectsBadOptions) {
    Primitive g = flat_ground(4, 1);
    auto make = [&](SnowOptions o) {
        SnowField f;
        return f.create(g.positions.data(), g.vertex_count(), g.indices.data(), g.indices.size(), o);
    };
    SnowOptions o;
    o.texel = -1;
    EXPECT_EQ(make(o).code, StatusCode::invalid_argument);
    o = {};
    o.compaction = 1.5;
    EXPECT_EQ(make(o).code, StatusCode::invalid_argument);
    o = {};
    o.snow_depth = NAN;
    EXPECT_EQ(make(o).code, StatusCode::invalid_argument);
    o = {};
    o.up = {0, 0, 0};
    EXPECT_EQ(make(o).code, StatusCode::invalid_argument);
}

TEST(SnowField, CountsOverhangs) {
    // A flat ground plus a downward-facing roof above part of it.
    Primitive g = flat_ground(4, 1);
    const uint32_t b = uint32_t(g.vertex_count());
    g.positions.insert(g.positions.end(), {-1, 1, -1, 1, 1, -1, 1, 1, 1});
    g.indices.insert(g.indices.end(), {b, b + 1, b + 2}); // counter-clockwise seen from below
    SnowField f = make_field(g, fine(0.02));
    EXPECT_EQ(f.overhang_triangles(), 1u);
    SnowField flat = make_field(flat_ground(4, 1), fine(0.02));
    EXPECT_EQ(flat.overhang_triangles(), 0u);
}

TEST(SnowField, WorksForAnyUpAxis) {
    // The same ground and sphere rotated so that +z is up.
    Primitive g = flat_ground(4, 1);
    for (size_t v = 0; v < g.vertex_count(); ++v) std::swap(g.positions[3 * v + 1], g.positions[3 * v + 2]);
    for (size_t t = 0; t < g.indices.size(); t += 3) std::swap(g.indices[t + 1], g.indices[t + 2]);
    SnowOptions o = fine(0.01);
    o.up = {0, 0, 1};
    SnowField f = make_field(g, o);
    ASSERT_TRUE(f.add_collider(sphere(0.35, {{0.1, -0.2, 0.35 - 0.12}})).ok());
    f.update();
    const double centre[3] = {0.1, -0.2, 0};
    EXPECT_NEAR(f.heightmap().sample_world(centre), -0.12, 1e-5);
}

namespace {

// The soft brush's profile: 1 at the solid, 0 at `falloff` from it (smoothstep).
double falloff_weight(double x) { return x >= 1 ? 0.0 : 1 - x * x * (3 - 2 * x); }

} // namespace

// Collider::falloff, box: the analytic soft imprint is −D·w(s / f), s the distance to the box's footprint.
// Inside the footprint the box's flat floor; outside, a smooth slope back to the surface over f (the sharp box
// once left a vertical wall there).
TEST(SnowField, SoftBoxFollowsTheAnalyticFalloff) {
    const double depth = 0.05, f = 0.1, hx = 0.2, hz = 0.15;
    SnowField field = make_field(flat_ground(2, 1), fine(0.005));
    Collider c = box({2 * hx, 0.3, 2 * hz}, 0, {{0.1, 0.15 - depth, -0.05}});
    c.falloff = f;
    ASSERT_TRUE(field.add_collider(c).ok());
    field.update();
    const Heightmap& h = field.heightmap();
    double worst = 0, sum = 0, slope_worst = 0;
    size_t n = 0, slope = 0;
    for (int j = 0; j < h.frame.height; ++j)
        for (int i = 0; i < h.frame.width; ++i) {
            auto xz = texel_xz(h.frame, i, j);
            const double dx = std::max(0.0, std::abs(xz[0] - 0.1) - hx), dz = std::max(0.0, std::abs(xz[1] + 0.05) - hz);
            const double s = std::hypot(dx, dz);
            const double want = -depth * falloff_weight(s / f);
            const double e = std::abs(double(h.at(i, j)) - want);
            worst = std::max(worst, e);
            sum += e, ++n;
            if (s > 0.01 && s < f) slope_worst = std::max(slope_worst, e), ++slope;
        }
    // The kernel samples the sharp imprint at texel centres: the nearest one to a slope point lies up to
    // ~0.85 texel further than the outline, and the outline itself is anti-aliased over a texel; on a profile
    // whose steepest slope is 1.5·D/f that is ≤ (0.85 + 0.5)·1.5·(texel/f)·D = 0.10·D here (measured
    // 0.106·D, 0.0022·D on average over the map).
    EXPECT_LT(slope_worst, 0.12 * depth);
    EXPECT_LT(sum / double(n), 0.003 * depth);
    EXPECT_LT(worst, 0.5 * depth);
    EXPECT_GT(slope, 1000u);
    EXPECT_EQ(texel_at(h, 0.1 + hx + f + 0.01, -0.05), 0.0f) << "nothing beyond the falloff";
}

// Collider::falloff, sphere: the imprint deepens towards the centre, so the minimum over the disc of radius f
// lies on the radial line: h_f(ρ) = min over r in [0, f] of h(max(ρ − r, 0))·w(r / f).
TEST(SnowField, SoftSphereFollowsTheAnalyticFalloff) {
    const double r = 0.3, p = 0.08, f = 0.12;
    SnowField field = make_field(flat_ground(2, 1), fine(0.005));
    Collider c = sphere(r, {{0, r - p, 0}});
    c.falloff = f;
    ASSERT_TRUE(field.add_collider(c).ok());
    field.update();
    const Heightmap& h = field.heightmap();
    auto oracle = [&](double rho) {
        double best = 0;
        for (int k = 0; k <= 4000; ++k) {
            const double d = f * k / 4000;
            best = std::min(best, sphere_imprint(r, p, std::max(rho - d, 0.0)) * falloff_weight(d / f));
        }
        return best;
    };
    double worst = 0;
    for (int j = 0; j < h.frame.height; j += 3)
        for (int i = 0; i < h.frame.width; i += 3) {
            auto xz = texel_xz(h.frame, i, j);
            worst = std::max(worst, std::abs(double(h.at(i, j)) - oracle(std::hypot(xz[0], xz[1]))));
        }
    // The kernel samples texel centres (5 mm): the oracle's continuous minimum is within a texel's slope.
    EXPECT_LT(worst, 0.02 * p);
    const double contact = std::sqrt(2 * r * p - p * p);
    EXPECT_LT(texel_at(h, contact + 0.5 * f, 0), -0.01 * p) << "the slope reaches beyond the contact ring";
    EXPECT_EQ(texel_at(h, contact + f + 0.02, 0), 0.0f);
}

namespace {

struct RimShape {
    double deepest = 0, tallest = 0, steepest_degrees = 0, removed = 0, raised = 0;
    size_t rim_texels = 0;
};

// A ball dragged 13 cm deep along a curve, no compaction, the caller's rim only 5 texels wide: the narrow
// rim that holds all that snow is a wall (0.37 m on a 0.13 m print in the demo before the limits).
RimShape dragged_ball_rim(const SnowOptions& base) {
    SnowOptions o = base;
    o.texel = 0.02;
    o.rim_width = 0.1;
    o.conserve_volume = true;
    o.compaction = 0;
    SnowField f = make_field(flat_ground(8, 1), o);
    EXPECT_TRUE(f.add_collider(sphere(0.35, {{-2.5, 0.22, -2}, {-1, 0.22, -0.5}, {0.5, 0.22, -0.2}, {2, 0.22, 1}})).ok());
    f.update();
    const Heightmap& h = f.heightmap();
    RimShape r;
    r.removed = f.removed_volume(), r.raised = f.raised_volume();
    const int W = h.frame.width, H = h.frame.height;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            const float v = h.at(i, j);
            r.deepest = std::max(r.deepest, double(-v));
            if (!(v > 0)) continue;
            r.tallest = std::max(r.tallest, double(v));
            ++r.rim_texels;
            // Slope between neighbouring rim texels (central differences where both sides are rim).
            if (i > 0 && i + 1 < W && j > 0 && j + 1 < H && h.at(i - 1, j) > 0 && h.at(i + 1, j) > 0 && h.at(i, j - 1) > 0 && h.at(i, j + 1) > 0) {
                const double gx = (h.at(i + 1, j) - h.at(i - 1, j)) / (2 * o.texel), gz = (h.at(i, j + 1) - h.at(i, j - 1)) / (2 * o.texel);
                r.steepest_degrees = std::max(r.steepest_degrees, std::atan(std::hypot(gx, gz)) * 180 / 3.14159265358979323846);
            }
        }
    return r;
}

} // namespace

// Volume-conserving rims: never taller than the print is deep, never steeper than the angle of repose (40° by
// default), still conserving volume within 1 %: the rim widens before it rises.
TEST(SnowField, ConservingRimWidensBeforeItRises) {
    const RimShape limited = dragged_ball_rim(fine(0.02));
    SnowOptions unlimited_o = fine(0.02);
    unlimited_o.rim_max_height = 0;
    unlimited_o.repose_degrees = 0;
    const RimShape unlimited = dragged_ball_rim(unlimited_o);
    // Without the limits: the old wall, taller than the print is deep and steeper than snow stands.
    EXPECT_GT(unlimited.tallest, unlimited.deepest);
    EXPECT_GT(unlimited.steepest_degrees, 45.0);
    // With them (the defaults).
    EXPECT_NEAR(limited.deepest, 0.13, 1e-3);
    EXPECT_LE(limited.tallest, limited.deepest);
    EXPECT_LT(limited.steepest_degrees, 40.0);
    EXPECT_GT(limited.rim_texels, 2 * unlimited.rim_texels) << "the same snow over a wider ring";
    EXPECT_NEAR(limited.raised, limited.removed, 0.01 * limited.removed);
    EXPECT_NEAR(unlimited.raised, unlimited.removed, 0.01 * unlimited.removed);
    // A lower angle of repose gives a lower, wider rim.
    SnowOptions gentle = fine(0.02);
    gentle.repose_degrees = 20;
    const RimShape g = dragged_ball_rim(gentle);
    EXPECT_LT(g.steepest_degrees, 20.0);
    EXPECT_LE(g.tallest, limited.tallest);
    EXPECT_NEAR(g.raised, g.removed, 0.01 * g.removed);
}

namespace {

// One frame of random walkers: balls swept from their last place, boxes and footprint images, random headings;
// at frame `big_at` a large ball joins (a wider reach: every rim texel changes).
struct WalkerStep {
    Collider shape;
    ColliderPose pose, previous;
    bool swept = false;
};

std::vector<std::vector<WalkerStep>> random_walk(unsigned seed, int frames, int walkers, int big_at) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(-1.7, 1.7), D(-0.08, 0.08), H(0, 360), S(0.02, 0.09);
    std::vector<ColliderPose> last(static_cast<size_t>(walkers));
    for (auto& p : last) p.centre = {U(rng), 0, U(rng)};
    std::vector<std::vector<WalkerStep>> out(static_cast<size_t>(frames));
    for (int f = 0; f < frames; ++f) {
        for (int w = 0; w < walkers; ++w) {
            ColliderPose p = last[size_t(w)];
            p.centre[0] += D(rng), p.centre[2] += D(rng), p.heading_degrees = H(rng);
            const double x = p.centre[0], z = p.centre[2];
            WalkerStep s;
            if (w % 3 == 0) s.shape = sphere(0.08, {}), s.swept = f > 0;
            else if (w % 3 == 1) s.shape = box({0.1, 0.1, 0.2}, 0, {});
            else s.shape = image(8, 16, 0.1, 0.25, 0.04, 0, {0, 0, 0}, [](int i, int j) { return ((i + j) % 5) / 4.0; });
            p.centre[1] = hill_height(x, z) + (w % 3 == 0 ? 0.08 - S(rng) : w % 3 == 1 ? 0.05 - S(rng) : 0.0);
            s.pose = p, s.previous = last[size_t(w)];
            last[size_t(w)] = p;
            out[size_t(f)].push_back(s);
        }
        if (f == big_at) {
            WalkerStep s;
            s.shape = sphere(0.4, {});
            s.pose.centre = {0.3, hill_height(0.3, -0.2) + 0.33, -0.2};
            out[size_t(f)].push_back(s);
        }
    }
    return out;
}

void stamp_frame(SnowField& f, const std::vector<WalkerStep>& steps) {
    for (const WalkerStep& s : steps) ASSERT_TRUE(f.stamp(s.shape, s.pose, s.swept ? &s.previous : nullptr).ok());
}

} // namespace

// Property: update() after every frame leaves the same heightmap bytes as one update() after all the same
// stamps, and the same bytes at 1 and 2 threads (cosmetic rims of several widths, none, a base map).
TEST(SnowField, IncrementalRimEqualsFromScratchByteForByte) {
    const Primitive g = hill_ground(4, 40);
    Heightmap base;
    {
        SnowField pre = make_field(g, fine(0.02));
        base.frame = pre.frame();
        base.values.assign(pre.heightmap().values.size(), 0.0f);
        for (size_t k = 0; k < base.values.size(); ++k) base.values[k] = (k % 97 == 0) ? -0.03f : 0.0f; // old pits
    }
    for (double rim_width : {0.0, 0.05, 0.12})
        for (bool with_base : {false, true}) {
            SCOPED_TRACE("rim " + std::to_string(rim_width) + (with_base ? " with a base" : ""));
            SnowOptions o = fine(0.02);
            o.rim_width = rim_width;
            const auto frames = random_walk(7 + unsigned(rim_width * 100), 24, 24, 12);
            std::vector<float> at_one_thread;
            for (int threads : {1, 2}) {
                tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
                SnowField inc = make_field(g, o), scratch = make_field(g, o);
                if (with_base) {
                    ASSERT_TRUE(inc.set_base(base).ok() && scratch.set_base(base).ok());
                }
                size_t changed = 0;
                for (const auto& frame : frames) {
                    stamp_frame(inc, frame);
                    stamp_frame(scratch, frame);
                    for (const TexelRect& r : inc.update()) changed += size_t(r.x1 - r.x0) * size_t(r.y1 - r.y0);
                }
                scratch.update();
                const std::vector<float>& a = inc.heightmap().values;
                const std::vector<float>& b = scratch.heightmap().values;
                ASSERT_EQ(a.size(), b.size());
                EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << threads << " threads";
                EXPECT_GT(changed, 0u);
                if (rim_width > 0) {
                    EXPECT_GT(*std::max_element(a.begin(), a.end()), 0.0f); // a rim rose
                }
                if (threads == 1) at_one_thread = a;
                else EXPECT_EQ(std::memcmp(at_one_thread.data(), a.data(), a.size() * sizeof(float)), 0) << "1 vs 2 threads";
            }
        }
}

// The batch stamp leaves, frame after frame, the bytes one stamp() call per walker leaves, at 1 and 2 threads,
// with a rim, with refill (decayed sub-steps), and a large ball that joins mid-way; its stats are the calls'
// sums (texels_written aside: it depends on the order overlapping stamps land in).
TEST(SnowField, BatchStampEqualsOneCallEachByteForByte) {
    const Primitive g = hill_ground(4, 40);
    for (double refill : {0.0, 0.7}) {
        SCOPED_TRACE(refill > 0 ? "with refill" : "no refill");
        SnowOptions o = fine(0.02);
        o.rim_width = 0.05;
        o.refill_rate = refill;
        const auto frames = random_walk(11, 10, 24, 5);
        for (int threads : {1, 2}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
            SnowField each = make_field(g, o), batch = make_field(g, o);
            for (size_t fi = 0; fi < frames.size(); ++fi) {
                const auto& frame = frames[fi];
                each.set_time(0.1 * double(fi)), batch.set_time(0.1 * double(fi));
                StampStats sum;
                for (const WalkerStep& w : frame) {
                    StampStats one;
                    ASSERT_TRUE(each.stamp(w.shape, w.pose, w.swept ? &w.previous : nullptr, &one).ok());
                    sum.samples += one.samples, sum.contacts += one.contacts, sum.rays += one.rays;
                    sum.missed_rays += one.missed_rays, sum.stamps += one.stamps, sum.deepest = std::max(sum.deepest, one.deepest);
                }
                std::vector<StampRequest> requests;
                for (const WalkerStep& w : frame) requests.push_back({&w.shape, w.pose, w.swept ? &w.previous : nullptr});
                StampStats st;
                ASSERT_TRUE(batch.stamp(requests.data(), requests.size(), &st).ok());
                EXPECT_EQ(st.samples, sum.samples);
                EXPECT_EQ(st.contacts, sum.contacts);
                EXPECT_EQ(st.rays, sum.rays);
                EXPECT_EQ(st.missed_rays, sum.missed_rays);
                EXPECT_EQ(st.stamps, sum.stamps);
                EXPECT_EQ(st.deepest, sum.deepest);
                EXPECT_GT(st.stamps, 0u);
                const std::vector<TexelRect> ra = each.update(), rb = batch.update();
                ASSERT_EQ(ra.size(), rb.size()) << "frame " << fi;
                for (size_t k = 0; k < ra.size(); ++k)
                    EXPECT_TRUE(ra[k].x0 == rb[k].x0 && ra[k].y0 == rb[k].y0 && ra[k].x1 == rb[k].x1 && ra[k].y1 == rb[k].y1);
                const std::vector<float>& a = each.heightmap().values;
                const std::vector<float>& b = batch.heightmap().values;
                ASSERT_EQ(a.size(), b.size());
                ASSERT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << threads << " threads, frame " << fi;
            }
        }
    }
}

// A batch with a request it cannot take is refused whole: nothing of it is stamped.
TEST(SnowField, BatchStampRefusesANullShapeOrAnUndecodedImageWhole) {
    SnowField f = make_field(flat_ground(4, 1), fine(0.02));
    const Collider ball = sphere(0.2, {});
    Collider undecoded;
    undecoded.name = "print";
    undecoded.shape = ColliderShape::image;
    const ColliderPose at{{0, 0.15, 0}, 0, 0};
    const StampRequest with_null[] = {{&ball, at, nullptr}, {nullptr, at, nullptr}};
    const Status a = f.stamp(with_null, 2);
    EXPECT_EQ(a.code, StatusCode::invalid_argument);
    const StampRequest with_image[] = {{&ball, at, nullptr}, {&undecoded, at, nullptr}};
    const Status b = f.stamp(with_image, 2);
    EXPECT_EQ(b.code, StatusCode::invalid_input);
    EXPECT_NE(b.message.find("print"), std::string::npos);
    EXPECT_EQ(f.stamp(static_cast<const StampRequest*>(nullptr), 1).code, StatusCode::invalid_argument);
    EXPECT_TRUE(f.stamp(static_cast<const StampRequest*>(nullptr), 0).ok()); // an empty frame
    EXPECT_TRUE(f.update().empty()); // nothing was stamped
    EXPECT_TRUE(f.stamp(with_null, 1).ok()); // the ball alone
    EXPECT_FALSE(f.update().empty());
}

// update() returns, per 16-texel tile, only the bounding box of the texels that changed (runs of boxes merged),
// not whole tiles: every rectangle lies within the bounding box of the texels whose output changed, and the
// rectangles are disjoint and hold every changed texel.
TEST(SnowField, DirtyRectanglesHoldOnlyWhatChanged) {
    SnowOptions o = fine(0.02);
    o.rim_width = 0.06;
    SnowField f = make_field(flat_ground(4, 1), o);
    f.update();
    const int W = f.frame().width;
    size_t tiles_area = 0, rects_area = 0;
    for (const std::array<double, 3> at : {std::array<double, 3>{0.13, 0.07, -0.21}, {0.29, 0.07, -0.13}, {-1.0, 0.05, 0.7}}) {
        const std::vector<float> before = f.heightmap().values;
        ASSERT_TRUE(f.stamp(sphere(0.1, {}), ColliderPose{at, 0, 0}).ok());
        const std::vector<TexelRect> rects = f.update();
        const std::vector<float>& after = f.heightmap().values;
        TexelRect changed;
        for (size_t k = 0; k < after.size(); ++k)
            if (std::memcmp(&after[k], &before[k], sizeof(float)) != 0) {
                const int i = int(k % size_t(W)), j = int(k / size_t(W));
                changed.unite({i, j, i + 1, j + 1});
                bool inside = false;
                for (const TexelRect& r : rects) inside = inside || (i >= r.x0 && i < r.x1 && j >= r.y0 && j < r.y1);
                ASSERT_TRUE(inside) << "changed texel " << i << ", " << j << " outside the dirty rectangles";
            }
        ASSERT_FALSE(changed.empty());
        for (size_t a = 0; a < rects.size(); ++a) {
            const TexelRect& p = rects[a];
            EXPECT_TRUE(p.x0 >= changed.x0 && p.y0 >= changed.y0 && p.x1 <= changed.x1 && p.y1 <= changed.y1)
                << "rectangle " << a << " reaches past the changed texels";
            rects_area += size_t(p.x1 - p.x0) * size_t(p.y1 - p.y0);
            for (size_t b = a + 1; b < rects.size(); ++b) {
                const TexelRect& q = rects[b];
                EXPECT_TRUE(p.x1 <= q.x0 || q.x1 <= p.x0 || p.y1 <= q.y0 || q.y1 <= p.y0) << "rectangles " << a << " and " << b << " overlap";
            }
        }
        const int T = 16; // the tiles holding the changed texels' box: what whole-tile rectangles would cover at least
        tiles_area += size_t((changed.x1 + T - 1) / T - changed.x0 / T) * size_t((changed.y1 + T - 1) / T - changed.y0 / T) * T * T;
    }
    EXPECT_LT(rects_area, tiles_area);
}

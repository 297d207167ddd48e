// save_heightmap / load_heightmap and SnowField::set_base.
#include "deform_test_util.h"
#include "test_support.h"

#include <fstream>

using namespace furrow;
using namespace furrow::test;

namespace {

Heightmap stamped_map(double texel = 0.02) {
    SnowOptions o;
    o.texel = texel;
    o.rim_width = 0.08;
    SnowField f = make_field(flat_ground(4, 1), o);
    EXPECT_TRUE(f.add_collider(sphere(0.3, {{-0.5, 0.2, 0}, {0.6, 0.22, 0.3}})).ok());
    f.update();
    return f.heightmap();
}

} // namespace

TEST(SaveHeightmap, PfmRoundTripIsExactWithItsFrame) {
    const Heightmap h = stamped_map();
    const auto dir = temp_dir();
    const auto file = dir / "h.pfm";
    ASSERT_TRUE(save_heightmap(h, file.string()).ok());
    Heightmap back;
    Status s = load_heightmap(back, file.string());
    ASSERT_TRUE(s.ok()) << s.message;
    EXPECT_EQ(back.values, h.values);
    EXPECT_EQ(back.frame.width, h.frame.width);
    EXPECT_EQ(back.frame.height, h.frame.height);
    EXPECT_DOUBLE_EQ(back.frame.texel, h.frame.texel);
    EXPECT_EQ(back.frame.origin, h.frame.origin);
    EXPECT_EQ(back.frame.axis_v, h.frame.axis_v);
    // A plain PFM header: readers that ignore the trailing line see a normal float image.
    auto bytes = read_bytes(file);
    const std::string head(bytes.begin(), bytes.begin() + 3);
    EXPECT_EQ(head, "Pf\n");
    EXPECT_EQ(list_dir(dir), std::vector<std::string>{"h.pfm"}); // no temp file left
}

TEST(SaveHeightmap, Png16RoundTripWithinItsQuantum) {
    const Heightmap h = stamped_map();
    const auto file = temp_dir() / "h.png";
    ASSERT_TRUE(save_heightmap(h, file.string()).ok());
    ImageF raw;
    ASSERT_TRUE(load_png(raw, file.string()).ok());
    EXPECT_EQ(raw.channels, 1);
    EXPECT_EQ(raw.width, h.frame.width);
    Heightmap back;
    Status s = load_heightmap(back, file.string());
    ASSERT_TRUE(s.ok()) << s.message;
    float lo = 0, hi = 0;
    for (float v : h.values) lo = std::min(lo, v), hi = std::max(hi, v);
    const double quantum = (double(hi) - lo) / 65535.0;
    double worst = 0;
    for (size_t k = 0; k < h.values.size(); ++k) worst = std::max(worst, double(std::abs(back.values[k] - h.values[k])));
    EXPECT_LE(worst, 0.51 * quantum + 1e-7);
    size_t kept = 0;
    for (size_t k = 0; k < h.values.size(); ++k)
        if (h.values[k] == 0) { // untouched snow comes back exactly untouched
            EXPECT_EQ(back.values[k], 0.0f);
            ++kept;
        }
    EXPECT_GT(kept, 1000u);
    EXPECT_DOUBLE_EQ(back.frame.texel, h.frame.texel);
}

// A map without a frame (what a plain PFM loads as) saves with texel 0 and must load back frame-less, in
// both formats (fuzz_heightmap found that the saved file was refused: "texel must be > 0").
TEST(SaveHeightmap, AFramelessMapRoundTripsFramelessInBothFormats) {
    Heightmap h;
    h.frame.width = 3, h.frame.height = 2;
    h.values = {0.0f, -0.25f, 0.5f, -1.0f, 0.125f, 0.0f};
    const auto dir = temp_dir();
    for (const char* name : {"h.pfm", "h.png"}) {
        ASSERT_TRUE(save_heightmap(h, (dir / name).string()).ok()) << name;
        Heightmap back;
        Status s = load_heightmap(back, (dir / name).string());
        ASSERT_TRUE(s.ok()) << name << ": " << s.message;
        EXPECT_EQ(back.frame.width, 3) << name;
        EXPECT_EQ(back.frame.height, 2) << name;
        EXPECT_EQ(back.frame.texel, 0.0) << name;
        ASSERT_EQ(back.values.size(), h.values.size()) << name;
        for (size_t k = 0; k < h.values.size(); ++k) EXPECT_NEAR(back.values[k], h.values[k], 1e-4) << name << " texel " << k;
    }
    // A negative texel is still a bad frame, not an empty one.
    write_text(dir / "neg.pfm", std::string("Pf\n1 1\n-1.0\n") + std::string(4, '\0') +
                                    "\n# furrow-heightmap {\"origin\":[0,0,0],\"axis_u\":[1,0,0],\"axis_v\":[0,0,1],\"up\":[0,1,0],"
                                    "\"texel\":-1,\"width\":1,\"height\":1}\n");
    Heightmap bad;
    EXPECT_EQ(load_heightmap(bad, (dir / "neg.pfm").string()).code, StatusCode::invalid_input);
}

TEST(LoadHeightmap, RejectsAPngWithoutScaleAndBadFiles) {
    const auto dir = temp_dir();
    ImageF im;
    im.width = 4, im.height = 4, im.channels = 1;
    im.pixels.assign(16, 0.5f);
    ASSERT_TRUE(save_png(im, (dir / "plain.png").string()).ok());
    Heightmap h;
    Status s = load_heightmap(h, (dir / "plain.png").string());
    EXPECT_EQ(s.code, StatusCode::invalid_input);
    EXPECT_NE(s.message.find("scale"), std::string::npos) << s.message;
    write_text(dir / "bad.pfm", "Pf\n10 10\n-1.0\nshort");
    EXPECT_EQ(load_heightmap(h, (dir / "bad.pfm").string()).code, StatusCode::invalid_input);
    write_text(dir / "bad2.pfm", "P6\n1 1\n255\nabc");
    EXPECT_EQ(load_heightmap(h, (dir / "bad2.pfm").string()).code, StatusCode::invalid_input);
    EXPECT_EQ(load_heightmap(h, (dir / "none.pfm").string()).code, StatusCode::io_error);
    EXPECT_EQ(load_heightmap(h, (dir / "x.exr").string()).code, StatusCode::io_error);
    EXPECT_EQ(save_heightmap(stamped_map(), (dir / "x.exr").string()).code, StatusCode::invalid_argument);
}

TEST(SetBase, ResamplesOntoAnotherGridAndCompositesNewStamps) {
    const Heightmap h = stamped_map(0.02);
    const auto file = temp_dir() / "h.pfm";
    ASSERT_TRUE(save_heightmap(h, file.string()).ok());
    Heightmap loaded;
    ASSERT_TRUE(load_heightmap(loaded, file.string()).ok());
    SnowOptions o;
    o.texel = 0.01; // a finer grid: bilinear resampling of the base
    o.rim_width = 0.08;
    SnowField f = make_field(flat_ground(4, 1), o);
    ASSERT_TRUE(f.set_base(loaded).ok());
    ASSERT_TRUE(f.add_collider(sphere(0.2, {{1.2, 0.15, -1.2}})).ok());
    f.update();
    const Heightmap& out = f.heightmap();
    // The old trail is there, the new print too, and the new rim only counts the new volume.
    EXPECT_NEAR(texel_at(out, -0.5, 0), texel_at(h, -0.5, 0), 1e-5);
    EXPECT_LT(texel_at(out, 1.2, -1.2), -0.04f);
    EXPECT_EQ(texel_at(out, 1.2, -1.8), 0.0f);
    // set_base after a stamp is refused.
    EXPECT_EQ(f.set_base(loaded).code, StatusCode::invalid_argument);
}

TEST(SetBase, AFramelessPfmIsStretchedOverTheGrid) {
    const auto dir = temp_dir();
    // 3 x 2 floats, bottom row first: rows (top) -1 -1 -1, (bottom) 0 0 0.
    std::string text = "Pf\n3 2\n-1.0\n";
    std::vector<float> rows = {0, 0, 0, -1, -1, -1};
    text.append(reinterpret_cast<const char*>(rows.data()), rows.size() * 4);
    write_text(dir / "plain.pfm", text);
    Heightmap b;
    ASSERT_TRUE(load_heightmap(b, (dir / "plain.pfm").string()).ok());
    EXPECT_EQ(b.frame.texel, 0.0);
    SnowOptions o;
    o.texel = 0.5;
    SnowField f = make_field(flat_ground(4, 1), o); // 9 x 9 texels
    ASSERT_TRUE(f.set_base(b).ok());
    f.update();
    EXPECT_EQ(f.heightmap().at(0, 0), -1.0f);  // top row of the image = row 0 = −z
    EXPECT_EQ(f.heightmap().at(8, 8), 0.0f);
    EXPECT_EQ(f.heightmap().at(4, 4), -0.5f);
}

// parse_colliders / load_colliders: the schema, and every kind of bad input with a message naming the member.
#include "deform_test_util.h"
#include "test_support.h"

using namespace furrow;
using namespace furrow::test;

namespace {

Status parse(const std::string& text, ColliderSet* out = nullptr) {
    ColliderSet set;
    Status s = parse_colliders(set, text, models_dir().string());
    if (out) *out = set;
    return s;
}

void expect_error(const std::string& text, const std::string& fragment) {
    Status s = parse(text);
    EXPECT_EQ(s.code, StatusCode::invalid_input) << text;
    EXPECT_NE(s.message.find(fragment), std::string::npos) << "message: " << s.message << "\nexpected: " << fragment;
}

} // namespace

TEST(ParseColliders, ReadsTheBundledExample) {
    ColliderSet set;
    Status s = load_colliders(set, (models_dir() / "colliders.json").string());
    ASSERT_TRUE(s.ok()) << s.message;
    EXPECT_EQ(set.up, (std::array<double, 3>{0, 1, 0}));
    ASSERT_EQ(set.colliders.size(), 23u);
    size_t images = 0;
    for (const Collider& c : set.colliders) {
        if (c.shape == ColliderShape::image) {
            ++images;
            ASSERT_TRUE(c.brush);
            EXPECT_EQ(c.brush->width, 128);
            EXPECT_EQ(c.brush->height, 320);
            EXPECT_EQ(c.heading.size(), 1u);
        }
    }
    EXPECT_EQ(images, 20u);
    EXPECT_EQ(set.colliders[20].shape, ColliderShape::sphere);
    EXPECT_EQ(set.colliders[20].path.size(), 17u);
    EXPECT_EQ(set.colliders[21].shape, ColliderShape::box);
    EXPECT_EQ(set.colliders[22].shape, ColliderShape::capsule);
    EXPECT_DOUBLE_EQ(set.colliders[22].length, 1.0);
}

TEST(ParseColliders, AcceptsEveryShapeAndOptionalMember) {
    ColliderSet set;
    Status s = parse(R"({"up": [0, 0, 2], "_comment": "z up", "colliders": [
        {"shape": "sphere", "radius": 0.3, "path": [[0, 0, 0], [1, 0, 0]], "time": [0, 0.5], "name": "ball"},
        {"shape": "box", "size": [1, 2, 3], "heading": 45, "path": [[0, 0, 0]]},
        {"shape": "capsule", "radius": 0.1, "length": 0, "axis": [0, 2, 0], "path": [[0, 0, 0]], "time": 3},
        {"shape": "image", "image": "footprint.png", "size": [0.1, 0.2], "depth": 0.05, "heading": [10, 20], "path": [[0,0,0],[0,0,1]]}
    ]})",
                     &set);
    ASSERT_TRUE(s.ok()) << s.message;
    EXPECT_EQ(set.up, (std::array<double, 3>{0, 0, 1}));
    EXPECT_EQ(set.colliders[0].name, "ball");
    EXPECT_EQ(set.colliders[1].name, "colliders[1]");
    EXPECT_EQ(set.colliders[1].heading, std::vector<double>{45});
    EXPECT_EQ(set.colliders[2].axis, (std::array<double, 3>{0, 1, 0}));
    EXPECT_EQ(set.colliders[2].time, std::vector<double>{3});
    EXPECT_EQ(set.colliders[3].heading.size(), 2u);
}

TEST(ParseColliders, EmptyListIsValid) {
    ColliderSet set;
    ASSERT_TRUE(parse(R"({"colliders": []})", &set).ok());
    EXPECT_TRUE(set.colliders.empty());
}

TEST(ParseColliders, MalformedJson) {
    expect_error(R"({"colliders": [ {"shape": "sphere", "radius": 1, )", "malformed JSON");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": NaN, "path": [[0,0,0]]}]})", "malformed JSON");
    expect_error("", "malformed JSON");
}

TEST(ParseColliders, WrongStructure) {
    expect_error(R"([1, 2])", "must be an object");
    expect_error(R"({"up": [0, 1, 0]})", "missing \"colliders\"");
    expect_error(R"({"colliders": {}})", "colliders: must be an array");
    expect_error(R"({"colliders": [], "extra": 1})", "unknown key \"extra\"");
    expect_error(R"({"up": [0, 0, 0], "colliders": []})", "up: must not be the zero vector");
    expect_error(R"({"up": [0, 1], "colliders": []})", "up: must be an array [x, y, z]");
}

TEST(ParseColliders, UnknownShape) {
    expect_error(R"({"colliders": [{"shape": "cone", "radius": 1, "path": [[0,0,0]]}]})",
                 "colliders[0].shape: unknown shape \"cone\" (expected sphere, box, capsule or image)");
    expect_error(R"({"colliders": [{"radius": 1, "path": [[0,0,0]]}]})", "colliders[0]: missing \"shape\"");
}

TEST(ParseColliders, NegativeZeroOrNonFiniteSizes) {
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": -0.5, "path": [[0,0,0]]}]})",
                 "colliders[0].radius: must be a finite number > 0, got -0.5");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 0, "path": [[0,0,0]]}]})", "colliders[0].radius: must be a finite number > 0");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1e999, "path": [[0,0,0]]}]})", "malformed JSON: number overflow");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": "nan", "path": [[0,0,0]]}]})", "colliders[0].radius: must be a finite number > 0");
    expect_error(R"({"colliders": [{"shape": "box", "size": [1, -2, 1], "path": [[0,0,0]]}]})", "colliders[0].size[1]: must be a finite number > 0");
    expect_error(R"({"colliders": [{"shape": "box", "size": [1, 1], "path": [[0,0,0]]}]})", "colliders[0].size: a box needs [sx, sy, sz]");
    expect_error(R"({"colliders": [{"shape": "capsule", "radius": 1, "length": -1, "path": [[0,0,0]]}]})",
                 "colliders[0].length: must be a finite number >= 0");
    expect_error(R"({"colliders": [{"shape": "image", "image": "footprint.png", "size": [0.1, 0.2], "depth": -1, "path": [[0,0,0]]}]})",
                 "colliders[0].depth: must be a finite number > 0");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1, "path": [[0, "1", 0]]}]})", "colliders[0].path[0][1]: must be a number");
}

TEST(ParseColliders, MissingOrUnreadableImage) {
    expect_error(R"({"colliders": [{"shape": "image", "image": "no_such_foot.png", "size": [0.1, 0.2], "depth": 0.05, "path": [[0,0,0]]}]})",
                 "colliders[0].image: cannot read 'no_such_foot.png'");
    expect_error(R"({"colliders": [{"shape": "image", "image": "colliders.json", "size": [0.1, 0.2], "depth": 0.05, "path": [[0,0,0]]}]})",
                 "colliders[0].image: cannot read 'colliders.json'");
    expect_error(R"({"colliders": [{"shape": "image", "size": [0.1, 0.2], "depth": 0.05, "path": [[0,0,0]]}]})", "colliders[0]: missing \"image\"");
}

TEST(ParseColliders, PathHeadingAndTimeRules) {
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1, "path": []}]})", "colliders[0].path: must be a non-empty array");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1}]})", "colliders[0]: missing \"path\"");
    expect_error(R"({"colliders": [{"shape": "box", "size": [1,1,1], "heading": [1, 2, 3], "path": [[0,0,0],[1,0,0]]}]})",
                 "colliders[0].heading: needs 1 or 2 values");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1, "time": [1, 0.5], "path": [[0,0,0],[1,0,0]]}]})",
                 "colliders[0].time[1]: times must not decrease");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1, "time": [-1, 0], "path": [[0,0,0],[1,0,0]]}]})",
                 "colliders[0].time[0]: must be >= 0");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1, "time": [0], "path": [[0,0,0],[1,0,0]]}]})",
                 "colliders[0].time: needs one value per path point (2)");
}

TEST(ParseColliders, UnknownOrMisplacedKeys) {
    expect_error(R"({"colliders": [{"shape": "sphere", "radious": 1, "path": [[0,0,0]]}]})", "colliders[0]: missing \"radius\"");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1, "length": 2, "path": [[0,0,0]]}]})",
                 "colliders[0]: unknown key \"length\"");
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1, "path": [[0,0,0]]}, {"shape": "box", "radius": 1, "size": [1,1,1], "path": [[0,0,0]]}]})",
                 "colliders[1]: unknown key \"radius\"");
}

TEST(ParseColliders, LoadReportsAMissingFile) {
    ColliderSet set;
    Status s = load_colliders(set, (temp_dir() / "missing.json").string());
    EXPECT_EQ(s.code, StatusCode::io_error);
}

TEST(ParseColliders, FalloffOnSolidShapesOnly) {
    ColliderSet set;
    ASSERT_TRUE(parse(R"({"colliders": [{"shape": "sphere", "radius": 1, "falloff": 0.25, "path": [[0,0,0]]},
                                        {"shape": "box", "size": [1,1,1], "falloff": 0, "path": [[0,0,0]]},
                                        {"shape": "capsule", "radius": 1, "length": 1, "falloff": 2, "path": [[0,0,0]]}]})",
                      &set)
                    .ok());
    ASSERT_EQ(set.colliders.size(), 3u);
    EXPECT_EQ(set.colliders[0].falloff, 0.25);
    EXPECT_EQ(set.colliders[1].falloff, 0.0);
    EXPECT_EQ(set.colliders[2].falloff, 2.0);
    expect_error(R"({"colliders": [{"shape": "sphere", "radius": 1, "falloff": -0.1, "path": [[0,0,0]]}]})",
                 "colliders[0].falloff: must be a finite number >= 0, got -0.1");
    // An image brush carries its own soft edge in its pixels.
    expect_error(R"({"colliders": [{"shape": "image", "image": "footprint.png", "size": [0.1, 0.2], "depth": 0.05, "falloff": 0.1, "path": [[0,0,0]]}]})",
                 "colliders[0]: unknown key \"falloff\"");
}

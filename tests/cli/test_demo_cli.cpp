// `furrow demo`: the main job runs on the bundled scene and writes valid glTF and non-empty previews.
#include "test_support.h"

#include <furrow/render.h>

#include <cmath>

using namespace furrow;
using namespace furrow::test;

TEST(demo_cli, WritesValidGltfAndPreviews) {
    const auto dir = temp_dir() / "out";
    RunResult r = run_furrow({"demo", "-o", dir.string(), "--ssaa", "1"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("furrow demo wrote"), std::string::npos);
    for (const char* glb : {"creature.glb", "creature_fur.glb", "ground.glb", "snow.glb"}) {
        ASSERT_TRUE(std::filesystem::exists(dir / glb)) << glb;
        EXPECT_VALID_GLTF(dir / glb);
    }
    for (const char* png : {"creature_shaded.png", "creature_wireframe.png", "creature_fur_shaded.png", "ground_shaded.png",
                            "ground_wireframe.png", "snow_shaded.png", "snow_wireframe.png"}) {
        ImageF img;
        ASSERT_TRUE(load_png(img, (dir / png).string()).ok()) << png;
        EXPECT_EQ(img.channels, 4);
        // The previews have an opaque background (the top-left pixel); the model covers a real part of the
        // frame, but not all of it.
        size_t differs = 0, n = size_t(img.width) * size_t(img.height);
        for (size_t i = 0; i < n; ++i) {
            float d = 0;
            for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(img.pixels[i * 4 + size_t(c)] - img.pixels[size_t(c)]));
            differs += d > 0.05f;
            ASSERT_EQ(img.pixels[i * 4 + 3], 1.0f);
        }
        EXPECT_GT(double(differs) / double(n), 0.05) << png;
        EXPECT_LT(double(differs) / double(n), 0.95) << png;
    }
}

TEST(demo_cli, MissingSceneDescriptionIsAnError) {
    const auto dir = temp_dir();
    RunResult r = run_furrow({"demo", "--models", dir.string(), "-o", (dir / "out").string()});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.err.rfind("Error: ", 0), 0u) << r.err;
}

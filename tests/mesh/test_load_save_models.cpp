// Round trip of the project's own sample assets (models/): load -> save -> validate -> reload -> identical.
#include "scene_compare.h"
#include "test_support.h"

using namespace furrow;
using namespace furrow::test;

TEST(load_save_models, EveryBundledModelRoundTrips) {
    size_t seen = 0;
    for (const auto& e : std::filesystem::directory_iterator(models_dir())) {
        const auto ext = e.path().extension().string();
        if (ext != ".glb" && ext != ".gltf") continue;
        SCOPED_TRACE(e.path().filename().string());
        ++seen;
        Scene a;
        Status s = load_scene(a, e.path().string());
        ASSERT_TRUE(s.ok()) << s.message;
        const auto out = temp_dir() / ("rt_" + e.path().filename().string());
        ASSERT_TRUE(save_scene(a, out.string()).ok());
        EXPECT_VALID_GLTF(out);
        Scene b;
        ASSERT_TRUE(load_scene(b, out.string()).ok());
        expect_same_scene(a, b);
        // The bundled models were written by furrow itself in the generator's vertex order (SaveOptions::optimize
        // off, models/generators.h), so a round trip in that order reproduces their bytes.
        if (ext == ".glb") {
            SaveOptions as_generated;
            as_generated.optimize = false;
            const auto same = temp_dir() / ("same_" + e.path().filename().string());
            ASSERT_TRUE(save_scene(a, same.string(), as_generated).ok());
            EXPECT_EQ(read_bytes(same), read_bytes(e.path()));
        }
    }
    EXPECT_GE(seen, 2u); // creature.glb and ground.glb at least
}

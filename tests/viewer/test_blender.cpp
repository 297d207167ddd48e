// The real-client stage, second client: Blender 3.4's own glTF importer and Cycles (render_blender.py says
// what is set up around them). Every demo output imports, and its Cycles silhouette matches furrow render of
// the same view (IoU >= 0.99). Cycles samples textures from their base level, so furrow render is asked for
// the same (RenderOptions::mipmaps = false). Skipped, with the reason, where Blender is not installed
// (.ci/install-deps installs it).
#include "viewer_support.h"

#include <unistd.h>

using namespace furrow;
using namespace furrow::test;
namespace fs = std::filesystem;

namespace {

fs::path find_blender() {
    for (const char* p : {"/usr/bin/blender", "/usr/local/bin/blender"})
        if (access(p, X_OK) == 0) return p;
    return {};
}

} // namespace

TEST(viewer, BlenderImportsEveryDemoOutput) {
    const fs::path blender = find_blender();
    if (blender.empty()) GTEST_SKIP() << "Blender is not installed (apt-get install blender python3-numpy)";
    const fs::path dir = temp_dir(), demo = dir / "demo";
    RunResult r = run_furrow({"demo", "-o", demo.string(), "--ssaa", "1", "-q"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    struct Case {
        const char* file;
        View view;
    };
    const Case cases[] = {
        {"creature.glb", kCreatureView},
        {"creature_fur.glb", kCreatureView},
        {"snow.glb", {{0, 9, 14}, {0, 0, 0}, 45, 0.1, 960, 720}},
        {"terrain.glb", {{-9, 3, 9}, {1, -0.5, -1}, 50, 0.1, 960, 720}},
    };
    nlohmann::json jobs = nlohmann::json::array();
    for (const Case& c : cases) {
        const View v = c.view.half();
        jobs.push_back({{"model", (demo / c.file).string()}, {"out", (dir / (std::string(c.file) + ".png")).string()},
                        {"width", v.width}, {"height", v.height}, {"eye", v.eye}, {"target", v.target},
                        {"fov", v.fov}, {"near", v.near_plane}});
    }
    write_text(dir / "jobs.json", jobs.dump(1));
    RunResult b = run_program({blender.string(), "-b", "--factory-startup", "-noaudio", "--python",
                               (source_dir() / "tests/viewer/render_blender.py").string(), "--",
                               (dir / "jobs.json").string()});
    ASSERT_EQ(b.exit_code, 0) << b.err;
    for (const Case& c : cases) {
        SCOPED_TRACE(c.file);
        const View v = c.view.half();
        ImageF cycles = load_image(dir / (std::string(c.file) + ".png"));
        ImageF ours = render_furrow(load_or_fail(demo / c.file), v, RenderMode::shaded, false, 8);
        const double iou = mask_iou(silhouette_mask(cycles), silhouette_mask(ours));
        EXPECT_GE(iou, kMinIoU);
        std::printf("%s: Cycles silhouette IoU %.4f\n", c.file, iou);
    }
}

// The real-client stage on a third-party model (../shared/corpus, label `corpus`): see test_viewer.cpp.
#include "viewer_support.h"

using namespace furrow;
using namespace furrow::test;
namespace fs = std::filesystem;

// Fox (glTF sample model: skinned, textured, about 155 units long): fur grown by the command line, viewer
// layout, seen from the demo's angle at three distances.
TEST(viewer, FoxFurShowsAtThreeDistances) {
    const fs::path dir = temp_dir(), out = dir / "fox_fur.glb";
    RunResult r = run_furrow({"shells", corpus("fox/Fox.glb").string(), "-o", out.string(), "--layers", "32",
                              "--length", "3", "-q"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    check_fur_at_three_distances(out, View{{150, 95, 190}, {0, 35, -10}, 40, 1.0, 960, 720}, dir);
}

// A textured model whose sampler mip-maps (Duck: NEAREST_MIPMAP_LINEAR), near and far: each
// pixel blends two mip levels, and furrow render's level of detail must be the GPU's.
TEST(viewer, MipmappedTextureColoursMatch) {
    const fs::path dir = temp_dir(), duck = corpus("duck/Duck.glb");
    const View near{{1.2, 1.1, 1.4}, {0, 0.8, 0}, 40, 0.05, 480, 360};
    std::vector<ThreeJob> jobs;
    for (double f : {1.0, 3.0, 9.0}) jobs.push_back({duck, dir / ("duck" + std::to_string(int(f)) + ".png"), near.at_distance(f)});
    ASSERT_EQ(render_three(jobs, dir), "");
    const Scene scene = load_or_fail(duck);
    for (const ThreeJob& j : jobs) {
        SCOPED_TRACE(j.out.filename().string());
        Compared c = compare_material(j.out, scene, j.view);
        EXPECT_GE(c.iou, kMinIoU);
        EXPECT_LE(c.colour, kColourBound);
        // Without mipmaps furrow render would sample the base level: measurably further from three.js far away.
        const ImageF three = load_image(j.out), base = render_furrow(scene, j.view, RenderMode::shaded, false);
        if (&j == &jobs.back()) {
            EXPECT_GT(mean_covered_difference(three, base), kColourBound); // measured 1.16/255
        }
        std::printf("%s: IoU %.4f, colour %.2f/255 (base level only: %.2f/255)\n", j.out.filename().c_str(), c.iou,
                    255 * c.colour, 255 * mean_covered_difference(three, base));
    }
}

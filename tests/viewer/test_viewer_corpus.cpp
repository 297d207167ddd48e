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

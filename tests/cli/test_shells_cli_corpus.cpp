// `furrow shells --refine-tolerance` on a coarse printed model (Thingi10K 73342, 1.6-1.8k triangles after
// refinement), whose starved faces the refinement splits in rounds, each regrowing the whole frame: the
// default stops once two rounds in a row change the share of the fur kept by less than 0.001, 0 refines
// until nothing is left to split. The summary line says how many rounds ran.
#include "test_support.h"

#include <regex>

namespace fs = std::filesystem;
using furrow::test::run_furrow;

namespace {

// "N base faces split where clamped corners starved the fur (R rounds)" -> {N, R}; {0, 0} without that line.
std::pair<long, long> refinement_of(const std::string& summary) {
    std::smatch m;
    static const std::regex line(R"(([0-9]+) base faces? split where clamped corners starved the fur \(([0-9]+) rounds?\))");
    if (!std::regex_search(summary, m, line)) return {0, 0};
    return {std::stol(m[1]), std::stol(m[2])};
}

} // namespace

TEST(furrow_shells_corpus, RefineToleranceTradesRoundsForFur) {
    const fs::path dir = furrow::test::temp_dir(), in = furrow::test::corpus("thingi10k_73342/73342.stl");
    // Length 1.33: `bench shells`' 0.02 x the bounding box's diagonal (66.5).
    auto shells = [&](const std::string& out, const std::string& tolerance) {
        std::vector<std::string> args{"shells", in.string(), "-o", (dir / out).string(), "--layers", "2", "--length", "1.33"};
        if (!tolerance.empty()) args.insert(args.end(), {"--refine-tolerance", tolerance});
        return run_furrow(args);
    };
    auto r = shells("default.glb", "");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto converged = refinement_of(r.err);
    EXPECT_VALID_GLTF(dir / "default.glb");
    r = shells("full.glb", "0");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto full = refinement_of(r.err);
    EXPECT_VALID_GLTF(dir / "full.glb");
    std::printf("73342.stl: %ld faces split in %ld rounds (default), %ld in %ld (tolerance 0)\n", converged.first, converged.second,
                full.first, full.second);
    EXPECT_GT(converged.second, 0);
    EXPECT_LT(converged.second, full.second);
    EXPECT_LT(converged.first, full.first);
}

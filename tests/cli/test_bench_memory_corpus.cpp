// The memory rule (issue 13) on the two corpus models of the README's `bench memory` table: a 69k-triangle
// scan (OBJ) and a terrain (GLB). Every writing command peaks at most 2 x (input + output bytes) + 64 MiB.
// Tessellating the bunny at rate 4 (40 MB of output) broke the rule until the glTF writer adopted its arrays
// instead of copying them and read the source indices in place (156 MiB against a 145 MiB limit).
#include "test_support.h"

using namespace furrow::test;

TEST(bench_memory_corpus, MemoryRuleHoldsOnTheScanAndTheTerrain) {
    if (under_address_sanitizer()) GTEST_SKIP() << "resident size under AddressSanitizer is not the program's";
    const std::set<std::string> commands = expect_memory_rule(
        {corpus("stanford_bunny_scan/stanford-bunny.obj").string(), corpus("terrain/terrain.glb").string()}, 8);
    EXPECT_EQ(commands.size(), 4u); // convert, shells, tessellate, render on each
}

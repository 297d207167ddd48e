// The commands as functions (cli/commands.h): run_X called with an Args struct does what `furrow X` does with
// the same flags, byte for byte, and reports bad input as an InputError naming the file, without a process.
#include "test_support.h"

#include "commands.h"

#include <furrow/shapes.h>

namespace furrow {
namespace {

namespace fs = std::filesystem;
using test::run_furrow;

fs::path write_sphere(const fs::path& dir) {
    const fs::path file = dir / "sphere.glb";
    EXPECT_TRUE(save_scene(make_scene(shapes::uv_sphere(1, 24, 12), "sphere"), file.string()).ok());
    return file;
}

TEST(commands, RunTessellateWritesWhatTheCommandWrites) {
    const fs::path dir = test::temp_dir(), in = write_sphere(dir);
    ASSERT_EQ(run_furrow({"tessellate", in.string(), "-o", (dir / "cli.glb").string(), "--uniform", "3", "-q"}).exit_code, 0);
    cli::TessellateArgs a;
    a.in = in.string();
    a.out = (dir / "fn.glb").string();
    a.uniform = 3;
    cli::run_tessellate(a, cli::GlobalFlags{true, 0});
    EXPECT_EQ(test::read_bytes(dir / "fn.glb"), test::read_bytes(dir / "cli.glb"));
}

TEST(commands, RunShellsWritesWhatTheCommandWrites) {
    const fs::path dir = test::temp_dir(), in = write_sphere(dir);
    ASSERT_EQ(run_furrow({"shells", in.string(), "-o", (dir / "cli.glb").string(), "--layers", "6", "--length", "0.1", "-q"}).exit_code, 0);
    cli::ShellsArgs a;
    a.in = in.string();
    a.out = (dir / "fn.glb").string();
    a.fur.shells.layers = 6;
    a.fur.shells.length = 0.1;
    a.fur.max_triangles = cli::kDefaultTriangleBudget; // as register_shells sets it
    cli::run_shells(a, cli::GlobalFlags{true, 0});
    EXPECT_EQ(test::read_bytes(dir / "fn.glb"), test::read_bytes(dir / "cli.glb"));
}

TEST(commands, RunConvertReportsAMissingInputAsAnInputError) {
    const fs::path dir = test::temp_dir();
    cli::ConvertArgs a;
    a.in = (dir / "missing.obj").string();
    a.out = (dir / "out.glb").string();
    try {
        cli::run_convert(a, cli::GlobalFlags{true, 0});
        FAIL() << "no error";
    } catch (const cli::InputError& e) {
        EXPECT_EQ(e.file, a.in);
        EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(dir / "out.glb"));
}

} // namespace
} // namespace furrow

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

namespace furrow {
namespace {

// main() registers only the command a line names (command_named); the rest of the line is CLI11's as before.
TEST(commands, CommandNamedSkipsTheThreadCountAndFindsTheFirstCommandWord) {
    auto named = [](std::vector<const char*> words) {
        words.insert(words.begin(), "furrow");
        return cli::command_named(int(words.size()), words.data(), {"check", "convert", "render"}, {"-j", "--threads"});
    };
    EXPECT_EQ(named({"convert", "in.obj", "-o", "out.glb"}), 1);
    EXPECT_EQ(named({"-q", "-j", "2", "render", "x.glb"}), 2);
    EXPECT_EQ(named({"--threads", "4", "check", "convert.glb"}), 0); // the first command word, not a file's name
    EXPECT_EQ(named({"-j", "check", "render"}), 2);                  // "check" is -j's value (CLI11 refuses it)
    EXPECT_EQ(named({"--help"}), -1);                               // none: every command is registered
    EXPECT_EQ(named({"bogus", "x.glb"}), -1);
    EXPECT_EQ(named({}), -1);
}

TEST(commands, TheLineReadsTheSameWithOnlyItsCommandRegistered) {
    // Help, version and the usage errors that name every command still see all of them.
    const auto help = run_furrow({"--help"});
    EXPECT_EQ(help.exit_code, 0);
    for (const char* c : {"check", "convert", "render", "shells", "stamp", "tessellate", "demo", "bench"})
        EXPECT_NE(help.out.find(c), std::string::npos) << c;
    const auto bogus = run_furrow({"bogus"});
    EXPECT_EQ(bogus.exit_code, 2);
    EXPECT_NE(bogus.err.find("unknown command 'bogus'"), std::string::npos);
    const auto sub = run_furrow({"-q", "convert", "--help"});
    EXPECT_EQ(sub.exit_code, 0);
    EXPECT_NE(sub.out.find("--output"), std::string::npos);
    const auto bad = run_furrow({"convert", "--bogus"});
    EXPECT_EQ(bad.exit_code, 2);
    EXPECT_EQ(bad.err.rfind("Error: ", 0), 0u);
}

} // namespace
} // namespace furrow

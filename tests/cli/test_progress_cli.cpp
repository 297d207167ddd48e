// Progress lines: on a terminal only. Every other test runs the CLI with stderr on a pipe (no progress, no
// control characters); here `script` gives the command a pseudo-terminal.
#include "test_support.h"

#include <cstdlib>

using namespace furrow::test;

namespace {

bool have_script() { return std::system("command -v script >/dev/null 2>&1") == 0; }

} // namespace

// On a pipe: the plain result line, no carriage returns or escape sequences.
TEST(progress_cli, NothingOnAPipe) {
    const auto dir = temp_dir();
    RunResult r = run_furrow({"tessellate", (models_dir() / "ground.glb").string(), "-o", (dir / "t.glb").string(), "--uniform", "2"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.err.find('\r'), std::string::npos);
    EXPECT_EQ(r.err.find('\033'), std::string::npos);
    EXPECT_NE(r.err.find("Wrote "), std::string::npos);
}

// On a terminal: each stage is shown, rewritten in place, and erased before the result line; -q shows nothing.
TEST(progress_cli, StagesOnATerminal) {
    if (!have_script()) GTEST_SKIP() << "util-linux `script` is not installed";
    const auto dir = temp_dir();
    const std::string cmd = std::string(FURROW_CLI) + " tessellate " + (models_dir() / "ground.glb").string() + " -o " +
                            (dir / "t.glb").string() + " --uniform 2";
    const auto log = dir / "tty.txt";
    ASSERT_EQ(std::system(("script -qfec '" + cmd + "' /dev/null > " + log.string()).c_str()), 0);
    const std::string tty = read_text(log);
    for (const char* stage : {"furrow tessellate: loading ", "furrow tessellate: tessellating...", "furrow tessellate: writing "})
        EXPECT_NE(tty.find(stage), std::string::npos) << stage << "\n" << tty;
    EXPECT_NE(tty.find("\r\033[KWrote "), std::string::npos) << tty; // the result line erased the progress line
    const auto quiet = dir / "quiet.txt";
    ASSERT_EQ(std::system(("script -qfec '" + cmd + " -q' /dev/null > " + quiet.string()).c_str()), 0);
    EXPECT_EQ(read_text(quiet).find("tessellating"), std::string::npos);
}

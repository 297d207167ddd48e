// furrow — geometry tools for fur shells and deformable terrain.
#include "commands.h"

#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>

#include <tbb/global_control.h>

#ifndef FURROW_VERSION
#define FURROW_VERSION "0.0.0"
#endif

int main(int argc, char** argv) {
    using namespace furrow::cli;
    CLI::App app{"furrow " FURROW_VERSION " — fur shells, adaptive tessellation and deformable terrain", "furrow"};
    app.set_version_flag("--version", "furrow " FURROW_VERSION);
    app.require_subcommand(1);
    app.fallthrough(); // -q and -j may also follow the command: `furrow check x.glb -q`
    // Usage errors (exit 2) follow the same contract as input errors: one line starting with "Error:" that
    // names the problem (CLI11's default printed the bare message, so scripts grepping for "Error:" missed
    // them), then the hint. Set before the subcommands are added: they inherit it.
    app.failure_message([](const CLI::App* a, const CLI::Error& e) {
        std::string what = e.what();
        // `furrow bogus`: CLI11 only says "A subcommand is required"; name the word it did not know.
        if (a && a->get_subcommands().empty() && !a->remaining().empty()) {
            const std::string word = a->remaining().front();
            what = (word.rfind('-', 0) == 0 ? "unknown option '" : "unknown command '") + word +
                   "' (commands: check, convert, render, shells, stamp, tessellate, demo, bench)";
        }
        for (char& c : what)
            if (c == '\n' || c == '\r') c = ' ';
        while (!what.empty() && what.back() == ' ') what.pop_back();
        return "Error: " + what + "\nRun with --help for more information.\n";
    });
    GlobalFlags g;
    app.add_flag("-q,--quiet", g.quiet, "Print nothing but errors");
    std::unique_ptr<tbb::global_control> thread_limit; // lives until the command has run
    app.add_option_function<int>(
           "-j,--threads",
           [&](int n) {
               g.threads = n;
               if (n > 0)
                   thread_limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                                        size_t(n));
           },
           "Worker threads (default: all cores); output bytes are identical for any count")
        ->check(finite_range(1, 1024));
    // Only the command named on the line is registered (all of them for `furrow --help`, or when none is
    // named): building every command's options was most of the start-up. `furrow -q convert suzanne.obj`
    // (48 KB): 14.8 M -> 11.2 M instructions (valgrind --tool=callgrind), 3.97 -> 3.51 ms wall (median of 61,
    // interleaved; gltfpack -noq: 3.9 ms).
    using Register = void (*)(CLI::App&, GlobalFlags&);
    static constexpr Register commands[] = {register_check, register_convert, register_render, register_shells,
                                            register_stamp, register_tessellate, register_demo, register_bench};
    const int named = command_named(argc, argv, {"check", "convert", "render", "shells", "stamp", "tessellate", "demo", "bench"},
                                    {"-j", "--threads"});
    if (named >= 0) commands[named](app, g);
    else
        for (Register add : commands) add(app, g);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version are "errors" with exit code 0 in CLI11.
        int rc = app.exit(e);
        return rc == 0 ? exit_ok : exit_usage;
    } catch (const InputError& e) {
        std::fprintf(stderr, "Error: %s: %s\n", e.file.c_str(), e.what());
        return exit_bad_input;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "Error: out of memory\n");
        return exit_bad_input;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "Error: internal: %s\n", e.what());
        return exit_internal;
    }
    return exit_ok;
}

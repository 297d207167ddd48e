// furrow — geometry tools for fur shells and deformable terrain.
#include "cli_common.h"

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
        ->check(CLI::Range(1, 1024));
    register_check(app, g);
    register_convert(app, g);
    register_render(app, g);
    register_shells(app, g);
    register_stamp(app, g);
    register_tessellate(app, g);
    register_demo(app, g);
    register_bench(app, g);
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

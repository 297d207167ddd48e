// furrow — geometry tools for fur shells and deformable terrain.
#include "cli_common.h"

#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>

#include <tbb/global_control.h>

#ifndef FURROW_VERSION
#define FURROW_VERSION "0.0.0"
#endif

namespace {

// CLI11's Range, PositiveNumber and NonNegativeNumber let "nan" through (every comparison with NaN is false), so
// `--texel nan` reached the library and came back as an input error naming the mesh (exit 1), and
// `check --sliver-angle nan` was silently accepted; PositiveNumber also printed "not in range 0.000000 to
// 1797693...(300 digits)". Every option with such a check now refuses non-finite values as a usage error (exit
// 2) and the open-ended ranges say what they want.
void harden_number_checks(CLI::App& app) {
    auto number = [](const std::string& s, double& v) {
        size_t used = 0;
        try {
            v = std::stod(s, &used);
        } catch (...) {
            return false;
        }
        return used == s.size();
    };
    for (CLI::Option* opt : app.get_options()) {
        bool ranged = false;
        for (int i = 0;; ++i) {
            CLI::Validator* v = nullptr;
            try {
                v = opt->get_validator(i);
            } catch (const CLI::OptionNotFound&) {
                break;
            }
            const std::string name = v->get_description(); // CLI11 stores "POSITIVE" etc. as the description
            if (name == "POSITIVE" || name == "NONNEGATIVE") {
                const bool positive = name == "POSITIVE";
                v->operation([number, positive](std::string& s) -> std::string {
                    double x = 0;
                    if (!number(s, x) || !std::isfinite(x) || (positive ? !(x > 0) : !(x >= 0)))
                        return std::string("must be a finite number ") + (positive ? "> 0" : ">= 0") + ", got '" + s + "'";
                    return {};
                });
                ranged = true;
            } else if (v->get_description().find(" in [") != std::string::npos) {
                ranged = true; // CLI::Range(a, b)
            }
        }
        if (ranged)
            opt->check(CLI::Validator(
                [number](std::string& s) -> std::string {
                    double x = 0;
                    if (number(s, x) && !std::isfinite(x)) return "must be a finite number, got '" + s + "'";
                    return {};
                },
                "", "FINITE"));
    }
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) harden_number_checks(*sub);
}

} // namespace

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
        ->check(CLI::Range(1, 1024));
    register_check(app, g);
    register_convert(app, g);
    register_render(app, g);
    register_shells(app, g);
    register_stamp(app, g);
    register_tessellate(app, g);
    register_demo(app, g);
    register_bench(app, g);
    harden_number_checks(app);
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

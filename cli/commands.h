// The commands of `furrow`, as functions: each has an Args struct (what its flags fill in), a run_X that does
// the work and prints the report, and a register_X that declares its flags with CLI11 and calls run_X. Tests
// (tests/cli/test_commands.cpp) call run_X directly, without a process or a command line; main.cpp only
// registers the commands. Bad input comes back from run_X as an InputError (cli_common.h).
#pragma once

#include "bench_common.h"
#include "cli_common.h"
#include "data_dirs.h"

#include <furrow/deform.h>
#include <furrow/mesh.h>
#include <furrow/shells.h>
#include <furrow/tessellate.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace furrow::cli {

// `furrow check`
struct CheckArgs {
    LoadOptions load; // --resource-root and the input limits (add_load_flags)
    std::string input;
    bool json = false;
    bool self_intersections = false;
    double sliver_angle = CheckOptions{}.sliver_angle_degrees;
    std::vector<std::string> require;
};

// `furrow render`
struct RenderArgs {
    LoadOptions load; // --resource-root and the input limits (add_load_flags)
    std::string in, out, mode, attribute, background, depth_out;
    bool ortho = false, no_legend = false, no_mipmaps = false;
    double ortho_height = 0, ambient = 0.25, near_plane = 0;
    int ssaa = 1, subpixel_bits = 8;
    CameraFlags camera;
};

// `furrow stamp`
struct StampArgs {
    LoadOptions load; // --resource-root and the input limits (add_load_flags)
    SaveOptions save; // --no-optimize, --quantize, --compress, --position-bits (add_save_flags)
    std::string in, out, colliders, heightmap_out, heightmap_in;
    StampOptions opt;
    CameraFlags camera;
    double pixel_error = 1.0;
    double time = NAN;
    double max_heightmap_mb = 1024;
    bool no_tessellate = false;
};

// `furrow tessellate`
struct TessellateArgs {
    LoadOptions load; // --resource-root and the input limits (add_load_flags)
    SaveOptions save; // --no-optimize, --quantize, --compress, --position-bits (add_save_flags)
    std::string in, out;
    std::string scheme = "catmark", boundary = "corner", uv = "corners";
    CameraFlags camera;
    int uniform = 0, max_rate = 0, accuracy = 2;
    std::optional<double> near, far;
    double pixel_error = 0, screen_error = 0, max_error = 0, crease_angle = 180;
    std::vector<FocusPoint> focus;
    size_t max_triangles = 0;
    bool strict = false;
};

// `furrow demo`
struct DemoArgs {
    std::string models = bundled_models_dir().string();
    std::string out = "furrow-demo";
    int width = 960, height = 720;
    int ssaa = 2;
};

// `furrow bench` with no tool named: every tool
struct BenchAllArgs {
    BenchRun run;
    BenchOutput out;
    std::vector<std::string> only; // tool names; empty = all
};

// `furrow convert`
struct ConvertArgs {
    LoadOptions load; // --resource-root and the input limits (add_load_flags)
    SaveOptions save; // --no-optimize, --quantize, --compress, --position-bits (add_save_flags)
    std::string in, out;
    bool pretty = false;
    bool no_recentre = false;
};

// `furrow shells`
struct ShellsArgs {
    LoadOptions load; // --resource-root and the input limits (add_load_flags)
    SaveOptions save; // --no-optimize, --quantize, --compress, --position-bits (add_save_flags)
    std::string in, out;
    std::string mask; // FILE[:r|g|b|a]
    std::string comb;
    std::string layout = "viewer";
    FurOptions fur;
};

void run_check(const CheckArgs& a, const GlobalFlags& g);
void run_convert(const ConvertArgs& a, const GlobalFlags& g);
void run_render(const RenderArgs& a, const GlobalFlags& g);
void run_shells(const ShellsArgs& a, const GlobalFlags& g);
void run_tessellate(const TessellateArgs& a, const GlobalFlags& g);
void run_stamp(const StampArgs& a, const GlobalFlags& g);
void run_demo(const DemoArgs& a, const GlobalFlags& g);
void run_bench_all(const BenchAllArgs& a, const GlobalFlags& g);

// Each adds its subcommand to `app`; the callback runs run_X with the parsed Args.
void register_check(CLI::App& app, GlobalFlags& g);
void register_convert(CLI::App& app, GlobalFlags& g);
void register_render(CLI::App& app, GlobalFlags& g);
void register_shells(CLI::App& app, GlobalFlags& g);
void register_tessellate(CLI::App& app, GlobalFlags& g);
void register_stamp(CLI::App& app, GlobalFlags& g);
void register_demo(CLI::App& app, GlobalFlags& g);
void register_bench(CLI::App& app, GlobalFlags& g);

} // namespace furrow::cli

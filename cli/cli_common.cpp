#include "cli_common.h"

#include <cstdio>
#include <filesystem>
#include <sstream>

#include <tbb/global_control.h>

namespace furrow::cli {

void require_ok(const Status& status, const std::string& file) {
    if (!status.ok()) throw InputError(file, status.message);
}

static std::array<double, 3> parse_vec3(const std::string& s, const char* flag) {
    std::array<double, 3> v{};
    std::istringstream in(s);
    char c1 = 0, c2 = 0;
    if (!(in >> v[0] >> c1 >> v[1] >> c2 >> v[2]) || c1 != ',' || c2 != ',' || !(in >> std::ws).eof())
        throw CLI::ValidationError(flag, "expected x,y,z, got '" + s + "'");
    for (double x : v)
        if (!std::isfinite(x)) throw CLI::ValidationError(flag, "values must be finite");
    return v;
}

void add_camera_flags(CLI::App& cmd, CameraFlags& f) {
    cmd.add_option_function<std::string>("--camera", [&f](const std::string& s) { f.eye = parse_vec3(s, "--camera"); },
                                         "Camera position x,y,z (default: frames the scene from a 3/4 view)");
    cmd.add_option_function<std::string>("--target", [&f](const std::string& s) { f.target = parse_vec3(s, "--target"); },
                                         "Point the camera looks at x,y,z (default: the scene's bounding-box centre)");
    cmd.add_option_function<std::string>("--up", [&f](const std::string& s) { f.up = parse_vec3(s, "--up"); },
                                         "Up direction x,y,z (default 0,1,0)");
    cmd.add_option("--fov", f.fov_degrees, "Vertical field of view in degrees (default 45)")
        ->check(CLI::Range(1.0, 179.0));
    cmd.add_option_function<std::string>(
        "--size",
        [&f](const std::string& s) {
            int w = 0, h = 0;
            char x = 0;
            std::istringstream in(s);
            if (!(in >> w >> x >> h) || (x != 'x' && x != 'X') || !(in >> std::ws).eof())
                throw CLI::ValidationError("--size", "expected WxH, got '" + s + "'");
            if (w < 1 || h < 1 || w > 16384 || h > 16384)
                throw CLI::ValidationError("--size", "width and height must be in 1..16384, got '" + s + "'");
            f.width = w;
            f.height = h;
        },
        "Image size WxH in pixels, each 1..16384 (default 1024x768)");
}

Scene load_or_throw(const std::string& path, const LoadOptions& options) {
    Scene scene;
    require_ok(load_scene(scene, path, options), path);
    return scene;
}

bool same_file(const std::string& a, const std::string& b) {
    std::error_code ec;
    if (std::filesystem::equivalent(a, b, ec)) return true;
    auto ca = std::filesystem::weakly_canonical(a, ec);
    auto cb = std::filesystem::weakly_canonical(b, ec);
    return !ec && ca == cb;
}

void save_or_throw(const Scene& scene, const std::string& out_path, const std::string& in_path) {
    if (!in_path.empty() && same_file(out_path, in_path))
        throw InputError(out_path, "output path is the input file; refusing to overwrite the input");
    require_ok(save_scene(scene, out_path), out_path);
}

void info(const GlobalFlags& g, const std::string& line) {
    if (!g.quiet) std::fprintf(stderr, "%s\n", line.c_str());
}

} // namespace furrow::cli

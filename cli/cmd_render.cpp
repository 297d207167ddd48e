// `furrow render IN -o OUT.png`: the verification rasterizer (furrow/render.h) on the command line.
#include "commands.h"

#include <furrow/render.h>
#include <furrow_kernel/atomic_file.h>

#include <cstdio>
#include <filesystem>
#include <sstream>

namespace furrow::cli {
namespace {

// Stages bytes beside `path` with the kernel's atomic file output (furrow_kernel/atomic_file.h), to be
// renamed into place by commit_file, so a failure never leaves a half-written output. Throws InputError
// naming `path`.
std::string stage_file(const std::string& path, const std::vector<uint8_t>& bytes) {
    std::string temp;
    if (Status s = kernel::stage_file(path, bytes.data(), bytes.size(), temp); !s.ok()) throw InputError(path, s.message);
    return temp;
}

void commit_file(const std::string& temp, const std::string& path) {
    if (Status s = kernel::commit_file(temp, path); !s.ok()) throw InputError(path, s.message);
}

// A float image as PFM (Netpbm's portable float map: greyscale "Pf", little-endian, bottom row first).
std::vector<uint8_t> encode_pfm(const ImageF& depth) {
    std::string header = "Pf\n" + std::to_string(depth.width) + " " + std::to_string(depth.height) + "\n-1.0\n";
    std::vector<uint8_t> bytes(header.begin(), header.end());
    size_t row_bytes = size_t(depth.width) * sizeof(float);
    for (int y = depth.height - 1; y >= 0; --y) {
        const auto* row = reinterpret_cast<const uint8_t*>(&depth.pixels[size_t(y) * size_t(depth.width)]);
        bytes.insert(bytes.end(), row, row + row_bytes); // x86/ARM are little-endian, as "-1.0" declares
    }
    return bytes;
}

std::array<float, 3> parse_colour(const std::string& s) {
    std::array<float, 3> c{};
    std::istringstream in(s);
    char c1 = 0, c2 = 0;
    if (!(in >> c[0] >> c1 >> c[1] >> c2 >> c[2]) || c1 != ',' || c2 != ',' || !(in >> std::ws).eof())
        throw CLI::ValidationError("--background", "expected R,G,B in 0..1, got '" + s + "'");
    for (float v : c)
        if (!(v >= 0 && v <= 1)) throw CLI::ValidationError("--background", "each of R,G,B must be in 0..1, got '" + s + "'");
    return c;
}

} // namespace

// Validates the arguments, renders, and writes the PNG (and the depth) atomically.
void run_render(const RenderArgs& a, const GlobalFlags& g) {
    RenderOptions o;
    o.width = a.camera.width;
    o.height = a.camera.height;
    o.camera.eye = a.camera.eye;
    o.camera.target = a.camera.target;
    o.camera.up = a.camera.up;
    o.camera.fov_degrees = a.camera.fov_degrees;
    o.camera.orthographic = a.ortho;
    o.camera.ortho_height = a.ortho_height;
    o.ssaa = a.ssaa;
    o.legend = !a.no_legend;
    o.mipmaps = !a.no_mipmaps;
    o.subpixel_bits = a.subpixel_bits;
    o.ambient = float(a.ambient);
    o.camera.near_plane = a.near_plane;
    static const std::pair<const char*, RenderMode> modes[] = {
        {"shaded", RenderMode::shaded}, {"normals", RenderMode::normals},     {"uv", RenderMode::uv},
        {"depth", RenderMode::depth},   {"wireframe", RenderMode::wireframe}, {"attribute", RenderMode::attribute},
        {"cutoff", RenderMode::cutoff}};
    std::string mode = a.mode.empty() ? (a.attribute.empty() ? "shaded" : "attribute") : a.mode;
    for (const auto& [name, m] : modes)
        if (mode == name) o.mode = m;
    if (o.mode == RenderMode::attribute && a.attribute.empty())
        throw CLI::ValidationError("--mode", "attribute mode needs --attribute NAME");
    if (o.mode != RenderMode::attribute && !a.attribute.empty())
        throw CLI::ValidationError("--attribute", "only used with --mode attribute");
    o.attribute = a.attribute;
    if (a.ortho_height > 0 && !a.ortho) throw CLI::ValidationError("--ortho-height", "needs --ortho");
    // Both given and equal is a bad command line (exit 2); it was an input error naming the mesh (exit 1).
    if (a.camera.eye && a.camera.target && *a.camera.eye == *a.camera.target)
        throw CLI::ValidationError("--camera", "the camera position and --target coincide");
    if (!a.background.empty()) o.background = parse_colour(a.background);
    require_extension(a.out, "--output", {".png"});
    if (!a.depth_out.empty()) require_extension(a.depth_out, "--depth-out", {".pfm"});
    for (const std::string* out : {&a.out, &a.depth_out})
        if (!out->empty() && same_file(*out, a.in))
            throw InputError(*out, "output path is the input file; refusing to overwrite the input");

    Progress progress(g, "furrow render");
    progress.stage("loading " + a.in);
    Scene scene = load_or_throw(a.in, a.load);
    for (const auto& w : scene.warnings) info(g, "Warning: " + a.in + ": " + w);
    RenderResult r;
    progress.stage("rendering");
    require_ok(render_scene(r, scene, o), a.in);
    for (const auto& w : r.warnings) info(g, "Warning: " + a.in + ": " + w);
    // Both outputs or neither: the PNG used to be renamed into place before the depth file was even
    // opened, so an unwritable --depth-out left the PNG behind. Stage both, then rename both.
    const std::string png_temp = stage_file(a.out, encode_png_rgba8(r.rgba8.data(), r.color.width, r.color.height));
    std::string depth_temp;
    if (!a.depth_out.empty()) {
        try {
            depth_temp = stage_file(a.depth_out, encode_pfm(r.depth));
        } catch (...) {
            std::error_code ec;
            std::filesystem::remove(png_temp, ec);
            throw;
        }
    }
    const bool had_png = std::filesystem::exists(a.out);
    try {
        commit_file(png_temp, a.out);
    } catch (...) {
        std::error_code ec;
        if (!depth_temp.empty()) std::filesystem::remove(depth_temp, ec);
        throw;
    }
    if (!depth_temp.empty()) {
        try {
            commit_file(depth_temp, a.depth_out);
        } catch (...) {
            std::error_code ec;
            if (!had_png) std::filesystem::remove(a.out, ec);
            throw;
        }
    }
    char timing[64];
    std::snprintf(timing, sizeof timing, "%.1f ms", r.timing.total);
    info(g, "Wrote " + a.out + " (" + std::to_string(o.width) + "x" + std::to_string(o.height) + ", " + mode +
                ", " + std::to_string(r.triangles) + " triangles, " + timing + ")");
}

void register_render(CLI::App& app, GlobalFlags& g) {
    auto args = std::make_shared<RenderArgs>();
    CLI::App* cmd = app.add_subcommand("render", "Render a scene to a PNG with the verification rasterizer");
    cmd->add_option("input", args->in, "Input file (.gltf .glb .obj .ply .off .stl)")->required();
    cmd->add_option("-o,--output", args->out, "Output PNG (RGBA; transparent where nothing is drawn)")->required();
    cmd->add_option("--mode", args->mode,
                    "shaded (default), normals (world normal as 0.5+0.5n), uv, depth, wireframe (shaded + edges), "
                    "attribute (heat map of --attribute), cutoff (alphaCutoff of the front MASK layer as grey: "
                    "which fur shell shows)")
        ->check(CLI::IsMember({"shaded", "normals", "uv", "depth", "wireframe", "attribute", "cutoff"}));
    cmd->add_option("--attribute", args->attribute,
                    "Scalar vertex attribute for the heat map, e.g. _FUR_LENGTH (implies --mode attribute)");
    cmd->add_flag("--ortho", args->ortho, "Orthographic view (default view: top-down along the up axis)");
    cmd->add_option("--ortho-height", args->ortho_height, "World units visible vertically with --ortho (default: fit)")
        ->check(positive());
    cmd->add_option("--ssaa", args->ssaa, "Supersampling: N×N samples per pixel, 1..8 (default 1)")
        ->check(finite_range(1, 8));
    cmd->add_option("--background", args->background, "Opaque background colour R,G,B in 0..1 (sRGB; default transparent)");
    cmd->add_option("--depth-out", args->depth_out,
                    "Also write the depth (view-axis distance, +inf where empty) as a float PFM image");
    cmd->add_flag("--no-legend", args->no_legend, "Attribute mode: leave out the colour bar");
    cmd->add_flag("--no-mipmaps", args->no_mipmaps,
                  "Sample every texture from its base level (default: follow each sampler's minFilter, mip-mapping "
                  "as real-time viewers do)");
    cmd->add_option("--ambient", args->ambient,
                    "Ambient share of the Lambert shading, 0..1 (default 0.25; 1 = unlit material colour)")
        ->check(finite_range(0.0, 1.0));
    cmd->add_option("--subpixel-bits", args->subpixel_bits,
                    "Vertex snapping precision, 1/2^N of a pixel: 8 (default) as Direct3D and desktop GPUs, 4 as "
                    "SwiftShader (Chromium's software GL)")
        ->check(finite_range(1, 8));
    cmd->add_option("--near", args->near_plane, "Near clipping plane distance (default: from the bounding box)")
        ->check(positive());
    add_camera_flags(*cmd, args->camera);
    add_load_flags(*cmd, args->load);
    cmd->footer("Examples:\n"
                "  furrow render fox.glb -o fox.png\n"
                "  furrow render fox.glb -o fox.png --size 1920x1080 --ssaa 4 --background 1,1,1\n"
                "  furrow render terrain.glb -o top.png --ortho --mode depth --depth-out top.pfm\n"
                "  furrow render shells.glb -o length.png --attribute _FUR_LENGTH\n"
                "  furrow render bunny.obj -o wire.png --mode wireframe --camera 0.3,0.2,0.4 --target 0,0.1,0 --fov 30");
    cmd->callback([args, &g] { run_render(*args, g); });
}

} // namespace furrow::cli

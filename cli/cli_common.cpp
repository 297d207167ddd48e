#include "cli_common.h"

#include <malloc.h>

#include <cctype>
#include <cmath>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include <unistd.h>

#include <nlohmann/json.hpp>
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

// --size WxH, each 1..16384.
static void add_size_flag(CLI::App& cmd, CameraFlags& f, const std::string& help) {
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
        help);
}

void add_camera_flags(CLI::App& cmd, CameraFlags& f, CameraUse use) {
    cmd.add_option_function<std::string>("--camera", [&f](const std::string& s) { f.eye = parse_vec3(s, "--camera"); },
                                         use == CameraUse::view
                                             ? "Camera position x,y,z (default: frames the scene from a 3/4 view)"
                                             : "Eye position x,y,z the output is refined for (distances are measured "
                                               "from it; where it looks does not matter)");
    if (use == CameraUse::eye) {
        cmd.add_option("--fov", f.fov_degrees, "Vertical field of view of that eye in degrees (default 45)")
            ->check(finite_range(1.0, 179.0));
        add_size_flag(cmd, f, "Image size WxH the pixel criteria refer to (only the height matters; default 1024x768)");
        return;
    }
    cmd.add_option_function<std::string>("--target", [&f](const std::string& s) { f.target = parse_vec3(s, "--target"); },
                                         "Point the camera looks at x,y,z (default: the scene's bounding-box centre)");
    // A zero up vector is a bad option value (exit 2), not a problem of the input file (it was reported by the
    // renderer as "Error: <input>: camera values must be finite, up non-zero", exit 1).
    cmd.add_option_function<std::string>("--up",
                                         [&f](const std::string& s) {
                                             f.up = parse_vec3(s, "--up");
                                             if (f.up[0] == 0 && f.up[1] == 0 && f.up[2] == 0)
                                                 throw CLI::ValidationError("--up", "must not be the zero vector");
                                         },
                                         "Up direction x,y,z (default 0,1,0)");
    cmd.add_option("--fov", f.fov_degrees, "Vertical field of view in degrees (default 45)")
        ->check(finite_range(1.0, 179.0));
    add_size_flag(cmd, f, "Image size WxH in pixels, each 1..16384 (default 1024x768)");
}

void add_save_flags(CLI::App& cmd, SaveOptions& o) {
    cmd.add_flag_callback("--no-optimize", [&o] { o.optimize = false; },
                          "Keep the vertex and triangle order (default: meshoptimizer's vertex cache and fetch order)");
    cmd.add_flag_callback("--quantize", [&o] { if (o.encoding == Encoding::plain) o.encoding = Encoding::quantize; },
                          "Integer positions, normals, tangents, UVs and colours (KHR_mesh_quantization, required); "
                          "positions on a grid of the mesh's bounding box, see --position-bits");
    cmd.add_flag_callback("--compress", [&o] { o.encoding = Encoding::compress; },
                          "--quantize, then EXT_meshopt_compression (required: three.js needs its MeshoptDecoder, "
                          "Blender 3.4 cannot read the file)");
    cmd.add_flag_callback("--drop-unused-uvs", [&o] { o.drop_unused_uvs = true; },
                          "Leave out texture coordinates that no texture of the material samples, as gltfpack does "
                          "(kept where the mesh has extras or extensions, e.g. --layout instanced)");
    cmd.add_option("--position-bits", o.position_bits,
                   "Bits per quantized position axis: step = the mesh's largest extent / (2^N - 1), error <= step/2 "
                   "(default " + std::to_string(default_position_bits) + ", as gltfpack -vp)")
        ->type_name("N")
        ->check(finite_range(1, 16).description(""));
}

void add_load_flags(CLI::App& cmd, LoadOptions& o) {
    const LoadOptions d;
    // An empty or missing folder is a bad option value (exit 2), before any input is read.
    cmd.add_option("--resource-root", o.resource_root,
                   "Folder a .gltf's external buffers and images must lie in, after '..' and symbolic links are "
                   "resolved (default: the input's own folder and below)")
        ->type_name("DIR")
        ->check(CLI::ExistingDirectory.description(""));
    cmd.add_option("--max-resource-bytes", o.max_resource_bytes,
                   "Most bytes of external buffers and images, together (default " + std::to_string(d.max_resource_bytes) + ")")
        ->type_name("N")
        ->check(positive().description(""));
    cmd.add_option("--max-image-pixels", o.max_image_pixels,
                   "Largest width x height of an image, read from its header (default " + std::to_string(d.max_image_pixels) + ")")
        ->type_name("N")
        ->check(positive().description(""));
    cmd.add_option("--max-nodes", o.max_nodes, "Most nodes in a glTF input (default " + std::to_string(d.max_nodes) + ")")
        ->type_name("N")
        ->check(positive().description(""));
    cmd.add_option("--max-primitives", o.max_primitives,
                   "Most primitives in a glTF input, over all meshes (default " + std::to_string(d.max_primitives) + ")")
        ->type_name("N")
        ->check(positive().description(""));
}

Scene load_or_throw(const std::string& path, const LoadOptions& options) {
    Scene scene;
    Status s = load_scene(scene, path, options);
    // The library names the LoadOptions field that raises a limit; on the command line it is a flag.
    static const std::pair<const char*, const char*> flags[] = {{"LoadOptions::max_image_pixels", "--max-image-pixels"},
                                                                {"LoadOptions::max_nodes", "--max-nodes"},
                                                                {"LoadOptions::max_primitives", "--max-primitives"},
                                                                {"LoadOptions::max_resource_bytes", "--max-resource-bytes"}};
    for (const auto& [field, flag] : flags)
        if (size_t at = s.message.find(field); at != std::string::npos) s.message.replace(at, std::strlen(field), flag);
    require_ok(s, path);
    return scene;
}

std::string lower_extension(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
    return e;
}

void require_extension(const std::string& path, const std::string& option, std::initializer_list<const char*> allowed) {
    const std::string ext = lower_extension(path);
    std::string list;
    size_t i = 0;
    for (const char* a : allowed) {
        if (ext == a) return;
        list += (i == 0 ? "" : i + 1 == allowed.size() ? " or " : ", ") + std::string(a);
        ++i;
    }
    throw CLI::ValidationError(option, "must end in " + list);
}

bool same_file(const std::string& a, const std::string& b) {
    std::error_code ec;
    if (std::filesystem::equivalent(a, b, ec)) return true;
    auto ca = std::filesystem::weakly_canonical(a, ec);
    auto cb = std::filesystem::weakly_canonical(b, ec);
    return !ec && ca == cb;
}

// The files a .gltf input reads besides itself: its buffers' and images' relative URIs (percent-decoded),
// resolved against its folder. Data URIs and absolute URLs are skipped.
static std::vector<std::string> gltf_resources(const std::string& in_path) {
    std::vector<std::string> files;
    if (lower_extension(in_path) != ".gltf") return files;
    std::ifstream in(in_path, std::ios::binary);
    nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (!j.is_object()) return files;
    for (const char* key : {"buffers", "images"}) {
        if (!j.contains(key) || !j[key].is_array()) continue;
        for (const auto& e : j[key]) {
            if (!e.is_object() || !e.contains("uri") || !e["uri"].is_string()) continue;
            const std::string uri = e["uri"].get<std::string>();
            if (uri.rfind("data:", 0) == 0 || uri.find("://") != std::string::npos) continue;
            std::string name;
            for (size_t i = 0; i < uri.size(); ++i) {
                if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
                    std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
                    name += char(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
                    i += 2;
                } else {
                    name += uri[i];
                }
            }
            files.push_back((std::filesystem::path(in_path).parent_path() / name).string());
        }
    }
    return files;
}

void refuse_overwriting_input(const std::string& out_path, const std::string& in_path) {
    if (in_path.empty()) return;
    if (same_file(out_path, in_path))
        throw InputError(out_path, "output path is the input file; refusing to overwrite the input");
    // A .gltf output also writes <stem>.bin beside it, which may be a file the input reads: `convert a.gltf
    // -o data.gltf` silently overwrote the input's data.bin. Inputs are never modified.
    if (lower_extension(out_path) != ".gltf") return;
    const std::string bin = std::filesystem::path(out_path).replace_extension(".bin").string();
    for (const std::string& f : gltf_resources(in_path))
        if (same_file(bin, f))
            throw InputError(out_path, "its buffer file " + bin + " is a file of the input; refusing to overwrite the input");
}

void save_or_throw(const Scene& scene, const std::string& out_path, const std::string& in_path,
                   const SaveOptions& options) {
    refuse_overwriting_input(out_path, in_path);
    // Hand the pages the command's own stage freed (a tessellation's or the shells' working arrays) back to the
    // system before the writer allocates its output: glibc keeps freed blocks below its mmap threshold in the
    // heap, scattered between live ones, so without this the writer's buffers came on top of them and the
    // command peaked near 3x its output (`furrow bench memory`).
    malloc_trim(0);
    require_ok(save_scene(scene, out_path, options), out_path);
}

// stderr is shared by info() lines and a Progress ticker thread: one writer at a time, and a line printed
// while a progress line is shown first erases it (the ticker redraws it on its next tick).
static std::mutex& stderr_mutex() {
    static std::mutex m;
    return m;
}
static bool stderr_is_terminal() {
    static const bool tty = ::isatty(STDERR_FILENO) != 0;
    return tty;
}

void info(const GlobalFlags& g, const std::string& line) {
    if (g.quiet) return;
    std::lock_guard lock(stderr_mutex());
    std::fprintf(stderr, "%s%s\n", stderr_is_terminal() ? "\r\033[K" : "", line.c_str());
}

struct Progress::State {
    std::string command, stage;
    std::chrono::steady_clock::time_point since = std::chrono::steady_clock::now();
    std::mutex m;
    std::condition_variable cv;
    bool done = false;
    std::thread ticker;

    void draw() { // with m held
        std::lock_guard lock(stderr_mutex());
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
        std::fprintf(stderr, "\r\033[K%s: %s... %.1f s", command.c_str(), stage.c_str(), s);
        std::fflush(stderr);
    }
};

Progress::Progress(const GlobalFlags& g, std::string command) {
    if (g.quiet || !stderr_is_terminal()) return;
    state_ = std::make_unique<State>();
    state_->command = std::move(command);
    State* st = state_.get();
    st->ticker = std::thread([st] {
        std::unique_lock lock(st->m);
        while (!st->cv.wait_for(lock, std::chrono::milliseconds(250), [st] { return st->done; }))
            if (!st->stage.empty()) st->draw();
    });
}

void Progress::stage(const std::string& what) {
    if (!state_) return;
    std::lock_guard lock(state_->m);
    state_->stage = what;
    state_->since = std::chrono::steady_clock::now();
    state_->draw();
}

Progress::~Progress() {
    if (!state_) return;
    {
        std::lock_guard lock(state_->m);
        state_->done = true;
    }
    state_->cv.notify_all();
    state_->ticker.join();
    std::lock_guard lock(stderr_mutex());
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
}

namespace {

// Parses the whole of s as a double (std::stod accepts "nan", "inf" and trailing junk; the latter is refused).
bool parse_number(const std::string& s, double& v) {
    size_t used = 0;
    try {
        v = std::stod(s, &used);
    } catch (...) {
        return false;
    }
    return used == s.size();
}

CLI::Validator bounded_below(bool strictly, const char* name) {
    return CLI::Validator(
        [strictly](std::string& s) -> std::string {
            double x = 0;
            if (!parse_number(s, x) || !std::isfinite(x) || (strictly ? !(x > 0) : !(x >= 0)))
                return std::string("must be a finite number ") + (strictly ? "> 0" : ">= 0") + ", got '" + s + "'";
            return {};
        },
        name);
}

template <class T>
CLI::Validator range_then_finite(T lo, T hi) {
    const CLI::Range range(lo, hi);
    return CLI::Validator(
        [range](std::string& s) -> std::string {
            if (std::string e = range(s); !e.empty()) return e;
            double x = 0;
            if (parse_number(s, x) && !std::isfinite(x)) return "must be a finite number, got '" + s + "'";
            return {};
        },
        range.get_description());
}

} // namespace

CLI::Validator positive() { return bounded_below(true, "POSITIVE"); }
CLI::Validator non_negative() { return bounded_below(false, "NONNEGATIVE"); }
CLI::Validator finite_range(int lo, int hi) { return range_then_finite(lo, hi); }
CLI::Validator finite_range(double lo, double hi) { return range_then_finite(lo, hi); }

int command_named(int argc, const char* const* argv, std::initializer_list<const char*> commands,
                  std::initializer_list<const char*> valued) {
    for (int a = 1; a < argc; ++a) {
        const std::string word = argv[a];
        int k = 0;
        for (const char* c : commands) {
            if (word == c) return k;
            ++k;
        }
        for (const char* v : valued)
            if (word == v) ++a; // its value
    }
    return -1;
}

} // namespace furrow::cli

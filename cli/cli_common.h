// Shared pieces of the `furrow` command: the error/exit-code contract, camera flags, output helpers.
#pragma once

#include <CLI/CLI.hpp>
#include <furrow/mesh.h>

#include <array>
#include <initializer_list>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

namespace furrow::cli {

// Exit codes (documented in README.md):
enum ExitCode : int {
    exit_ok = 0,
    exit_bad_input = 1, // bad input, unwritable output or failed --require: one "Error: <file>: <what>" line
    exit_usage = 2,     // bad command line: one "Error: <what>" line (main.cpp's CLI11 failure message)
    exit_internal = 3,  // a bug: an unexpected exception (please report)
};

// Thrown inside commands; main() prints "Error: <file>: <what>" and returns exit_bad_input.
struct InputError : std::runtime_error {
    std::string file;
    InputError(std::string file_, const std::string& what) : std::runtime_error(what), file(std::move(file_)) {}
};

// Throws InputError(file, status.message) if status is not ok.
void require_ok(const Status& status, const std::string& file);

// Number checks for options. CLI11's own (PositiveNumber, NonNegativeNumber, Range) accept "nan" (every
// comparison with NaN is false) and "inf", and PositiveNumber's message printed its bound as 300 digits
// (`check --sliver-angle nan` was accepted silently). These refuse non-finite values as a usage error (exit 2)
// and say what they want: "must be a finite number > 0, got 'nan'".
CLI::Validator positive();     // finite and > 0 (shown as POSITIVE in --help)
CLI::Validator non_negative(); // finite and >= 0 (NONNEGATIVE)
CLI::Validator finite_range(int lo, int hi);       // CLI::Range(lo, hi), then finite
CLI::Validator finite_range(double lo, double hi); // CLI::Range(lo, hi), then finite

// Which of `commands` a command line names: the index of the first argument that is one of them, the word
// after an option in `valued` (a global option that takes a value: `-j 4`) skipped; -1 when none is named.
// main() registers only that command.
int command_named(int argc, const char* const* argv, std::initializer_list<const char*> commands,
                  std::initializer_list<const char*> valued);

struct GlobalFlags {
    bool quiet = false;
    int threads = 0; // 0 = all cores
};

// Camera flags shared by every command that needs a view.
struct CameraFlags {
    std::optional<std::array<double, 3>> eye;    // --camera x,y,z
    std::optional<std::array<double, 3>> target; // --target x,y,z
    std::array<double, 3> up{0, 1, 0};           // --up x,y,z
    double fov_degrees = 45.0;                   // --fov (vertical)
    int width = 1024, height = 768;              // --size WxH
};
// view: a camera that renders (render): --camera (default: a 3/4 view framing the scene), --target, --up,
// --fov, --size. eye: the eye an output is refined for (stamp, tessellate), where only the position, the
// field of view and the image height matter: --camera, --fov, --size; --target and --up are not accepted.
enum class CameraUse { view, eye };
void add_camera_flags(CLI::App& cmd, CameraFlags& flags, CameraUse use = CameraUse::view);

// The output size commands refuse above unless --max-triangles says otherwise: 20 M triangles is a GLB of
// about 0.6 GB with normals and UVs, well inside the format's 4 GiB and a machine's memory.
constexpr size_t kDefaultTriangleBudget = 20'000'000;

// The flags of every command that reads a scene, into `options` (README "Threat model"): --resource-root DIR
// (external buffers and images only from DIR and below; default: the input's folder), --max-resource-bytes,
// --max-image-pixels, --max-nodes, --max-primitives (defaults: LoadOptions's).
void add_load_flags(CLI::App& cmd, LoadOptions& options);
// The flags of every command that writes a glTF, into `options` (README "Output size"): --no-optimize
// (keep the vertex order), --quantize (KHR_mesh_quantization), --compress (quantization +
// EXT_meshopt_compression; wins over --quantize), --position-bits N (1..16; default 14).
void add_save_flags(CLI::App& cmd, SaveOptions& options);

// Loads a scene or throws InputError naming the file.
Scene load_or_throw(const std::string& path, const LoadOptions& options = {});
// Saves or throws InputError naming the output; refuses output == input.
void save_or_throw(const Scene& scene, const std::string& out_path, const std::string& in_path = {},
                   const SaveOptions& options = {});
bool same_file(const std::string& a, const std::string& b);
// Throws InputError naming the output if writing out_path would overwrite in_path or, for a .gltf output, if
// its .bin would overwrite a buffer or image file the .gltf input reads.
void refuse_overwriting_input(const std::string& out_path, const std::string& in_path);

// The extension of `path` in lower case, with its dot (".glb"; "" without one): what save_scene and
// save_heightmap choose the format by, so a name that passes require_extension is one they write.
std::string lower_extension(const std::string& path);
// The output checks of every command, before any work: throws CLI::ValidationError(option, "must end in .glb
// or .gltf") unless the lower-case extension of `path` is one of `allowed` (lower case, with the dot).
void require_extension(const std::string& path, const std::string& option, std::initializer_list<const char*> allowed);

// Prints to stderr unless quiet.
void info(const GlobalFlags& g, const std::string& line);

// Progress for long work: one stderr line, rewritten in place with the current stage and the seconds spent in
// it ("furrow shells: growing 32 shells... 3.2 s"), erased when the object goes away (also on an error, before
// main prints it). Only when stderr is a terminal and not --quiet: logs, pipes and tests see nothing.
class Progress {
public:
    Progress(const GlobalFlags& g, std::string command);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;
    void stage(const std::string& what);

private:
    struct State;
    std::unique_ptr<State> state_; // null when not on a terminal
};


} // namespace furrow::cli

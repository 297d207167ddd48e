// Determinism: every command that writes files (convert, render, shells, tessellate, stamp, demo, and the JSON
// report of check) gives byte-identical output for -j 1, -j 2 and -j 8 (README: "output bytes are the same for
// any N"), and again when run twice with the same count. Every file a run writes is compared, not only the
// main output (.bin beside a .gltf, depth and heightmap files, all demo files).
#include "test_support.h"

#include <furrow/shapes.h>

#include <functional>
#include <map>

namespace furrow {
namespace {

namespace fs = std::filesystem;
using test::run_furrow;

// The inputs every job reads, written once per test into <dir>/in: a small creature with UVs (4K triangles),
// the bundled fur mask and footprint brush, a small snow ground, colliders of every shape, and a demo scene
// description using them.
void write_inputs(const fs::path& in) {
    fs::create_directories(in);
    ASSERT_TRUE(save_scene(make_scene(shapes::creature(64, 32), "creature"), (in / "creature.glb").string()).ok());
    ASSERT_TRUE(save_scene(make_scene(shapes::grid(6, 6, 24, 24), "ground"), (in / "ground.glb").string()).ok());
    fs::copy_file(test::models_dir() / "creature_fur_mask.png", in / "mask.png");
    fs::copy_file(test::models_dir() / "footprint.png", in / "footprint.png");
    test::write_text(in / "colliders.json", R"({"colliders": [
  {"shape": "sphere", "radius": 0.3, "path": [[-2, 0.2, -2], [-1, 0.22, -1.5], [0, 0.2, -1]], "time": [0, 1, 2]},
  {"shape": "box", "size": [0.5, 0.3, 0.6], "heading": 20, "path": [[1.5, 0.1, 1.5]]},
  {"shape": "capsule", "radius": 0.1, "length": 0.8, "path": [[1, 0.05, -1], [1.2, 0.05, 0]]},
  {"shape": "image", "image": "footprint.png", "size": [0.12, 0.3], "depth": 0.06, "heading": 45, "path": [[-1, 0.2, 1]]}
]})");
    test::write_text(in / "scene.json", R"({
  "creature": {"model": "creature.glb", "fur_mask": "mask.png", "camera": {"eye": [1.6, 1.1, 2.2], "target": [0, 0.45, 0], "fov": 40}},
  "snow": {"ground": "ground.glb", "colliders": "colliders.json", "camera": {"eye": [0, 5, 7], "target": [0, 0, 0], "fov": 45}},
  "terrain": {"ground": "ground.glb", "scheme": "catmark", "screen_error": 2, "max_rate": 8,
              "camera": {"eye": [-5, 2, 5], "target": [0, 0, 0], "fov": 50}}
})");
}

struct Job {
    std::string name;
    // The command line for one run reading from `in` and writing into the (empty) folder `out`.
    std::function<std::vector<std::string>(const fs::path& in, const fs::path& out)> args;
    bool compare_stdout = false; // check --json prints its report
};

void PrintTo(const Job& j, std::ostream* os) { *os << j.name; }

std::vector<Job> jobs() {
    auto s = [](const fs::path& p) { return p.string(); };
    return {
        // .gltf output: the .bin beside it is compared too.
        {"Convert", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"convert", s(in / "creature.glb"), "-o", s(out / "creature.gltf"), "--pretty"};
         }},
        {"RenderShadedWithDepth", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"render", s(in / "creature.glb"), "-o", s(out / "c.png"), "--size", "160x120", "--ssaa", "2",
                                             "--background", "1,1,1", "--depth-out", s(out / "c.pfm")};
         }},
        {"RenderWireframe", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"render", s(in / "ground.glb"), "-o", s(out / "w.png"), "--size", "160x120", "--mode", "wireframe",
                                             "--camera", "0,4,6"};
         }},
        {"ShellsViewerGltf", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"shells", s(in / "creature.glb"), "-o", s(out / "fur.gltf"), "--layers", "6", "--length", "0.04",
                                             "--mask", s(in / "mask.png"), "--fins", "--lod", "2", "--droop", "0.5", "--texture-size", "64"};
         }},
        {"ShellsViewerCompressed", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"shells", s(in / "creature.glb"), "-o", s(out / "fur.glb"), "--layers", "6", "--length", "0.04",
                                             "--mask", s(in / "mask.png"), "--texture-size", "64", "--compress"};
         }},
        {"ConvertQuantizedGltf", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"convert", s(in / "ground.glb"), "-o", s(out / "q.gltf"), "--quantize", "--position-bits", "12"};
         }},
        {"ShellsEngine", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"shells", s(in / "creature.glb"), "-o", s(out / "fur.glb"), "--layers", "8", "--length", "0.03",
                                             "--layout", "engine", "--spacing-power", "1.5", "--texture-size", "64", "--seed", "9"};
         }},
        {"TessellateAdaptive", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"tessellate", s(in / "creature.glb"), "-o", s(out / "t.glb"), "--scheme", "loop", "--camera",
                                             "0,0.6,2", "--size", "320x240", "--screen-error", "1", "--max-triangles", "30000"};
         }},
        {"TessellateCatmarkMaxError", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"tessellate", s(in / "ground.glb"), "-o", s(out / "t.gltf"), "--max-error", "0.005", "--max-rate", "6",
                                             "--focus", "0,0,0,1", "--crease-angle", "30", "--uv", "linear"};
         }},
        {"StampWithHeightmaps", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"stamp", s(in / "ground.glb"), "-o", s(out / "snow.glb"), "--colliders", s(in / "colliders.json"),
                                             "--resolution", "256", "--rim", "0.1", "--conserve-volume", "--refill", "0.1", "--heightmap-out",
                                             s(out / "h.pfm")};
         }},
        {"StampPngHeightmapCamera", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"stamp", s(in / "ground.glb"), "-o", s(out / "snow.gltf"), "--colliders", s(in / "colliders.json"),
                                             "--resolution", "200", "--rim", "0.05", "--camera", "0,4,6", "--heightmap-out", s(out / "h.png")};
         }},
        {"Demo", [=](const fs::path& in, const fs::path& out) {
             return std::vector<std::string>{"demo", "--models", s(in), "-o", s(out / "demo"), "--ssaa", "1"};
         }},
        {"CheckJson", [=](const fs::path& in, const fs::path&) {
             return std::vector<std::string>{"check", s(in / "creature.glb"), "--json", "--self-intersections", "--require", "closed,manifold"};
         },
         true},
    };
}

// Every file under `dir` (relative path -> bytes).
std::map<std::string, std::vector<uint8_t>> files_under(const fs::path& dir) {
    std::map<std::string, std::vector<uint8_t>> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = test::read_bytes(e.path());
    return files;
}

std::string first_difference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
    if (a.size() != b.size()) return "sizes " + std::to_string(a.size()) + " and " + std::to_string(b.size());
    for (size_t i = 0; i < a.size(); ++i)
        if (a[i] != b[i]) return "first difference at byte " + std::to_string(i);
    return "";
}

class Determinism : public ::testing::TestWithParam<Job> {};

TEST_P(Determinism, SameBytesForAnyThreadCountAndRun) {
    const Job& job = GetParam();
    const fs::path dir = test::temp_dir();
    write_inputs(dir / "in");
    const auto inputs_before = files_under(dir / "in");

    struct Run {
        std::string label;
        std::map<std::string, std::vector<uint8_t>> files;
        std::string out;
    };
    std::vector<Run> runs;
    // -j 1, -j 2, -j 8, and -j 8 once more; and -j 2 given after the command (the global flag may follow it).
    const std::vector<std::pair<std::string, bool>> counts = {{"1", false}, {"2", false}, {"8", false}, {"8", false}, {"2", true}};
    for (size_t k = 0; k < counts.size(); ++k) {
        const auto& [n, after] = counts[k];
        const std::string label = "-j " + n + (after ? " (after the command)" : "") + " run " + std::to_string(k + 1);
        const fs::path out = dir / ("out" + std::to_string(k + 1));
        fs::create_directories(out);
        std::vector<std::string> args = job.args(dir / "in", out);
        if (after) args.insert(args.end(), {"-j", n});
        else args.insert(args.begin(), {"-j", n});
        const test::RunResult r = run_furrow(args);
        ASSERT_EQ(r.exit_code, 0) << label << ":\n" << r.err;
        runs.push_back({label, files_under(out), job.compare_stdout ? r.out : std::string()});
    }
    const Run& ref = runs.front();
    if (job.compare_stdout) {
        EXPECT_FALSE(ref.out.empty());
    } else {
        ASSERT_FALSE(ref.files.empty()) << "the command wrote nothing";
    }
    for (size_t k = 1; k < runs.size(); ++k) {
        const Run& r = runs[k];
        std::vector<std::string> a, b;
        for (const auto& f : ref.files) a.push_back(f.first);
        for (const auto& f : r.files) b.push_back(f.first);
        ASSERT_EQ(b, a) << r.label << " wrote other files than " << ref.label;
        for (const auto& [name, bytes] : ref.files) {
            const auto& other = r.files.at(name);
            EXPECT_TRUE(other == bytes) << name << ": " << r.label << " differs from " << ref.label << ": " << first_difference(bytes, other);
        }
        EXPECT_EQ(r.out, ref.out) << r.label << ": stdout differs from " << ref.label;
    }
    // The inputs were only read.
    const auto inputs_after = files_under(dir / "in");
    EXPECT_TRUE(inputs_after == inputs_before);
}

INSTANTIATE_TEST_SUITE_P(Commands, Determinism, ::testing::ValuesIn(jobs()),
                         [](const ::testing::TestParamInfo<Job>& info) { return info.param.name; });

} // namespace
} // namespace furrow

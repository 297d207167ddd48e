// Helpers shared by the test executables: paths, temp folders, the CLI runner, the Khronos validator.
#pragma once

#include <algorithm>
#include <cstdint>

#include <furrow/mesh.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace furrow::test {

std::filesystem::path source_dir();         // the repository
std::filesystem::path corpus_dir();         // ../shared/corpus
std::filesystem::path corpus(const std::string& relative); // corpus_dir()/relative; fails the test if missing
std::filesystem::path models_dir();         // repository models/

// A fresh, empty folder for one test (under the build tree), named after the running test.
std::filesystem::path temp_dir();

struct RunResult {
    int exit_code = -1;
    std::string out, err;
};
// Runs the built `furrow` executable with the given arguments (no shell involved).
RunResult run_furrow(const std::vector<std::string>& args);
// Runs a program (argv[0] a path) with the given arguments, no shell involved.
RunResult run_program(const std::vector<std::string>& argv);
// Runs Node.js (the one CMake found) with the given arguments.
RunResult run_node(const std::vector<std::string>& args);

// Runs the Khronos glTF-Validator on a written file. Returns "" when it reports 0 errors and 0 warnings,
// otherwise the validator's report. Use: EXPECT_VALID_GLTF(path).
std::string validate_gltf(const std::filesystem::path& file);
#define EXPECT_VALID_GLTF(path)                                                                    \
    do {                                                                                           \
        std::string report_ = ::furrow::test::validate_gltf(path);                                 \
        EXPECT_TRUE(report_.empty()) << report_;                                                   \
    } while (0)

std::vector<uint8_t> read_bytes(const std::filesystem::path& file);
std::string read_text(const std::filesystem::path& file); // the bytes as a string
void write_bytes(const std::filesystem::path& file, const std::vector<uint8_t>& bytes);
void write_text(const std::filesystem::path& file, const std::string& text);
// Files in a folder (names only, sorted): to assert that a failed command left nothing behind.
std::vector<std::string> list_dir(const std::filesystem::path& dir);

bool all_finite(const Scene& scene);

// Whether this build runs under AddressSanitizer (its shadow memory multiplies resident sizes).
bool under_address_sanitizer();
// `furrow bench memory` on the inputs: expects `rows` rows, each exiting 0 with a real peak (above 4 MiB) within
// the memory rule's limit. Returns the commands measured.
std::set<std::string> expect_memory_rule(const std::vector<std::string>& inputs, size_t rows);

// A reproducible random stream for generated test files (Knuth's MMIX linear congruential generator): the
// same numbers on every platform, unlike the standard distributions. next(n) is in [0, n).
struct Lcg {
    uint64_t state;
    explicit Lcg(uint64_t seed) : state(seed) {}
    uint64_t operator()(uint64_t n) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return (state >> 33) % n;
    }
};

// A face's n distinct vertex indices below nv, drawn from `next` (n <= nv).
inline std::vector<uint32_t> distinct_corners(Lcg& next, size_t nv, size_t n) {
    std::vector<uint32_t> corners;
    while (corners.size() < n) {
        const uint32_t c = uint32_t(next(nv));
        if (std::find(corners.begin(), corners.end(), c) == corners.end()) corners.push_back(c);
    }
    return corners;
}

// The JSON document of a .gltf or .glb file (the GLB's JSON chunk); null on failure.
nlohmann::json gltf_json(const std::filesystem::path& file);

// splitmix64 (G. Steele, D. Lea, C. Flood, "Fast Splittable Pseudorandom Number Generators", OOPSLA 2014): the
// property tests' generator, the same stream on every platform and standard library (unlike <random>'s
// distributions), so a failing case is the same case everywhere.
inline uint64_t splitmix64(uint64_t& s) {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
// Uniform in [0, 1) from 53 random bits.
inline double unit_uniform(uint64_t& s) { return double(splitmix64(s) >> 11) * 0x1.0p-53; }

} // namespace furrow::test

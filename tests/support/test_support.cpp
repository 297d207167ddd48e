#include "test_support.h"

#include <cmath>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace furrow::test {
namespace fs = std::filesystem;

fs::path source_dir() { return FURROW_SOURCE_DIR; }
fs::path corpus_dir() { return FURROW_CORPUS_DIR; }
fs::path models_dir() { return source_dir() / "models"; }

fs::path corpus(const std::string& relative) {
    fs::path p = corpus_dir() / relative;
    if (!fs::exists(p)) ADD_FAILURE() << "corpus file missing: " << p << " (../shared/corpus must sit beside the repo)";
    return p;
}

fs::path temp_dir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "no_test";
    for (char& c : name)
        if (c == '/') c = '_';
    fs::path dir = fs::current_path() / "tmp" / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

static std::string slurp_fd(int fd) {
    std::string s;
    char buf[65536];
    ssize_t n;
    while ((n = read(fd, buf, sizeof buf)) > 0) s.append(buf, size_t(n));
    return s;
}

// Runs argv, capturing stdout and stderr through temp files (no deadlock on large outputs).
static RunResult run_process(const std::vector<std::string>& argv) {
    RunResult r;
    char out_name[] = "/tmp/furrow_test_outXXXXXX";
    char err_name[] = "/tmp/furrow_test_errXXXXXX";
    int out_fd = mkstemp(out_name), err_fd = mkstemp(err_name);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, out_fd, 1);
    posix_spawn_file_actions_adddup2(&actions, err_fd, 2);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    std::vector<char*> cargv;
    for (const auto& a : argv) cargv.push_back(const_cast<char*>(a.c_str()));
    cargv.push_back(nullptr);
    pid_t pid = 0;
    if (posix_spawn(&pid, cargv[0], &actions, nullptr, cargv.data(), environ) == 0) {
        int status = 0;
        waitpid(pid, &status, 0);
        r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    posix_spawn_file_actions_destroy(&actions);
    lseek(out_fd, 0, SEEK_SET);
    lseek(err_fd, 0, SEEK_SET);
    r.out = slurp_fd(out_fd);
    r.err = slurp_fd(err_fd);
    close(out_fd);
    close(err_fd);
    unlink(out_name);
    unlink(err_name);
    return r;
}

RunResult run_program(const std::vector<std::string>& argv) { return run_process(argv); }

RunResult run_node(const std::vector<std::string>& args) {
    std::vector<std::string> argv{FURROW_NODE};
    argv.insert(argv.end(), args.begin(), args.end());
    return run_process(argv);
}

RunResult run_furrow(const std::vector<std::string>& args) {
    std::vector<std::string> argv{FURROW_CLI};
    argv.insert(argv.end(), args.begin(), args.end());
    return run_process(argv);
}

std::string validate_gltf(const fs::path& file) {
    RunResult r = run_process({FURROW_NODE, (source_dir() / "tests/support/validate_gltf.js").string(), "--validator",
                               FURROW_VALIDATOR_DIR, file.string()});
    if (r.exit_code == 0) return "";
    return "validator exit " + std::to_string(r.exit_code) + ":\n" + r.out + r.err;
}

std::string read_text(const fs::path& file) {
    const std::vector<uint8_t> b = read_bytes(file);
    return std::string(b.begin(), b.end());
}

std::vector<uint8_t> read_bytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

void write_bytes(const fs::path& file, const std::vector<uint8_t>& bytes) {
    std::ofstream out(file, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

void write_text(const fs::path& file, const std::string& text) {
    std::ofstream out(file, std::ios::binary);
    out << text;
}

std::vector<std::string> list_dir(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

bool all_finite(const Scene& scene) {
    auto finite = [](const std::vector<float>& v) {
        for (float x : v)
            if (!std::isfinite(x)) return false;
        return true;
    };
    for (const auto& m : scene.meshes)
        for (const auto& p : m.primitives) {
            if (!finite(p.positions) || !finite(p.normals) || !finite(p.uv0) || !finite(p.uv1) || !finite(p.colors) ||
                !finite(p.weights) || !finite(p.tangents))
                return false;
            for (const auto& c : p.custom)
                if (!finite(c.values)) return false;
            for (const auto& t : p.targets)
                if (!finite(t.position_deltas) || !finite(t.normal_deltas)) return false;
        }
    return true;
}

nlohmann::json gltf_json(const fs::path& file) {
    std::vector<uint8_t> b = read_bytes(file);
    if (b.size() >= 20 && std::memcmp(b.data(), "glTF", 4) == 0) {
        uint32_t len = 0;
        std::memcpy(&len, b.data() + 12, 4);
        if (20 + size_t(len) > b.size()) return nullptr;
        return nlohmann::json::parse(b.begin() + 20, b.begin() + 20 + len, nullptr, false);
    }
    return nlohmann::json::parse(b.begin(), b.end(), nullptr, false);
}

bool under_address_sanitizer() {
#if defined(__SANITIZE_ADDRESS__)
    return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
    return true;
#endif
#endif
    return false;
}

std::set<std::string> expect_memory_rule(const std::vector<std::string>& inputs, size_t rows) {
    std::vector<std::string> args{"bench", "memory"};
    args.insert(args.end(), inputs.begin(), inputs.end());
    args.push_back("--json");
    RunResult r = run_furrow(args);
    std::set<std::string> commands;
    EXPECT_EQ(r.exit_code, 0) << r.err;
    nlohmann::json j = nlohmann::json::parse(r.out, nullptr, false);
    if (j.is_discarded() || !j.contains("rows")) {
        ADD_FAILURE() << "bench memory printed no JSON: " << r.out.substr(0, 500);
        return commands;
    }
    EXPECT_EQ(j["rows"].size(), rows);
    for (const auto& row : j["rows"]) {
        const std::string what = row["model"].get<std::string>() + " " + row["command"].get<std::string>();
        commands.insert(row["command"].get<std::string>());
        EXPECT_EQ(row["exit_code"], 0) << what;
        EXPECT_GT(row["output_bytes"].get<double>(), 0.0) << what;
        EXPECT_GT(row["peak_mib"].get<double>(), 4.0) << what; // a real peak: above what any process of this size takes
        EXPECT_LE(row["peak_mib"].get<double>(), row["limit_mib"].get<double>()) << what;
        EXPECT_TRUE(row["within"].get<bool>()) << what;
    }
    return commands;
}

} // namespace furrow::test

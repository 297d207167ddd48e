#include "bench_common.h"
#include "data_dirs.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fcntl.h>
#include <unistd.h>
#include <spawn.h>
#include <sys/wait.h>

extern char** environ;

namespace furrow::cli {
namespace fs = std::filesystem;

int run_peer(const std::vector<std::string>& argv) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_t pid = 0;
    int status = 0, code = -1;
    if (posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ) == 0 && waitpid(pid, &status, 0) == pid)
        code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    posix_spawn_file_actions_destroy(&actions);
    return code;
}

bool on_path(const std::string& program) {
    const char* path = std::getenv("PATH");
    std::stringstream folders(path ? path : "");
    for (std::string dir; std::getline(folders, dir, ':');)
        if (!dir.empty() && ::access((fs::path(dir) / program).c_str(), X_OK) == 0) return true;
    return false;
}

std::vector<std::vector<double>> blender_peer_values(const std::string& script, const std::vector<std::string>& args) {
    if (!on_path("blender")) return {};
    const fs::path dir = fs::temp_directory_path() / ("furrow_blender_" + std::to_string(::getpid()));
    std::error_code ec;
    fs::create_directories(dir, ec);
    const fs::path py = dir / "peer.py", result = dir / "result.txt";
    std::ofstream(py) << script;
    fs::remove(result, ec);
    std::vector<std::string> argv{"blender", "-b", "--factory-startup", "-t", "1", "--python", py.string(), "--",
                                  result.string()};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<std::vector<double>> lines;
    if (run_peer(argv) == 0) {
        std::ifstream in(result);
        for (std::string line; std::getline(in, line);) {
            std::istringstream words(line);
            std::vector<double> values;
            for (double v; words >> v;) values.push_back(v);
            if (!values.empty()) lines.push_back(std::move(values));
        }
    }
    fs::remove_all(dir, ec);
    return lines;
}

double median_seconds(int repeat, const std::function<void()>& f) {
    f(); // warm-up: page faults, allocator growth
    std::vector<double> t;
    for (int i = 0; i < repeat; ++i) {
        auto a = std::chrono::steady_clock::now();
        f();
        auto b = std::chrono::steady_clock::now();
        t.push_back(std::chrono::duration<double>(b - a).count());
    }
    std::sort(t.begin(), t.end());
    return t[t.size() / 2];
}

static double status_kib(const char* key) {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind(key, 0) == 0) return std::stod(line.substr(std::strlen(key)));
    return 0;
}

PeakMemory::PeakMemory() {
    std::ofstream("/proc/self/clear_refs") << "5"; // reset VmHWM to the current RSS
    base_kib_ = status_kib("VmRSS:");
}

double PeakMemory::peak_mib() const { return std::max(0.0, status_kib("VmHWM:") - base_kib_) / 1024.0; }

std::vector<fs::path> collect_bench_inputs(const BenchArgs& args, const std::vector<std::string>& extensions) {
    std::vector<std::string> inputs = args.inputs;
    if (inputs.empty()) {
        for (const fs::path& d : {bundled_models_dir(), corpus_dir()})
            if (fs::is_directory(d)) inputs.push_back(d.string());
    }
    auto wanted = [&](const fs::path& p) {
        return std::find(extensions.begin(), extensions.end(), lower_extension(p.string())) != extensions.end();
    };
    std::vector<fs::path> files;
    for (const auto& in : inputs) {
        if (fs::is_directory(in)) {
            std::vector<fs::path> found;
            for (const auto& e : fs::recursive_directory_iterator(in))
                if (e.is_regular_file() && wanted(e.path())) found.push_back(e.path());
            std::sort(found.begin(), found.end());
            files.insert(files.end(), found.begin(), found.end());
        } else if (fs::exists(in)) {
            files.push_back(in);
        } else {
            throw InputError(in, "file not found");
        }
    }
    return files;
}

std::string fmt(double v, int decimals) {
    char b[64];
    std::snprintf(b, sizeof b, "%.*f", decimals, v);
    return b;
}

std::string fmt_sci(double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.3g", v);
    return b;
}

void Table::print() const {
    std::vector<size_t> w;
    for (const auto& r : rows_)
        for (size_t c = 0; c < r.size(); ++c) {
            if (w.size() <= c) w.push_back(0);
            w[c] = std::max(w[c], r[c].size());
        }
    for (size_t i = 0; i < rows_.size(); ++i) {
        std::string line;
        for (size_t c = 0; c < rows_[i].size(); ++c) {
            const std::string& s = rows_[i][c];
            std::string pad(w[c] - s.size(), ' ');
            line += c == 0 ? s + pad : "  " + pad + s; // first column left-aligned, numbers right-aligned
        }
        std::printf("%s\n", line.c_str());
        if (i == 0) {
            size_t total = 0;
            for (size_t c = 0; c < w.size(); ++c) total += w[c] + (c ? 2 : 0);
            std::printf("%s\n", std::string(total, '-').c_str());
        }
    }
}

} // namespace furrow::cli

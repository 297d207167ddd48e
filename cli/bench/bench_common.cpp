#include "bench_common.h"
#include "data_dirs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include <fcntl.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <unistd.h>
#include <tbb/global_control.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>

extern char** environ;

namespace furrow::cli {
namespace fs = std::filesystem;

static double status_kib(const char* key) {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind(key, 0) == 0) return std::stod(line.substr(std::strlen(key)));
    return 0;
}

PeerRun run_peer_measured(const std::vector<std::string>& argv) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    PeerRun r;
    pid_t pid = 0;
    int status = 0;
    struct rusage usage {};
    const auto start = std::chrono::steady_clock::now();
    if (posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ) == 0 && wait4(pid, &status, 0, &usage) == pid) {
        r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        r.max_rss_kib = double(usage.ru_maxrss); // Linux: KiB
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    posix_spawn_file_actions_destroy(&actions);
    return r;
}

int run_peer(const std::vector<std::string>& argv) { return run_peer_measured(argv).exit_code; }

bool on_path(const std::string& program) {
    const char* path = std::getenv("PATH");
    std::stringstream folders(path ? path : "");
    for (std::string dir; std::getline(folders, dir, ':');)
        if (!dir.empty() && ::access((fs::path(dir) / program).c_str(), X_OK) == 0) return true;
    return false;
}

double bbox_diagonal(const Scene& s) {
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    std::vector<std::array<double, 16>> world = s.world_matrices();
    for (size_t n = 0; n < s.nodes.size(); ++n) {
        int mi = s.nodes[n].mesh;
        if (mi < 0 || mi >= int(s.meshes.size())) continue;
        const auto& M = world[n];
        const bool skinned = s.nodes[n].skin >= 0; // bind pose: take the mesh as it is
        for (const auto& p : s.meshes[size_t(mi)].primitives)
            for (size_t v = 0; v + 3 <= p.positions.size(); v += 3) {
                double x = p.positions[v], y = p.positions[v + 1], z = p.positions[v + 2];
                double w[3] = {x, y, z};
                if (!skinned)
                    for (int k = 0; k < 3; ++k) w[k] = M[size_t(k)] * x + M[size_t(4 + k)] * y + M[size_t(8 + k)] * z + M[size_t(12 + k)];
                for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], w[k]), hi[k] = std::max(hi[k], w[k]);
            }
    }
    double d = 0;
    for (int k = 0; k < 3; ++k)
        if (hi[k] >= lo[k]) d += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    return std::sqrt(d);
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

double blender_peer_seconds(const std::string& script_text, const std::vector<std::string>& args) {
    const std::vector<std::vector<double>> lines = blender_peer_values(script_text, args);
    if (lines.empty() || !(lines[0][0] > 0)) return std::numeric_limits<double>::quiet_NaN();
    return lines[0][0];
}

double median_of(std::vector<double> values) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
}

double median_fresh_seconds(int repeat, const std::function<double(int run)>& run) {
    std::vector<double> t;
    for (int r = 0; r <= repeat; ++r) {
#if defined(__GLIBC__)
        malloc_trim(0);
#endif
        const double s = run(r);
        if (r > 0) t.push_back(s);
    }
    return median_of(std::move(t));
}

int active_threads() { return int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)); }

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


PeakMemory::PeakMemory() {
    std::ofstream("/proc/self/clear_refs") << "5"; // reset VmHWM to the current RSS
    base_kib_ = status_kib("VmRSS:");
}

double PeakMemory::base_mib() const { return base_kib_ / 1024.0; }

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

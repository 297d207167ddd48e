#include "atomic_file.h"

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <unistd.h>

namespace furrow::detail {

std::string temp_path_beside(const std::string& path) {
    static std::atomic<unsigned> counter{0};
    namespace fs = std::filesystem;
    fs::path p(path);
    std::string name = "." + p.filename().string() + ".furrow-tmp-" + std::to_string(getpid()) + "-" +
                       std::to_string(counter.fetch_add(1));
    return (p.parent_path() / name).string();
}

Status atomic_write(const std::string& path, const void* data, size_t size) {
    namespace fs = std::filesystem;
    fs::path p(path);
    fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        return Status::error(StatusCode::io_error, "output folder '" + dir.string() + "' does not exist");
    if (fs::is_directory(p, ec)) return Status::error(StatusCode::io_error, "output path is a directory");
    const std::string tmp = temp_path_beside(path);
    FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) return Status::error(StatusCode::io_error, std::string("cannot write: ") + std::strerror(errno));
    bool ok = size == 0 || std::fwrite(data, 1, size, f) == size;
    ok = (std::fflush(f) == 0) && ok;
    int err = errno;
    ok = (std::fclose(f) == 0) && ok;
    if (!ok) {
        std::remove(tmp.c_str());
        return Status::error(StatusCode::io_error, std::string("write failed: ") + std::strerror(err));
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        err = errno;
        std::remove(tmp.c_str());
        return Status::error(StatusCode::io_error, std::string("cannot rename into place: ") + std::strerror(err));
    }
    return Status::success();
}

} // namespace furrow::detail

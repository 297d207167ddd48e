// furrow's private kernel: atomic file output (write to a temporary file beside the target, then rename), in
// one place. Shared because every writer of furrow (mesh's glTF and PNG output, deform's heightmaps, the
// sample-model generator) must refuse a missing output folder the same way and must never leave a
// half-written output, or a stray temporary, behind. Header-only, so that a tool that links only
// furrow::mesh (models/generate_models.cpp) reaches it too. Not installed and not part of any public header
// (see affine.h).
#pragma once

#include <furrow/mesh.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>
#include <unistd.h>

namespace furrow::kernel {

// A unique temporary path beside `path` (same folder, so rename is atomic).
inline std::string temp_path_beside(const std::string& path) {
    static std::atomic<unsigned> counter{0};
    namespace fs = std::filesystem;
    fs::path p(path);
    // Appended piece by piece: GCC 12 warns (-Wrestrict, a false positive) on `"." + std::string&&`.
    std::string name = ".";
    name += p.filename().string();
    name += ".furrow-tmp-" + std::to_string(getpid()) + "-" + std::to_string(counter.fetch_add(1));
    return (p.parent_path() / name).string();
}

// A run of bytes to write: a file is written from a list of them, so that a writer never has to copy its
// pieces (a GLB's header, JSON and binary chunk) into one buffer first. That copy was a whole extra output
// in memory at the peak of every writing command.
struct ByteSpan {
    const void* data = nullptr;
    size_t size = 0;
};

// Writes the spans, in order, to a temporary file beside `path` (tmp), after checking that `path` can be
// replaced.
[[nodiscard]] inline Status stage_file(const std::string& path, const std::vector<ByteSpan>& spans, std::string& tmp) {
    namespace fs = std::filesystem;
    fs::path p(path);
    fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        return Status::error(StatusCode::io_error, "output folder '" + dir.string() + "' does not exist");
    if (fs::is_directory(p, ec)) return Status::error(StatusCode::io_error, "output path is a directory");
    tmp = temp_path_beside(path);
    FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) return Status::error(StatusCode::io_error, std::string("cannot write: ") + std::strerror(errno));
    bool ok = true;
    for (const ByteSpan& b : spans) ok = ok && (b.size == 0 || std::fwrite(b.data, 1, b.size, f) == b.size);
    ok = (std::fflush(f) == 0) && ok;
    int err = errno;
    ok = (std::fclose(f) == 0) && ok;
    if (!ok) {
        std::remove(tmp.c_str());
        return Status::error(StatusCode::io_error, std::string("write failed: ") + std::strerror(err));
    }
    return Status::success();
}

[[nodiscard]] inline Status stage_file(const std::string& path, const void* data, size_t size, std::string& tmp) {
    return stage_file(path, std::vector<ByteSpan>{{data, size}}, tmp);
}

// Renames a staged temporary into place (removing it on failure).
[[nodiscard]] inline Status commit_file(const std::string& tmp, const std::string& path) {
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        int err = errno;
        std::remove(tmp.c_str());
        return Status::error(StatusCode::io_error, std::string("cannot rename into place: ") + std::strerror(err));
    }
    return Status::success();
}

// Writes the spans to `path` atomically (temporary file in the same folder, then rename).
[[nodiscard]] inline Status atomic_write(const std::string& path, const std::vector<ByteSpan>& spans) {
    std::string tmp;
    Status s = stage_file(path, spans, tmp);
    if (!s.ok()) return s;
    return commit_file(tmp, path);
}

[[nodiscard]] inline Status atomic_write(const std::string& path, const void* data, size_t size) {
    return atomic_write(path, std::vector<ByteSpan>{{data, size}});
}

// Writes two files (a .gltf's .bin, then the .gltf) both or neither: both are staged as temporaries first,
// so a second output that cannot be written no longer leaves the first one behind.
[[nodiscard]] inline Status atomic_write_pair(const std::string& first, const std::vector<ByteSpan>& first_spans,
                                              const std::string& second, const void* second_data, size_t second_size) {
    std::string tmp1, tmp2;
    Status s = stage_file(first, first_spans, tmp1);
    if (!s.ok()) return s;
    s = stage_file(second, second_data, second_size, tmp2);
    if (!s.ok()) {
        std::remove(tmp1.c_str());
        return s;
    }
    std::error_code ec;
    const bool first_existed = std::filesystem::exists(first, ec);
    s = commit_file(tmp1, first);
    if (!s.ok()) {
        std::remove(tmp2.c_str());
        return s;
    }
    s = commit_file(tmp2, second);
    if (!s.ok() && !first_existed) std::remove(first.c_str());
    return s;
}

} // namespace furrow::kernel

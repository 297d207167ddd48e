#include "data_dirs.h"

#include <cstdlib>
#include <system_error>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

fs::path executable_dir() {
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec); // Linux; elsewhere the working folder
    return ec ? fs::current_path(ec) : exe.parent_path();
}

} // namespace

fs::path bundled_models_dir() {
    if (const char* env = std::getenv("FURROW_MODELS"); env && *env) return fs::path(env);
    return (executable_dir() / ".." / "share" / "furrow" / "models").lexically_normal();
}

fs::path corpus_dir() {
    if (const char* env = std::getenv("FURROW_CORPUS"); env && *env) return fs::path(env);
    std::error_code ec;
    const fs::path here = fs::path("..") / "shared" / "corpus";
    if (fs::is_directory(here, ec)) return here;
    return (executable_dir() / ".." / ".." / ".." / "shared" / "corpus").lexically_normal();
}

} // namespace furrow::cli

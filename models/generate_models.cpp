// furrow_generate_models [OUT_DIR] — writes furrow's sample assets (models/README.md lists them) into OUT_DIR,
// by default the repository's models/ folder. Deterministic: every run writes the same bytes, which
// tests/mesh/test_models.cpp checks against the committed files.
#include "generators.h"

#include <cstdio>
#include <filesystem>
#include <system_error>

int main(int argc, char** argv) {
    namespace fs = std::filesystem;
    if (argc > 2 || (argc == 2 && (std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help"))) {
        std::fprintf(stderr, "usage: furrow_generate_models [OUT_DIR]   (default: %s)\n", FURROW_MODELS_DIR);
        return 2;
    }
    const fs::path dir = argc == 2 ? fs::path(argv[1]) : fs::path(FURROW_MODELS_DIR);
    std::error_code ec;
    fs::create_directories(dir, ec);
    furrow::Status st = furrow::models::generate_all(dir);
    if (!st.ok()) {
        std::fprintf(stderr, "Error: %s: %s\n", dir.string().c_str(), st.message.c_str());
        return 1;
    }
    for (const std::string& name : furrow::models::model_files())
        std::printf("%-24s %8llu bytes\n", (dir / name).string().c_str(),
                    static_cast<unsigned long long>(fs::file_size(dir / name)));
    return 0;
}

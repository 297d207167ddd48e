// Replays inputs through a fuzz harness without libFuzzer, so the harnesses build with any compiler and run
// as CTest tests over the seed corpus and the kept crashers (tests/fuzz/regressions/<target>/).
//
//   fuzz_<target>_replay FILE|FOLDER...
//
// Folders are read recursively, files in sorted order. Each file's name is printed before it runs, so a
// crash names its input. Exit 0 when every input ran; 1 when an argument does not exist or nothing was
// found (an empty replay would pass while testing nothing).
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);
extern "C" __attribute__((weak)) int LLVMFuzzerInitialize(int* argc, char*** argv);

int main(int argc, char** argv) {
    namespace fs = std::filesystem;
    if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
    std::vector<fs::path> files;
    for (int i = 1; i < argc; ++i) {
        const fs::path arg(argv[i]);
        std::error_code ec;
        if (fs::is_directory(arg, ec)) {
            std::vector<fs::path> found;
            for (const auto& e : fs::recursive_directory_iterator(arg))
                if (e.is_regular_file() && e.path().filename().string()[0] != '.') found.push_back(e.path());
            std::sort(found.begin(), found.end());
            files.insert(files.end(), found.begin(), found.end());
        } else if (fs::is_regular_file(arg, ec)) {
            files.push_back(arg);
        } else {
            std::fprintf(stderr, "%s: no such file or folder\n", argv[i]);
            return 1;
        }
    }
    if (files.empty()) {
        std::fprintf(stderr, "no inputs: give files or folders that hold some\n");
        return 1;
    }
    for (const fs::path& f : files) {
        std::fprintf(stderr, "%s\n", f.string().c_str());
        std::ifstream in(f, std::ios::binary);
        std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
        // A heap block of exactly the input's size, as libFuzzer gives it, so that ASan sees a read past the end
        // (a vector's spare capacity would hide it).
        std::unique_ptr<uint8_t[]> exact(new uint8_t[std::max<size_t>(bytes.size(), 1)]);
        std::copy(bytes.begin(), bytes.end(), exact.get());
        LLVMFuzzerTestOneInput(exact.get(), bytes.size());
    }
    std::printf("%zu inputs ran\n", files.size());
    return 0;
}

// The API promises no exceptions (mesh.h): when memory runs out inside a public entry point, the caller gets
// StatusCode::out_of_memory, not a std::bad_alloc. Each case runs in a child process whose address space is
// capped a little above what it already uses (setrlimit), then asks for far more: a request the size guards
// allow but the machine, so capped, cannot hold. The child exits 0 only if the call came back as a Status
// with out_of_memory; an escaping exception would abort it.
#include <furrow/render.h>
#include <furrow/shapes.h>
#include <furrow/shells.h>
#include <furrow/tessellate.h>

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>

namespace furrow {
namespace {

#if defined(__SANITIZE_ADDRESS__)
#define FURROW_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define FURROW_ASAN 1
#endif
#endif

// Caps the address space at what the process maps now plus `headroom` bytes.
void cap_address_space(size_t headroom) {
    size_t pages = 0;
    std::ifstream("/proc/self/statm") >> pages;
    const rlim_t cap = rlim_t(pages) * 4096 + headroom;
    rlimit r{cap, cap};
    if (setrlimit(RLIMIT_AS, &r) != 0) std::_Exit(3);
}

// Runs `call` in the capped child; exit 0 = it returned out_of_memory, 1 = another status (printed).
template <class Call>
void expect_out_of_memory_status(Call call) {
#ifdef FURROW_ASAN
    GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space: an address-space cap cannot apply";
#endif
    EXPECT_EXIT(
        {
            cap_address_space(size_t(512) << 20);
            const Status s = call();
            if (s.code != StatusCode::out_of_memory) {
                std::fprintf(stderr, "status %d: %s\n", int(s.code), s.message.c_str());
                std::_Exit(1);
            }
            std::fprintf(stderr, "%s\n", s.message.c_str());
            std::_Exit(0);
        },
        ::testing::ExitedWithCode(0), "out of memory while");
}

TEST(OutOfMemory, TessellateReturnsAStatus) {
    // 65,536 quads at rate 64: 537 million triangles, about 20 GB of output.
    const Primitive cage = shapes::quad_grid(1, 1, 256, 256);
    expect_out_of_memory_status([&] {
        TessellateInput in;
        in.positions = cage.positions.data();
        in.vertex_count = cage.vertex_count();
        in.indices = cage.indices.data();
        in.index_count = cage.indices.size();
        in.face_sizes = cage.face_sizes.data();
        in.face_count = cage.face_sizes.size();
        TessellateOptions o;
        o.rates.uniform = 64;
        o.rates.max_rate = 64;
        TessellateOutput out;
        return tessellate(out, in, o);
    });
}

TEST(OutOfMemory, RenderReturnsAStatus) {
    // 16384² pixels at 8 × 8 samples: the largest frame validate() allows, 17 billion samples.
    const Scene scene = make_scene(shapes::icosphere(1, 1), "ball");
    expect_out_of_memory_status([&] {
        RenderOptions o;
        o.width = o.height = 16384;
        o.ssaa = 8;
        RenderResult r;
        return render_scene(r, scene, o);
    });
}

} // namespace
} // namespace furrow

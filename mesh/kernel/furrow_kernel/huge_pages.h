// Large output buffers backed by transparent huge pages (Linux), to cut the page-fault cost of first touch.
//
// A fresh allocation of tens of MiB comes from mmap: every 4 KiB page faults on first write. Measured on this
// project's 2-core VM (paravirtualised, ~25 us per fault): zero-filling a fresh 125 MiB std::vector takes
// 700-1000 ms with 4 KiB pages and 26-50 ms after madvise(MADV_HUGEPAGE) (2 MiB pages, 512x fewer faults);
// the tessellation's output arrays (positions, normals, indices, per-triangle faces) are that size at 4M
// triangles. The kernel's THP mode is usually "madvise" (Debian's default), so the advice must be given on
// the still untouched range, between reserve() and the first write: that is what reserve_huge and assign_huge do. Only the
// 2 MiB-aligned interior of the block is advised; the contents are exactly those of std::vector::assign.
// Elsewhere (other systems, small sizes) it is a plain assign.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace furrow::kernel {

// The 2 MiB-aligned interior of [p, p + bytes) advised for transparent huge pages: memory not yet touched
// there gets 2 MiB pages on first touch. Advice only: where THP is off or missing, nothing changes.
inline void advise_huge_pages(const void* p, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr uintptr_t huge = uintptr_t(2) << 20;
    const uintptr_t begin = (uintptr_t(p) + huge - 1) & ~(huge - 1);
    const uintptr_t end = (uintptr_t(p) + bytes) & ~(huge - 1);
    if (end > begin) (void)::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
    (void)p, (void)bytes;
#endif
}

// An empty v with room for n elements, a newly allocated block advised for huge pages when it is at least
// 4 MiB (for a vector then filled by push_back up to n: no reallocation, few page faults).
template <class T>
void reserve_huge(std::vector<T>& v, size_t n) {
    v.clear();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr uintptr_t huge = uintptr_t(2) << 20;
    if (n * sizeof(T) >= 2 * huge && v.capacity() < n) {
        std::vector<T>().swap(v);
        v.reserve(n);
        advise_huge_pages(v.data(), n * sizeof(T));
    }
#endif
    v.reserve(n);
}

// v = n copies of value, in a block from reserve_huge.
template <class T>
void assign_huge(std::vector<T>& v, size_t n, const T& value = T()) {
    reserve_huge(v, n);
    v.assign(n, value);
}

// n uninitialised bytes (a file read whole), in a block advised for huge pages when it is at least 4 MiB:
// a 100 MB OBJ faulted 24k times into its read buffer, now 50 times. Null if the allocation fails.
struct FreeBytes {
    void operator()(uint8_t* p) const { std::free(p); }
};
using HugeBytes = std::unique_ptr<uint8_t[], FreeBytes>;
inline HugeBytes allocate_huge_bytes(size_t n) {
    n = std::max<size_t>(n, 1);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr size_t huge = size_t(2) << 20;
    if (n >= 2 * huge) {
        const size_t rounded = (n + huge - 1) & ~(huge - 1); // aligned_alloc wants a multiple of the alignment
        auto* p = static_cast<uint8_t*>(std::aligned_alloc(huge, rounded));
        // The n bytes asked for, not the rounding: a huge page past them would be resident for nothing.
        if (p) advise_huge_pages(p, n);
        return HugeBytes(p);
    }
#endif
    return HugeBytes(static_cast<uint8_t*>(std::malloc(n)));
}

// n bytes for a block the caller writes whole right away, mapped in one system call (MADV_POPULATE_WRITE,
// Linux 5.14) instead of one fault per 4 KiB page on first touch: a 32 MiB block written on this project's VM
// took 130-135 ms so, against 260-340 ms faulted page by page (huge pages: 34-37 ms, but a huge page
// rounds the resident size up where a block ends). Where the call is refused, the pages fault as usual.
// Null if the allocation fails.
inline HugeBytes allocate_prefaulted_bytes(size_t n) {
    constexpr size_t page = 4096;
    const size_t rounded = (std::max<size_t>(n, 1) + page - 1) & ~(page - 1);
    auto* p = static_cast<uint8_t*>(std::aligned_alloc(page, rounded));
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
    if (p) (void)::madvise(p, rounded, MADV_POPULATE_WRITE);
#endif
    return HugeBytes(p);
}

} // namespace furrow::kernel

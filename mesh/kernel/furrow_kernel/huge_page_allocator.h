// An allocator for the few very large working arrays (tens of MiB, filled once per call): blocks of 4 MiB and
// more are aligned to 2 MiB and advised as transparent huge pages (Linux madvise(MADV_HUGEPAGE); the kernel's
// default THP mode is "madvise"), so that first touching them costs one page fault per 2 MiB instead of one
// per 4 KiB. On a virtual machine a page fault costs microseconds: filling a fresh 38 MiB array of per-face
// terms took longer than computing them. Smaller blocks, and other systems, use plain operator new.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace furrow::kernel {

template <class T>
struct HugePageAllocator {
    using value_type = T;
    static constexpr size_t kHuge = size_t(2) << 20, kThreshold = size_t(4) << 20;

    HugePageAllocator() = default;
    template <class U>
    HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

    static size_t rounded(size_t n) { return (n * sizeof(T) + kHuge - 1) / kHuge * kHuge; }
    T* allocate(size_t n) {
        if (n > size_t(-1) / sizeof(T) / 2) throw std::bad_alloc();
        if (n * sizeof(T) < kThreshold) return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(alignof(T))));
        void* p = std::aligned_alloc(kHuge, rounded(n));
        if (!p) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
        ::madvise(p, rounded(n), MADV_HUGEPAGE); // advice only: without THP the pages are ordinary
#endif
        return static_cast<T*>(p);
    }
    void deallocate(T* p, size_t n) noexcept {
        if (n * sizeof(T) < kThreshold) ::operator delete(p, std::align_val_t(alignof(T)));
        else std::free(p);
    }
    template <class U>
    bool operator==(const HugePageAllocator<U>&) const noexcept { return true; }
};

} // namespace furrow::kernel

// The furrow command's global operator new: large blocks on transparent huge pages.
//
// Why: production-scale outputs (32 fur shells of a 69k-triangle scan: 80 MiB; a rate-8 tessellation: 160 MiB)
// are written into memory just allocated, and the kernel maps fresh memory one 4 KiB page at a time, on first
// touch. On the 2-core VM of `furrow bench` a first-touch fault costs about 17 us: a memcpy of the bunny's
// 80 MiB of shells into fresh memory took 340 ms against 4.8 ms into warm memory, so page faults, not the
// geometry, were most of the shell emission and a good part of every large command. Linux maps 2 MiB
// transparent huge pages where a program asks for them (madvise(MADV_HUGEPAGE): Debian's default THP mode is
// "madvise"), one fault per 512 pages.
//
// How, following what glibc's own `glibc.malloc.hugetlb=1` tunable does (which a program cannot set for itself
// once started):
// - a large block (>= 4 MiB here) is advised as it is allocated: glibc maps it on its own, untouched, and its
//   2 MiB-aligned interior gets huge pages on first touch;
// - smaller blocks of the main thread come from the heap that glibc grows with brk: blocks below 32 MiB are
//   kept there (M_MMAP_THRESHOLD), it grows in steps of 32 MiB (M_TOP_PAD), and each step is advised once the
//   program break has moved. Shell layers and mesh attributes are mostly blocks of 0.1-2 MiB;
// - worker threads (TBB) allocate from glibc's other arenas, heaps of 64 MiB reserved at 64 MiB-aligned
//   addresses and committed as they grow: each such heap is advised whole, once, when it first serves a block
//   of 64 KiB or more (the advice stays on the part not yet committed).
// The checks run for blocks of 64 KiB or more only: small blocks cost what they did.
// Replacing the global operator new is the C++ way for a program to choose how it allocates ([new.delete]);
// only the command does it: the libraries allocate with whatever their caller chose. Allocators that map
// huge pages themselves (mimalloc with large OS pages, jemalloc with thp:always) were measured too: as fast,
// but they peaked 17-51 MiB higher on the bunny's rate-4 tessellation (glibc: 111 MiB), mimalloc past the
// memory rule of `furrow bench memory` (145 MiB there).
// The libraries advise their own largest arrays (mesh/kernel's huge_pages.h: reserve_huge, assign_huge), for
// any program that links them; this file extends the advice to every block of the command.
// Small blocks and everything freed go through malloc and free unchanged.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <algorithm>
#include <atomic>
#include <new>

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <furrow_kernel/huge_pages.h>

namespace {

using furrow::kernel::advise_huge_pages;
constexpr std::size_t kHugePage = std::size_t(2) << 20;
// Below this a block holds at most one whole huge page: not worth a system call.
constexpr std::size_t kAdviseFrom = std::size_t(4) << 20;

// The heap grows by at least this much at a time, so that its new part holds whole huge pages.
constexpr std::size_t kHeapStep = std::size_t(32) << 20;
std::atomic<std::uintptr_t> g_heap_advised{0}; // the program break up to which the heap was advised
// Set while the program starts: blocks below kHeapStep stay in the heaps, and the main heap grows by kHeapStep.
const bool g_heap_configured = mallopt(M_MMAP_THRESHOLD, int(kHeapStep)) == 1 && mallopt(M_TOP_PAD, int(kHeapStep)) == 1;

// The heap's part above the last advised break, advised (glibc wrote only its chunk headers there).
void advise_heap_growth() {
    if (!g_heap_configured) return;
    const auto brk = reinterpret_cast<std::uintptr_t>(sbrk(0)); // glibc's cached break: no system call
    std::uintptr_t from = g_heap_advised.load(std::memory_order_relaxed);
    if (brk < from) { // glibc trimmed the heap: what grows again is new memory
        g_heap_advised.compare_exchange_strong(from, brk);
        return;
    }
    if (brk <= from + kHugePage) return;
    if (!g_heap_advised.compare_exchange_strong(from, brk)) return; // another thread advises it
    if (from == 0) from = brk - std::min<std::uintptr_t>(brk, kHeapStep);
    advise_huge_pages(reinterpret_cast<void*>(from), brk - from);
}

// A worker thread's arena heap (glibc's HEAP_MAX_SIZE on 64-bit: 64 MiB, aligned to its size), advised whole
// the first time one of its blocks is seen. Heaps seen so far: a few per thread, kept in a fixed table (this
// code cannot allocate).
constexpr std::size_t kArenaHeap = std::size_t(64) << 20;
std::atomic<std::uintptr_t> g_arena_heaps[256];

void advise_arena_heap(const void* p) {
    const auto base = reinterpret_cast<std::uintptr_t>(p) & ~(kArenaHeap - 1);
    for (auto& slot : g_arena_heaps) {
        std::uintptr_t seen = slot.load(std::memory_order_relaxed);
        if (seen == base) return;
        if (seen == 0 && slot.compare_exchange_strong(seen, base)) {
            // The parts not mapped (a heap not grown to its reservation's end) make madvise report ENOMEM;
            // the mapped parts are advised all the same.
            (void)madvise(reinterpret_cast<void*>(base), kArenaHeap, MADV_HUGEPAGE);
            return;
        }
        if (seen == base) return;
    }
}

constexpr std::size_t kCheckFrom = std::size_t(64) << 10;

void* allocate(std::size_t size) noexcept {
    void* p = std::malloc(size ? size : 1);
    if (!p || size < kCheckFrom) return p;
    if (size >= kAdviseFrom) advise_huge_pages(p, size);
    if (reinterpret_cast<std::uintptr_t>(p) < reinterpret_cast<std::uintptr_t>(sbrk(0)))
        advise_heap_growth(); // the main heap: below the program break
    else if (g_heap_configured && size < kHeapStep)
        advise_arena_heap(p); // above it: a worker's arena (blocks below kHeapStep are never mapped alone)
    return p;
}

void* allocate_or_throw(std::size_t size) {
    for (;;) {
        if (void* p = allocate(size)) return p;
        std::new_handler handler = std::get_new_handler();
        if (!handler) throw std::bad_alloc();
        handler();
    }
}

} // namespace

void* operator new(std::size_t size) { return allocate_or_throw(size); }
void* operator new[](std::size_t size) { return allocate_or_throw(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
    try {
        return allocate_or_throw(size);
    } catch (...) {
        return nullptr;
    }
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept { return operator new(size, tag); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }

// The furrow command's operator new (cli/huge_page_new.cpp): a large block, and the heap that smaller blocks
// come from, are advised for transparent huge pages before they are written; a failed allocation still
// throws std::bad_alloc (or returns null for the nothrow form). The advice shows in /proc/self/smaps as the
// VmFlags entry "hg" of the mapping that holds the block.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <limits>
#include <memory>
#include <new>
#include <sstream>
#include <string>
#include <vector>

namespace {

// The kernel gives huge pages to advised memory (THP mode "always" or "madvise").
bool huge_pages_on_advice() {
    std::ifstream f("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string mode((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    return mode.find("[always]") != std::string::npos || mode.find("[madvise]") != std::string::npos;
}

// The VmFlags of the mapping that holds p ("" if none does).
std::string vm_flags_of(const void* p) {
    const auto a = reinterpret_cast<std::uintptr_t>(p);
    std::ifstream smaps("/proc/self/smaps");
    std::string line;
    bool inside = false;
    while (std::getline(smaps, line)) {
        unsigned long lo = 0, hi = 0;
        char dash = 0;
        std::istringstream head(line);
        if (head >> std::hex >> lo >> dash >> hi && dash == '-' && line.find(':') > line.find(' ')) {
            inside = lo <= a && a < hi;
            continue;
        }
        if (inside && line.rfind("VmFlags:", 0) == 0) return line + " ";
    }
    return "";
}

void skip_unless_advising() {
#ifndef FURROW_HUGE_PAGE_NEW
    GTEST_SKIP() << "this build's command keeps the default operator new (sanitizers)";
#endif
    if (!huge_pages_on_advice()) GTEST_SKIP() << "transparent huge pages are off on this machine";
}

} // namespace

TEST(huge_page_new, LargeBlockIsAdvised) {
    skip_unless_advising();
    if (IsSkipped()) return;
    const size_t bytes = size_t(64) << 20;
    std::unique_ptr<char[]> block(new char[bytes]);
    const std::string flags = vm_flags_of(block.get() + bytes / 2);
    ASSERT_FALSE(flags.empty());
    EXPECT_NE(flags.find(" hg "), std::string::npos) << flags;
}

TEST(huge_page_new, HeapGrowthIsAdvised) {
    skip_unless_advising();
    if (IsSkipped()) return;
    // 96 blocks of 1 MiB: glibc serves them from its heap, which grows in 32 MiB steps; each step is advised
    // once the break has moved, apart from the part below its first 2 MiB boundary.
    std::vector<std::unique_ptr<char[]>> blocks;
    for (int i = 0; i < 96; ++i) blocks.emplace_back(new char[size_t(1) << 20]);
    int advised = 0;
    for (const auto& b : blocks) advised += vm_flags_of(b.get() + (1 << 19)).find(" hg ") != std::string::npos;
    EXPECT_GE(advised, 48) << "of 96 blocks";
}

TEST(huge_page_new, FailedAllocationThrowsOrReturnsNull) {
#ifndef FURROW_HUGE_PAGE_NEW
    GTEST_SKIP() << "this build's command keeps the default operator new (sanitizers: AddressSanitizer aborts here)";
#endif
    const size_t absurd = std::numeric_limits<size_t>::max() / 2;
    EXPECT_THROW((void)::operator new(absurd), std::bad_alloc);
    EXPECT_EQ(::operator new(absurd, std::nothrow), nullptr);
    EXPECT_EQ(::operator new[](absurd, std::nothrow), nullptr);
}

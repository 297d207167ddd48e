// The text readers' numbers (mesh/src/text_numbers.h): Clinger's fast path gives the bits std::from_chars
// gives, on random decimals of every length and on the edges of the path (2^53 and 2^24 significant
// integers, 22 and 10 fraction digits, signed zeros); what the path does not take goes to from_chars.
#include "text_numbers.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <bit>
#include <charconv>
#include <cstring>
#include <string>
#include <vector>

using namespace furrow::mesh_detail;

namespace {

template <class T>
auto bits(T v) {
    if constexpr (sizeof(T) == 8) return std::bit_cast<uint64_t>(v);
    else return std::bit_cast<uint32_t>(v);
}

// [-] int digits [. fraction digits] [e [sign] digits], leading zeros sometimes, lengths 0 to 24 each.
std::string random_decimal(furrow::test::Lcg& next) {
    std::string s;
    if (next(2)) s += '-';
    const size_t whole = next(25), fraction = next(4) ? next(25) : 0;
    for (size_t i = 0; i < whole; ++i) s += char('0' + (i == 0 && next(3) ? 0 : next(10)));
    if (fraction || next(4) == 0) s += '.';
    for (size_t i = 0; i < fraction; ++i) s += char('0' + next(10));
    if (next(5) == 0) { // an exponent: the general path's
        s += next(2) ? 'e' : 'E';
        if (next(2)) s += next(2) ? '-' : '+';
        for (size_t i = 0, n = next(4); i < n; ++i) s += char('0' + next(10));
    }
    return s;
}

template <class T>
void expect_fast_path_matches_from_chars(size_t& fast, size_t& total) {
    furrow::test::Lcg next(sizeof(T));
    for (int k = 0; k < 200000; ++k) {
        const std::string s = random_decimal(next);
        const char *b = s.data(), *e = s.data() + s.size();
        T want{}, got{};
        const auto r = std::from_chars(b, e, want);
        const bool whole = r.ec == std::errc() && r.ptr == e;
        if (const char* q = fast_number(b, e, got)) {
            ASSERT_EQ(q, e) << s; // the path never takes an exponent: its span is the whole string
            ++fast;
            ASSERT_TRUE(whole) << s;
            ASSERT_EQ(bits(got), bits(want)) << s;
        }
        T read{};
        const char* end = read_number(b, e, read);
        if (whole && r.ec == std::errc()) {
            ASSERT_EQ(end, e) << s;
            ASSERT_EQ(bits(read), bits(want)) << s;
        }
        ++total;
    }
}

} // namespace

TEST(mesh_text_numbers, FastPathGivesFromCharsBitsOnRandomDecimals) {
    size_t fast = 0, total = 0;
    expect_fast_path_matches_from_chars<double>(fast, total);
    expect_fast_path_matches_from_chars<float>(fast, total);
    EXPECT_GT(fast, total / 10) << "the random decimals must exercise the fast path";
    EXPECT_LT(fast, total) << "and the fallback";
}

TEST(mesh_text_numbers, FastPathEdges) {
    auto fast_double = [](const char* s, double& v) { return fast_number(s, s + std::strlen(s), v) == s + std::strlen(s); };
    auto fast_float = [](const char* s, float& v) { return fast_number(s, s + std::strlen(s), v) == s + std::strlen(s); };
    double d = 1;
    float f = 1;
    EXPECT_TRUE(fast_double("-0.0", d));
    EXPECT_TRUE(std::signbit(d) && d == 0);
    EXPECT_TRUE(fast_double("9007199254740992", d)); // 2^53: exact
    EXPECT_EQ(d, 9007199254740992.0);
    EXPECT_FALSE(fast_double("9007199254740993", d)); // 2^53 + 1: from_chars rounds it
    EXPECT_TRUE(fast_double("0.1234567890123456", d)); // 16 digits: m < 2^53
    EXPECT_EQ(d, 0.1234567890123456);
    EXPECT_FALSE(fast_double("0.12345678901234567", d)); // 17: m > 2^53
    EXPECT_TRUE(fast_double("0.0000000000000000000001", d)); // k = 22, m = 1
    EXPECT_EQ(d, 1e-22);
    EXPECT_FALSE(fast_double("0.00000000000000000000001", d)); // k = 23
    EXPECT_FALSE(fast_double("1e5", d));                        // exponents go to from_chars
    EXPECT_FALSE(fast_double("-", d));
    EXPECT_FALSE(fast_double(".", d));
    const char* two_points = "1.2.3";
    EXPECT_EQ(fast_number(two_points, two_points + 5, d), two_points + 3); // the span float_span_end takes
    EXPECT_EQ(d, 1.2);
    EXPECT_FALSE(fast_double("+-1", d)); // one sign only: the general path refuses it
    EXPECT_TRUE(fast_double("+.5", d));
    EXPECT_EQ(d, 0.5);
    EXPECT_TRUE(fast_double(".5", d));
    EXPECT_EQ(d, 0.5);
    EXPECT_TRUE(fast_double("5.", d));
    EXPECT_EQ(d, 5.0);
    EXPECT_TRUE(fast_float("16777216", f)); // 2^24
    EXPECT_FALSE(fast_float("16777217", f));
    EXPECT_TRUE(fast_float("0.0000000001", f)); // k = 10
    EXPECT_FALSE(fast_float("0.00000000001", f));
    EXPECT_TRUE(fast_float("-0.037830", f));
    float want = 0;
    std::from_chars("-0.037830", "-0.037830" + 9, want);
    EXPECT_EQ(std::bit_cast<uint32_t>(f), std::bit_cast<uint32_t>(want));
}

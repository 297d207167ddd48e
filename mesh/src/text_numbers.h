// Internal: the numbers of the text mesh readers (obj_load.cpp, off_load.cpp, ply_load.cpp), read straight from the file's
// bytes with std::from_chars the way a C++ stream (`in >> value`, what OpenMesh's readers used) reads them, so
// that a file means what it meant before: the same spans are numbers, the same ones fail.
#pragma once

#include <charconv>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

namespace furrow::mesh_detail {

// C's isspace in the "C" locale: ' ' and '\t' '\n' '\v' '\f' '\r' (9 to 13).
inline bool is_space(char c) { return c == ' ' || static_cast<unsigned char>(c - '\t') <= 4; }
inline bool is_digit(char c) { return c >= '0' && c <= '9'; }

// The end of the span num_get takes for a floating-point `stream >> value` from p (no whitespace skipped):
// [sign] digits [. digits] [e [sign] digits], the exponent only after a mantissa digit. The span is taken
// even when it then fails to convert (and a stream that reached `end` while taking it is at eof).
inline const char* float_span_end(const char* p, const char* end) {
    if (p < end && (*p == '+' || *p == '-')) ++p;
    bool digits = false;
    while (p < end && is_digit(*p)) ++p, digits = true;
    if (p < end && *p == '.')
        for (++p; p < end && is_digit(*p); ++p) digits = true;
    if (digits && p < end && (*p == 'e' || *p == 'E')) {
        ++p;
        if (p < end && (*p == '+' || *p == '-')) ++p;
        while (p < end && is_digit(*p)) ++p;
    }
    return p;
}

// The end of the span num_get takes for an integer `stream >> value` from p: [sign] digits.
inline const char* integer_span_end(const char* p, const char* end) {
    if (p < end && (*p == '+' || *p == '-')) ++p;
    while (p < end && is_digit(*p)) ++p;
    return p;
}

// Clinger's fast path (W. D. Clinger, "How to Read Floating Point Numbers Accurately", PLDI 1990): a span
// [sign] digits [. digits] with no exponent after it, whose digits read as one integer m are exact in T
// (m <= 2^53 for double, 2^24 for float), with k <= 22 (double) or 10 (float) of them after the point, is
// m / 10^k, both exact, in one correctly rounded division: the value std::from_chars gives on the span that
// float_span_end takes (test mesh_text_numbers), in one scan. The numbers were a third of reading
// spot_quadrangulated.obj (read_number 5.3 M of 16.0 M instructions, callgrind); with this path 3.4 M.
// Returns the span's end, or nullptr for read_number's general path (an exponent, more digits, no digit).
template <class T> const char* fast_number(const char* p, const char* end, T& value) {
    static_assert(sizeof(T) == 4 || sizeof(T) == 8);
    constexpr bool wide = sizeof(T) == 8;
    constexpr int max_k = wide ? 22 : 10;
    constexpr uint64_t max_m = wide ? uint64_t(1) << 53 : uint64_t(1) << 24;
    static constexpr T p10[23] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11,
                                  1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22}; // exact to max_k
    bool negative = false;
    if (p < end && (*p == '+' || *p == '-')) negative = *p++ == '-';
    uint64_t m = 0;
    int digits = 0, k = 0;
    auto run = [&](bool fraction) {
        for (; p < end && is_digit(*p); ++p) {
            if (m > max_m / 10) return false;
            m = m * 10 + uint64_t(*p - '0');
            ++digits, k += fraction;
        }
        return true;
    };
    if (!run(false)) return nullptr;
    if (p < end && *p == '.' && (++p, !run(true))) return nullptr;
    if (digits == 0 || k > max_k || m > max_m || (p < end && (*p == 'e' || *p == 'E'))) return nullptr;
    const T v = T(m) / p10[k];
    value = negative ? -v : v;
    return p;
}

// A number as `stream >> value` reads it: the span num_get takes, which must convert whole. Leading
// whitespace is skipped. Returns the end of the number, nullptr if there is none.
template <class T> const char* read_number(const char* p, const char* end, T& value) {
    while (p < end && is_space(*p)) ++p;
    if (const char* fast = fast_number(p, end, value)) return fast;
    const char* b = p;
    p = float_span_end(p, end);
    const char* s = b < p && *b == '+' ? b + 1 : b;
    const auto r = std::from_chars(s, p, value);
    if (r.ptr != p || s == p) return nullptr;
    if (r.ec == std::errc::result_out_of_range) { // overflow fails the stream; underflow reads as tiny or 0
        const std::string copy(s, p);
        const double d = std::strtod(copy.c_str(), nullptr);
        if (std::abs(d) >= 1) return nullptr;
        value = T(d);
    }
    return p;
}

// An index as `stream >> int` reads it: [sign] digits, what follows ignored; out of range clamps and fails.
struct IntRead {
    bool ok = false;
    int value = 0;
};
inline IntRead read_int(const char* p, const char* end) {
    bool negative = false;
    if (p < end && (*p == '+' || *p == '-')) negative = *p++ == '-';
    if (p == end || !is_digit(*p)) return {};
    long long v = 0;
    for (; p < end && is_digit(*p) && v <= 1LL << 32; ++p) v = v * 10 + (*p - '0');
    v = negative ? -v : v;
    if (v > INT_MAX || v < INT_MIN || (p < end && is_digit(*p))) return {false, negative ? INT_MIN : INT_MAX};
    return {true, int(v)};
}

// A count or index as `stream >> unsigned int` reads it, after skipping whitespace: [sign] digits; a '-'
// negates modulo 2^32 ("-1" is 4294967295), more than 2^32 - 1 fails. Returns the end, nullptr on failure.
inline const char* read_unsigned(const char* p, const char* end, uint32_t& value) {
    while (p < end && is_space(*p)) ++p;
    bool negative = false;
    if (p < end && (*p == '+' || *p == '-')) negative = *p++ == '-';
    if (p == end || !is_digit(*p)) return nullptr;
    uint64_t v = 0;
    for (; p < end && is_digit(*p); ++p)
        if ((v = v * 10 + uint64_t(*p - '0')) > UINT32_MAX) return nullptr;
    value = negative ? uint32_t(0u - uint32_t(v)) : uint32_t(v);
    return p;
}

// The 1-based line of position p in text (for messages: counted only when one is needed).
inline size_t line_of(const char* text, const char* p) {
    size_t line = 1;
    for (const char* q = text; q < p; ++q) line += *q == '\n';
    return line;
}

} // namespace furrow::mesh_detail

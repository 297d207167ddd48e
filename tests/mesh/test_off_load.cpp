// The one-pass OFF reader (mesh/src/off_load.cpp): its refusals name the line; on random OFF text, valid or
// broken, it agrees with the former reader (a validation pass, then OpenMesh's stream reader, still reachable
// as load_openmesh_bytes(".off")) on what it accepts, the scene it gives and what it refuses; and it gives what
// an independent reading of the written numbers gives.
#include "scene_compare.h"
#include "test_support.h"

#include <cstdio>

using namespace furrow;

namespace {
// Both readers on one text: the same verdict, and on success the same scene.
void expect_same_as_former_reader(const std::string& text) {
    Scene now, before;
    const Status a = test::load_text(now, text, ".off");
    const Status b = load_openmesh_bytes(before, text, ".off", LoadOptions{});
    ASSERT_EQ(a.code, b.code) << a.message << " | " << b.message << "\n" << text;
    if (!a.ok()) return;
    test::expect_same_reading(now, before, text);
}
} // namespace

// Each refusal says what and on which line (where the read that failed was).
TEST(off_load, RefusalsNameTheLine) {
    const std::pair<const char*, const char*> cases[] = {
        {"OFF\n", "OFF line 2: no vertex, face and edge counts after the header"},
        {"OFF\n4 x 0\n", "OFF line 2: no vertex, face and edge counts after the header"},
        {"OFF\n4000 1 0\n0 0 0\n", "OFF line 2: the counts (4000 vertices, 1 faces) are more than the file holds"},
        {"OFF\n4 1 0\n0 0 0\n1 0 0\nx y z\n0 1 0\n4 0 1 2 3\n", "OFF line 5: vertex 2 is not three numbers"},
        {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 1e39\n3 0 1 2\n", "OFF line 5: vertex 2 is not three numbers"}, // not a float
        {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n\n\n4000000 0 1 2\n", "OFF line 8: face 0 has no valid corner count"},
        {"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1\n", "OFF line 7: face 1 has fewer indices than its corner count"},
        {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 4294967296\n", "OFF line 6: face 0 has fewer indices than its corner count"},
        {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "1 faces reference vertices that do not exist"},
        {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n", "1 faces reference vertices that do not exist"}, // 4294967295
        {"COFFEE\n3 1 0\n", "OFF: the first line must be OFF (or STOFF, COFF, NOFF...), not 'COFFEE'"},
        {"4OFF\n1 0 0\n0 0 0 1\n", "OFF: the first line must be OFF (or STOFF, COFF, NOFF...), not '4OFF'"},
    };
    for (const auto& [text, message] : cases) {
        Scene s;
        const Status st = test::load_text(s, text, ".off");
        EXPECT_EQ(st.code, StatusCode::invalid_input) << text;
        EXPECT_NE(st.message.find(message), std::string::npos) << st.message << "\n" << text;
        expect_same_as_former_reader(text); // refused by both
    }
    Scene s;
    EXPECT_EQ(test::load_text(s, "OFF BINARY\n", ".off").code, StatusCode::unsupported);
}

// What the stream did is kept: counts after the first line only (counts on it are skipped), a vertex may run
// over lines and its line's rest is ignored, faces are a stream of numbers across lines, a last line without
// its line end ends the vertices, faces of fewer than 3 corners are dropped with a warning.
TEST(off_load, StreamReadingIsKept) {
    Scene s;
    Status st = test::load_text(s, "NOFF 9 9 9\n3 2 0\n0 0\n0 0 0 1 junk\n1\t0 0\r\n0 1 0\n3 0\n1 2 2\n1 0\n", ".off");
    ASSERT_TRUE(st.ok()) << st.message;
    const Primitive& p = s.meshes[0].primitives.at(0);
    EXPECT_EQ(p.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
    EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2}));
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_NE(s.warnings[0].find("1 faces with fewer than 3 distinct corners were dropped"), std::string::npos) << s.warnings[0];
    expect_same_as_former_reader("NOFF 9 9 9\n3 2 0\n0 0\n0 0 0 1 junk\n1\t0 0\r\n0 1 0\n3 0\n1 2 2\n1 0\n");
    // Three vertices announced, the file ends on the second's line: two vertices, no faces (nothing to draw).
    expect_same_as_former_reader("OFF\n3 0 0\n0 0 0\n1 0 0");
    expect_same_as_former_reader("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2");
}

// Property: random OFF text (keyword variants, spacing, line ends, extra values on vertex lines, far from the
// origin or not) gives what a direct reading of the written numbers gives and what the former reader gave; and
// the same text broken at random (cut short, a character replaced) is accepted or refused as the former reader
// did, with the same scene when accepted.
TEST(off_load, RandomTextMatchesDirectReadingAndFormerReader) {
    test::Lcg next(2024);
    const char* keywords[] = {"OFF", "COFF", "NOFF", "STOFF", "CNOFF"};
    for (int round = 0; round < 300; ++round) {
        const size_t nv = 3 + next(15), nf = 1 + next(10);
        const bool crlf = next(4) == 0;
        const double offset = next(4) == 0 ? 1e5 : 0;
        auto space = [&] { return std::string(next(3) ? " " : next(2) ? "\t" : "  \t"); };
        auto eol = [&] { return std::string(crlf ? "\r\n" : "\n"); };
        std::string text = std::string(keywords[next(5)]) + eol() + std::to_string(nv) + space() + std::to_string(nf) + space() + "0" + eol();
        std::vector<float> want_pos;
        for (size_t i = 0; i < nv; ++i) {
            for (int k = 0; k < 3; ++k) {
                const double x = offset + (double(next(2000001)) - 1e6) / double(1000 + next(1000));
                char b[40];
                std::snprintf(b, sizeof b, "%.9g", x);
                text += (k ? space() : "") + b;
                want_pos.push_back(std::stof(b));
            }
            if (next(4) == 0) text += space() + "255 128 0"; // a colour the reader skips
            text += eol();
        }
        std::vector<uint32_t> want_indices, want_sizes;
        for (size_t f = 0; f < nf; ++f) {
            const size_t n = 3 + next(std::min<size_t>(nv - 2, 3));
            const std::vector<uint32_t> corners = test::distinct_corners(next, nv, n);
            text += std::to_string(n);
            for (uint32_t c : corners) text += space() + std::to_string(c);
            text += eol();
            want_indices.insert(want_indices.end(), corners.begin(), corners.end());
            want_sizes.push_back(uint32_t(n));
        }
        Scene s;
        const Status st = test::load_text(s, text, ".off");
        ASSERT_TRUE(st.ok()) << st.message << "\n" << text;
        const Primitive& p = s.meshes[0].primitives.at(0);
        const std::array<double, 3> centre = s.nodes[0].translation;
        ASSERT_EQ(p.positions.size(), want_pos.size()) << text;
        for (size_t i = 0; i < want_pos.size(); ++i) // recentred in double: exact when not recentred
            EXPECT_EQ(p.positions[i], float(double(want_pos[i]) - centre[i % 3])) << text;
        EXPECT_EQ(p.indices, want_indices) << text;
        const bool all_triangles = std::all_of(want_sizes.begin(), want_sizes.end(), [](uint32_t n) { return n == 3; });
        EXPECT_EQ(p.face_sizes, all_triangles ? std::vector<uint32_t>{} : want_sizes) << text;
        expect_same_as_former_reader(text);
        // Broken copies.
        for (int k = 0; k < 4; ++k) {
            std::string broken = text;
            if (next(2)) {
                broken.resize(next(broken.size()));
            } else {
                const char swaps[] = {'x', '-', '.', 'e', ' ', '\n', '9', '+', '0'};
                broken[next(broken.size())] = swaps[next(sizeof swaps)];
            }
            expect_same_as_former_reader(broken);
        }
    }
}

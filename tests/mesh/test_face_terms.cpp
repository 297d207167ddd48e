// The kernel's batched face terms (furrow_kernel/face_terms.h) against its scalar functions
// (angle_weighted_normal.h), bit for bit, at every vector width this processor runs: random triangles at
// scales from 1e-6 to 1e6 and far from the origin, slivers, needles, zero-area (collinear) faces, repeated
// points, obtuse and right corners; in ranges and in lists, of lengths that leave partial blocks.
#include <furrow_kernel/angle_weighted_normal.h>
#include <furrow_kernel/face_terms.h>

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

using namespace furrow::kernel;

namespace {

FaceTerm scalar_term(const double* P, const uint32_t* t) { return face_term(point_at(P, t[0]), point_at(P, t[1]), point_at(P, t[2])); }

// Triangles of every kind the normals meet, three fresh points each.
void hard_triangles(std::vector<double>& P, std::vector<uint32_t>& tris, size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(-1, 1);
    std::uniform_int_distribution<int> kind(0, 7), exponent(-6, 6);
    for (size_t t = 0; t < n; ++t) {
        const double scale = std::pow(10.0, exponent(rng)), far = kind(rng) == 0 ? 1e5 : 0.0;
        double p[3][3];
        for (auto& q : p)
            for (double& x : q) x = far + scale * U(rng);
        switch (kind(rng)) {
        case 1: // collinear: zero area
            for (int d = 0; d < 3; ++d) p[2][d] = p[0][d] + 2.0 * (p[1][d] - p[0][d]);
            break;
        case 2: // a sliver: the third point a hair off the line
            for (int d = 0; d < 3; ++d) p[2][d] = 0.5 * (p[0][d] + p[1][d]);
            p[2][1] += 1e-9 * scale;
            break;
        case 3: // a repeated point
            for (int d = 0; d < 3; ++d) p[2][d] = p[0][d];
            break;
        case 4: // a right corner at p0
            p[2][0] = p[0][0], p[2][1] = p[0][1] + scale, p[2][2] = p[0][2];
            p[1][0] = p[0][0] + scale, p[1][1] = p[0][1], p[1][2] = p[0][2];
            break;
        case 5: // a needle: one very short edge
            for (int d = 0; d < 3; ++d) p[1][d] = p[0][d] + 1e-7 * scale * U(rng);
            break;
        default:
            break;
        }
        for (auto& q : p) {
            tris.push_back(uint32_t(P.size() / 3));
            P.insert(P.end(), q, q + 3);
        }
    }
}

bool same_bits(const FaceTerm& a, const FaceTerm& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

} // namespace

TEST(face_terms, EveryWidthGivesTheScalarBits) {
    std::vector<double> P;
    std::vector<uint32_t> tris;
    hard_triangles(P, tris, 20000, 5);
    const size_t T = tris.size() / 3;
    std::vector<FaceTerm> want(T);
    size_t degenerate = 0;
    for (size_t f = 0; f < T; ++f) {
        want[f] = scalar_term(P.data(), &tris[3 * f]);
        degenerate += want[f].angle[0] < 0;
    }
    EXPECT_GT(degenerate, T / 20); // the degenerate kinds are there
    EXPECT_LT(degenerate, T / 2);
    std::printf("face_terms: widest %d lanes, %zu of %zu triangles degenerate\n", face_term_lanes(), degenerate, T);
    for (int lanes : {2, 4, 8}) {
        if (lanes > face_term_lanes()) continue;
        SCOPED_TRACE(std::to_string(lanes) + " lanes");
        for (size_t first : {size_t(0), size_t(3)})
            for (size_t count : {size_t(1), size_t(7), size_t(1001), T - first}) { // a range
                std::vector<FaceTerm> got(T);
                face_terms(got.data(), P.data(), tris.data(), first, nullptr, count, lanes);
                size_t differ = 0;
                for (size_t f = first; f < first + count; ++f) differ += !same_bits(got[f], want[f]);
                EXPECT_EQ(differ, 0u) << "range from " << first << ", " << count << " faces";
            }
        std::vector<uint32_t> list; // every third face, backwards: out[faces[k]]
        for (size_t f = T; f-- > 0;)
            if (f % 3 != 1) list.push_back(uint32_t(f));
        for (size_t count : {size_t(5), list.size()}) {
            std::vector<FaceTerm> got(T);
            face_terms(got.data(), P.data(), tris.data(), 0, list.data(), count, lanes);
            size_t differ = 0, untouched = 0;
            for (size_t k = 0; k < count; ++k) differ += !same_bits(got[list[k]], want[list[k]]);
            for (size_t f = 1; f < T; f += 3) untouched += same_bits(got[f], FaceTerm{});
            EXPECT_EQ(differ, 0u) << "list of " << count;
            EXPECT_EQ(untouched, (T + 1) / 3); // faces off the list are not written
        }
    }
}

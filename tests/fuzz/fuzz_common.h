// Shared by the fuzz harnesses (tests/fuzz/fuzz_*.cpp) and the seed generator (make_seeds.cpp): a byte
// reader that never runs out (missing bytes read as 0, like LLVM's FuzzedDataProvider, so every input is a
// valid program), its writer twin for the seeds, the small-mesh encoding the tool harnesses share, and the
// output checks that turn a broken invariant into an abort (which libFuzzer and the replay tests report).
//
// Why a mesh encoding of our own instead of a file format: the tool harnesses should spend their time in
// the tool, not in a parser, and a fixed layout lets the mutator change one coordinate or one index at a time.
#pragma once

#include <furrow/mesh.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

// A broken invariant: report what and where, then abort (a crash for libFuzzer, a failure for CTest).
#define FUZZ_CHECK(cond, ...)                                                                                   \
    do {                                                                                                        \
        if (!(cond)) {                                                                                          \
            std::fprintf(stderr, "FUZZ_CHECK failed at %s:%d: %s\n  ", __FILE__, __LINE__, #cond);              \
            std::fprintf(stderr, __VA_ARGS__);                                                                  \
            std::fprintf(stderr, "\n");                                                                         \
            std::abort();                                                                                       \
        }                                                                                                       \
    } while (0)

namespace furrow::fuzz {

class Reader {
public:
    Reader(const uint8_t* data, size_t size) : p_(data), n_(size) {}
    size_t remaining() const { return n_ - at_; }
    uint8_t u8() { return at_ < n_ ? p_[at_++] : 0; }
    uint16_t u16() { return uint16_t(u8() | (u8() << 8)); }
    uint32_t u32() { return uint32_t(u16()) | (uint32_t(u16()) << 16); }
    bool flag() { return u8() & 1; }
    // Raw IEEE bits: NaN, infinities, denormals and 1e38 are all one mutation away.
    float f32() {
        uint32_t b = u32();
        float f;
        std::memcpy(&f, &b, 4);
        return f;
    }
    // A value in [lo, hi] from 16 bits (for inputs the harness keeps finite on purpose).
    double range(double lo, double hi) { return lo + (hi - lo) * double(u16()) / 65535.0; }
    std::vector<uint8_t> rest() {
        std::vector<uint8_t> r(p_ + at_, p_ + n_);
        at_ = n_;
        return r;
    }

private:
    const uint8_t* p_;
    size_t n_, at_ = 0;
};

class Writer {
public:
    std::vector<uint8_t> bytes;
    void u8(uint8_t v) { bytes.push_back(v); }
    void u16(uint16_t v) { u8(uint8_t(v)), u8(uint8_t(v >> 8)); }
    void u32(uint32_t v) { u16(uint16_t(v)), u16(uint16_t(v >> 16)); }
    void flag(bool v) { u8(v ? 1 : 0); }
    void f32(float f) {
        uint32_t b;
        std::memcpy(&b, &f, 4);
        u32(b);
    }
    void range(double v, double lo, double hi) {
        double t = (v - lo) / (hi - lo);
        t = t < 0 ? 0 : t > 1 ? 1 : t;
        u16(uint16_t(std::lround(t * 65535.0)));
    }
    void append(const std::vector<uint8_t>& b) { bytes.insert(bytes.end(), b.begin(), b.end()); }
};

// ---------------------------------------------------------------------------------------------------------
// Small meshes. Layout: u8 vertex count (mod kMaxVertices + 1); xyz f32 per vertex; u8 flags (bit 0: UVs);
// with UVs, u16 u and v per vertex mapped to [-2, 2]; u8 face count (mod kMaxFaces + 1); per face, if
// polygons are allowed, u8 size (3 + value mod 4), then one u8 per corner: values below 250 are taken modulo
// the vertex count (always valid), 250..255 name vertex count + 0..5 (out of range, to reach the checks).
// ---------------------------------------------------------------------------------------------------------
constexpr size_t kMaxVertices = 48;
constexpr size_t kMaxFaces = 64;

struct SmallMesh {
    std::vector<float> positions;
    std::vector<float> uvs;
    std::vector<uint32_t> indices;
    std::vector<uint32_t> face_sizes; // always filled (3 for triangles)
    size_t vertex_count() const { return positions.size() / 3; }
};

inline SmallMesh read_mesh(Reader& r, bool polygons) {
    SmallMesh m;
    const size_t nv = r.u8() % (kMaxVertices + 1);
    m.positions.resize(nv * 3);
    for (float& x : m.positions) x = r.f32();
    if (r.u8() & 1) {
        m.uvs.resize(nv * 2);
        for (float& x : m.uvs) x = float(r.range(-2, 2));
    }
    const size_t nf = r.u8() % (kMaxFaces + 1);
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t size = polygons ? 3 + r.u8() % 4 : 3;
        for (uint32_t c = 0; c < size; ++c) {
            const uint8_t v = r.u8();
            m.indices.push_back(v < 250 ? (nv ? v % uint32_t(nv) : 0) : uint32_t(nv) + (v - 250u));
        }
        m.face_sizes.push_back(size);
    }
    return m;
}

inline void write_mesh(Writer& w, const SmallMesh& m, bool polygons) {
    const size_t nv = m.vertex_count();
    w.u8(uint8_t(nv));
    for (float x : m.positions) w.f32(x);
    w.u8(m.uvs.empty() ? 0 : 1);
    for (float x : m.uvs) w.range(x, -2, 2);
    w.u8(uint8_t(m.face_sizes.size()));
    size_t at = 0;
    for (uint32_t s : m.face_sizes) {
        if (polygons) w.u8(uint8_t(s - 3));
        for (uint32_t c = 0; c < s; ++c) w.u8(uint8_t(m.indices[at + c]));
        at += s;
    }
}

// A piece of a model's first primitive: the faces of a breadth-first growth from face `seed` over shared
// vertices, at most `max_faces` faces and kMaxVertices vertices, renumbered. Keeps the source's polygons
// when `polygons` (else fans them); UVs from TEXCOORD_0 when present. For the seeds.
SmallMesh crop(const Primitive& p, size_t seed, size_t max_faces, bool polygons);

// A harness calls this where the library refused its input. Two environment variables make that visible:
// FURROW_FUZZ_VERBOSE=1 prints the step and the message; FURROW_FUZZ_EXPECT_OK=1 aborts, which the seed
// replay tests set, because every seed is a valid piece of a model and must go all the way through.
void rejected(const char* step, const Status& status);

// False for PNG/JPEG bytes whose header declares more than `max_pixels` pixels. decode_image accepts up to
// 2^28 (its memory guard), and a 1 KB file can declare that many: a second of decoding that the harnesses
// skip, so that every input stays within milliseconds. Other bytes: true.
bool small_image(const uint8_t* data, size_t size, size_t max_pixels = size_t(1) << 20);

// A per-process scratch file for the APIs that take a path (save_scene, load_heightmap): $TMPDIR or /tmp,
// named after the process id so that parallel fuzzers do not share it.
std::string scratch_path(const std::string& name);

// True when every value is finite.
inline bool finite(const std::vector<float>& v) {
    for (float x : v)
        if (!std::isfinite(x)) return false;
    return true;
}

// The loaded scene is internally consistent: every array the size its vertex count says, every index and
// every reference in range, positions finite (unless allowed). Aborts otherwise.
void check_scene(const Scene& scene, bool allow_non_finite);

} // namespace furrow::fuzz

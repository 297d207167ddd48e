// Strand textures for shells and fins.
//
// Reference: Lengyel et al., "Real-Time Fur over Arbitrary Surfaces" (I3D 2001), section 4: a volume of
// strands sliced into shell textures, and a fin texture showing the strands from the side. Here the volume
// is not stored slice by slice: a strand is a cone (tapered: full height on its axis, zero at its root
// radius), so the one alpha value "height at which the strand through this texel ends" describes every
// slice, and shell i is its slice through glTF's alpha test (alpha >= alphaCutoff = height fraction).
//
// Deterministic: strands come from a SplitMix64 stream of the seed (S. Vigna; G. Steele, D. Lea,
// C. Flood, "Fast Splittable Pseudorandom Number Generators", OOPSLA 2014) and are drawn in a fixed order;
// each texel keeps the maximum, which does not depend on the order anyway.
//
// add_fur_shells stores both textures as PNG, and the deflate step of the encoder costs more than drawing
// them (about 10 ms for the default 256² tile, as much as growing fur on a few thousand triangles): the
// encoded bytes depend on the options alone, so they are kept for the next call with the same options.
#include "shells_internal.h"

#include <furrow/shells.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <mutex>

namespace furrow {
namespace {

struct SplitMix64 {
    uint64_t state;
    uint64_t next() {
        uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
        return z ^ (z >> 31);
    }
    double uniform() { return double(next() >> 11) * (1.0 / 9007199254740992.0); } // [0, 1)
};

uint8_t to8(double v) { return uint8_t(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); }

StrandTextureOptions sane(StrandTextureOptions o) {
    o.size = std::clamp(o.size, 16, 4096);
    o.strands = std::clamp(o.strands, 0, 1 << 22);
    if (!(o.radius > 0.25)) o.radius = 0.25;
    o.radius = std::min(o.radius, double(o.size) / 4);
    o.min_height = std::isfinite(o.min_height) ? std::clamp(o.min_height, 0.0, 1.0) : 0.5;
    return o;
}

} // namespace

std::vector<uint8_t> make_strand_texture(const StrandTextureOptions& options) {
    const StrandTextureOptions o = sane(options);
    const int n = o.size;
    std::vector<double> height(size_t(n) * size_t(n), 0.0), shade(size_t(n) * size_t(n), 0.0);
    SplitMix64 rng{o.seed * 0x2545F4914F6CDD1DULL + 0x51ED2701ULL};
    for (int s = 0; s < o.strands; ++s) {
        const double cx = rng.uniform() * n, cy = rng.uniform() * n;
        const double h = o.min_height + (1.0 - o.min_height) * rng.uniform();
        const double radius = o.radius * (0.75 + 0.5 * rng.uniform());
        const double bright = 0.78 + 0.22 * rng.uniform();
        const int r = int(std::ceil(radius));
        for (int dy = -r - 1; dy <= r + 1; ++dy)
            for (int dx = -r - 1; dx <= r + 1; ++dx) {
                const int x = int(std::floor(cx)) + dx, y = int(std::floor(cy)) + dy;
                const double ex = x + 0.5 - cx, ey = y + 0.5 - cy; // texel centre to axis
                const double d = std::sqrt(ex * ex + ey * ey);
                if (d >= radius + 0.5) continue;
                // The cone: where this strand ends above the texel; the texel holding the axis gets the full
                // height, so the tallest strands reach alpha 1 and the top shell shows their tips.
                const double a = h * (1.0 - std::max(0.0, d - 0.5) / radius);
                const size_t i = size_t((y % n + n) % n) * size_t(n) + size_t((x % n + n) % n); // tiles
                if (a > height[i]) {
                    height[i] = a;
                    shade[i] = bright;
                }
            }
    }
    std::vector<uint8_t> rgba(size_t(n) * size_t(n) * 4);
    for (size_t i = 0; i < height.size(); ++i) {
        // Between strands: the colour of the skin below, so that filtering at strand edges does not
        // bleed a dark fringe.
        const double c = height[i] > 0 ? shade[i] : 0.9;
        rgba[4 * i] = rgba[4 * i + 1] = rgba[4 * i + 2] = to8(c);
        rgba[4 * i + 3] = to8(height[i]);
    }
    return rgba;
}

std::vector<uint8_t> make_fin_texture(const StrandTextureOptions& options) {
    const StrandTextureOptions o = sane(options);
    const int w = o.size, h = std::max(8, o.size / 2);
    std::vector<double> alpha(size_t(w) * size_t(h), 0.0), shade(size_t(w) * size_t(h), 0.9);
    SplitMix64 rng{o.seed * 0x9E3779B97F4A7C15ULL + 0xF1715ULL};
    // Strands seen from the side: as many as cross one row of the density texture.
    const int count = std::max(1, int(std::lround(std::sqrt(double(o.strands)) * 2)));
    for (int s = 0; s < count; ++s) {
        const double root = rng.uniform() * w;
        const double len = (o.min_height + (1.0 - o.min_height) * rng.uniform()) * h;
        const double lean = (rng.uniform() - 0.5) * 0.3 * h;
        const double half = std::max(0.6, o.radius * (0.75 + 0.5 * rng.uniform()) * 0.5);
        const double bright = 0.78 + 0.22 * rng.uniform();
        for (int y = 0; y < h; ++y) {
            const double up = (h - 0.5 - y); // height of the row centre above the root row
            if (up > len) continue;
            const double f = up / len;                      // 0 at the root .. 1 at the tip
            const double centre = root + lean * f * f;      // a slight curl toward the tip
            const double width = half * (1.0 - f);          // tapered
            for (int dx = -int(half) - 2; dx <= int(half) + 2; ++dx) {
                const int x = int(std::floor(centre)) + dx;
                if (std::abs(x + 0.5 - centre) > width) continue;
                const size_t i = size_t(y) * size_t(w) + size_t((x % w + w) % w);
                alpha[i] = 1.0;
                shade[i] = bright * (0.6 + 0.4 * f);
            }
        }
    }
    std::vector<uint8_t> rgba(alpha.size() * 4);
    for (size_t i = 0; i < alpha.size(); ++i) {
        rgba[4 * i] = rgba[4 * i + 1] = rgba[4 * i + 2] = to8(shade[i]);
        rgba[4 * i + 3] = to8(alpha[i]);
    }
    return rgba;
}

namespace shells_detail {

std::shared_ptr<const std::vector<uint8_t>> strand_texture_png(const StrandTextureOptions& options, bool fin) {
    const StrandTextureOptions o = sane(options);
    struct Entry {
        StrandTextureOptions key;
        bool fin;
        std::shared_ptr<const std::vector<uint8_t>> png;
    };
    auto same = [&](const Entry& e) {
        // Bitwise on the doubles: the same options always map to the same bytes, and nothing else does.
        return e.fin == fin && e.key.size == o.size && e.key.strands == o.strands && e.key.seed == o.seed &&
               std::memcmp(&e.key.radius, &o.radius, sizeof(double)) == 0 &&
               std::memcmp(&e.key.min_height, &o.min_height, sizeof(double)) == 0;
    };
    static std::mutex mutex;
    static std::deque<Entry> cache; // a few entries (two per option set in use), oldest first
    {
        std::lock_guard<std::mutex> lock(mutex);
        for (const Entry& e : cache)
            if (same(e)) return e.png;
    }
    // Encoded outside the lock: two threads asking at once both encode, and get equal bytes.
    const int w = o.size, h = fin ? std::max(8, o.size / 2) : o.size;
    const std::vector<uint8_t> rgba = fin ? make_fin_texture(o) : make_strand_texture(o);
    auto png = std::make_shared<const std::vector<uint8_t>>(encode_png_rgba8(rgba.data(), w, h));
    std::lock_guard<std::mutex> lock(mutex);
    for (const Entry& e : cache)
        if (same(e)) return e.png;
    cache.push_back(Entry{o, fin, png});
    if (cache.size() > 8) cache.pop_front();
    return png;
}

} // namespace shells_detail
} // namespace furrow

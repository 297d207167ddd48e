// Fuzz target: the colliders file reader (parse_colliders, deform/src/colliders_json.cpp), then the parsed
// colliders stamped into a SnowField over a small fixed ground, as `furrow stamp` would.
//
// Input: the JSON text. Images are resolved in models/ (footprint.png, creature_fur_mask.png), so image
// colliders decode a real brush.
// Properties: a parse either fails with a message or gives colliders that satisfy every rule of the schema
// (deform/README.md); stamping them never fails, never writes a non-finite height, and the volumes and
// dirty rectangles stay finite and inside the grid.
#include "fuzz_common.h"

#include <furrow/deform.h>

#include <cmath>
#include <string>

using namespace furrow;

#ifndef FURROW_MODELS_DIR
#error "FURROW_MODELS_DIR must name the repository's models/ folder"
#endif

namespace {

bool unit(const std::array<double, 3>& v) {
    const double n = std::hypot(v[0], v[1], v[2]);
    return std::isfinite(n) && std::abs(n - 1) < 1e-9;
}

bool finite_positive(double x) { return std::isfinite(x) && x > 0; }

void check_collider(const Collider& c) {
    const char* name = c.name.c_str();
    FUZZ_CHECK(!c.name.empty(), "a collider without a name");
    FUZZ_CHECK(!c.path.empty(), "%s: empty path", name);
    for (const auto& p : c.path)
        FUZZ_CHECK(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]), "%s: non-finite path point", name);
    FUZZ_CHECK(c.heading.empty() || c.heading.size() == 1 || c.heading.size() == c.path.size(), "%s: %zu headings", name,
               c.heading.size());
    for (double h : c.heading) FUZZ_CHECK(std::isfinite(h), "%s: non-finite heading", name);
    FUZZ_CHECK(c.time.empty() || c.time.size() == c.path.size(), "%s: %zu times for %zu points", name, c.time.size(),
               c.path.size());
    for (size_t k = 0; k < c.time.size(); ++k) {
        FUZZ_CHECK(std::isfinite(c.time[k]) && c.time[k] >= 0, "%s: time %g", name, c.time[k]);
        FUZZ_CHECK(k == 0 || c.time[k] >= c.time[k - 1], "%s: decreasing time", name);
    }
    switch (c.shape) {
    case ColliderShape::sphere: FUZZ_CHECK(finite_positive(c.radius), "%s: radius %g", name, c.radius); break;
    case ColliderShape::box:
        for (double s : c.size) FUZZ_CHECK(finite_positive(s), "%s: box size %g", name, s);
        break;
    case ColliderShape::capsule:
        FUZZ_CHECK(finite_positive(c.radius), "%s: radius %g", name, c.radius);
        FUZZ_CHECK(std::isfinite(c.length) && c.length >= 0, "%s: length %g", name, c.length);
        FUZZ_CHECK(unit(c.axis), "%s: axis not unit", name);
        break;
    case ColliderShape::image:
        FUZZ_CHECK(finite_positive(c.size[0]) && finite_positive(c.size[1]), "%s: image size", name);
        FUZZ_CHECK(finite_positive(c.depth), "%s: depth %g", name, c.depth);
        FUZZ_CHECK(c.brush && c.brush->width >= 1 && c.brush->height >= 1 && c.brush->channels >= 1 &&
                       c.brush->pixels.size() == size_t(c.brush->width) * size_t(c.brush->height) * size_t(c.brush->channels),
                   "%s: brush", name);
        break;
    default: FUZZ_CHECK(false, "%s: shape %d", name, int(c.shape));
    }
}

// A 2 m × 2 m ground of 6 × 6 vertices with gentle bumps, about the origin: small enough that a field over
// it builds in well under a millisecond.
struct Ground {
    std::vector<float> positions;
    std::vector<uint32_t> indices;
    Ground() {
        const int n = 6;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const float x = -1.0f + 2.0f * float(i) / float(n - 1), z = -1.0f + 2.0f * float(j) / float(n - 1);
                positions.insert(positions.end(), {x, 0.05f * std::sin(3.0f * x) * std::cos(2.0f * z), z});
            }
        for (int j = 0; j + 1 < n; ++j)
            for (int i = 0; i + 1 < n; ++i) {
                const uint32_t a = uint32_t(j * n + i), b = a + 1, c = a + uint32_t(n), d = c + 1;
                indices.insert(indices.end(), {a, c, b, b, c, d});
            }
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size > 64 * 1024) return 0;
    const std::string text(reinterpret_cast<const char*>(data), size);
    // Image names are file paths; keep the fuzzer away from device files (reading /dev/zero never ends).
    if (text.find("/dev") != std::string::npos || text.find("/proc") != std::string::npos ||
        text.find("/sys") != std::string::npos)
        return 0;
    ColliderSet set;
    Status s = parse_colliders(set, text, FURROW_MODELS_DIR);
    if (!s.ok()) {
        FUZZ_CHECK(s.message.find('\n') == std::string::npos, "a message of several lines: '%s'", s.message.c_str());
        fuzz::rejected("parse_colliders", s);
        return 0;
    }
    FUZZ_CHECK(unit(set.up), "up is not a unit vector");
    size_t points = 0;
    for (const Collider& c : set.colliders) {
        check_collider(c);
        points += c.path.size();
    }
    if (set.colliders.size() > 8 || points > 32) return 0; // keep one input within milliseconds

    static const Ground ground;
    SnowOptions o;
    o.up = set.up;
    o.resolution = 48;
    o.rim_width = 0.1;
    o.conserve_volume = true;
    SnowField field;
    s = field.create(ground.positions.data(), ground.positions.size() / 3, ground.indices.data(), ground.indices.size(), o);
    if (!s.ok()) { // an up along which the fixed ground has no extent
        fuzz::rejected("SnowField::create", s);
        return 0;
    }
    double latest = 0;
    for (const Collider& c : set.colliders)
        for (double t : c.time) latest = std::max(latest, t);
    field.set_time(latest);
    StampStats stats;
    s = field.add_colliders(set, &stats);
    FUZZ_CHECK(s.ok(), "stamping parsed colliders failed: %s", s.message.c_str());
    const std::vector<TexelRect> dirty = field.update();
    const Heightmap& hm = field.heightmap();
    const HeightmapFrame& f = hm.frame;
    FUZZ_CHECK(hm.values.size() == size_t(f.width) * size_t(f.height), "heightmap size");
    for (size_t k = 0; k < hm.values.size(); ++k)
        FUZZ_CHECK(std::isfinite(hm.values[k]), "heightmap texel %zu is %g", k, double(hm.values[k]));
    for (const TexelRect& r : dirty)
        FUZZ_CHECK(r.x0 >= 0 && r.y0 >= 0 && r.x1 <= f.width && r.y1 <= f.height && !r.empty(), "dirty rectangle outside");
    FUZZ_CHECK(std::isfinite(field.removed_volume()) && field.removed_volume() >= 0, "removed volume %g", field.removed_volume());
    FUZZ_CHECK(std::isfinite(field.raised_volume()) && field.raised_volume() >= 0, "raised volume %g", field.raised_volume());
    FUZZ_CHECK(std::isfinite(stats.deepest), "deepest %g", stats.deepest);
    return 0;
}

// Fuzz target: `furrow stamp` on a small fuzzed ground — stamp_scene (SnowField: ground raster, contact rays,
// shape stamps and sweeps, rim, refill, base heightmap; ground tessellation; displacement) with one to three
// colliders built from the input.
//
// Input: a fuzz::SmallMesh (the ground's triangles), u8 flags (bit 0 conserve volume, bit 1 tessellate, bit 2
// along up, bit 3 camera, bit 4 a base heightmap, bit 5 an option far out of range, bit 6 a fuzzed up
// vector), the options, then the colliders (read_collider). Collider values obey the schema that
// parse_colliders enforces (finite, positive) but are otherwise raw floats, 1e-38 to 3e38 included; the
// heightmap stays at most 64 texels on a side, rates at most 8.
// Properties: far-out options are refused (never an ok result; a bad ground may be reported first); an ok
// result is a consistent scene with finite positions, normals and UVs, a finite heightmap of the reported
// frame, finite non-negative volumes; when nothing touched the ground the scene is unchanged; and the same
// colliders' points stamped at runtime, one call each or in one batch, leave the same heightmap bytes.
#include "fuzz_common.h"

#include <furrow/deform.h>

#include <algorithm>
#include <cmath>
#include <cstring>

using namespace furrow;

namespace {

double positive(fuzz::Reader& r, double fallback) {
    const double x = std::abs(double(r.f32()));
    return std::isfinite(x) && x > 0 ? x : fallback;
}

double finite(fuzz::Reader& r) {
    const double x = r.f32();
    return std::isfinite(x) ? x : 0.0;
}

Collider read_collider(fuzz::Reader& r) {
    Collider c;
    c.shape = ColliderShape(r.u8() % 4);
    c.name = "fuzzed";
    c.radius = positive(r, 0.1);
    c.length = positive(r, 0.0);
    for (double& s : c.size) s = positive(r, 0.2);
    c.depth = positive(r, 0.05);
    std::array<double, 3> axis{r.range(-1, 1), r.range(-1, 1), r.range(-1, 1)};
    const double an = std::hypot(axis[0], axis[1], axis[2]);
    if (an > 1e-6) c.axis = {axis[0] / an, axis[1] / an, axis[2] / an};
    if (c.shape == ColliderShape::image) {
        auto brush = std::make_shared<ImageF>();
        brush->width = 1 + r.u8() % 6;
        brush->height = 1 + r.u8() % 6;
        brush->channels = 1;
        for (int k = 0; k < brush->width * brush->height; ++k) brush->pixels.push_back(float(r.u8()) / 255.0f);
        c.brush = std::move(brush);
    }
    const size_t points = 1 + r.u8() % 4;
    double t = 0;
    const uint8_t mode = r.u8();
    for (size_t k = 0; k < points; ++k) {
        c.path.push_back({finite(r), finite(r), finite(r)});
        if (mode & 1) c.time.push_back(t += r.range(0, 2));
    }
    if (mode & 2) c.heading.push_back(r.range(-720, 720));
    else if (mode & 4)
        for (size_t k = 0; k < points; ++k) c.heading.push_back(finite(r));
    return c;
}

// The runtime path's oracle: each collider's path points stamped as a walker's steps (a sweep from the point
// before), one stamp() call each or all in one batch, leave the same heightmap bytes.
void check_batch_equals_calls(const fuzz::SmallMesh& m, SnowOptions so, const ColliderSet& set) {
    so.up = set.up;
    SnowField each, batch;
    if (!each.create(m.positions.data(), m.vertex_count(), m.indices.data(), m.indices.size(), so).ok()) return;
    FUZZ_CHECK(batch.create(m.positions.data(), m.vertex_count(), m.indices.data(), m.indices.size(), so).ok(), "a second create failed");
    std::vector<ColliderPose> poses;
    std::vector<size_t> first; // per collider: its first pose
    for (const Collider& c : set.colliders) {
        first.push_back(poses.size());
        for (size_t k = 0; k < c.path.size(); ++k) {
            const double heading = c.heading.empty() ? 0.0 : c.heading.size() == 1 ? c.heading[0] : c.heading[k];
            poses.push_back({c.path[k], heading, c.time.empty() ? 0.0 : c.time[k]});
        }
    }
    std::vector<StampRequest> requests;
    for (size_t ci = 0; ci < set.colliders.size(); ++ci)
        for (size_t k = 0; k < set.colliders[ci].path.size(); ++k)
            requests.push_back({&set.colliders[ci], poses[first[ci] + k], k > 0 ? &poses[first[ci] + k - 1] : nullptr});
    for (const StampRequest& q : requests) FUZZ_CHECK(each.stamp(*q.shape, q.pose, q.previous).ok(), "a runtime stamp was refused");
    FUZZ_CHECK(batch.stamp(requests.data(), requests.size()).ok(), "a batch stamp was refused");
    each.update(), batch.update();
    const std::vector<float>& a = each.heightmap().values;
    const std::vector<float>& b = batch.heightmap().values;
    FUZZ_CHECK(a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0,
               "the batch stamp's heightmap differs from one call each");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fuzz::Reader r(data, size);
    const fuzz::SmallMesh m = fuzz::read_mesh(r, false);
    const uint8_t flags = r.u8();

    ColliderSet set;
    if (flags & 0x40) {
        std::array<double, 3> up{r.range(-1, 1), r.range(-1, 1), r.range(-1, 1)};
        const double n = std::hypot(up[0], up[1], up[2]);
        if (n > 1e-6) set.up = {up[0] / n, up[1] / n, up[2] / n};
    }
    StampOptions o;
    SnowOptions& so = o.snow;
    so.resolution = 2 + r.u8() % 63;
    so.snow_depth = r.flag() ? r.range(0, 1) : 0.0;
    so.rim_width = r.flag() ? r.range(0, 0.5) : 0.0;
    so.rim_height = r.range(0, 1.5);
    so.conserve_volume = flags & 1;
    so.compaction = r.range(0, 1);
    so.refill_rate = r.flag() ? r.range(0, 2) : 0.0;
    so.margin = r.flag() ? r.range(0, 1) : 0.0;
    if (r.flag()) o.time = r.range(0, 10);
    o.max_error = r.flag() ? r.range(0, 0.1) : 0.0;
    o.max_rate = 1 + r.u8() % 8;
    o.max_triangles = 20000;
    o.tessellate = flags & 2;
    o.along_up = flags & 4;
    if (flags & 8) {
        StampCamera cam;
        cam.eye = {r.range(-20, 20), r.range(-20, 20), r.range(-20, 20)};
        cam.fov_degrees = r.range(1, 179);
        cam.viewport_height = 1 + r.u16() % 4096;
        cam.pixel_error = r.range(0.1, 10);
        o.camera = cam;
    }
    bool far_out = false;
    if (flags & 0x20) {
        far_out = true;
        switch (r.u8() % 4) {
        case 0: o.max_rate = 4097 + r.u16(); break;
        case 1: o.max_rate = -int(r.u16()); break;
        case 2: so.compaction = 1.0 + r.range(1e-3, 10); break;
        default: so.rim_height = -r.range(1e-3, 10); break;
        }
    }
    Heightmap base;
    if (flags & 0x10) { // a frame-less map, stretched over the grid (what a plain PFM gives)
        base.frame.width = 1 + r.u8() % 8;
        base.frame.height = 1 + r.u8() % 8;
        for (int k = 0; k < base.frame.width * base.frame.height; ++k) base.values.push_back(float(r.range(-0.2, 0.1)));
        o.base = &base;
    }
    for (int k = 1 + r.u8() % 3; k > 0; --k) set.colliders.push_back(read_collider(r));

    if (!far_out) check_batch_equals_calls(m, so, set);

    Primitive p;
    p.positions = m.positions;
    p.indices = m.indices;
    p.uv0 = m.uvs;
    Scene scene = make_scene(std::move(p));
    const std::vector<float> before = scene.meshes[0].primitives[0].positions;
    StampReport report;
    Heightmap out;
    Status s = stamp_scene(scene, set, o, &report, &out);
    if (far_out) FUZZ_CHECK(!s.ok(), "far-out options were accepted");
    if (!s.ok()) {
        if (!far_out) fuzz::rejected("stamp_scene", s);
        return 0;
    }
    fuzz::check_scene(scene, false);
    for (const Mesh& mesh : scene.meshes)
        for (const Primitive& q : mesh.primitives)
            FUZZ_CHECK(fuzz::finite(q.normals) && fuzz::finite(q.uv0), "non-finite normal or uv after stamping");
    const HeightmapFrame& f = out.frame;
    FUZZ_CHECK(f.width >= 1 && f.height >= 1 && out.values.size() == size_t(f.width) * size_t(f.height), "heightmap %dx%d, %zu values",
               f.width, f.height, out.values.size());
    FUZZ_CHECK(std::isfinite(f.texel) && f.texel > 0, "texel %g", f.texel);
    FUZZ_CHECK(fuzz::finite(out.values), "non-finite heightmap value");
    FUZZ_CHECK(std::isfinite(report.removed_volume) && report.removed_volume >= 0 && std::isfinite(report.raised_volume) &&
                   report.raised_volume >= 0,
               "volumes %g %g", report.removed_volume, report.raised_volume);
    FUZZ_CHECK(std::isfinite(report.max_depth) && std::isfinite(report.max_rim), "depth %g rim %g", report.max_depth, report.max_rim);
    if (!report.changed) {
        FUZZ_CHECK(scene.meshes.size() == 1 && scene.meshes[0].primitives.size() == 1, "an unchanged scene grew");
        const std::vector<float>& after = scene.meshes[0].primitives[0].positions;
        FUZZ_CHECK(after.size() == before.size() && std::equal(after.begin(), after.end(), before.begin()),
                   "report.changed is false but the ground moved");
    }
    return 0;
}

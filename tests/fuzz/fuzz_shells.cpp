// Fuzz target: fur shells on a small fuzzed triangle mesh — compute_shell_frame and shell_positions on plain
// arrays, and (flag) add_fur_shells on a one-primitive scene with a tiny mask and comb map.
//
// Input: a fuzz::SmallMesh (triangles), then u8 flags (bit 0 mask, bit 1 comb, bit 2 add_fur_shells, bit 3
// fins, bit 4 engine layout (with bit 6: the instanced layout), bit 5 an option far out of range, bit 7 far
// LOD levels on a simplified base), then the options (see read_options), then per-vertex mask (u8) and comb
// (3 × u16) values.
// Properties: options outside the documented ranges are an invalid_argument error; an ok frame has the
// documented sizes, finite values, unit or zero directions, 0 <= H <= requested × max_even_thickness,
// bit-identical values on the copies of one position (what keeps shells crack-free), and finite shells;
// add_fur_shells gives a consistent scene with finite attributes and extras that are JSON objects, or a Status.
#include "fuzz_common.h"

#include <furrow/shells.h>

#include <nlohmann/json.hpp>

#include <cmath>

using namespace furrow;

namespace {

bool in_range(const ShellOptions& o) {
    bool ok = o.layers >= 1 && o.layers <= 256 && std::isfinite(o.length) && o.length >= 0 && o.spacing_power >= 0.1 &&
              o.spacing_power <= 10 && o.droop >= 0 && o.droop <= 4 && o.comb_strength >= 0 && o.comb_strength <= 10 &&
              o.lod_levels >= 1 && o.lod_levels <= 8 && o.max_even_thickness >= 1 && o.max_even_thickness <= 100 &&
              o.safe_fraction > 0 && o.safe_fraction <= 1 && o.min_area_ratio >= 0 && o.min_area_ratio < 1;
    for (double g : o.gravity) ok = ok && std::isfinite(g);
    return ok;
}

ShellOptions read_options(fuzz::Reader& r, bool far_out) {
    ShellOptions o;
    o.layers = int(r.u8() % 12); // 0 is out of range; the rest stays fast
    o.length = r.f32();
    o.spacing_power = r.range(0, 11);
    o.droop = r.range(-0.5, 4.5);
    for (double& g : o.gravity) g = r.f32();
    o.comb_strength = r.range(-0.5, 10.5);
    o.lod_levels = int(r.u8() % 10);
    o.max_even_thickness = r.range(0.5, 101);
    o.feature_clamp = r.flag();
    o.safe_fraction = r.range(-0.1, 1.1);
    o.min_area_ratio = r.range(-0.1, 1.1);
    if (far_out) { // values no in-range harness run would try: must be refused, not used
        switch (r.u8() % 4) {
        case 0: o.layers = int(r.u32() | 0x80000000u); break; // negative
        case 1: o.layers = 257 + int(r.u16()); break;
        case 2: o.spacing_power = r.f32(); break;
        default: o.lod_levels = 9 + int(r.u16()); break;
        }
    }
    return o;
}

void check_frame(const ShellFrame& f, const ShellOptions& o, const fuzz::SmallMesh& m) {
    const size_t n = m.vertex_count();
    FUZZ_CHECK(f.direction.size() == 3 * n && f.length.size() == n && f.requested.size() == n && f.lean.size() == 3 * n &&
                   f.sag.size() == 3 * n && f.flags.size() == n,
               "frame array sizes for %zu vertices", n);
    FUZZ_CHECK(fuzz::finite(f.direction) && fuzz::finite(f.length) && fuzz::finite(f.requested) && fuzz::finite(f.lean) &&
                   fuzz::finite(f.sag),
               "non-finite frame value");
    for (size_t v = 0; v < n; ++v) {
        const double d = std::hypot(f.direction[3 * v], f.direction[3 * v + 1], f.direction[3 * v + 2]);
        FUZZ_CHECK(d == 0 || std::abs(d - 1) < 1e-5, "vertex %zu: direction of length %g", v, d);
        FUZZ_CHECK(f.length[v] >= 0, "vertex %zu: H = %g", v, double(f.length[v]));
        FUZZ_CHECK(double(f.length[v]) <= double(f.requested[v]) * o.max_even_thickness * (1 + 1e-6) + 1e-30,
                   "vertex %zu: H = %g above requested %g x even cap %g", v, double(f.length[v]), double(f.requested[v]),
                   o.max_even_thickness);
    }
    FUZZ_CHECK(f.welded_vertices <= n && f.clamped_vertices <= f.welded_vertices && f.bald_vertices <= f.welded_vertices,
               "counters: welded %zu clamped %zu bald %zu of %zu", f.welded_vertices, f.clamped_vertices, f.bald_vertices, n);
    // Copies of one position carry bit-identical frames (exact weld, -0 == +0, as the library welds).
    std::vector<uint32_t> remap(n);
    if (n) weld_positions(remap.data(), m.positions.data(), n);
    for (size_t v = 0; v < n; ++v) {
        const uint32_t w = remap[v];
        if (w == v) continue;
        FUZZ_CHECK(f.length[v] == f.length[w] && f.flags[v] == f.flags[w], "copies %zu and %u of one position differ", v, w);
        for (int k = 0; k < 3; ++k)
            FUZZ_CHECK(f.direction[3 * v + k] == f.direction[3 * w + k] && f.lean[3 * v + k] == f.lean[3 * w + k] &&
                           f.sag[3 * v + k] == f.sag[3 * w + k],
                       "copies %zu and %u of one position differ", v, w);
    }
    std::vector<float> shell(3 * n);
    for (int layer = 1; layer <= o.layers; ++layer) {
        shell_positions(shell.data(), f, m.positions.data(), n, layer, o.layers, o.spacing_power);
        for (size_t v = 0; v < n; ++v)
            if (std::isfinite(m.positions[3 * v]) && std::isfinite(m.positions[3 * v + 1]) && std::isfinite(m.positions[3 * v + 2]))
                for (int k = 0; k < 3; ++k)
                    FUZZ_CHECK(std::isfinite(shell[3 * v + k]), "shell %d vertex %zu is not finite", layer, v);
    }
}

void check_fur_scene(const Scene& scene) {
    // The base (and its copies in the LOD meshes) may hold NaN in vertices no triangle uses: only vertices
    // that a face uses must be finite.
    fuzz::check_scene(scene, true);
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi)
        for (size_t pi = 0; pi < scene.meshes[mi].primitives.size(); ++pi) {
            const Primitive& p = scene.meshes[mi].primitives[pi];
            for (uint32_t i : p.indices)
                FUZZ_CHECK(std::isfinite(p.positions[3 * size_t(i)]) && std::isfinite(p.positions[3 * size_t(i) + 1]) &&
                               std::isfinite(p.positions[3 * size_t(i) + 2]),
                           "primitive %zu/%zu: vertex %u of a face is not finite", mi, pi, i);
            FUZZ_CHECK(fuzz::finite(p.normals), "non-finite normal in a fur primitive");
            FUZZ_CHECK(fuzz::finite(p.uv0) && fuzz::finite(p.uv1), "non-finite uv in a fur primitive");
            FUZZ_CHECK(fuzz::finite(p.colors), "non-finite colour in a fur primitive");
            for (const CustomAttribute& c : p.custom) FUZZ_CHECK(fuzz::finite(c.values), "%s is not finite", c.name.c_str());
        }
    for (const Mesh& m : scene.meshes) // the instanced layout's FURROW_shells; the writer refuses anything else
        FUZZ_CHECK(m.extras_json.empty() || nlohmann::json::parse(m.extras_json, nullptr, false).is_object(),
                   "mesh '%s': extras_json is not a JSON object", m.name.c_str());
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fuzz::Reader r(data, size);
    const fuzz::SmallMesh m = fuzz::read_mesh(r, false);
    const uint8_t flags = r.u8();
    const ShellOptions o = read_options(r, flags & 0x20);
    const size_t n = m.vertex_count();
    std::vector<float> mask, comb;
    if (flags & 1) {
        mask.resize(n);
        for (float& x : mask) x = float(r.u8()) / 255.0f;
    }
    if (flags & 2) {
        comb.resize(3 * n);
        for (float& x : comb) x = float(r.range(-2, 2));
    }

    ShellFrame frame;
    Status s = compute_shell_frame(frame, m.positions.data(), n, m.indices.data(), m.indices.size(),
                                   mask.empty() ? nullptr : mask.data(), comb.empty() ? nullptr : comb.data(), o);
    if (!in_range(o))
        FUZZ_CHECK(s.code == StatusCode::invalid_argument, "out-of-range options gave code %d (%s)", int(s.code),
                   s.message.c_str());
    if (s.ok()) check_frame(frame, o, m);
    else if (in_range(o)) fuzz::rejected("compute_shell_frame", s);

    if (!(flags & 4)) return 0;
    // The scene path, kept small: at most 4 layers, 2 LOD levels and a 16-pixel strand texture.
    Primitive p;
    p.positions = m.positions;
    p.indices = m.indices;
    p.uv0 = m.uvs;
    Scene scene = make_scene(std::move(p));
    FurOptions fo;
    fo.shells = o;
    fo.shells.layers = std::min(o.layers, 4);
    fo.shells.lod_levels = std::min(o.lod_levels, 2);
    fo.fins = flags & 8;
    fo.layout = !(flags & 16) ? ShellLayout::viewer : flags & 64 ? ShellLayout::instanced : ShellLayout::engine;
    if (flags & 128) fo.lod_simplify_error = 0.02;
    fo.strands.size = 16;
    fo.strands.strands = 6;
    // Refinement to at most 8·T + 256 triangles: the same rounds and code paths as the default 8·T + 4096, at
    // a cost that keeps one input fast under the sanitizers (a 45-triangle input refined to 2800 triangles took
    // 6 s here; RefineStarvedFaces tests the default budget).
    fo.refine_budget = 256;
    if (flags & 1) { // a 4 × 4 mask from the input
        fo.mask.width = fo.mask.height = 4;
        fo.mask.channels = 1;
        for (int k = 0; k < 16; ++k) fo.mask.pixels.push_back(float(r.u8()) / 255.0f);
    }
    if (flags & 2) {
        fo.comb.width = fo.comb.height = 2;
        fo.comb.channels = 2;
        for (int k = 0; k < 8; ++k) fo.comb.pixels.push_back(float(r.u8()) / 255.0f);
    }
    FurReport report;
    s = add_fur_shells(scene, fo, &report);
    if (!in_range(fo.shells)) FUZZ_CHECK(s.code == StatusCode::invalid_argument, "out-of-range options accepted");
    if (s.ok()) check_fur_scene(scene);
    else if (in_range(fo.shells)) fuzz::rejected("add_fur_shells", s);
    return 0;
}

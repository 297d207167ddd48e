// Fuzz target: adaptive tessellation (tessellate/) on a small fuzzed polygon mesh — Tessellator::prepare
// (weld, repairs, OpenSubdiv Bfr surfaces), tessellate with every rate criterion, measure; and (flag)
// tessellate_scene on a one-primitive scene with UVs, colours, a skin and a morph target.
//
// Input: a fuzz::SmallMesh (faces of 3..6 corners), u8 flags (bit 0 UVs, bit 1 a colour attribute, bit 2
// vertex data, bit 3 a skin, bit 4 keep_parameters + measure, bit 5 the scene path, bit 6 an option far out
// of range, bit 7 face groups), then SurfaceOptions and RateOptions (read_options), then per-vertex values.
// Rates stay at most 8 and the triangle budget at most 20000, so one input takes milliseconds.
// Properties: far-out options are refused (never an ok result); an ok output has triangles only, every index in
// range, finite positions, unit normals, finite UVs/attributes, skin weights summing to 1, each triangle's
// input face in range, and the counts its stats report; measure() gives finite errors.
#include "fuzz_common.h"

#include <furrow/tessellate.h>

#include <cmath>

using namespace furrow;

namespace {

struct Options {
    TessellateOptions t;
    bool far_out = false;
};

Options read_options(fuzz::Reader& r, bool far_out) {
    Options o;
    SurfaceOptions& s = o.t.surface;
    s.scheme = SubdivisionScheme(r.u8() % 3);
    s.boundary = BoundaryInterpolation(r.u8() % 2);
    s.uv_interpolation = UvInterpolation(r.u8() % 6);
    s.crease_angle_degrees = r.range(0, 180);
    s.accuracy = 1 + r.u8() % 4;
    s.weld_tolerance = r.flag() ? 0.0 : std::abs(double(r.f32()));
    if (!std::isfinite(s.weld_tolerance)) s.weld_tolerance = 0;
    s.refuse_bad_topology = r.flag();
    RateOptions& k = o.t.rates;
    k.uniform = r.u8() % 9;
    k.max_rate = 1 + r.u8() % 8;
    k.max_triangles = 20000;
    if (r.flag()) {
        TessellationCamera c;
        for (double& x : c.eye) x = r.f32();
        if (!(std::isfinite(c.eye[0]) && std::isfinite(c.eye[1]) && std::isfinite(c.eye[2]))) c.eye = {0, 0, 5};
        c.fov_degrees = r.range(1, 179);
        c.viewport_height = 1 + r.u16();
        k.camera = c;
        k.distance = r.flag();
        k.near = r.range(0, 10);
        k.far = k.near + r.range(0.01, 100);
        k.pixel_error = r.flag() ? r.range(0.1, 50) : 0.0;
        k.screen_error = r.flag() ? r.range(0.1, 50) : 0.0;
    }
    const float me = r.f32();
    k.max_error = std::isfinite(me) ? std::abs(double(me)) : 0.0;
    for (int f = r.u8() % 3; f > 0; --f) {
        FocusPoint p;
        for (double& x : p.centre) x = r.range(-10, 10);
        p.radius = r.range(0.001, 10);
        p.rate = r.u8() % 9;
        k.focus.push_back(p);
    }
    for (int i = r.u8() % 3; i > 0; --i) { // instances: scale + translation
        std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        const double sc = r.range(-10, 10);
        m[0] = m[5] = m[10] = sc;
        m[12] = r.range(-100, 100), m[13] = r.range(-100, 100), m[14] = r.range(-100, 100);
        k.instances.push_back(m);
    }
    if (k.uniform == 0 && !k.distance && k.pixel_error == 0 && k.screen_error == 0 && k.max_error == 0 && k.focus.empty())
        k.uniform = 1; // at least one criterion: an input without any is a plain usage error
    if (far_out) {
        o.far_out = true;
        switch (r.u8() % 6) {
        case 0: s.scheme = SubdivisionScheme(3 + r.u8()); break;
        case 1: s.accuracy = 11 + r.u8(); break;
        case 2: s.crease_angle_degrees = -1 - double(r.u16()); break;
        case 3: k.max_rate = 32768 + int(r.u16()); break;
        case 4: k.max_rate = -int(r.u16()); break;
        default: s.weld_tolerance = -1e-3 - double(r.u16()); break;
        }
    }
    return o;
}

void check_output(const TessellateOutput& out, const TessellateInput& in, size_t input_faces) {
    FUZZ_CHECK(out.positions.size() % 3 == 0 && out.indices.size() % 3 == 0, "sizes %zu %zu", out.positions.size(),
               out.indices.size());
    const size_t nv = out.positions.size() / 3, nt = out.indices.size() / 3;
    FUZZ_CHECK(out.stats.vertices == nv && out.stats.triangles == nt, "stats say %zu/%zu, output has %zu/%zu",
               out.stats.vertices, out.stats.triangles, nv, nt);
    for (uint32_t i : out.indices) FUZZ_CHECK(i < nv, "index %u of %zu vertices", i, nv);
    FUZZ_CHECK(fuzz::finite(out.positions), "non-finite output position");
    FUZZ_CHECK(out.normals.size() == out.positions.size(), "normals %zu", out.normals.size());
    for (size_t v = 0; v < nv; ++v) {
        const double l = std::hypot(out.normals[3 * v], out.normals[3 * v + 1], out.normals[3 * v + 2]);
        FUZZ_CHECK(std::abs(l - 1) < 1e-3, "normal %zu has length %g", v, l);
    }
    FUZZ_CHECK(in.uvs ? out.uvs.size() == 2 * nv : out.uvs.empty(), "uvs %zu for %zu vertices", out.uvs.size(), nv);
    FUZZ_CHECK(fuzz::finite(out.uvs), "non-finite output uv");
    FUZZ_CHECK(out.attributes.size() == in.attributes.size() && out.vertex_data.size() == in.vertex_data.size(),
               "attribute channels");
    for (size_t a = 0; a < in.attributes.size(); ++a)
        FUZZ_CHECK(out.attributes[a].size() == nv * size_t(in.attributes[a].components) && fuzz::finite(out.attributes[a]),
                   "attribute %zu", a);
    for (size_t a = 0; a < in.vertex_data.size(); ++a)
        FUZZ_CHECK(out.vertex_data[a].size() == nv * size_t(in.vertex_data[a].components) && fuzz::finite(out.vertex_data[a]),
                   "vertex data %zu", a);
    if (in.joints) {
        FUZZ_CHECK(out.joints.size() == 4 * nv && out.weights.size() == 4 * nv, "skin sizes");
        FUZZ_CHECK(fuzz::finite(out.weights), "non-finite skin weight");
        for (size_t v = 0; v < nv; ++v) {
            const double sum = double(out.weights[4 * v]) + out.weights[4 * v + 1] + out.weights[4 * v + 2] + out.weights[4 * v + 3];
            FUZZ_CHECK(std::abs(sum - 1) < 1e-4, "vertex %zu: skin weights sum to %g", v, sum);
        }
    }
    FUZZ_CHECK(out.triangle_faces.size() == nt, "triangle_faces %zu", out.triangle_faces.size());
    for (uint32_t f : out.triangle_faces) FUZZ_CHECK(f < input_faces, "triangle of input face %u of %zu", f, input_faces);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fuzz::Reader r(data, size);
    const fuzz::SmallMesh m = fuzz::read_mesh(r, true);
    const uint8_t flags = r.u8();
    const Options o = read_options(r, flags & 0x40);
    const size_t n = m.vertex_count(), faces = m.face_sizes.size();

    std::vector<float> colour, deltas, weights;
    std::vector<uint16_t> joints;
    std::vector<uint32_t> groups;
    if (flags & 2)
        for (size_t k = 0; k < 3 * n; ++k) colour.push_back(float(r.u8()) / 255.0f);
    if (flags & 4)
        for (size_t k = 0; k < 3 * n; ++k) deltas.push_back(float(r.range(-1, 1)));
    if (flags & 8)
        for (size_t v = 0; v < n; ++v) {
            for (int k = 0; k < 4; ++k) joints.push_back(uint16_t(r.u8() % 4));
            float w[4], sum = 0;
            for (float& x : w) sum += x = float(r.u8());
            for (float x : w) weights.push_back(sum > 0 ? x / sum : 0.25f);
        }
    if (flags & 0x80)
        for (size_t f = 0; f < faces; ++f) groups.push_back(r.u8() % 3);

    TessellateInput in;
    in.positions = m.positions.data();
    in.vertex_count = n;
    in.indices = m.indices.data();
    in.index_count = m.indices.size();
    in.face_sizes = m.face_sizes.data();
    in.face_count = faces;
    in.face_groups = groups.empty() ? nullptr : groups.data();
    in.uvs = (flags & 1) && !m.uvs.empty() ? m.uvs.data() : nullptr;
    if (!colour.empty()) in.attributes.push_back({colour.data(), 3});
    if (!deltas.empty()) in.vertex_data.push_back({deltas.data(), 3});
    if (!joints.empty()) in.joints = joints.data(), in.weights = weights.data();

    if (!(flags & 0x20)) {
        Tessellator t;
        Status s = t.prepare(in, o.t.surface);
        TessellateOutput out;
        if (s.ok()) s = t.tessellate(out, o.t.rates, flags & 0x10);
        if (o.far_out) FUZZ_CHECK(!s.ok(), "far-out options were accepted");
        if (!s.ok()) {
            if (!o.far_out) fuzz::rejected("tessellate", s);
            return 0;
        }
        check_output(out, in, faces);
        if (flags & 0x10) {
            ErrorReport e;
            s = t.measure(e, out, o.t.rates);
            FUZZ_CHECK(s.ok(), "measure failed: %s", s.message.c_str());
            FUZZ_CHECK(std::isfinite(e.max_error) && std::isfinite(e.mean_error) && std::isfinite(e.max_pixels) &&
                           std::isfinite(e.mean_pixels) && e.max_error >= 0,
                       "error report %g %g %g %g", e.max_error, e.mean_error, e.max_pixels, e.mean_pixels);
        }
        return 0;
    }

    // The scene path: attributes become a Primitive's, the skin a two-joint Skin, the deltas a morph target.
    Primitive p;
    p.positions = m.positions;
    p.indices = m.indices;
    bool triangles_only = true;
    for (uint32_t s : m.face_sizes) triangles_only &= s == 3;
    if (!triangles_only) p.face_sizes = m.face_sizes;
    if (in.uvs) p.uv0 = m.uvs;
    if (!colour.empty())
        for (size_t v = 0; v < n; ++v) p.colors.insert(p.colors.end(), {colour[3 * v], colour[3 * v + 1], colour[3 * v + 2], 1.0f});
    if (!deltas.empty()) p.targets.push_back({deltas, {}, {}});
    Scene scene = make_scene(std::move(p));
    if (!joints.empty()) {
        for (uint16_t& j : joints) j %= 2;
        scene.meshes[0].primitives[0].joints = joints;
        scene.meshes[0].primitives[0].weights = weights;
        Node a, b;
        a.name = "joint0", b.name = "joint1";
        b.translation = {0, 1, 0};
        scene.nodes.push_back(a);
        scene.nodes.push_back(b);
        scene.nodes[0].children = {1};
        scene.nodes[1].children = {2};
        scene.nodes[0].skin = 0;
        scene.skins.push_back({"skin", {1, 2}, {}, 1});
    }
    SceneTessellateReport report;
    Status s = tessellate_scene(scene, o.t, &report);
    if (o.far_out) FUZZ_CHECK(!s.ok(), "far-out options were accepted");
    if (!s.ok()) {
        if (!o.far_out) fuzz::rejected("tessellate_scene", s);
        return 0;
    }
    fuzz::check_scene(scene, false);
    for (const Mesh& mesh : scene.meshes)
        for (const Primitive& q : mesh.primitives) {
            FUZZ_CHECK(fuzz::finite(q.normals) && fuzz::finite(q.uv0) && fuzz::finite(q.colors) && fuzz::finite(q.weights),
                       "non-finite attribute after tessellate_scene");
            for (const MorphTarget& t : q.targets) FUZZ_CHECK(fuzz::finite(t.position_deltas), "non-finite morph delta");
        }
    return 0;
}

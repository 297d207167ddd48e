// The real-client stage's shared pieces: one camera for both renderers, three.js in headless Chromium
// (render_three.mjs) and `furrow render` of the same view, and the measures they are compared by.
#pragma once

#include "test_support.h"

#include <furrow/render.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace furrow::test {

// A perspective view, the same for three.js (PerspectiveCamera(fov, w/h, near, far) + lookAt) and for
// render_scene (RenderCamera with an explicit near plane and no far plane).
struct View {
    std::array<double, 3> eye{0, 0, 1}, target{0, 0, 0};
    double fov = 40, near_plane = 0.05;
    int width = 960, height = 720;
    // The same view from `factor` times the distance along the same line of sight.
    View at_distance(double factor) const {
        View v = *this;
        for (int i = 0; i < 3; ++i) v.eye[size_t(i)] = target[size_t(i)] + factor * (eye[size_t(i)] - target[size_t(i)]);
        v.near_plane = near_plane * std::min(1.0, factor);
        return v;
    }
    View half() const {
        View v = *this;
        v.width /= 2, v.height /= 2;
        return v;
    }
    View scaled(int s) const {
        View v = *this;
        v.width *= s, v.height *= s;
        return v;
    }
};

// One three.js render. mode: "material" (unlit material colours), "coverage" (alphaCutoff grey, like
// RenderMode::cutoff) or "lit"; mipmaps false = every texture sampled from its base level.
struct ThreeJob {
    std::filesystem::path model, out;
    View view;
    std::string mode = "material";
    bool mipmaps = true;
    // Non-empty: the instanced-layout check instead (render_three.mjs "task": "instanced"): `model` is the
    // `--layout instanced` file, `engine` the `--layout engine` file of the same fur; `out` gets the shader's
    // frame, out + ".engine.png" the engine layout's, out + ".straight.png" the control (lean = sag = 0),
    // out + ".cutoffs.png" the shells' coverage (each shell's own cutoff, written as grey, as the "coverage"
    // mode draws the viewer layout), out + ".placeholder.png" the same with the material's one cutoff (the
    // control), and out + ".json" the position gaps.
    std::filesystem::path engine = {};
};

// Renders every job in one browser session (tests/viewer/render_three.mjs, three.js from
// FURROW_VIEWER_DIR). Returns "" on success, else what went wrong (node's stderr).
inline std::string render_three(const std::vector<ThreeJob>& jobs, const std::filesystem::path& dir) {
    nlohmann::json list = nlohmann::json::array();
    for (const ThreeJob& j : jobs) {
        double dist = 0;
        for (int i = 0; i < 3; ++i) dist += (j.view.eye[size_t(i)] - j.view.target[size_t(i)]) * (j.view.eye[size_t(i)] - j.view.target[size_t(i)]);
        list.push_back({{"model", j.model.string()}, {"out", j.out.string()}, {"width", j.view.width},
                        {"height", j.view.height}, {"eye", j.view.eye}, {"target", j.view.target},
                        {"up", {0, 1, 0}}, {"fov", j.view.fov}, {"near", j.view.near_plane},
                        {"far", 1000 * std::sqrt(dist) + 1}, {"mode", j.mode},
                        {"mipmaps", j.mipmaps ? "sampler" : "off"}});
        if (!j.engine.empty()) {
            const std::string o = j.out.string();
            list.back().update({{"task", "instanced"}, {"engine", j.engine.string()}, {"engine_out", o + ".engine.png"},
                                {"straight_out", o + ".straight.png"}, {"report", o + ".json"}});
        }
    }
    const auto file = dir / "three_jobs.json";
    write_text(file, list.dump(1));
    RunResult r = run_node({(source_dir() / "tests/viewer/render_three.mjs").string(), "--modules", FURROW_VIEWER_DIR,
                            file.string()});
    return r.exit_code == 0 ? std::string() : "render_three.mjs exit " + std::to_string(r.exit_code) + ": " + r.err;
}

inline ImageF load_image(const std::filesystem::path& png) {
    ImageF im;
    EXPECT_TRUE(load_png(im, png.string()).ok()) << png;
    return im;
}

// `furrow render` of the same view, in process: shaded with ambient 1 (the unlit material colour, which is
// what three.js's MeshBasicMaterial shows) or RenderMode::cutoff; one sample per pixel, like three.js
// without antialiasing. subpixel_bits 4 snaps vertices as SwiftShader does (Chromium's software GL, which
// three.js runs on here); 8 is the exact rasterizer a ray tracer comes closer to.
inline ImageF render_furrow(const Scene& scene, const View& v, RenderMode mode, bool mipmaps = true, int subpixel_bits = 4) {
    RenderOptions o;
    o.width = v.width;
    o.height = v.height;
    o.camera.eye = v.eye;
    o.camera.target = v.target;
    o.camera.fov_degrees = v.fov;
    o.camera.near_plane = v.near_plane;
    o.mode = mode;
    o.ambient = 1.0f;
    o.mipmaps = mipmaps;
    o.subpixel_bits = subpixel_bits;
    RenderResult r;
    Status s = render_scene(r, scene, o);
    EXPECT_TRUE(s.ok()) << s.message;
    // The 8-bit image, as the PNG would hold it (three.js's side is 8-bit too).
    ImageF im{r.color.width, r.color.height, 4, {}};
    im.pixels.resize(r.rgba8.size());
    for (size_t i = 0; i < r.rgba8.size(); ++i) im.pixels[i] = float(r.rgba8[i]) / 255.0f;
    return im;
}

inline Scene load_or_fail(const std::filesystem::path& file) {
    Scene s;
    Status st = load_scene(s, file.string());
    EXPECT_TRUE(st.ok()) << file << ": " << st.message;
    return s;
}

// The bounds of the stage, with three.js on SwiftShader and furrow render snapping vertices as SwiftShader does
// (subpixel_bits 4). Measured on every case here: IoU 0.9998–1.0000, mean colour difference 0.00–0.01 steps
// of 1/255 on covered pixels. With the default 8-bit snapping the fur's fringe differs (IoU down to 0.981 on
// the Fox at twice the distance: minified strands make each pixel's sample a coin toss at a strand edge), the
// opaque outputs do not.
inline constexpr double kColourBound = 0.5 / 255.0;
inline constexpr double kMinIoU = 0.995;
inline const View kCreatureView{{1.6, 1.1, 2.2}, {0, 0.45, 0}, 40, 0.05, 960, 720}; // models/scene.json "creature"


struct Compared {
    double iou = 0, colour = 0;
};

inline Compared compare_material(const std::filesystem::path& three_png, const Scene& scene, const View& v) {
    ImageF three = load_image(three_png), ours = render_furrow(scene, v, RenderMode::shaded);
    return {mask_iou(silhouette_mask(three), silhouette_mask(ours)), mean_covered_difference(three, ours)};
}

// Checks fur at the three distances: IoU and colour against furrow render, and the coverage three.js keeps.
inline void check_fur_at_three_distances(const std::filesystem::path& model, const View& base, const std::filesystem::path& dir) {
    const double factors[3] = {1.0, 0.5, 2.0};
    std::vector<ThreeJob> jobs;
    for (double f : factors) {
        const std::string tag = std::to_string(int(f * 10));
        jobs.push_back({model, dir / ("material_" + tag + ".png"), base.at_distance(f), "material", true});
        jobs.push_back({model, dir / ("coverage_" + tag + ".png"), base.at_distance(f), "coverage", true});
        jobs.push_back({model, dir / ("reference_" + tag + ".png"), base.at_distance(f).scaled(2), "coverage", false});
    }
    ASSERT_EQ(render_three(jobs, dir), "");
    const Scene scene = load_or_fail(model);
    for (int k = 0; k < 3; ++k) {
        const View v = base.at_distance(factors[k]);
        SCOPED_TRACE("distance × " + std::to_string(factors[k]));
        Compared c = compare_material(jobs[size_t(3 * k)].out, scene, v);
        EXPECT_GE(c.iou, kMinIoU);
        EXPECT_LE(c.colour, kColourBound);
        const CutoffCoverage three = cutoff_coverage(load_image(jobs[size_t(3 * k + 1)].out));
        const CutoffCoverage ref = cutoff_coverage(load_image(jobs[size_t(3 * k + 2)].out));
        const CutoffCoverage ours = cutoff_coverage(render_furrow(scene, v, RenderMode::cutoff));
        ASSERT_GT(ref.height, 0.0) << "no fur in the reference view";
        EXPECT_GE(three.height / ref.height, 0.9);
        EXPECT_NEAR(three.covered / ref.covered, 1.0, 0.1);
        EXPECT_NEAR(ours.height / ref.height, three.height / ref.height, 0.05);
        EXPECT_NEAR(ours.covered / ref.covered, three.covered / ref.covered, 0.05);
        std::printf("distance x%.1f: IoU %.4f, colour %.2f/255, three.js coverage %.3f (height-weighted %.3f), "
                    "furrow render predicts %.3f (%.3f)\n",
                    factors[k], c.iou, 255 * c.colour, three.covered / ref.covered, three.height / ref.height,
                    ours.covered / ref.covered, ours.height / ref.height);
    }
}


} // namespace furrow::test

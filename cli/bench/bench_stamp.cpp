// `furrow bench stamp`: accuracy of stamped + displaced snow against analytic imprints (speed versus error),
// and the throughput of the pieces a game loop uses: contact rays, stamps, a frame of 256 colliders with
// re-displacement, displacement + normals. Baselines are measured in the same run (a uniform grid at the texel
// size, brute-force rays, plain rectangle fills, a full re-displacement, the mesh library's normals).
#include "bench_common.h"
#include "data_dirs.h"
#include "cli_common.h"

#include <furrow/deform.h>
#include <furrow/shapes.h>
#include <furrow/tessellate.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>

#include <unistd.h>

namespace furrow::cli {
namespace {

struct Args {
    int repeat = 3;
    bool quick = false;
    std::vector<int> sections; // empty = all
    bool wants(int section) const { return sections.empty() || std::find(sections.begin(), sections.end(), section) != sections.end(); }
};

double sphere_surface(double r, double p, double rho) {
    const double contact = std::sqrt(std::max(0.0, 2 * r * p - p * p));
    return rho < contact ? -(p - r + std::sqrt(r * r - rho * rho)) : 0.0;
}

// Vertical deviation of a mesh from y = f(x, z) at corners, edge midpoints and centroids of its triangles
// whose centroid passes `keep`.
template <class F, class K>
std::pair<double, double> deviation(const Primitive& p, F f, K keep) {
    double worst = 0, sum = 0;
    size_t n = 0;
    const double w[7][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5, 0.5, 0}, {0, 0.5, 0.5}, {0.5, 0, 0.5}, {1 / 3., 1 / 3., 1 / 3.}};
    for (size_t t = 0; t + 3 <= p.indices.size(); t += 3) {
        double c[3] = {0, 0, 0};
        for (int k = 0; k < 3; ++k)
            for (int d = 0; d < 3; ++d) c[d] += p.positions[3 * size_t(p.indices[t + size_t(k)]) + size_t(d)] / 3.0;
        if (!keep(c[0], c[2])) continue;
        for (const auto& b : w) {
            double q[3] = {0, 0, 0};
            for (int k = 0; k < 3; ++k)
                for (int d = 0; d < 3; ++d) q[d] += b[k] * p.positions[3 * size_t(p.indices[t + size_t(k)]) + size_t(d)];
            const double e = std::abs(q[1] - f(q[0], q[2]));
            worst = std::max(worst, e);
            sum += e;
            ++n;
        }
    }
    return {worst, n ? sum / double(n) : 0.0};
}

struct OracleRow {
    std::string shape, method;
    double texel = 0, max_error = 0;
    size_t triangles = 0;
    double seconds = 0, worst = 0, mean = 0;
};

OracleRow run_oracle(const std::string& shape, double texel, double max_error, bool uniform, int repeat) {
    const double size = 3.0;
    const double r = 0.35, p = 0.12, cx = 0.037, cz = -0.051;
    const double bx = 0.6, bz = 0.8, bd = 0.08, heading = 30.0;
    ColliderSet set;
    Collider c;
    if (shape == "sphere") {
        c.shape = ColliderShape::sphere;
        c.radius = r;
        c.path = {{cx, r - p, cz}};
    } else {
        c.shape = ColliderShape::box;
        c.size = {bx, 0.4, bz};
        c.heading = {heading};
        c.path = {{cx, 0.2 - bd, cz}};
    }
    set.colliders.push_back(c);
    // Adaptive: a coarse ground (0.5 m cells) refined where the heightmap has detail. Uniform baseline: a grid
    // at the texel size displaced as it is.
    const int cells = uniform ? int(std::lround(size / texel)) : 6;
    const Scene ground = make_scene(shapes::grid(float(size), float(size), cells, cells), "ground");
    StampOptions o;
    o.snow.texel = texel;
    o.max_error = max_error;
    o.tessellate = !uniform;
    o.max_rate = 256;
    Scene out;
    StampReport rep;
    OracleRow row;
    row.shape = shape, row.method = uniform ? "uniform grid" : "adaptive";
    row.texel = texel, row.max_error = uniform ? 0 : max_error;
    row.seconds = median_seconds(repeat, [&] {
        Scene s = ground;
        require_ok(stamp_scene(s, set, o, &rep), "bench stamp");
        out = std::move(s);
    });
    const Primitive& m = out.meshes[0].primitives[0];
    row.triangles = m.triangle_count();
    const double hr = heading * std::numbers::pi / 180;
    if (shape == "sphere") {
        std::tie(row.worst, row.mean) = deviation(
            m, [&](double x, double z) { return sphere_surface(r, p, std::hypot(x - cx, z - cz)); },
            [&](double x, double z) { return std::hypot(x - cx, z - cz) < 0.5; });
    } else {
        // The flat floor and the untouched snow around it, a band of 1.5 texels around the walls left out.
        auto local = [&](double x, double z) {
            const double rx = x - cx, rz = z - cz;
            return std::array<double, 2>{rx * std::cos(hr) - rz * std::sin(hr), rx * std::sin(hr) + rz * std::cos(hr)};
        };
        auto margin = [&](double x, double z) {
            auto l = local(x, z);
            return std::min(bx / 2 - std::abs(l[0]), bz / 2 - std::abs(l[1]));
        };
        std::tie(row.worst, row.mean) = deviation(
            m, [&](double x, double z) { return margin(x, z) > 0 ? -bd : 0.0; },
            [&](double x, double z) { return std::abs(margin(x, z)) > 2.5 * texel && std::hypot(x - cx, z - cz) < 0.8; });
    }
    return row;
}

// Möller–Trumbore, nearest hit along (0, −1, 0) — the baseline for the tree's ray casts.
double brute_force_down(const std::vector<float>& P, const std::vector<uint32_t>& I, double ox, double oy, double oz) {
    double best = NAN;
    for (size_t t = 0; t + 3 <= I.size(); t += 3) {
        const float* a = &P[3 * size_t(I[t])];
        const float* b = &P[3 * size_t(I[t + 1])];
        const float* c = &P[3 * size_t(I[t + 2])];
        const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        // d = (0, −1, 0): p = d × e2 = (−e2z, 0, e2x)
        const double pv[3] = {-e2[2], 0, e2[0]};
        const double det = e1[0] * pv[0] + e1[2] * pv[2];
        if (std::abs(det) < 1e-18) continue;
        const double s[3] = {ox - a[0], oy - a[1], oz - a[2]};
        const double u = (s[0] * pv[0] + s[2] * pv[2]) / det;
        if (u < 0 || u > 1) continue;
        const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
        const double v = -q[1] / det;
        if (v < 0 || u + v > 1) continue;
        const double tt = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
        if (tt > 0 && !(tt >= best)) best = tt;
    }
    return std::isnan(best) ? best : oy - best;
}

// ---- 1. Imprint accuracy: the analytic oracle, speed versus error ------------------------------------------------
// Prints the table, adds results["oracle"] and returns the points of the plot.
std::vector<PlotPoint> bench_imprint_accuracy(const Args& a, bool text, nlohmann::json& J) {
    const int repeat = a.repeat;
    std::vector<OracleRow> rows;
    const std::vector<double> texels = a.quick ? std::vector<double>{0.02, 0.01} : std::vector<double>{0.04, 0.02, 0.01, 0.005};
    const std::vector<double> errors = a.quick ? std::vector<double>{0.002} : std::vector<double>{0.004, 0.001, 0.00025};
    for (const char* shape : {"sphere", "box"}) {
        for (double t : texels) {
            rows.push_back(run_oracle(shape, t, 0, true, repeat));
            for (double e : errors) rows.push_back(run_oracle(shape, t, e, false, repeat));
        }
    }
    if (text) {
        std::printf("furrow bench stamp — 1. analytic oracle on a 3 x 3 m flat ground of 6 x 6 cells: a sphere r 0.35 m pressed 0.12 m\n"
                    "(surface y = -(p - r + sqrt(r^2 - rho^2)), sampled within 0.5 m), a box 0.6 x 0.8 m turned 30 deg "
                    "pressed 0.08 m (flat\n"
                    "floor and surround within 0.8 m; triangles whose centroid is within 2.5 texels of a wall left out: the wall itself\n"
                    "is a one-texel ramp). Deviation = |y_mesh - y_analytic| at corners, edge midpoints and centroids (mm). Baseline: a\n"
                    "uniform grid at the texel size, displaced as is. Median of %d runs.\n",
                    repeat);
        Table t({"shape", "method", "texel mm", "max-error mm", "triangles", "ms", "max dev mm", "mean dev mm", "tris/uniform",
                 "time/uniform"});
        const OracleRow* base = nullptr;
        for (const auto& r : rows) {
            if (r.method == "uniform grid") base = &r;
            t.add({r.shape, r.method, fmt(r.texel * 1e3, 1), r.max_error > 0 ? fmt(r.max_error * 1e3, 2) : "-", std::to_string(r.triangles),
                   fmt(r.seconds * 1e3, 1), fmt(r.worst * 1e3, 3), fmt(r.mean * 1e3, 4),
                   base ? fmt(double(r.triangles) / double(base->triangles), 3) : "-", base ? fmt(r.seconds / base->seconds, 2) : "-"});
        }
        t.print();
    }
    std::vector<PlotPoint> points;
    for (const auto& r : rows)
        points.push_back({r.shape, r.method + (r.max_error > 0 ? ", max-error " + fmt(r.max_error * 1e3, 2) + " mm" : ""),
                          "texel " + fmt(r.texel * 1e3, 1) + " mm", r.seconds, double(r.triangles), r.worst * 1e3});
    for (const auto& r : rows)
        J["oracle"].push_back({{"shape", r.shape}, {"method", r.method}, {"texel", r.texel}, {"max_error", r.max_error},
                               {"triangles", r.triangles}, {"seconds", r.seconds}, {"max_dev", r.worst}, {"mean_dev", r.mean}});
    return points;
}

// ---- 2. Contact rays: the tree against brute force, on ground.glb (and the corpus terrain when present) ---------
// Prints the table, adds results["rays"].
void bench_contact_rays(const Args& a, const GlobalFlags& g, bool text, nlohmann::json& J) {
    const int repeat = a.repeat;
    std::vector<std::pair<std::string, std::string>> grounds = {{"ground.glb", bundled_models_dir().string() + "/ground.glb"}};
    {
        const std::string terrain = corpus_dir().string() + "/terrain/terrain.glb";
        if (std::filesystem::exists(terrain)) grounds.push_back({"terrain.glb (corpus)", terrain});
    }
    Table rays({"ground", "triangles", "build ms", "rays", "rays/s (tree)", "rays/s (brute force)", "tree/brute"});
    for (const auto& ground : grounds) {
        // Named, not a structured binding: clang before 16 cannot capture a binding in the lambdas below.
        const std::string& name = ground.first;
        const std::string& path = ground.second;
        Scene s = load_or_throw(path);
        std::vector<float> P;
        std::vector<uint32_t> I;
        scene_triangles(P, I, s);
        SnowOptions so;
        so.resolution = 512;
        SnowField f;
        double build = median_seconds(1, [&] { require_ok(f.create(P.data(), P.size() / 3, I.data(), I.size(), so), path); });
        const HeightmapFrame& fr = f.frame();
        const size_t n = a.quick ? 20000 : 200000;
        std::mt19937 rng(5);
        std::uniform_real_distribution<double> U(0, 1);
        std::vector<double> pts(3 * n), out(n);
        for (size_t k = 0; k < n; ++k) {
            const double u = U(rng) * fr.texel * (fr.width - 1), v = U(rng) * fr.texel * (fr.height - 1);
            for (int d = 0; d < 3; ++d)
                pts[3 * k + size_t(d)] = fr.origin[size_t(d)] + u * fr.axis_u[size_t(d)] + v * fr.axis_v[size_t(d)] + 50 * fr.up[size_t(d)];
        }
        const double tree_s = median_seconds(repeat, [&] { f.cast_down(out.data(), pts.data(), n); });
        const size_t nb = 300;
        std::vector<double> outb(nb);
        const double brute_s = median_seconds(repeat, [&] {
            for (size_t k = 0; k < nb; ++k) outb[k] = brute_force_down(P, I, pts[3 * k], pts[3 * k + 1], pts[3 * k + 2]);
            do_not_optimize(outb.data());
        });
        for (size_t k = 0; k < nb; ++k) // the two must agree
            if (std::isnan(outb[k]) != std::isnan(out[k]) || (!std::isnan(out[k]) && std::abs(outb[k] - out[k]) > 1e-4))
                throw InputError("bench stamp", "ray cast mismatch against brute force on " + name);
        const double rate = double(n) / tree_s, brate = double(nb) / brute_s;
        rays.add({name, std::to_string(I.size() / 3), fmt(build * 1e3, 1), std::to_string(n), fmt_sci(rate), fmt_sci(brate),
                  fmt(rate / brate, 0)});
        J["rays"].push_back({{"ground", name}, {"triangles", I.size() / 3}, {"build_s", build}, {"rays_per_s", rate},
                             {"brute_rays_per_s", brate}});
    }
    if (text) {
        std::printf("\n2. contact queries: rays cast down from above random points (CGAL AABB tree, %s threads); baseline: the same rays\n"
                    "against every triangle (Moller-Trumbore), on 300 rays; results checked equal. Build = field (raster + tree).\n",
                    g.threads ? std::to_string(g.threads).c_str() : "all");
        rays.print();
    }
}

// What stages 3 to 5 share: the triangles of the bundled ground.glb and the demo's colliders (colliders.json).
struct DemoGround {
    std::vector<float> P;
    std::vector<uint32_t> I;
    ColliderSet demo;
};

DemoGround load_demo_ground() {
    DemoGround d;
    Scene ground = load_or_throw(bundled_models_dir().string() + "/ground.glb");
    require_ok(load_colliders(d.demo, bundled_models_dir().string() + "/colliders.json"), "colliders.json");
    scene_triangles(d.P, d.I, ground);
    return d;
}

// ground.glb uniformly tessellated at `rate` (bilinear: the fixed mesh a game displaces).
TessellateOutput tessellate_ground(const DemoGround& d, int rate) {
    TessellateInput tin;
    tin.positions = d.P.data();
    tin.vertex_count = d.P.size() / 3;
    tin.indices = d.I.data();
    tin.index_count = d.I.size();
    TessellateOptions to;
    to.surface.scheme = SubdivisionScheme::bilinear;
    to.rates.uniform = rate;
    TessellateOutput out;
    require_ok(tessellate(out, tin, to), "ground.glb");
    return out;
}

// ---- 3. Stamp throughput: stamps per second against a plain min() blit --------------------------------------------
// Prints the table, adds results["stamps"].
void bench_stamp_throughput(const Args& a, const DemoGround& d, bool text, nlohmann::json& J) {
    const int repeat = a.repeat;
    SnowOptions so;
    so.texel = 0.02;
    Table st({"shape", "size", "stamps", "stamps/s", "texels/stamp", "Mtexels/s", "fill Mtexels/s", "stamp/fill"});
    struct Kind {
        std::string name, size;
        Collider c;
    };
    std::vector<Kind> kinds;
    {
        Collider s;
        s.shape = ColliderShape::sphere, s.radius = 0.35;
        kinds.push_back({"sphere", "r 0.35", s});
        Collider b;
        b.shape = ColliderShape::box, b.size = {0.6, 0.4, 0.6};
        kinds.push_back({"box (turned)", "0.6 x 0.6", b});
        Collider c;
        c.shape = ColliderShape::capsule, c.radius = 0.12, c.length = 1.0;
        kinds.push_back({"capsule", "r 0.12 l 1", c});
        kinds.push_back({"image (footprint)", "0.12 x 0.30", d.demo.colliders[0]});
    }
    const size_t nstamps = a.quick ? 200 : 2000;
    for (auto& k : kinds) {
        SnowField f;
        require_ok(f.create(d.P.data(), d.P.size() / 3, d.I.data(), d.I.size(), so), "ground.glb");
        std::mt19937 rng(9);
        std::uniform_real_distribution<double> U(-9, 9), H(0, 360);
        std::vector<ColliderPose> poses(nstamps);
        std::vector<double> pts(3 * nstamps), h(nstamps);
        for (size_t i = 0; i < nstamps; ++i) pts[3 * i] = U(rng), pts[3 * i + 1] = 10, pts[3 * i + 2] = U(rng);
        f.cast_down(h.data(), pts.data(), nstamps);
        const double sink = k.c.shape == ColliderShape::image    ? 0.0
                            : k.c.shape == ColliderShape::sphere ? 0.35 - 0.1
                            : k.c.shape == ColliderShape::box    ? 0.2 - 0.06
                                                                 : 0.12 - 0.05;
        for (size_t i = 0; i < nstamps; ++i) poses[i] = {{pts[3 * i], h[i] + sink, pts[3 * i + 2]}, H(rng), 0};
        StampStats total;
        const double secs = median_seconds(repeat, [&] {
            SnowField fresh;
            fresh = std::move(f);
            total = {};
            for (const auto& p : poses) {
                StampStats s1;
                require_ok(fresh.stamp(k.c, p, nullptr, &s1), "stamp");
                total.texels_written += s1.texels_written;
            }
            f = std::move(fresh);
        });
        // Baseline: writing min() into the footprint's bounding square, as a brush blit without any shape.
        const double R = k.c.shape == ColliderShape::sphere    ? 0.35
                         : k.c.shape == ColliderShape::box     ? 0.43
                         : k.c.shape == ColliderShape::capsule ? 0.62
                                                               : 0.17;
        const int side = int(2 * R / so.texel) + 1;
        std::vector<float> canvas(size_t(1024) * 1024, 0.0f);
        const double fill_s = median_seconds(repeat, [&] {
            for (size_t i = 0; i < nstamps; ++i) {
                const int x0 = int(i * 37 % (1024 - size_t(side))), y0 = int(i * 91 % (1024 - size_t(side)));
                for (int y = y0; y < y0 + side; ++y)
                    for (int x = x0; x < x0 + side; ++x) {
                        float& c = canvas[size_t(y) * 1024 + size_t(x)];
                        c = std::min(c, -0.01f * float(i));
                    }
            }
            do_not_optimize(canvas.data());
        });
        const double tex = double(side) * side;
        const double rate = double(nstamps) / secs;
        st.add({k.name, k.size, std::to_string(nstamps), fmt_sci(rate), fmt(tex, 0), fmt(rate * tex / 1e6, 1),
                fmt(double(nstamps) * tex / fill_s / 1e6, 1), fmt(secs / fill_s, 1)});
        J["stamps"].push_back({{"shape", k.name}, {"stamps_per_s", rate}, {"texels_per_stamp", tex}, {"fill_seconds", fill_s},
                               {"seconds", secs}});
    }
    if (text) {
        std::printf("\n3. stamps: one collider sample (contact ray + rasterised lower surface + atomic min) on ground.glb at 2 cm texels,\n"
                    "random places and headings; baseline: a min() blit over the same bounding square (texels/stamp), no shape.\n");
        st.print();
    }
}

// ---- 4. A frame: 256 walkers stamped + rim + re-displacement, against re-displacing the whole ground --------------
struct WalkerStamp {
    bool ball = false, swept = false;
    ColliderPose pose, previous;
};

// One configuration (rim or not) at the current thread count: per-frame means of each step, the full pass
// per point, and the consistency checks (incremental against from scratch).
struct FrameRun {
    double stamp_ms = 0, rim_ms = 0, update_ms = 0, redisplace_ms = 0, frame_ms = 0;
    double moved = 0, rects = 0, full_ms = 0, full_rim_ms = 0, rim_texels = 0, grid_texels = 0;
    size_t welded = 0;
    double max_displace_diff = 0; // max |incremental − displace_all| over positions and normals
    double max_scratch_diff = 0;  // max |incremental − from scratch| over the heightmap
    bool scratch_bytes_equal = false;
    std::vector<float> heightmap;  // final output, to compare thread counts
    // DisplacedGround::update's own account, per frame (mean): work counts and phase seconds.
    double shifted = 0, faces = 0, normals = 0;
    double phase_s[5] = {};        // search, displace, sweep, terms, normals (DisplaceUpdateStats)
};

// The frame's walkers in one call (SnowField::stamp over requests: the same field as one call each).
void stamp_walkers(SnowField& f, const std::vector<WalkerStamp>& ws, const Collider& ball, const Collider& foot) {
    std::vector<StampRequest> requests(ws.size());
    for (size_t i = 0; i < ws.size(); ++i)
        requests[i] = {ws[i].ball ? &ball : &foot, ws[i].pose, ws[i].swept ? &ws[i].previous : nullptr};
    require_ok(f.stamp(requests.data(), requests.size()), "stamp");
}

FrameRun run_walker_frames(const Args& a, const DemoGround& d, const TessellateOutput& tess, bool rim) {
    SnowOptions fo;
    fo.texel = 0.02;
    if (rim) fo.rim_width = 0.06;
    SnowField f;
    require_ok(f.create(d.P.data(), d.P.size() / 3, d.I.data(), d.I.size(), fo), "ground.glb");
    DisplacedGround dg;
    require_ok(dg.prepare(tess.positions.data(), tess.positions.size() / 3, tess.indices.data(), tess.indices.size(), f.frame()), "ground");
    std::vector<float> pos(tess.positions.size()), nor(tess.positions.size());
    f.update();
    FrameRun run;
    run.welded = dg.welded_count();
    run.full_ms = 1e3 * median_seconds(a.repeat, [&] { dg.displace_all(f.heightmap(), pos.data(), nor.data()); });
    // 256 walkers: footprints and small balls, each a step from where it was last frame.
    std::mt19937 rng(2);
    std::uniform_real_distribution<double> U(-9, 9), D(-0.2, 0.2);
    const size_t nc = 256;
    std::vector<ColliderPose> prev(nc);
    std::vector<double> pts(3 * nc), h(nc);
    for (size_t i = 0; i < nc; ++i) pts[3 * i] = U(rng), pts[3 * i + 1] = 10, pts[3 * i + 2] = U(rng);
    Collider ball;
    ball.shape = ColliderShape::sphere, ball.radius = 0.1;
    const Collider& foot = d.demo.colliders[0];
    const int frames = a.quick ? 2 : 5;
    std::vector<double> frame_times;
    std::vector<WalkerStamp> history;
    using clock = std::chrono::steady_clock;
    auto ms = [](auto x, auto y) { return std::chrono::duration<double>(y - x).count() * 1e3; };
    for (int fnum = 0; fnum <= frames; ++fnum) {
        for (size_t i = 0; i < nc; ++i) pts[3 * i] += D(rng), pts[3 * i + 2] += D(rng);
        f.cast_down(h.data(), pts.data(), nc);
        std::vector<WalkerStamp> ws;
        for (size_t i = 0; i < nc; ++i) {
            if (std::isnan(h[i])) continue;
            const bool is_ball = i % 4 == 0;
            const ColliderPose p{{pts[3 * i], h[i] + (is_ball ? 0.07 : 0.0), pts[3 * i + 2]}, double(i * 13 % 360), 0};
            ws.push_back({is_ball, is_ball && fnum > 0, p, prev[i]});
            prev[i] = p;
        }
        const auto t0 = clock::now();
        stamp_walkers(f, ws, ball, foot);
        const auto t1 = clock::now();
        SnowUpdateStats us;
        const auto dirty = f.update(&us);
        const auto t2 = clock::now();
        DisplaceUpdateStats ds;
        const size_t m = dg.update(f.heightmap(), dirty, pos.data(), nor.data(), &ds);
        const auto t3 = clock::now();
        history.insert(history.end(), ws.begin(), ws.end());
        if (fnum == 0) continue; // warm-up
        run.stamp_ms += ms(t0, t1), run.rim_ms += us.rim_seconds * 1e3, run.update_ms += us.output_seconds * 1e3;
        run.redisplace_ms += ms(t2, t3);
        frame_times.push_back(ms(t0, t3));
        run.moved += double(m), run.rects += double(dirty.size()), run.rim_texels += double(us.rim_texels);
        run.shifted += double(ds.shifted), run.faces += double(ds.faces), run.normals += double(ds.normals);
        const double phases[5] = {ds.search_seconds, ds.displace_seconds, ds.sweep_seconds, ds.terms_seconds, ds.normals_seconds};
        for (int k = 0; k < 5; ++k) run.phase_s[k] += phases[k];
    }
    for (double* v : {&run.stamp_ms, &run.rim_ms, &run.update_ms, &run.redisplace_ms, &run.moved, &run.rects, &run.rim_texels, &run.shifted,
                      &run.faces, &run.normals, &run.phase_s[0], &run.phase_s[1], &run.phase_s[2], &run.phase_s[3], &run.phase_s[4]})
        *v /= frames;
    run.grid_texels = double(f.frame().width) * double(f.frame().height);
    std::sort(frame_times.begin(), frame_times.end());
    run.frame_ms = frame_times[frame_times.size() / 2];
    // Consistency: the incremental buffers against one full pass, the heightmap against a field that took the
    // same stamps and updated once.
    std::vector<float> full_pos(pos.size()), full_nor(nor.size());
    dg.displace_all(f.heightmap(), full_pos.data(), full_nor.data());
    for (size_t k = 0; k < pos.size(); ++k)
        run.max_displace_diff = std::max({run.max_displace_diff, double(std::abs(pos[k] - full_pos[k])), double(std::abs(nor[k] - full_nor[k]))});
    SnowField scratch;
    require_ok(scratch.create(d.P.data(), d.P.size() / 3, d.I.data(), d.I.size(), fo), "ground.glb");
    stamp_walkers(scratch, history, ball, foot);
    SnowUpdateStats full;
    scratch.update(&full);
    run.full_rim_ms = full.rim_seconds * 1e3;
    run.heightmap = f.heightmap().values;
    const std::vector<float>& ref = scratch.heightmap().values;
    run.scratch_bytes_equal = ref.size() == run.heightmap.size() && std::memcmp(ref.data(), run.heightmap.data(), ref.size() * sizeof(float)) == 0;
    for (size_t k = 0; k < ref.size(); ++k) run.max_scratch_diff = std::max(run.max_scratch_diff, double(std::abs(ref[k] - run.heightmap[k])));
    return run;
}

// Prints the table, adds results["frame"]: each configuration at 1 and 2 threads in the same run.
void bench_walker_frame(const Args& a, const DemoGround& d, bool text, nlohmann::json& J) {
    const TessellateOutput tess = tessellate_ground(d, a.quick ? 2 : 6);
    Table fr({"frame", "-j", "ground tris", "dirty rects", "points moved", "rim texels", "stamp ms", "rim ms", "update ms", "redisplace ms", "frame ms",
              "full redisplace ms", "us/pt incr", "us/pt full", "incr/full per pt", "full rim ms", "max|incr-full|", "= scratch"});
    // Where the re-displacement's time goes, per moved point (DisplaceUpdateStats), against the full pass's
    // time per welded point: what each moved point brings (shifted, faces, normals) and each phase's ns.
    Table ph({"frame", "-j", "points moved", "shifted", "faces / moved", "normals / moved", "search ns", "displace ns", "sweep ns",
              "terms ns", "normals ns", "update ns", "full pass ns / pt"});
    for (bool rim : {false, true}) {
        std::vector<float> first;
        for (int asked : {1, 2}) {
            FrameRun r;
            int threads = 0; // what the row ran with (a global -j 1 caps the second row)
            {
                tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(asked));
                threads = active_threads();
                r = run_walker_frames(a, d, tess, rim);
            }
            if (first.empty()) first = r.heightmap;
            else if (first != r.heightmap) throw InputError("bench stamp", "the frame's heightmap differs between 1 and 2 threads");
            const double inc_us = r.moved > 0 ? r.redisplace_ms * 1e3 / r.moved : 0, full_us = r.full_ms * 1e3 / double(r.welded);
            fr.add({rim ? "with rim 6 cm" : "no rim", std::to_string(threads), std::to_string(tess.indices.size() / 3), fmt(r.rects, 0),
                    fmt(r.moved, 0), fmt(r.rim_texels, 0) + " of " + fmt(r.grid_texels, 0), fmt(r.stamp_ms, 2), fmt(r.rim_ms, 2), fmt(r.update_ms, 2), fmt(r.redisplace_ms, 2), fmt(r.frame_ms, 2),
                    fmt(r.full_ms, 2), fmt(inc_us, 3), fmt(full_us, 3), fmt(inc_us / full_us, 2), fmt(r.full_rim_ms, 2),
                    fmt_sci(std::max(r.max_displace_diff, r.max_scratch_diff)), r.scratch_bytes_equal ? "bytes" : "NO"});
            J["frame"].push_back({{"rim", rim}, {"threads", threads}, {"triangles", tess.indices.size() / 3}, {"colliders", 256},
                                  {"frame_ms", r.frame_ms}, {"stamp_ms", r.stamp_ms}, {"rim_ms", r.rim_ms}, {"update_ms", r.update_ms},
                                  {"redisplace_ms", r.redisplace_ms}, {"full_redisplace_ms", r.full_ms}, {"points_moved", r.moved}, {"rim_texels", r.rim_texels},
                                  {"welded_points", r.welded}, {"per_point_ratio", inc_us / full_us}, {"full_rim_ms", r.full_rim_ms},
                                  {"max_displace_diff", r.max_displace_diff}, {"max_scratch_diff", r.max_scratch_diff},
                                  {"scratch_bytes_equal", r.scratch_bytes_equal}});
            const double per = r.moved > 0 ? 1e9 / r.moved : 0; // a frame's seconds -> ns a moved point
            std::vector<std::string> row{rim ? "with rim 6 cm" : "no rim", std::to_string(threads), fmt(r.moved, 0),
                                         fmt(r.moved > 0 ? 100 * r.shifted / r.moved : 0, 0) + " %", fmt(r.moved > 0 ? r.faces / r.moved : 0, 2),
                                         fmt(r.moved > 0 ? r.normals / r.moved : 0, 2)};
            double total = 0;
            for (double s : r.phase_s) row.push_back(fmt(s * per, 0)), total += s * per;
            row.push_back(fmt(total, 0));
            row.push_back(fmt(1e6 * r.full_ms / double(r.welded), 0));
            ph.add(row);
            J["frame"].back()["update_phases_ns_per_moved_point"] = {{"search", r.phase_s[0] * per}, {"displace", r.phase_s[1] * per},
                                                                     {"sweep", r.phase_s[2] * per}, {"terms", r.phase_s[3] * per},
                                                                     {"normals", r.phase_s[4] * per}};
            J["frame"].back()["shifted_points"] = r.shifted;
            J["frame"].back()["faces_recomputed"] = r.faces;
            J["frame"].back()["normals_recomputed"] = r.normals;
        }
    }
    if (text) {
        std::printf("\n4. a frame: 256 walkers on ground.glb (uniformly tessellated, fixed mesh) - 3 in 4 stamp a footprint, 1 in 4 a\n"
                    "ball swept from its last position; then update() (rim; update = output over the changed tiles) and\n"
                    "re-displacement of the points under the dirty rectangles with their normals, at 1 and 2 threads. Baseline:\n"
                    "re-displacing the whole ground (per point: redisplace ms / points moved against full ms / welded points) and\n"
                    "the rim of a field that took the same stamps in one update (full rim ms). max|incr-full|: positions and normals\n"
                    "against one full pass, heightmap against that field; = scratch: its bytes equal. Mean of %d frames (frame ms:\n"
                    "median); the heightmap is checked equal at 1 and 2 threads.\n",
                    a.quick ? 2 : 5);
        fr.print();
        std::printf("\nThe re-displacement's phases (DisplacedGround::update's own stats, mean of the frames), in ns per point\n"
                    "moved, against the full pass's ns per welded point: shifted = moved points whose position changed in bits;\n"
                    "faces and normals = recomputed around them, per moved point (a full pass: about 2 faces and 1 normal a point);\n"
                    "at -j 1 the displace phase also marks what each shifted point changes, and the sweep only lists the marks.\n");
        ph.print();
    }
}

// ---- 5. Displacement + normals, against the mesh library's normals and Blender's Displace modifier -----------------
// The peer (Blender 3.4, one thread): a side x side grid of quads over [-1, 1]² displaced along its normals by a
// Displace modifier whose image texture is the same heightmap (float, non-colour, local coordinates, mid-level 0,
// strength 1); timed inside Blender: one modifier-stack evaluation with its vertex normals (mesh tagged, depsgraph
// update, to_mesh, normals read), the median of `repeat` after a warm-up. Not timed: start-up and building the scene.
constexpr const char* kBlenderDisplace = R"PY(
import array, bpy, sys, time
argv = sys.argv[sys.argv.index("--") + 1:]
result, heights_path = argv[0], argv[1]
hw, hh, side, repeat = int(argv[2]), int(argv[3]), int(argv[4]), int(argv[5])
heights = array.array("f")
with open(heights_path, "rb") as f:
    heights.frombytes(f.read())
pixels = array.array("f", bytes(16 * hw * hh))
for c in range(3):
    pixels[c::4] = heights
pixels[3::4] = array.array("f", [1.0]) * (hw * hh)
image = bpy.data.images.new("height", hw, hh, alpha=False, float_buffer=True)
image.colorspace_settings.name = "Non-Color"
image.pixels.foreach_set(pixels)
texture = bpy.data.textures.new("height", type="IMAGE")
texture.image = image
texture.extension = "EXTEND"
step = 2.0 / (side - 1)
verts = [(i * step - 1.0, j * step - 1.0, 0.0) for j in range(side) for i in range(side)]
quads = [(j * side + i, j * side + i + 1, (j + 1) * side + i + 1, (j + 1) * side + i) for j in range(side - 1) for i in range(side - 1)]
mesh = bpy.data.meshes.new("grid")
mesh.from_pydata(verts, [], quads)
mesh.update()
grid = bpy.data.objects.new("grid", mesh)
bpy.context.scene.collection.objects.link(grid)
mod = grid.modifiers.new("Displace", "DISPLACE")
mod.texture = texture
mod.texture_coords = "LOCAL"
mod.mid_level = 0.0
mod.strength = 1.0
depsgraph = bpy.context.evaluated_depsgraph_get()
def evaluate():
    mesh.update()  # tags the geometry: the modifier stack runs again
    depsgraph.update()
    evaluated = grid.evaluated_get(depsgraph)
    out = evaluated.to_mesh()
    assert len(out.vertices) == side * side
    out.vertex_normals[0].vector  # the normals, as furrow computes them
    evaluated.to_mesh_clear()
evaluate()
times = []
for _ in range(repeat):
    t0 = time.perf_counter()
    evaluate()
    times.append(time.perf_counter() - t0)
times.sort()
print("furrow-bench blender displace seconds", times)
with open(result, "w") as f:
    f.write(repr(times[len(times) // 2]))
)PY";

// Blender's Displace on a grid of about `vertices` points by heightmap h (seconds; NaN: not installed or failed).
double blender_displace_seconds(const Heightmap& h, size_t vertices, int repeat) {
    if (!on_path("blender")) return std::numeric_limits<double>::quiet_NaN();
    const std::filesystem::path raw = std::filesystem::temp_directory_path() / ("furrow-bench-stamp-heights-" + std::to_string(getpid()) + ".f32");
    {
        std::ofstream o(raw, std::ios::binary);
        o.write(reinterpret_cast<const char*>(h.values.data()), std::streamsize(h.values.size() * sizeof(float)));
    }
    const int side = std::max(2, int(std::lround(std::sqrt(double(vertices)))));
    const double s = blender_peer_seconds(kBlenderDisplace, {raw.string(), std::to_string(h.frame.width), std::to_string(h.frame.height),
                                                             std::to_string(side), std::to_string(repeat)});
    std::error_code ec;
    std::filesystem::remove(raw, ec);
    return s;
}

// Prints the table, adds results["displace"].
void bench_displacement(const Args& a, const DemoGround& d, bool text, nlohmann::json& J) {
    const int repeat = a.repeat;
    SnowOptions so;
    so.texel = 0.02;
    SnowField f;
    require_ok(f.create(d.P.data(), d.P.size() / 3, d.I.data(), d.I.size(), so), "ground.glb");
    require_ok(f.add_colliders(d.demo), "colliders");
    f.update();
    Table dt({"mesh", "vertices", "welded", "fresh prepare ms", "prepare ms", "displace+normals ms", "1st update ms", "Mvertices/s", "mesh-lib normals ms",
              "ratio", "Blender grid", "Blender Displace ms", "Blender / (fresh prepare+displace)", "Blender / (prepare+displace)"});
    const bool blender = on_path("blender");
    for (int rate : a.quick ? std::vector<int>{2} : std::vector<int>{4, 8}) {
        const TessellateOutput big = tessellate_ground(d, rate);
        const size_t V = big.positions.size() / 3;
        // A fresh object each run on a trimmed heap: the page faults of a first prepare (a `furrow stamp`).
        const double fresh = median_fresh_seconds(repeat, [&](int) {
            DisplacedGround first;
            const auto t0 = std::chrono::steady_clock::now();
            require_ok(first.prepare(big.positions.data(), V, big.indices.data(), big.indices.size(), f.frame()), "ground");
            return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        });
        // The same object prepared again (warm-up first): it reuses its storage, as an engine re-preparing a ground.
        DisplacedGround dg;
        const double prep = median_seconds(repeat, [&] {
            require_ok(dg.prepare(big.positions.data(), V, big.indices.data(), big.indices.size(), f.frame()), "ground");
        });
        std::vector<float> pos(big.positions.size()), nor(big.positions.size()), ref(big.positions.size());
        const double disp = median_seconds(repeat, [&] { dg.displace_all(f.heightmap(), pos.data(), nor.data()); });
        // The update's indexes and face terms, built by the first update() after a prepare (not part of a one-shot
        // displacement).
        const double index = median_fresh_seconds(repeat, [&](int) {
            require_ok(dg.prepare(big.positions.data(), V, big.indices.data(), big.indices.size(), f.frame()), "ground");
            const auto t0 = std::chrono::steady_clock::now();
            dg.update(f.heightmap(), std::vector<TexelRect>{}, pos.data(), nor.data()); // no rectangle: the indexes alone
            return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        });
        const double lib = median_seconds(repeat, [&] {
            compute_vertex_normals(ref.data(), pos.data(), V, big.indices.data(), big.indices.size());
            do_not_optimize(ref.data());
        });
        const double peer = blender ? blender_displace_seconds(f.heightmap(), V, repeat) : std::numeric_limits<double>::quiet_NaN();
        const int side = int(std::lround(std::sqrt(double(V))));
        const std::string peer_ms = !blender ? "peer not installed" : std::isnan(peer) ? "peer failed" : fmt(peer * 1e3, 1);
        dt.add({"ground.glb x" + std::to_string(rate), std::to_string(V), std::to_string(dg.welded_count()), fmt(fresh * 1e3, 1), fmt(prep * 1e3, 1),
                fmt(disp * 1e3, 2), fmt(index * 1e3, 2), fmt(double(V) / disp / 1e6, 2), fmt(lib * 1e3, 2), fmt(disp / lib, 2),
                std::to_string(side) + "^2", peer_ms, std::isnan(peer) ? "-" : fmt(peer / (fresh + disp), 2),
                std::isnan(peer) ? "-" : fmt(peer / (prep + disp), 2)});
        J["displace"].push_back({{"vertices", V}, {"fresh_prepare_s", fresh}, {"prepare_s", prep}, {"displace_s", disp}, {"first_update_s", index}, {"mesh_normals_s", lib},
                                 {"blender_displace_s", std::isnan(peer) ? nlohmann::json(nullptr) : nlohmann::json(peer)}});
    }
    if (text) {
        std::printf("\n5. displacement + welded normals (DisplacedGround::displace_all) of ground.glb uniformly tessellated, "
                    "by the demo\nheightmap; baseline: furrow::compute_vertex_normals alone on the same mesh (normals only, no "
                    "displacement).\nPeer: Blender 3.4's Displace modifier (one thread) on a grid of as many points with an image "
                    "texture of the same heightmap,\ntimed inside Blender (one modifier evaluation with normals; not start-up or "
                    "set-up); last columns: its time over furrow's prepare + displace.\nfresh prepare: a new DisplacedGround, "
                    "heap trimmed first (every page faulted in, as in a `furrow stamp`); prepare: the same object prepared\n"
                    "again (it reuses its storage, as an engine re-preparing a ground; Blender's evaluation also runs warm).\n"
                    "1st update: what the first update() after a prepare adds (the faces per point, the points per tile and\n"
                    "every face's normal terms an update reads; a one-shot displacement, like Blender's, never builds them).\n");
        dt.print();
    }
}

} // namespace

// The benchmark as the list of its stages, in the order of their tables; each stage prints its table (when
// `tables`) and adds its rows to the results.
static nlohmann::json run_bench_stamp(const Args& a, const GlobalFlags& g, bool tables) {
    nlohmann::json J;
    std::vector<PlotPoint> points;
    if (a.wants(1)) {
        info(g, "bench stamp: analytic oracle");
        points = bench_imprint_accuracy(a, tables, J);
    }
    if (a.wants(2)) {
        info(g, "bench stamp: contact rays");
        bench_contact_rays(a, g, tables, J);
    }
    const DemoGround ground = load_demo_ground();
    if (a.wants(3)) {
        info(g, "bench stamp: stamps");
        bench_stamp_throughput(a, ground, tables, J);
    }
    if (a.wants(4)) {
        info(g, "bench stamp: frame");
        bench_walker_frame(a, ground, tables, J);
    }
    if (a.wants(5)) {
        info(g, "bench stamp: displacement");
        bench_displacement(a, ground, tables, J);
    }
    return {{"bench", "stamp"}, {"repeat", a.repeat}, {"results", J}, {"plot", plot_json("max deviation (mm)", points)}};
}

nlohmann::json bench_stamp_default(const BenchRun& r, const GlobalFlags& g) {
    Args a;
    a.quick = r.quick;
    if (r.repeat > 0) a.repeat = r.repeat;
    return run_bench_stamp(a, g, r.tables);
}

void register_bench_stamp(CLI::App& bench, GlobalFlags& g) {
    auto a = std::make_shared<Args>();
    auto out = std::make_shared<BenchOutput>();
    CLI::App* cmd = bench.add_subcommand("stamp", "Snow stamping: analytic-oracle error vs time, rays/s, stamps/s, a 256-collider frame");
    cmd->add_option("--repeat", a->repeat, "Runs per measurement; the median is reported (default 3)")->check(finite_range(1, 1000));
    add_bench_output_flags(*cmd, *out);
    cmd->add_flag("--quick", a->quick, "Fewer sizes and samples (a smoke run)");
    cmd->add_option("--section", a->sections, "Run only these sections (1 oracle, 2 rays, 3 stamps, 4 frame, 5 displacement); default all")
        ->check(CLI::Range(1, 5));
    cmd->footer("Examples:\n  furrow bench stamp\n  furrow bench stamp --quick --json\n  furrow bench stamp -j 1 --repeat 5\n  furrow bench stamp --section 4");
    cmd->callback([a, out, &g] { finish_bench(run_bench_stamp(*a, g, !out->json), *out, g); });
}

} // namespace furrow::cli

// SnowField: the stamping state — contact rays, min-composited stamps, refill, rim, dirty rectangles.
//
// References: Rise of the Tomb Raider's deformation snow (GDC 2016): a float map, deformers merged by min,
// exponential refill; Batman: Arkham Origins (GDC 2014): per-frame refill of an ankle-high map; Blender
// Dynamic Paint: substeps for fast brushes, dissolve over time. Layers per texel: undeformed ground height
// (NaN = none), base (a loaded map), carve (base min stamps), rim (derived), output = carve + rim.
//
// Refill commutes with compositing: scaling by a positive factor preserves min, so decaying the field and
// then stamping equals stamping every stamp pre-decayed by its own age — the result does not depend on the
// order of stamps, only on their times. The rim is linear in the removed depth with a fixed receiver set,
// so it decays with the same factor.
//
// update() is a game's per-frame cost, so it redoes only what the stamps since the last call can change: a
// cosmetic rim within its reach of the stamped texels (the rim is local and computed exactly, snow_rim.cpp,
// so this equals recomputing everything), and the output where the imprint deepened or the rim changed (per
// tile, those texels' bounding box: what the caller re-displaces); a wider reach (a larger collider) redoes
// the rim around every imprint. A volume-conserving rim is recomputed per connected region,
// each balancing its own volume.
#include "deform_internal.h"
#include <furrow_kernel/no_throw.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <tuple>

namespace furrow {

using namespace deform_detail;

struct SnowField::Impl {
    SnowOptions opt;
    Heightmap ground, out;
    std::vector<float> carve, rim, base;
    GroundRaycaster rays;
    double now = 0;
    TexelRect content;
    // Dirty state per 16 x 16-texel tile: stamped since the last update, output changed by refill.
    static constexpr int kTile = 16;
    int tiles_x = 0, tiles_y = 0;
    std::vector<uint8_t> carve_tiles, out_tiles, rim_tiles; // rim: recomputed
    // Per tile, the bounding box of the texels whose output is to be recomputed: deepened since the last
    // update (carve_box), rim changed in bits in this update (rim_box). Empty: none.
    std::vector<TexelRect> carve_box, rim_box;
    std::vector<TexelRect> stamped_rects; // texels stamped since the last update (the cosmetic rim's sources)
    int rim_reach = -1;                   // the cosmetic rim's reach (texels) at the last update
    void mark(std::vector<uint8_t>& tiles, const TexelRect& r) {
        if (r.empty()) return;
        for (int ty = r.y0 / kTile; ty <= (r.y1 - 1) / kTile; ++ty)
            for (int tx = r.x0 / kTile; tx <= (r.x1 - 1) / kTile; ++tx) tiles[size_t(ty) * size_t(tiles_x) + size_t(tx)] = 1;
    }
    TexelRect tile_rect(size_t t) const {
        const int tx = int(t % size_t(tiles_x)), ty = int(t / size_t(tiles_x));
        return {tx * kTile, ty * kTile, std::min(ground.frame.width, (tx + 1) * kTile), std::min(ground.frame.height, (ty + 1) * kTile)};
    }
    void mark_box(std::vector<TexelRect>& boxes, const TexelRect& r) { // each tile's box grown by its part of r
        if (r.empty()) return;
        for (int ty = r.y0 / kTile; ty <= (r.y1 - 1) / kTile; ++ty)
            for (int tx = r.x0 / kTile; tx <= (r.x1 - 1) / kTile; ++tx) {
                const size_t t = size_t(ty) * size_t(tiles_x) + size_t(tx);
                const TexelRect c = tile_rect(t);
                boxes[t].unite({std::max(r.x0, c.x0), std::max(r.y0, c.y0), std::min(r.x1, c.x1), std::min(r.y1, c.y1)});
            }
    }
    bool all_dirty = false;
    bool stamped = false;
    double max_reach = 0;
    size_t overhangs = 0;
    mutable bool volumes_valid = false;
    mutable double removed = 0, raised = 0;
    double lost_rim = 0;

    TexelRect full() const { return {0, 0, ground.frame.width, ground.frame.height}; }
    double rim_width() const { return opt.rim_width > 0 ? opt.rim_width : (opt.conserve_volume ? 8 * ground.frame.texel : 0.0); }
    // How wide a volume-conserving rim may grow to keep its height and slope limits (the windows hold it).
    double rim_max_width() const {
        const bool limited = opt.rim_max_height > 0 || (opt.repose_degrees > 0 && opt.repose_degrees < 90);
        return opt.conserve_volume && limited ? rim_width() + 4 * max_reach : rim_width();
    }

    LocalPose local(const ColliderPose& p) const {
        auto t = ground.frame.to_texel(p.centre.data());
        return {t[0] * ground.frame.texel, t[1] * ground.frame.texel, t[2], p.heading_degrees * kPi / 180.0, 0.0};
    }

    // Contact ray for a pose: sets penetration, returns whether the collider touches.
    struct Contact {
        bool hit = false, touching = false;
        double penetration = 0;
    };
    Contact contact(const Collider& c, const LocalPose& p) const {
        Contact r;
        const double top = collider_top_offset(c), bottom = collider_bottom_offset(c);
        const double lift = 2 * top + bottom + 2 * ground.frame.texel;
        const Vec3 up = d3(ground.frame.up);
        const Vec3 origin = d3(ground.frame.origin) + d3(ground.frame.axis_u) * p.u + d3(ground.frame.axis_v) * p.v + up * (p.w + lift);
        const double t = rays.first_hit(origin, up * -1.0);
        if (std::isnan(t)) return r;
        r.hit = true;
        const double g = p.w + lift - t;
        r.penetration = g - (p.w - bottom);
        r.touching = r.penetration > 0;
        return r;
    }
};

SnowField::SnowField() : impl_(std::make_unique<Impl>()) {}
SnowField::~SnowField() = default;
SnowField::SnowField(SnowField&&) noexcept = default;
SnowField& SnowField::operator=(SnowField&&) noexcept = default;

Status SnowField::create(const float* positions, size_t vertex_count, const uint32_t* indices, size_t index_count,
                         const SnowOptions& o) {
    return kernel::no_throw("creating the snow field", [&]() -> Status {
        auto bad = [](const std::string& m) { return Status::error(StatusCode::invalid_argument, m); };
        auto finite_ge0 = [](double x) { return std::isfinite(x) && x >= 0; };
        if (!finite_ge0(o.texel)) return bad("texel must be a finite number >= 0");
        if (o.texel == 0 && (o.resolution < 2 || o.resolution > 1000000)) return bad("resolution must be in 2..1000000");
        if (!finite_ge0(o.snow_depth)) return bad("snow depth must be a finite number >= 0");
        if (!finite_ge0(o.rim_width)) return bad("rim width must be a finite number >= 0");
        if (!finite_ge0(o.rim_height) || o.rim_height > 10) return bad("rim height must be in 0..10");
        if (!finite_ge0(o.rim_max_height)) return bad("rim max height must be a finite number >= 0");
        if (!finite_ge0(o.repose_degrees) || o.repose_degrees > 90) return bad("angle of repose must be in 0..90 degrees");
        if (!(o.compaction >= 0 && o.compaction <= 1)) return bad("compaction must be in 0..1");
        if (!finite_ge0(o.refill_rate)) return bad("refill rate must be a finite number >= 0");
        if (!finite_ge0(o.margin)) return bad("margin must be a finite number >= 0");
        const double upn = std::hypot(o.up[0], o.up[1], o.up[2]);
        if (!(upn > 0) || !std::isfinite(upn)) return bad("up must be a finite non-zero vector");
        if (!positions || !indices || index_count < 3) return Status::error(StatusCode::invalid_input, "the ground has no triangles");

        auto impl = std::make_unique<Impl>();
        impl->opt = o;
        HeightmapFrame f;
        frame_axes(o.up, f.axis_u, f.axis_v, f.up);
        double lo_u = kInf, hi_u = -kInf, lo_v = kInf, hi_v = -kInf;
        for (size_t k = 0; k < index_count; ++k) {
            const uint32_t v = indices[k];
            if (v >= vertex_count) return Status::error(StatusCode::invalid_input, "a ground index is out of range");
            const Vec3 p{positions[3 * size_t(v)], positions[3 * size_t(v) + 1], positions[3 * size_t(v) + 2]};
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                return Status::error(StatusCode::invalid_input, "the ground has a non-finite position");
            const double u = dot(p, d3(f.axis_u)), w = dot(p, d3(f.axis_v));
            lo_u = std::min(lo_u, u), hi_u = std::max(hi_u, u), lo_v = std::min(lo_v, w), hi_v = std::max(hi_v, w);
        }
        lo_u -= o.margin, lo_v -= o.margin, hi_u += o.margin, hi_v += o.margin;
        const double ext = std::max(hi_u - lo_u, hi_v - lo_v);
        if (!(ext > 0)) return Status::error(StatusCode::invalid_input, "the ground has no extent in the plane normal to up");
        f.texel = o.texel > 0 ? o.texel : ext / double(o.resolution - 1);
        const double wd = std::ceil((hi_u - lo_u) / f.texel - 1e-9) + 1, hd = std::ceil((hi_v - lo_v) / f.texel - 1e-9) + 1;
        const double bytes = wd * hd * double(kBytesPerTexel);
        if (!(bytes <= double(o.max_bytes)) || wd > 2e9 || hd > 2e9) {
            char buf[320];
            std::snprintf(buf, sizeof buf,
                          "heightmap of %.0f x %.0f texels (texel %.4g m over %.4g x %.4g m) needs %.0f MiB, more than the %.0f MiB "
                          "limit; use a larger --texel or a smaller --resolution",
                          wd, hd, f.texel, hi_u - lo_u, hi_v - lo_v, bytes / 1048576.0, double(o.max_bytes) / 1048576.0);
            return Status::error(StatusCode::out_of_memory, buf);
        }
        f.width = int(wd), f.height = int(hd);
        f.origin = arr(d3(f.axis_u) * lo_u + d3(f.axis_v) * lo_v);
        const size_t N = size_t(f.width) * size_t(f.height);
        impl->ground.frame = f;
        impl->ground.values.resize(N);
        impl->out.frame = f;
        impl->out.values.assign(N, 0.0f);
        impl->carve.assign(N, 0.0f);
        impl->rim.assign(N, 0.0f);
        impl->tiles_x = (f.width + Impl::kTile - 1) / Impl::kTile;
        impl->tiles_y = (f.height + Impl::kTile - 1) / Impl::kTile;
        impl->carve_tiles.assign(size_t(impl->tiles_x) * size_t(impl->tiles_y), 0);
        impl->out_tiles = impl->rim_tiles = impl->carve_tiles;
        impl->carve_box.assign(impl->carve_tiles.size(), TexelRect{});
        impl->overhangs = rasterize_ground(impl->ground.values.data(), f, positions, vertex_count, indices, index_count);
        bool any = false;
        for (float g : impl->ground.values)
            if (!std::isnan(g)) {
                any = true;
                break;
            }
        if (!any) return Status::error(StatusCode::invalid_input, "no ground triangle covers a texel (the ground is edge-on to up?)");
        impl->rays.build(positions, vertex_count, indices, index_count);
        impl_ = std::move(impl);
        return Status::success();
    });
}

Status SnowField::set_base(const Heightmap& b) {
    return kernel::no_throw("setting the base heightmap", [&]() -> Status {
        Impl& m = *impl_;
        if (m.ground.values.empty()) return Status::error(StatusCode::invalid_argument, "create() the field first");
        if (m.stamped) return Status::error(StatusCode::invalid_argument, "set_base() must come before the first stamp");
        const int bw = b.frame.width, bh = b.frame.height;
        if (bw <= 0 || bh <= 0 || b.values.size() != size_t(bw) * size_t(bh))
            return Status::error(StatusCode::invalid_input, "the base heightmap is empty or its size does not match its frame");
        const HeightmapFrame& f = m.ground.frame;
        m.base.assign(m.carve.size(), 0.0f);
        tbb::parallel_for(tbb::blocked_range<int>(0, f.height, 16), [&](const tbb::blocked_range<int>& r) {
            for (int j = r.begin(); j != r.end(); ++j)
                for (int i = 0; i < f.width; ++i) {
                    double v;
                    if (b.frame.texel > 0) {
                        const Vec3 p = d3(f.origin) + d3(f.axis_u) * (i * f.texel) + d3(f.axis_v) * (j * f.texel);
                        const double q[3] = {p.x, p.y, p.z};
                        v = b.sample_world(q);
                    } else { // no frame: stretched over this grid
                        v = b.sample(f.width > 1 ? double(i) * (bw - 1) / (f.width - 1) : 0.0,
                                     f.height > 1 ? double(j) * (bh - 1) / (f.height - 1) : 0.0);
                    }
                    const size_t x = size_t(j) * size_t(f.width) + size_t(i);
                    if (std::isnan(m.ground.values[x])) v = 0;
                    m.base[x] = float(v);
                    m.carve[x] = float(v);
                }
        });
        m.all_dirty = true;
        m.content = m.full();
        return Status::success();
    });
}

namespace {

struct Job {
    const Collider* collider = nullptr;
    LocalPose p0, p1;
    double decay = 1;
    double share = 1; // the part of its path segment (stamp_sweep's caps are per segment)
};

} // namespace

// Turns samples into stamp jobs: heading and time per sample, contact rays, refill sub-steps (collect_jobs,
// below: every collider's samples, all their contact rays in one parallel loop, then the jobs in order).
struct Sampled {
    std::vector<LocalPose> lp;
    std::vector<SnowField::Impl::Contact> hits;
};
static void locals_of(const SnowField::Impl& m, const std::vector<ColliderPose>& poses, Sampled& s) {
    s.lp.resize(poses.size());
    s.hits.resize(poses.size());
    for (size_t k = 0; k < poses.size(); ++k) s.lp[k] = m.local(poses[k]);
}
static void jobs_of(const SnowField::Impl& m, const Collider& c, const std::vector<ColliderPose>& poses, Sampled& s,
                    std::vector<Job>& jobs, StampStats& st) {
    const size_t n = poses.size();
    std::vector<LocalPose>& lp = s.lp;
    const std::vector<SnowField::Impl::Contact>& hits = s.hits;
    for (size_t k = 0; k < n; ++k) {
        ++st.samples;
        ++st.rays;
        if (!hits[k].hit) ++st.missed_rays;
        if (hits[k].touching) {
            ++st.contacts;
            st.deepest = std::max(st.deepest, hits[k].penetration);
        }
        lp[k].penetration = std::max(0.0, hits[k].penetration);
    }
    const double rate = m.opt.refill_rate;
    auto decay_at = [&](double t) { return rate > 0 ? std::exp(-rate * std::max(0.0, m.now - t)) : 1.0; };
    auto add = [&](const LocalPose& a, const LocalPose& b, double ta, double tb) {
        int steps = 1;
        if (rate > 0) steps = clamped_int(std::ceil(rate * (tb - ta) / 0.005), 1, 10000);
        for (int k = 0; k < steps; ++k) {
            const double f0 = double(k) / steps, f1 = double(k + 1) / steps;
            auto lerp = [&](double f) {
                return LocalPose{a.u + (b.u - a.u) * f, a.v + (b.v - a.v) * f, a.w + (b.w - a.w) * f,
                                 a.heading + (b.heading - a.heading) * f, a.penetration + (b.penetration - a.penetration) * f};
            };
            jobs.push_back({&c, lerp(f0), lerp(f1), decay_at(ta + (tb - ta) * f1), 1.0 / steps});
        }
    };
    if (n == 1) {
        if (hits[0].touching) add(lp[0], lp[0], poses[0].time, poses[0].time);
        return;
    }
    for (size_t k = 1; k < n; ++k)
        if (hits[k - 1].touching || hits[k].touching) add(lp[k - 1], lp[k], poses[k - 1].time, poses[k].time);
}
// The jobs of shapes[i] over its samples poses[i], for every i in order: what stamping them one call at a
// time makes, in the same order, with every sample's contact ray cast in one parallel loop.
static void collect_jobs(const SnowField::Impl& m, const std::vector<const Collider*>& shapes,
                         const std::vector<std::vector<ColliderPose>>& poses, std::vector<Job>& jobs, StampStats& st) {
    std::vector<Sampled> sampled(shapes.size());
    std::vector<std::pair<uint32_t, uint32_t>> rays; // (shape, sample)
    for (size_t i = 0; i < shapes.size(); ++i) {
        locals_of(m, poses[i], sampled[i]);
        for (size_t k = 0; k < poses[i].size(); ++k) rays.emplace_back(uint32_t(i), uint32_t(k));
    }
    tbb::parallel_for(size_t(0), rays.size(), [&](size_t r) {
        const auto [i, k] = rays[r];
        sampled[i].hits[k] = m.contact(*shapes[i], sampled[i].lp[k]);
    });
    for (size_t i = 0; i < shapes.size(); ++i) jobs_of(m, *shapes[i], poses[i], sampled[i], jobs, st);
}

// An image collider stamps its decoded brush: without one it is refused (the caller decodes the file).
static Status stampable(const Collider& c) {
    if (c.shape == ColliderShape::image && !c.brush)
        return Status::error(StatusCode::invalid_input, c.name + ": image collider without a decoded brush");
    return Status::success();
}

static StampStats run_jobs(SnowField::Impl& m, const std::vector<Job>& jobs, StampStats st) {
    if (jobs.empty()) return st;
    StampTarget T;
    T.carve = m.carve.data();
    T.ground = m.ground.values.data();
    T.width = m.ground.frame.width, T.height = m.ground.frame.height;
    T.texel = m.ground.frame.texel;
    T.snow_depth = m.opt.snow_depth;
    std::vector<StampResult> res(jobs.size());
    tbb::parallel_for(size_t(0), jobs.size(), [&](size_t k) { res[k] = stamp_sweep(T, *jobs[k].collider, jobs[k].p0, jobs[k].p1, jobs[k].decay, jobs[k].share);
    });
    for (const StampResult& r : res) {
        ++st.stamps;
        st.texels_written += r.written;
        m.mark(m.carve_tiles, r.rect);
        m.mark_box(m.carve_box, r.rect);
        if (!r.rect.empty()) m.stamped_rects.push_back(r.rect);
        if (m.stamped_rects.size() > 4096) { // many stamps between updates: their bounding box (more rim, same bits)
            TexelRect box;
            for (const TexelRect& q : m.stamped_rects) box.unite(q);
            m.stamped_rects.assign(1, box);
        }
        m.content.unite(r.rect);
        m.max_reach = std::max(m.max_reach, r.reach);
    }
    m.stamped = true;
    return st;
}

// Stamps shapes[i] over its samples poses[i], for every i in order (collect_jobs, then run_jobs); *stats (if
// set) receives what it did.
static void stamp_samples(SnowField::Impl& m, const std::vector<const Collider*>& shapes, const std::vector<std::vector<ColliderPose>>& poses,
                          StampStats* stats) {
    StampStats st;
    std::vector<Job> jobs;
    collect_jobs(m, shapes, poses, jobs, st);
    st = run_jobs(m, jobs, st);
    if (stats) *stats = st;
}

static double heading_of(const Collider& c, size_t k) {
    if (!c.heading.empty()) return c.heading.size() == 1 ? c.heading[0] : c.heading[k];
    const size_t n = c.path.size();
    if (n < 2) return 0.0;
    // Path direction: previous → next point (one-sided at the ends), its component in the ground plane is
    // measured by the caller's frame; here in world x/z is not enough for any up, so the frame does it.
    return std::numeric_limits<double>::quiet_NaN();
}

// `h` moved by whole turns to within 180 degrees of `reference`, so that interpolating turns the short way
// (exactly ±180 keeps the sign of the difference). Subtracting 360 in a loop never ended for a heading of
// 1e30, where h − 360 == h (found by fuzz_stamp): std::remainder is exact for any finite value.
static double unwrap_heading(double h, double reference) {
    const double d = h - reference;
    if (!(std::abs(d) > 180)) return h; // also NaN
    double r = std::remainder(d, 360.0);
    if (std::abs(r) == 180) r = std::copysign(180.0, d);
    return reference + r;
}

static std::vector<ColliderPose> poses_of(const SnowField::Impl& m, const Collider& c) {
    std::vector<ColliderPose> poses;
    const size_t n = c.path.size();
    const HeightmapFrame& f = m.ground.frame;
    auto planar = [&](const std::array<double, 3>& p) { return std::array<double, 2>{dot(d3(p), d3(f.axis_u)), dot(d3(p), d3(f.axis_v))}; };
    double last_heading = 0;
    std::vector<double> headings(n);
    for (size_t k = 0; k < n; ++k) {
        double h = heading_of(c, k);
        if (std::isnan(h)) {
            const auto a = planar(c.path[k == 0 ? 0 : k - 1]), b = planar(c.path[k + 1 == n ? k : k + 1]);
            const double du = b[0] - a[0], dv = b[1] - a[1];
            h = (du * du + dv * dv > 1e-24) ? std::atan2(du, dv) * 180.0 / kPi : last_heading;
        }
        // Unwrapped, so that interpolating between samples turns the short way.
        if (k > 0) h = unwrap_heading(h, last_heading);
        headings[k] = last_heading = h;
    }
    for (size_t k = 0; k < n; ++k) {
        const double t = c.time.empty() ? 0.0 : c.time[k];
        if (t > m.now) {
            if (k > 0) { // the segment that crosses now(): swept up to it
                const double t0 = c.time[k - 1];
                const double a = (m.now - t0) / (t - t0);
                ColliderPose p;
                for (int d = 0; d < 3; ++d) p.centre[size_t(d)] = c.path[k - 1][size_t(d)] + a * (c.path[k][size_t(d)] - c.path[k - 1][size_t(d)]);
                p.heading_degrees = headings[k - 1] + a * (headings[k] - headings[k - 1]);
                p.time = m.now;
                if (a > 0) poses.push_back(p);
            }
            break;
        }
        poses.push_back({c.path[k], headings[k], t});
    }
    return poses;
}

Status SnowField::add_collider(const Collider& c, StampStats* stats) {
    return kernel::no_throw("stamping", [&]() -> Status {
        ColliderSet one;
        one.up = impl_->opt.up;
        one.colliders.push_back(c);
        return add_colliders(one, stats);
    });
}

Status SnowField::add_colliders(const ColliderSet& set, StampStats* stats) {
    return kernel::no_throw("stamping", [&]() -> Status {
        Impl& m = *impl_;
        if (m.ground.values.empty()) return Status::error(StatusCode::invalid_argument, "create() the field first");
        std::vector<const Collider*> shapes;
        std::vector<std::vector<ColliderPose>> poses;
        for (const Collider& c : set.colliders) {
            if (Status s = stampable(c); !s.ok()) return s;
            shapes.push_back(&c);
            poses.push_back(poses_of(m, c));
        }
        stamp_samples(m, shapes, poses, stats);
        return Status::success();
    });
}

// A runtime stamp's samples: the pose, or the sweep from `previous` to it, turning the short way.
static std::vector<ColliderPose> runtime_poses(const ColliderPose& pose, const ColliderPose* previous) {
    std::vector<ColliderPose> poses;
    if (previous) poses.push_back(*previous);
    poses.push_back(pose);
    if (previous) {
        double& h = poses[1].heading_degrees;
        h = unwrap_heading(h, poses[0].heading_degrees);
    }
    return poses;
}

Status SnowField::stamp(const Collider& shape, const ColliderPose& pose, const ColliderPose* previous, StampStats* stats) {
    const StampRequest one{&shape, pose, previous};
    return stamp(&one, 1, stats);
}

Status SnowField::stamp(const StampRequest* requests, size_t count, StampStats* stats) {
    return kernel::no_throw("stamping", [&]() -> Status {
        Impl& m = *impl_;
        if (m.ground.values.empty()) return Status::error(StatusCode::invalid_argument, "create() the field first");
        if (count > 0 && !requests) return Status::error(StatusCode::invalid_argument, "no requests");
        for (size_t i = 0; i < count; ++i) {
            const Collider* c = requests[i].shape;
            if (!c) return Status::error(StatusCode::invalid_argument, "request " + std::to_string(i) + " has no shape");
            if (Status s = stampable(*c); !s.ok()) return s;
        }
        // The jobs in request order: those stamp() makes one call at a time, in the same order (run_jobs'
        // dirty rectangles too).
        std::vector<const Collider*> shapes(count);
        std::vector<std::vector<ColliderPose>> poses(count);
        for (size_t i = 0; i < count; ++i) shapes[i] = requests[i].shape, poses[i] = runtime_poses(requests[i].pose, requests[i].previous);
        stamp_samples(m, shapes, poses, stats);
        return Status::success();
    });
}

void SnowField::set_time(double t) {
    Impl& m = *impl_;
    if (!(t > m.now)) return;
    if (m.opt.refill_rate > 0 && !m.content.empty()) {
        const float f = float(std::exp(-m.opt.refill_rate * (t - m.now)));
        const int W = m.ground.frame.width;
        const TexelRect c = m.content;
        tbb::parallel_for(c.y0, c.y1, [&](int j) {
            for (int i = c.x0; i < c.x1; ++i) {
                const size_t x = size_t(j) * size_t(W) + size_t(i);
                m.carve[x] *= f;
                m.rim[x] *= f;
                m.out.values[x] *= f;
                if (!m.base.empty()) m.base[x] *= f;
            }
        });
        m.mark(m.out_tiles, c);
        m.volumes_valid = false;
    }
    m.now = t;
}

double SnowField::now() const { return impl_->now; }

// Disjoint rectangles covering the tiles' boxes: runs along a tile row of boxes that touch with the same rows,
// merged with identical runs on the next rows (whole tiles merge as whole-tile rectangles).
static std::vector<TexelRect> box_rects(const std::vector<TexelRect>& boxes, int tx, int ty) {
    std::vector<TexelRect> out;
    std::vector<TexelRect> open; // runs of the previous tile row, extendable downwards
    for (int y = 0; y < ty; ++y) {
        std::vector<TexelRect> row;
        for (int x = 0; x < tx; ++x) {
            const TexelRect& b = boxes[size_t(y) * size_t(tx) + size_t(x)];
            if (b.empty()) continue;
            if (!row.empty() && row.back().x1 == b.x0 && row.back().y0 == b.y0 && row.back().y1 == b.y1) row.back().x1 = b.x1;
            else row.push_back(b);
        }
        std::vector<TexelRect> next;
        for (TexelRect r : row) {
            bool merged = false;
            for (TexelRect& o : open)
                if (o.x0 == r.x0 && o.x1 == r.x1 && o.y1 == r.y0) {
                    o.y1 = r.y1;
                    next.push_back(o);
                    o.x1 = o.x0; // consumed
                    merged = true;
                    break;
                }
            if (!merged) next.push_back(r);
        }
        for (const TexelRect& o : open)
            if (!o.empty()) out.push_back(o);
        open = std::move(next);
    }
    for (const TexelRect& o : open) out.push_back(o);
    std::sort(out.begin(), out.end(), [](const TexelRect& a, const TexelRect& b) { return std::tie(a.y0, a.x0) < std::tie(b.y0, b.x0); });
    return out;
}

static RimInput rim_input(const SnowField::Impl& m) {
    const HeightmapFrame& f = m.ground.frame;
    RimInput in;
    in.carve = m.carve.data();
    in.base = m.base.empty() ? nullptr : m.base.data();
    in.ground = m.ground.values.data();
    in.width = f.width, in.height = f.height;
    in.texel = f.texel;
    in.width_m = m.rim_width();
    in.gather_m = m.max_reach;
    in.height_ratio = m.opt.rim_height;
    in.conserve = m.opt.conserve_volume;
    in.compaction = m.opt.compaction;
    in.max_height = m.opt.rim_max_height;
    in.max_slope_degrees = m.opt.repose_degrees;
    in.max_width_m = m.rim_max_width();
    return in;
}

// Volume-conserving rim: the stamped tiles grown by the rim's reach and gathering radius form regions, each
// recomputed on its own so that it balances its own removed and raised volume (`region` receives the tiles).
static void update_conserving_rim(SnowField::Impl& m, std::vector<uint8_t>& region, SnowUpdateStats& st) {
    const HeightmapFrame& f = m.ground.frame;
    const int T = SnowField::Impl::kTile, TX = m.tiles_x, TY = m.tiles_y;
    // A reach beyond the grid covers all of it: capped there before it can overflow an int.
    const int pad = clamped_int(std::ceil((m.rim_max_width() + m.max_reach) / f.texel), 0, std::max(f.width, f.height)) + 2;
    const int tp = (pad + T - 1) / T;
    for (int y = 0; y < TY; ++y)
        for (int x = 0; x < TX; ++x) {
            if (!m.carve_tiles[size_t(y) * size_t(TX) + size_t(x)]) continue;
            for (int yy = std::max(0, y - tp); yy <= std::min(TY - 1, y + tp); ++yy)
                for (int xx = std::max(0, x - tp); xx <= std::min(TX - 1, x + tp); ++xx) region[size_t(yy) * size_t(TX) + size_t(xx)] = 1;
        }
    // Connected regions (8-connected tiles), each with its window (bounding box + margin); regions whose
    // windows overlap are merged, so that no texel is computed twice and each computation owns whole rims.
    struct Group {
        TexelRect window;
        std::vector<size_t> tiles;
    };
    std::vector<Group> groups;
    std::vector<uint8_t> seen(region.size(), 0);
    for (size_t s0 = 0; s0 < region.size(); ++s0) {
        if (!region[s0] || seen[s0]) continue;
        Group gr;
        std::vector<size_t> stack{s0};
        seen[s0] = 1;
        TexelRect box;
        while (!stack.empty()) {
            const size_t c = stack.back();
            stack.pop_back();
            gr.tiles.push_back(c);
            const int cx = int(c % size_t(TX)), cy = int(c / size_t(TX));
            box.unite({cx * T, cy * T, std::min(f.width, (cx + 1) * T), std::min(f.height, (cy + 1) * T)});
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int nx = cx + dx, ny = cy + dy;
                    if (nx < 0 || ny < 0 || nx >= TX || ny >= TY) continue;
                    const size_t nb = size_t(ny) * size_t(TX) + size_t(nx);
                    if (region[nb] && !seen[nb]) seen[nb] = 1, stack.push_back(nb);
                }
        }
        gr.window = {std::max(0, box.x0 - pad), std::max(0, box.y0 - pad), std::min(f.width, box.x1 + pad), std::min(f.height, box.y1 + pad)};
        groups.push_back(std::move(gr));
    }
    auto overlap = [](const TexelRect& a, const TexelRect& b) { return a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1; };
    for (bool merged = true; merged;) {
        merged = false;
        for (size_t a = 0; a < groups.size() && !merged; ++a)
            for (size_t b = a + 1; b < groups.size(); ++b)
                if (overlap(groups[a].window, groups[b].window)) {
                    groups[a].window.unite(groups[b].window);
                    groups[a].tiles.insert(groups[a].tiles.end(), groups[b].tiles.begin(), groups[b].tiles.end());
                    groups.erase(groups.begin() + long(b));
                    merged = true;
                    break;
                }
    }
    std::vector<uint8_t> own(region.size(), 0);
    const RimInput in = rim_input(m);
    for (const Group& gr : groups) {
        for (size_t c : gr.tiles) own[c] = 1;
        m.lost_rim += compute_rim(m.rim.data(), in, gr.window, RimOwner{own.data(), TX, T}, gr.window);
        ++st.rim_windows;
        st.rim_texels += gr.tiles.size() * size_t(T) * size_t(T);
        for (size_t c : gr.tiles) own[c] = 0;
        m.content.unite(gr.window);
    }
}

// Cosmetic rim, incrementally: a rim texel depends only on the carve within rim_reach of it (exact, ordered
// sums), so only the tiles within that reach of a stamped rectangle change, and each is recomputed from a
// window holding its reach: the same bits as recomputing the whole field. The tiles are gathered per band
// of four tile rows into runs of columns (runs whose windows would overlap merged), one window per run.
// Only the texels whose rim came out different in bits join the output's changed region (per tile, their
// bounding box, in `boxes`): the reach is a bound, and most of it lies where no older imprint is near.
static void update_local_rim(SnowField::Impl& m, std::vector<TexelRect>& boxes, SnowUpdateStats& st) {
    const HeightmapFrame& f = m.ground.frame;
    const int T = SnowField::Impl::kTile, TX = m.tiles_x, TY = m.tiles_y;
    const int reach = m.rim_reach;
    std::vector<uint8_t>& rim_tiles = m.rim_tiles;
    std::fill(rim_tiles.begin(), rim_tiles.end(), 0);
    m.rim_box.assign(rim_tiles.size(), TexelRect{});
    for (const TexelRect& r : m.stamped_rects)
        m.mark(rim_tiles, {std::max(0, r.x0 - reach), std::max(0, r.y0 - reach), std::min(f.width, r.x1 + reach), std::min(f.height, r.y1 + reach)});
    RimInput in = rim_input(m);
    std::vector<TexelRect> outs; // the texels each window writes
    const int band = 64 / T, gap = (2 * reach + T - 1) / T; // bands of 64 texel rows
    for (int b0 = 0; b0 < TY; b0 += band) {
        const int b1 = std::min(TY, b0 + band);
        auto column_dirty = [&](int x, int& y_lo, int& y_hi) {
            for (int y = b0; y < b1; ++y)
                if (rim_tiles[size_t(y) * size_t(TX) + size_t(x)]) y_lo = std::min(y_lo, y), y_hi = std::max(y_hi, y + 1);
        };
        for (int x = 0; x < TX;) {
            int y_lo = b1, y_hi = b0;
            column_dirty(x, y_lo, y_hi);
            if (y_hi <= y_lo) {
                ++x;
                continue;
            }
            int e = x + 1, last = x;
            for (; e < TX && e - last <= gap + 1; ++e) { // extend while the next dirty column is near
                int lo = b1, hi = b0;
                column_dirty(e, lo, hi);
                if (hi > lo) last = e, y_lo = std::min(y_lo, lo), y_hi = std::max(y_hi, hi);
            }
            const TexelRect out{x * T, y_lo * T, std::min(f.width, (last + 1) * T), std::min(f.height, y_hi * T)};
            outs.push_back(out);
            x = last + 1;
        }
    }
    // The windows write disjoint texels and each is computed alone: in parallel, one thread per window.
    in.parallel = false;
    tbb::parallel_for(size_t(0), outs.size(), [&](size_t k) {
        const TexelRect& out = outs[k];
        const TexelRect win{std::max(0, out.x0 - reach), std::max(0, out.y0 - reach), std::min(f.width, out.x1 + reach),
                            std::min(f.height, out.y1 + reach)};
        compute_rim(m.rim.data(), in, win, RimOwner{rim_tiles.data(), TX, T, m.rim_box.data()}, out); // loses nothing
    });
    for (const TexelRect& out : outs) m.content.unite(out);
    st.rim_windows += outs.size();
    for (size_t k = 0; k < boxes.size(); ++k) { // the output changes where the rim did
        boxes[k].unite(m.rim_box[k]);
        if (rim_tiles[k]) st.rim_texels += size_t(T) * size_t(T);
    }
}

std::vector<TexelRect> SnowField::update(SnowUpdateStats* stats) {
    Impl& m = *impl_;
    if (m.ground.values.empty()) return {};
    using clock = std::chrono::steady_clock;
    const auto t0 = clock::now();
    const HeightmapFrame& f = m.ground.frame;
    const int TX = m.tiles_x, TY = m.tiles_y;
    const double rw = m.rim_width();
    const bool local_rim = rw > 0 && !m.opt.conserve_volume;
    if (local_rim) { // another reach (a larger collider) changes the rim around every imprint
        const int reach = rim_reach(rw, m.max_reach, f.texel);
        if (reach != m.rim_reach && !m.content.empty()) m.stamped_rects.push_back(m.content);
        m.rim_reach = reach;
    }
    if (m.all_dirty) {
        std::fill(m.carve_tiles.begin(), m.carve_tiles.end(), 1);
        m.stamped_rects.assign(1, m.full());
    }
    // Per tile, the texels whose output is recomputed: deepened, rim changed (a conserving rim's whole region).
    std::vector<TexelRect> boxes = m.carve_box;
    if (m.all_dirty)
        for (size_t k = 0; k < boxes.size(); ++k) boxes[k] = m.tile_rect(k);
    SnowUpdateStats st;
    if (local_rim) update_local_rim(m, boxes, st);
    else if (rw > 0) {
        std::vector<uint8_t> region = m.carve_tiles;
        update_conserving_rim(m, region, st);
        for (size_t k = 0; k < region.size(); ++k)
            if (region[k]) boxes[k] = m.tile_rect(k);
    }
    const auto t1 = clock::now();
    const std::vector<TexelRect> rects = box_rects(boxes, TX, TY);
    tbb::parallel_for(size_t(0), rects.size(), [&](size_t k) { // disjoint rectangles
        const TexelRect& A = rects[k];
        for (int j = A.y0; j < A.y1; ++j)
            for (int i = A.x0; i < A.x1; ++i) {
                const size_t x = size_t(j) * size_t(f.width) + size_t(i);
                m.out.values[x] = m.carve[x] + m.rim[x];
            }
    });
    if (!rects.empty()) m.volumes_valid = false;
    for (size_t k = 0; k < boxes.size(); ++k) // refill changed the whole tile
        if (m.out_tiles[k]) boxes[k] = m.tile_rect(k);
    std::fill(m.carve_tiles.begin(), m.carve_tiles.end(), 0);
    std::fill(m.carve_box.begin(), m.carve_box.end(), TexelRect{});
    std::fill(m.out_tiles.begin(), m.out_tiles.end(), 0);
    m.stamped_rects.clear();
    m.all_dirty = false;
    std::vector<TexelRect> changed = box_rects(boxes, TX, TY);
    st.rim_seconds = std::chrono::duration<double>(t1 - t0).count();
    st.output_seconds = std::chrono::duration<double>(clock::now() - t1).count();
    if (stats) *stats = st;
    return changed;
}

const Heightmap& SnowField::heightmap() const { return impl_->out; }
const Heightmap& SnowField::ground() const { return impl_->ground; }
const HeightmapFrame& SnowField::frame() const { return impl_->ground.frame; }
size_t SnowField::overhang_triangles() const { return impl_->overhangs; }

static void volumes(const SnowField::Impl& m) {
    if (m.volumes_valid) return;
    double removed = 0, raised = 0;
    const size_t N = m.carve.size();
    for (size_t x = 0; x < N; ++x) {
        const double b = m.base.empty() ? 0.0 : double(m.base[x]);
        removed += std::max(0.0, b - double(m.carve[x]));
        raised += double(m.rim[x]);
    }
    const double a = m.ground.frame.texel * m.ground.frame.texel;
    m.removed = removed * a, m.raised = raised * a;
    m.volumes_valid = true;
}

double SnowField::removed_volume() const {
    volumes(*impl_);
    return impl_->removed;
}
double SnowField::raised_volume() const {
    volumes(*impl_);
    return impl_->raised;
}

void SnowField::cast_down(double* out, const double* points, size_t count) const {
    const Impl& m = *impl_;
    const Vec3 up = d3(m.ground.frame.up);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
            const Vec3 o{points[3 * k], points[3 * k + 1], points[3 * k + 2]};
            const double t = m.rays.first_hit(o, up * -1.0);
            out[k] = std::isnan(t) ? t : dot(o, up) - t;
        }
    });
}

} // namespace furrow

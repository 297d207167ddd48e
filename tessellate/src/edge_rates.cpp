// Tessellation rates per edge: the criteria of RateOptions, each computed once per edge of the welded mesh.
//
//   - distance: Unity's distance-based tessellation (the "seed"; Unity manual, "Surface Shader tessellation",
//     UnityDistanceBasedTess): f = clamp(1 - (d - near)/(far - near), 0.01, 1) * tess per control vertex,
//     an edge takes the mean of its two ends;
//   - pixel_error: Blender Cycles' adaptive subdivision / DiagSplit (Fisher et al. 2009): T = ceil(projected
//     length / dicing rate), the projected length measured along the limit curve of the edge (4 segments);
//   - max_error / screen_error: linear interpolation of a function with second derivative D along a segment
//     of parametric length h errs by |D| h^2 / 8 at the midpoint, and on a triangle by at most 1/6 of the
//     largest |e^T H e| over its edges e (at the centroid). Second derivatives come from Bfr at the points of a
//     rate-3 probe of every face. Quads (and the quad sub-faces of n-gons) are cut into cells of h_u x h_v
//     split along a diagonal (error (Duu h_u^2 +- 2 Duv h_u h_v + Dvv h_v^2) / 8); R_u and R_v are chosen per
//     face to minimise R_u R_v with all four directions within e (quad_need). Loop triangles take the lattice
//     directions of Bfr's patterns and the medians of its transition corners (triangle_need). Each edge takes
//     the most demanding face beside it, along its own direction, so a cylinder stays anisotropic on quads;
//     screen_error divides by the eye distance of each probe (error in pixels = error x focal / distance);
//   - focus points, a per-vertex array and a per-edge callback for callers with their own detail measure.
// Everything here depends on one edge's data and its two faces only, and each edge's rate is one number
// shared by both faces: no T-junction can appear (DiagSplit's argument).
#include "tessellate_internal.h"

#include <opensubdiv/bfr/tessellation.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <numbers>
#include <string>

namespace furrow::tessellate_detail {
namespace {

constexpr double pi = std::numbers::pi;

bool finite3(const std::array<double, 3>& v) {
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}


double focal_pixels(const TessellationCamera& c) {
    return 0.5 * double(c.viewport_height) / std::tan(0.5 * c.fov_degrees * pi / 180.0);
}

double segment_distance(const std::array<double, 3>& p, const std::array<double, 3>& a, const std::array<double, 3>& b) {
    std::array<double, 3> ab{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ap{p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    double l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    double t = l2 > 0 ? std::clamp((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / l2, 0.0, 1.0) : 0.0;
    return distance3(p, {a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]});
}

// Second derivatives at one probe point, in world space, and the pixels per world unit there.
struct CurvatureSample {
    int tile;
    std::array<double, 3> uu, uv, vv;
    double pixel_scale;
};

std::array<double, 3> combine(const std::array<double, 3>& a, double x, const std::array<double, 3>& b, double y,
                              const std::array<double, 3>& c, double z) {
    return {a[0] * x + b[0] * y + c[0] * z, a[1] * x + b[1] * y + c[1] * z, a[2] * x + b[2] * y + c[2] * z};
}

// e * R^2 for a Loop triangle: |D| / 8 at the midpoints of segments along the three lattice directions of
// Bfr's triangle patterns ((1,0), (0,1), (1,-1)) and along the medians its non-uniform patterns use to join
// each corner to the inner ring ((1,1), (-2,1), (1,-2)); and (1/18) |sum of the edge terms| at the centroids
// of the two lattice triangles, |Duu + Dvv -+ Duv| / 9.
double triangle_need(const CurvatureSample& s) {
    return std::max({length3(s.uu) / 8, length3(s.vv) / 8, length3(combine(s.uu, 1, s.uv, -2, s.vv, 1)) / 8,
                     length3(combine(s.uu, 1, s.uv, 2, s.vv, 1)) / 8, length3(combine(s.uu, 4, s.uv, -4, s.vv, 1)) / 8,
                     length3(combine(s.uu, 1, s.uv, -4, s.vv, 4)) / 8, length3(combine(s.uu, 1, s.uv, -1, s.vv, 1)) / 9,
                     length3(combine(s.uu, 1, s.uv, 1, s.vv, 1)) / 9});
}

// e * R_u^2 and e * R_v^2 for the quad cells of one tile: with R_v = rho R_u the four directional errors
// (u, v and both diagonals, |D| h^2 / 8) scale with 1 / R_u^2, so for each aspect rho the smallest R_u is
// known; rho is chosen among powers of 2^(1/4) to minimise R_u R_v (the cell count).
std::array<double, 2> quad_need(const std::vector<CurvatureSample>& samples, int tile, bool pixels) {
    double best_cost = -1;
    std::array<double, 2> best{0, 0};
    for (int i = 0; i <= 48; ++i) { // k = 0, 1, -1, 2, -2, ...: ties go to the aspect nearest 1
        const int k = (i + 1) / 2 * (i % 2 ? 1 : -1);
        const double rho = std::exp2(k / 4.0), r2 = 1.0 / (rho * rho);
        double a = 0;
        for (const auto& s : samples) {
            if (s.tile != tile) continue;
            const double worst =
                std::max({length3(s.uu), length3(s.vv) * r2, length3(combine(s.uu, 1, s.uv, 2 / rho, s.vv, r2)),
                          length3(combine(s.uu, 1, s.uv, -2 / rho, s.vv, r2))});
            a = std::max(a, (pixels ? s.pixel_scale : 1.0) * worst / 8.0);
        }
        if (best_cost < 0 || rho * a < best_cost * (1 - 1e-9)) {
            best_cost = rho * a;
            best = {a, rho * rho * a};
        }
    }
    return best;
}

// The limit surface's curvature is unbounded at extraordinary vertices, and the deeper Bfr approximates it
// (SurfaceOptions::accuracy) the larger the second derivatives it reports right at such a corner. Probes are
// therefore pulled 10% towards the inside of the face (of its sub-face for n-gons), where they measure the
// curvature the triangles there actually span.
void pull_inside(const osd::Bfr::Parameterization& p, const float* in, float* out) {
    constexpr float keep = 0.9f;
    switch (p.GetType()) {
    case osd::Bfr::Parameterization::QUAD:
        out[0] = 0.5f + keep * (in[0] - 0.5f);
        out[1] = 0.5f + keep * (in[1] - 0.5f);
        return;
    case osd::Bfr::Parameterization::TRI:
        out[0] = 1.0f / 3 + keep * (in[0] - 1.0f / 3);
        out[1] = 1.0f / 3 + keep * (in[1] - 1.0f / 3);
        return;
    case osd::Bfr::Parameterization::QUAD_SUBFACES: {
        float st[2];
        const int sub = p.ConvertCoordToNormalizedSubFace(in, st);
        st[0] = 0.5f + keep * (std::clamp(st[0], 0.0f, 1.0f) - 0.5f);
        st[1] = 0.5f + keep * (std::clamp(st[1], 0.0f, 1.0f) - 0.5f);
        p.ConvertNormalizedSubFaceToCoord(sub, st, out);
        return;
    }
    }
    out[0] = in[0];
    out[1] = in[1];
}

// What the probe of one face contributes to the edges of that face.
struct SideProbe {
    double need_world = 0; // max |C''| along the edge, world units
    double need_pixels = 0; // max |C''| * focal / distance
    double length_pixels = 0; // projected length along the limit curve (owner side only)
};

const float* point_pos(const PreparedMesh& m, uint32_t p) { return &m.welded_data[size_t(m.point_welded[p]) * size_t(m.W)]; }

std::array<double, 3> world(const Mat4& M, const float* p) {
    double d[3] = {p[0], p[1], p[2]};
    return kernel::transform_point(M, d);
}

// The criteria measured on the control mesh alone: uniform rate, distance, focus points, per-vertex rates
// and the edge hook.
void control_mesh_criteria(std::vector<double>& out, const PreparedMesh& m, const RateOptions& r,
                           const std::vector<Mat4>& inst) {
    const size_t E = m.edges.size();
    const double max_rate = r.max_rate;

    if (r.uniform > 0)
        for (auto& x : out) x = std::max(x, double(r.uniform));

    if (r.distance) {
        std::vector<double> factor(m.point_welded.size(), 0.0);
        for (size_t p = 0; p < factor.size(); ++p)
            for (const auto& M : inst) {
                double d = distance3(world(M, point_pos(m, uint32_t(p))), r.camera->eye);
                double f = std::clamp(1.0 - (d - r.near) / (r.far - r.near), 0.01, 1.0) * max_rate;
                factor[p] = std::max(factor[p], f);
            }
        for (size_t e = 0; e < E; ++e) out[e] = std::max(out[e], 0.5 * (factor[m.edges[e][0]] + factor[m.edges[e][1]]));
    }

    for (const auto& fp : r.focus) {
        const double rate = fp.rate > 0 ? double(fp.rate) : max_rate;
        for (size_t e = 0; e < E; ++e)
            for (const auto& M : inst) {
                double d = segment_distance(fp.centre, world(M, point_pos(m, m.edges[e][0])), world(M, point_pos(m, m.edges[e][1])));
                out[e] = std::max(out[e], std::clamp(2.0 - d / fp.radius, 0.0, 1.0) * rate);
            }
    }

    if (r.vertex_rates)
        for (size_t e = 0; e < E; ++e) {
            const uint32_t c = m.side_corner[m.edge_owner[e]];
            double v = std::max(r.vertex_rates[m.corner_input[c]], r.vertex_rates[m.corner_input[m.next_corner(c)]]);
            if (std::isfinite(v)) out[e] = std::max(out[e], v);
        }

    if (r.edge_rate) {
        std::vector<double> hook(E, 0.0);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, E, 1024), [&](const tbb::blocked_range<size_t>& range) {
            for (size_t e = range.begin(); e != range.end(); ++e)
                hook[e] = r.edge_rate(point_pos(m, m.edges[e][0]), point_pos(m, m.edges[e][1]));
        });
        for (size_t e = 0; e < E; ++e)
            if (std::isfinite(hook[e])) out[e] = std::max(out[e], hook[e]);
    }
}

// What the probes of all faces share: the view, and their results per side.
struct Probes {
    const PreparedMesh& m;
    const RateOptions& r;
    const std::vector<Mat4>& inst;
    bool probe_curvature;
    double focal;
    std::array<double, 3> eye;
    double min_distance;
    std::vector<SideProbe> side;
};

Probes make_probes(const PreparedMesh& m, const RateOptions& r, const std::vector<Mat4>& inst, bool probe_curvature) {
    const double focal = r.camera ? focal_pixels(*r.camera) : 1.0;
    const std::array<double, 3> eye = r.camera ? r.camera->eye : std::array<double, 3>{0, 0, 0};
    double diag = distance3(m.bbox_min, m.bbox_max);
    double scale = 1.0; // largest instance scale, for the near clamp
    for (const auto& M : inst)
        for (int c = 0; c < 3; ++c)
            scale = std::max(scale, std::sqrt(M[size_t(4 * c)] * M[size_t(4 * c)] + M[size_t(4 * c + 1)] * M[size_t(4 * c + 1)] +
                                              M[size_t(4 * c + 2)] * M[size_t(4 * c + 2)]));
    // An eye on the surface would ask for infinite rates; the cap takes them anyway, this keeps them finite.
    const double min_distance = std::max(1e-4 * diag * scale, 1e-12);
    return Probes{m, r, inst, probe_curvature, focal, eye, min_distance, std::vector<SideProbe>(m.side_corner.size())};
}

// One face's probe: its limit surface (its control polygon for a face tessellated linearly), evaluated with
// the calling thread's buffers.
struct FaceProbe {
    Probes& pr;
    const PreparedMesh& m;
    const uint32_t c0;
    const int n;
    const osd::Bfr::Parameterization param;
    Surface& surface;
    std::vector<float>& patch;
    const bool smooth;

    FaceProbe(Probes& pr, size_t f, Surface& surface, std::vector<float>& patch)
        : pr(pr), m(pr.m), c0(m.face_offset[f]), n(int(m.face_size(f))), param(m.parameterization(f)), surface(surface),
          patch(patch), smooth(m.smooth(f) && m.factory && m.factory_of(f).InitVertexSurface(m.face_refiner[f], &surface)) {
        if (smooth) {
            patch.resize(size_t(surface.GetNumPatchPoints()) * 3);
            surface.PreparePatchPoints(m.refiner_data.data(), Surface::PointDescriptor(3, m.W), patch.data(), 3);
        }
    }
    void eval(const float uv[2], float* P) const;
    void edge_lengths();
    void curvature(std::vector<float>& coords, std::vector<CurvatureSample>& samples);
};

void FaceProbe::eval(const float uv[2], float* P) const {
    if (smooth) {
        surface.Evaluate(uv, patch.data(), 3, P);
    } else {
        float w[64];
        std::vector<float> wv;
        float* wp = w;
        if (n > 64) {
            wv.resize(size_t(n));
            wp = wv.data();
        }
        linear_weights(param, uv, wp);
        P[0] = P[1] = P[2] = 0;
        for (int k = 0; k < n; ++k) {
            const float* q = &m.welded_data[size_t(m.corner_welded[c0 + uint32_t(k)]) * size_t(m.W)];
            for (int j = 0; j < 3; ++j) P[j] += wp[k] * q[j];
        }
    }
}

// Projected length of the owned edges.
void FaceProbe::edge_lengths() {
    for (int k = 0; k < n; ++k) {
        const uint32_t s = m.corner_side[c0 + uint32_t(k)];
        if (m.edge_owner[m.corner_edge[c0 + uint32_t(k)]] != s) continue;
        constexpr int segments = 4;
        float P[segments + 1][3];
        for (int j = 0; j <= segments; ++j) {
            float uv[2];
            param.GetEdgeCoord(k, float(j) / segments, uv);
            eval(uv, P[j]);
        }
        double best = 0;
        for (const auto& M : pr.inst) {
            double len = 0;
            for (int j = 0; j < segments; ++j) {
                double a[3] = {P[j][0], P[j][1], P[j][2]}, b[3] = {P[j + 1][0], P[j + 1][1], P[j + 1][2]};
                auto wa = kernel::transform_point(M, a), wb = kernel::transform_point(M, b);
                std::array<double, 3> mid{0.5 * (wa[0] + wb[0]), 0.5 * (wa[1] + wb[1]), 0.5 * (wa[2] + wb[2])};
                len += distance3(wa, wb) * pr.focal / std::max(distance3(mid, pr.eye), pr.min_distance);
            }
            best = std::max(best, len);
        }
        pr.side[s].length_pixels = best;
    }
}

// Second derivatives at the points of a rate-3 probe, turned into the needs of the face's sides.
void FaceProbe::curvature(std::vector<float>& coords, std::vector<CurvatureSample>& samples) {
    osd::Bfr::Tessellation probe(param, 3);
    coords.resize(size_t(probe.GetNumCoords()) * 2);
    probe.GetCoords(coords.data());
    samples.clear();
    for (int i = 0; i < probe.GetNumCoords(); ++i) {
        float uv[2];
        pull_inside(param, &coords[size_t(i) * 2], uv);
        float P[3], Du[3], Dv[3], Duu[3], Duv[3], Dvv[3];
        surface.Evaluate(uv, patch.data(), 3, P, Du, Dv, Duu, Duv, Dvv);
        const int tile = param.HasSubFaces() ? param.GetSubFace(uv) : 0;
        for (const auto& M : pr.inst) {
            double p[3] = {P[0], P[1], P[2]};
            auto w = [&](const float* v) {
                double d[3] = {v[0], v[1], v[2]};
                return kernel::transform_vector(M, d);
            };
            const double dist = std::max(distance3(kernel::transform_point(M, p), pr.eye), pr.min_distance);
            samples.push_back({tile, w(Duu), w(Duv), w(Dvv), pr.focal / dist});
        }
    }
    auto need = [&](int edge, double world, double pixels) {
        SideProbe& sp = pr.side[m.corner_side[c0 + uint32_t((edge + n) % n)]];
        sp.need_world = std::max(sp.need_world, world);
        sp.need_pixels = std::max(sp.need_pixels, pixels);
    };
    if (param.GetType() == osd::Bfr::Parameterization::TRI) {
        double world = 0, pixels = 0;
        for (const auto& sm : samples) {
            const double a = triangle_need(sm);
            world = std::max(world, a);
            pixels = std::max(pixels, a * sm.pixel_scale);
        }
        for (int k = 0; k < 3; ++k) need(k, world, pixels);
    } else {
        const int tiles = param.HasSubFaces() ? n : 1;
        for (int tile = 0; tile < tiles; ++tile) {
            const auto world = quad_need(samples, tile, false), pixels = quad_need(samples, tile, true);
            if (param.HasSubFaces()) {
                need(tile, world[0], pixels[0]);
                need(tile - 1, world[1], pixels[1]);
            } else {
                need(0, world[0], pixels[0]);
                need(2, world[0], pixels[0]);
                need(1, world[1], pixels[1]);
                need(3, world[1], pixels[1]);
            }
        }
    }
}

void probe_faces(Probes& pr) {
    const PreparedMesh& m = pr.m;
    const size_t F = m.face_count();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, F, 64), [&](const tbb::blocked_range<size_t>& range) {
        Surface surface;
        std::vector<float> patch, coords;
        std::vector<CurvatureSample> samples;
        for (size_t f = range.begin(); f != range.end(); ++f) {
            FaceProbe face(pr, f, surface, patch);
            if (pr.r.pixel_error > 0) face.edge_lengths();
            if (!pr.probe_curvature || !face.smooth) continue;
            face.curvature(coords, samples);
        }
    });
}

// Each edge takes the most demanding of its sides.
void probed_criteria(std::vector<double>& out, const Probes& pr) {
    const PreparedMesh& m = pr.m;
    const RateOptions& r = pr.r;
    const std::vector<SideProbe>& side = pr.side;
    const size_t E = m.edges.size();
    for (size_t e = 0; e < E; ++e) {
        double need_world = 0, need_pixels = 0;
        for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s) {
            need_world = std::max(need_world, side[s].need_world);
            need_pixels = std::max(need_pixels, side[s].need_pixels);
        }
        if (r.pixel_error > 0) out[e] = std::max(out[e], side[m.edge_owner[e]].length_pixels / r.pixel_error);
        if (r.max_error > 0) out[e] = std::max(out[e], std::sqrt(need_world / r.max_error));
        if (r.screen_error > 0) out[e] = std::max(out[e], std::sqrt(need_pixels / r.screen_error));
    }
}

} // namespace

std::vector<Mat4> instance_matrices(const RateOptions& r) {
    std::vector<Mat4> out;
    for (const auto& m : r.instances) out.push_back(m);
    if (out.empty()) out.push_back(kernel::kIdentity);
    return out;
}

Status validate_rates(const RateOptions& r) {
    auto bad = [](const std::string& what) { return Status::error(StatusCode::invalid_argument, what); };
    if (r.max_rate < 1 || r.max_rate > 32767) return bad("max rate must be 1..32767, got " + std::to_string(r.max_rate));
    if (r.uniform < 0 || r.uniform > 32767) return bad("uniform rate must be 1..32767, got " + std::to_string(r.uniform));
    for (double x : {r.pixel_error, r.screen_error, r.max_error})
        if (!(x >= 0.0) || !std::isfinite(x)) return bad("error thresholds must be finite and >= 0");
    const bool view = r.distance || r.pixel_error > 0 || r.screen_error > 0;
    if (view && !r.camera) return bad("the distance, pixel-error and screen-error criteria need a camera");
    if (r.camera) {
        if (!finite3(r.camera->eye)) return bad("camera position must be finite");
        if (!(r.camera->fov_degrees > 0.0 && r.camera->fov_degrees < 180.0))
            return bad("field of view must be in (0, 180) degrees");
        if (r.camera->viewport_height < 1) return bad("viewport height must be >= 1 pixel");
    }
    if (r.distance) {
        if (!std::isfinite(r.near) || !std::isfinite(r.far) || r.near < 0)
            return bad("near and far must be finite and >= 0");
        if (!(r.near < r.far))
            return bad("near (" + std::to_string(r.near) + ") must be less than far (" + std::to_string(r.far) + ")");
    }
    for (const auto& f : r.focus) {
        if (!finite3(f.centre)) return bad("focus centre must be finite");
        if (!(f.radius > 0.0) || !std::isfinite(f.radius)) return bad("focus radius must be > 0");
        if (f.rate < 0 || f.rate > 32767) return bad("focus rate must be 0..32767");
    }
    for (const auto& m : r.instances)
        for (double x : m)
            if (!std::isfinite(x)) return bad("instance matrices must be finite");
    const bool any = r.uniform > 0 || r.distance || r.pixel_error > 0 || r.screen_error > 0 || r.max_error > 0 ||
                     !r.focus.empty() || r.vertex_rates || r.edge_rate;
    if (!any)
        return bad("no rate criterion: give a uniform rate, distance, pixel error, screen error, max error, focus "
                   "points or a rate hook");
    return Status::success();
}

Status wanted_rates(std::vector<double>& out, const PreparedMesh& m, const RateOptions& r) {
    out.assign(m.edges.size(), 0.0);
    const std::vector<Mat4> inst = instance_matrices(r);
    control_mesh_criteria(out, m, r, inst);

    const bool probe_curvature = r.max_error > 0 || r.screen_error > 0;
    if (!(probe_curvature || r.pixel_error > 0)) return Status::success();

    // ---- probes of the limit surface, one face at a time, results per side
    Probes pr = make_probes(m, r, inst, probe_curvature);
    probe_faces(pr);
    probed_criteria(out, pr);
    if (probe_curvature) verify_error(out, m, r, inst, pr.eye, pr.focal, pr.min_distance);
    return Status::success();
}

int face_rates(const PreparedMesh& m, size_t f, const std::vector<int>& edge_rates, std::vector<int>& out) {
    out.clear();
    int largest = 1;
    for (uint32_t c = m.face_offset[f]; c < m.face_offset[f + 1]; ++c) {
        out.push_back(edge_rates[m.corner_edge[c]]);
        largest = std::max(largest, out.back());
    }
    if (out.size() == 4 && m.parameterization(f).GetType() == osd::Bfr::Parameterization::QUAD) {
        out.push_back(std::max(out[0], out[2]));
        out.push_back(std::max(out[1], out[3]));
    } else {
        out.push_back(largest);
    }
    return int(out.size());
}

size_t count_triangles(const PreparedMesh& m, const std::vector<int>& rates) {
    const size_t F = m.face_count();
    std::vector<uint32_t> per_face(F, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, F, 512), [&](const tbb::blocked_range<size_t>& range) {
        std::vector<int> face_rates;
        for (size_t f = range.begin(); f != range.end(); ++f) {
            const int n = tessellate_detail::face_rates(m, f, rates, face_rates);
            osd::Bfr::Tessellation t(m.parameterization(f), n, face_rates.data());
            per_face[f] = uint32_t(t.GetNumFacets());
        }
    });
    size_t total = 0;
    for (uint32_t x : per_face) total += x;
    return total;
}

} // namespace furrow::tessellate_detail

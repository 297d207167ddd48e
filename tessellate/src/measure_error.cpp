// Chordal error of a tessellation against the limit surface.
//
// Each output triangle is sampled at its centroid and edge midpoints (where linear interpolation of a smooth
// surface errs most) and compared with the limit surface evaluated at the same parametric location: the
// distance is an upper bound of the distance to the surface, exact in the limit of small triangles. Reported
// as max / mean, in world units and — with a camera — in pixels, following the Metro convention of
// reporting distances relative to the bounding-box diagonal (P. Cignoni, C. Rocchini, R. Scopigno, "Metro:
// measuring error on simplified surfaces", Computer Graphics Forum 17(2), 1998).
#include "tessellate_internal.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <numbers>

namespace furrow::tessellate_detail {
namespace {

struct FaceError {
    double max_world = 0, sum_world = 0, max_pixels = 0, sum_pixels = 0;
    size_t samples = 0;
};

} // namespace

Status measure_tessellation(ErrorReport& out, const PreparedMesh& m, const TessellateOutput& t, const RateOptions& view) {
    out = ErrorReport{};
    const size_t T = t.indices.size() / 3;
    if (t.triangle_patches.size() != T || t.triangle_coords.size() != T * 6)
        return Status::error(StatusCode::invalid_argument, "measure needs a tessellation made with keep_parameters");
    const std::vector<Mat4> inst = instance_matrices(view);
    for (const auto& M : inst) {
        std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};
        for (int corner = 0; corner < 8; ++corner) {
            double p[3] = {(corner & 1) ? m.bbox_max[0] : m.bbox_min[0], (corner & 2) ? m.bbox_max[1] : m.bbox_min[1],
                           (corner & 4) ? m.bbox_max[2] : m.bbox_min[2]};
            auto w = kernel::transform_point(M, p);
            for (int k = 0; k < 3; ++k) {
                lo[size_t(k)] = corner ? std::min(lo[size_t(k)], w[size_t(k)]) : w[size_t(k)];
                hi[size_t(k)] = corner ? std::max(hi[size_t(k)], w[size_t(k)]) : w[size_t(k)];
            }
        }
        out.diagonal = std::max(out.diagonal, distance3(lo, hi));
    }
    const bool camera = view.camera.has_value();
    const double focal = camera ? 0.5 * view.camera->viewport_height /
                                      std::tan(0.5 * view.camera->fov_degrees * std::numbers::pi / 180.0)
                                : 0.0;
    const double min_distance = std::max(1e-4 * out.diagonal, 1e-12);

    // Triangles of one face are consecutive (evaluate_tessellation writes them face by face).
    std::vector<size_t> begin;
    for (size_t i = 0; i < T; ++i)
        if (i == 0 || t.triangle_patches[i] != t.triangle_patches[i - 1]) begin.push_back(i);
    begin.push_back(T);
    const size_t runs = begin.size() - 1;
    std::vector<FaceError> per_run(runs);
    static const float bary[4][3] = {{1.f / 3, 1.f / 3, 1.f / 3}, {0.5f, 0.5f, 0}, {0, 0.5f, 0.5f}, {0.5f, 0, 0.5f}};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, runs, 16), [&](const tbb::blocked_range<size_t>& range) {
        Surface surface;
        std::vector<float> patch;
        for (size_t run = range.begin(); run != range.end(); ++run) {
            const size_t f = t.triangle_patches[begin[run]];
            if (f >= m.face_count() || !m.smooth(f) || !m.factory) continue;
            if (!m.factory_of(f).InitVertexSurface(m.face_refiner[f], &surface)) continue;
            patch.resize(size_t(surface.GetNumPatchPoints()) * 3);
            surface.PreparePatchPoints(m.refiner_data.data(), Surface::PointDescriptor(3, m.W), patch.data(), 3);
            const auto param = m.parameterization(f);
            FaceError& fe = per_run[run];
            for (size_t tri = begin[run]; tri < begin[run + 1]; ++tri) {
                float chart[6];
                int tile = 0;
                if (!common_chart(param, &t.triangle_coords[tri * 6], chart, tile)) continue;
                for (const auto& b : bary) {
                    float c[2] = {0, 0}, uv[2], P[3];
                    double q[3] = {0, 0, 0};
                    for (int k = 0; k < 3; ++k) {
                        const float* pos = &t.positions[size_t(t.indices[tri * 3 + size_t(k)]) * 3];
                        for (int j = 0; j < 3; ++j) q[j] += double(b[k]) * pos[j];
                        c[0] += b[k] * chart[2 * k];
                        c[1] += b[k] * chart[2 * k + 1];
                    }
                    chart_to_coord(param, tile, c, uv);
                    surface.Evaluate(uv, patch.data(), 3, P);
                    double d[3] = {q[0] - P[0], q[1] - P[1], q[2] - P[2]};
                    double worst = 0, worst_px = 0;
                    for (const auto& M : inst) {
                        const double e = length3(kernel::transform_vector(M, d));
                        worst = std::max(worst, e);
                        if (camera) {
                            double p[3] = {P[0], P[1], P[2]};
                            worst_px = std::max(worst_px, e * focal / std::max(distance3(kernel::transform_point(M, p), view.camera->eye), min_distance));
                        }
                    }
                    fe.max_world = std::max(fe.max_world, worst);
                    fe.sum_world += worst;
                    fe.max_pixels = std::max(fe.max_pixels, worst_px);
                    fe.sum_pixels += worst_px;
                    ++fe.samples;
                }
            }
        }
    });
    double sum = 0, sum_px = 0;
    for (const auto& fe : per_run) {
        out.samples += fe.samples;
        out.max_error = std::max(out.max_error, fe.max_world);
        out.max_pixels = std::max(out.max_pixels, fe.max_pixels);
        sum += fe.sum_world;
        sum_px += fe.sum_pixels;
    }
    if (out.samples) {
        out.mean_error = sum / double(out.samples);
        out.mean_pixels = sum_px / double(out.samples);
    }
    return Status::success();
}

} // namespace furrow::tessellate_detail

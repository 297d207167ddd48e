// Verifying the rates of the chordal-error criteria (max_error, screen_error) by measuring.
//
// Second-derivative estimates are exact on polynomial patches with a uniform pattern, but Bfr's non-uniform
// patterns (corner triangles, strips to the inner ring, the centre of n-gons) and the fast-varying curvature
// near extraordinary vertices can leave a face above the error asked for. So the error is measured as
// Tessellator::measure does (each triangle's centroid and edge midpoints against the limit surface at the
// same parametric location, here on the face's own surface) and the edges of a face over the target are
// raised by 1.1 sqrt(error / target) (the error falls with the square of the rate), up to 4 rounds. Shared
// points make no difference here: each face's boundary points are the ones its neighbours evaluate too.
#include "tessellate_internal.h"

#include <opensubdiv/bfr/tessellation.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace furrow::tessellate_detail {

void verify_error(std::vector<double>& wanted, const PreparedMesh& m, const RateOptions& r, const std::vector<Mat4>& inst,
                  const std::array<double, 3>& eye, double focal, double min_distance) {
    const size_t F = m.face_count(), E = m.edges.size();
    static const float bary[4][3] = {{1.f / 3, 1.f / 3, 1.f / 3}, {0.5f, 0.5f, 0}, {0, 0.5f, 0.5f}, {0.5f, 0, 0.5f}};
    for (int round = 0; round < 4; ++round) {
        std::vector<int> rates(E);
        for (size_t e = 0; e < E; ++e) rates[e] = final_rate(wanted[e], 1.0, r.max_rate);
        std::vector<float> face_ratio(F, 0.0f);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, F, 16), [&](const tbb::blocked_range<size_t>& range) {
            Surface surface;
            std::vector<float> patch, coords, pos;
            std::vector<int> fr, facets;
            for (size_t f = range.begin(); f != range.end(); ++f) {
                if (!m.smooth(f) || !m.factory || !m.factory_of(f).InitVertexSurface(m.face_refiner[f], &surface)) continue;
                patch.resize(size_t(surface.GetNumPatchPoints()) * 3);
                surface.PreparePatchPoints(m.refiner_data.data(), Surface::PointDescriptor(3, m.W), patch.data(), 3);
                const auto param = m.parameterization(f);
                const int nr = face_rates(m, f, rates, fr);
                osd::Bfr::Tessellation tess(param, nr, fr.data());
                coords.resize(size_t(tess.GetNumCoords()) * 2);
                tess.GetCoords(coords.data());
                pos.resize(size_t(tess.GetNumCoords()) * 3);
                for (int i = 0; i < tess.GetNumCoords(); ++i) surface.Evaluate(&coords[size_t(i) * 2], patch.data(), 3, &pos[size_t(i) * 3]);
                facets.resize(size_t(tess.GetNumFacets()) * 3);
                tess.GetFacets(facets.data());
                double ratio = 0;
                for (size_t t = 0; t < facets.size(); t += 3) {
                    float corner_uv[6], chart[6];
                    for (int k = 0; k < 3; ++k) {
                        corner_uv[2 * k] = coords[size_t(facets[t + size_t(k)]) * 2];
                        corner_uv[2 * k + 1] = coords[size_t(facets[t + size_t(k)]) * 2 + 1];
                    }
                    int tile = 0;
                    if (!common_chart(param, corner_uv, chart, tile)) continue;
                    for (const auto& b : bary) {
                        float c[2] = {0, 0}, uv[2], P[3];
                        double q[3] = {0, 0, 0};
                        for (int k = 0; k < 3; ++k) {
                            for (int j = 0; j < 3; ++j) q[j] += double(b[k]) * pos[size_t(facets[t + size_t(k)]) * 3 + size_t(j)];
                            c[0] += b[k] * chart[2 * k];
                            c[1] += b[k] * chart[2 * k + 1];
                        }
                        chart_to_coord(param, tile, c, uv);
                        surface.Evaluate(uv, patch.data(), 3, P);
                        double d[3] = {q[0] - P[0], q[1] - P[1], q[2] - P[2]}, p[3] = {P[0], P[1], P[2]};
                        for (const auto& M : inst) {
                            const double err = length3(kernel::transform_vector(M, d));
                            if (r.max_error > 0) ratio = std::max(ratio, err / r.max_error);
                            if (r.screen_error > 0)
                                ratio = std::max(ratio, err * focal / std::max(distance3(kernel::transform_point(M, p), eye), min_distance) / r.screen_error);
                        }
                    }
                }
                face_ratio[f] = float(ratio);
            }
        });
        bool raised = false;
        for (size_t e = 0; e < E; ++e) {
            double factor = 1.0;
            for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s) {
                const float q = face_ratio[m.corner_face[m.side_corner[s]]];
                if (q > 1.0f) factor = std::max(factor, 1.1 * std::sqrt(double(q)));
            }
            if (factor > 1.0 && rates[e] < r.max_rate) {
                wanted[e] = std::max(wanted[e], double(rates[e]) * factor);
                raised = true;
            }
        }
        if (!raised) break;
    }
}

} // namespace furrow::tessellate_detail

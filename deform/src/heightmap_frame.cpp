// The heightmap's frame (a grid in the plane normal to up) and bilinear sampling.
//
// Reference for the layout: the deformation map of Rise of the Tomb Raider (GDC 2016, "Rendering Rise of the
// Tomb Raider", deformation snow): a float texture laid flat over the terrain in the plane normal to up, one
// offset per texel, sampled bilinearly by the displacement. Texel centres sit on the grid's lines (texel
// (i, j) at i·texel, j·texel), so the grid's corners lie exactly on the ground's extent and resampling two
// grids of the same frame is exact.
#include "deform_internal.h"

#include <algorithm>

namespace furrow {

namespace deform_detail {

void frame_axes(const std::array<double, 3>& up_in, std::array<double, 3>& axis_u, std::array<double, 3>& axis_v,
                std::array<double, 3>& unit_up) {
    Vec3 up = d3(up_in);
    double n = norm(up);
    up = n > 0 ? up * (1.0 / n) : Vec3{0, 1, 0};
    // +x projected onto the plane, unless up is close to x: then +z (keeps +y up → (+x, +z), +z up → (+x, −y)).
    Vec3 ref = std::abs(up.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 0, 1};
    Vec3 u = ref - up * dot(ref, up);
    u = u * (1.0 / norm(u));
    Vec3 v = cross(u, up);
    axis_u = arr(u);
    axis_v = arr(v * (1.0 / norm(v)));
    unit_up = arr(up);
}

} // namespace deform_detail

std::array<double, 3> HeightmapFrame::to_texel(const double* p) const {
    using namespace deform_detail;
    const auto t = texel_of(*this, texel > 0 ? 1.0 / texel : 0.0, p);
    return {t[0], t[1], dot(Vec3{p[0], p[1], p[2]} - d3(origin), d3(up))};
}

void TexelRect::unite(const TexelRect& o) {
    if (o.empty()) return;
    if (empty()) {
        *this = o;
        return;
    }
    x0 = std::min(x0, o.x0), y0 = std::min(y0, o.y0), x1 = std::max(x1, o.x1), y1 = std::max(y1, o.y1);
}

double Heightmap::sample(double ti, double tj) const {
    return deform_detail::sample_split(*this, deform_detail::split_texel(ti, tj));
}

double Heightmap::sample_world(const double* p) const {
    auto t = frame.to_texel(p);
    return sample(t[0], t[1]);
}

} // namespace furrow

// The pixel side of the verification rasterizer: clip, cull, snap, bin, rasterize, shade, resolve.
//
// References:
//   J. Pineda, "A Parallel Algorithm for Polygon Rasterization", SIGGRAPH 1988 — edge functions.
//   Direct3D 10+ rasterization rules / OpenGL pixel-centre convention — the top-left fill rule on sample
//     centres at (x + 0.5, y + 0.5), so a sample on an edge shared by two triangles belongs to one of them.
//   F. Giesen, "The barycentric conspiracy" and "Triangle rasterization in practice" (2013) — fixed-point
//     snapping, the bias trick for the fill rule, 64-bit edge functions.
//   I. Sutherland, G. Hodgman, "Reentrant Polygon Clipping", CACM 1974 — clipping in homogeneous clip space;
//     J. Blinn, "Clipping using homogeneous coordinates", SIGGRAPH 1978 — clip before the divide by w.
//   Perspective-correct interpolation: attributes / w interpolate linearly in screen space (Heckbert &
//     Moreton 1991); tinyrenderer (D. Sokolov) for the overall shape of a small, readable rasterizer.
//
// Determinism: triangles are set up in fixed chunks and binned into horizontal bands; each band is drawn by
// one task, visiting the chunks in draw order. No result depends on which thread did what.
#include "render_internal.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace furrow::render_detail {
namespace {

constexpr int kBandRows = 16;     // output rows per band
constexpr size_t kChunk = 8192;   // source triangles per set-up task
constexpr double kGuard = 1 << 20; // clip to ±2^20 samples, so snapped coordinates fit int32 and edge
                                   // functions (products of two 2^29 differences) fit int64

// A triangle ready to rasterize, in snapped sample coordinates, with positive area.
struct Tri {
    uint32_t v[3];       // into Draw::verts, or past its end into Chunk::extra
    int32_t X[3], Y[3];  // fixed point, Grid::bits fractional bits
    int32_t x0, y0, x1, y1; // the samples whose centres fall in the bounding box (inclusive)
    uint8_t flags;       // bit k: edge v[k] -> v[k+1] is an edge of the source triangle; bit 3: back face
};

struct Chunk {
    size_t draw = 0, first = 0, count = 0; // source triangles [first, first + count) of one draw
    std::vector<Vert> extra;               // vertices made by clipping
    std::vector<Tri> tris;
    std::vector<uint32_t> band_start;      // tris of band b: band_items[band_start[b] .. band_start[b + 1])
    std::vector<uint32_t> band_items;
    size_t nan = 0, culled = 0;
};

// The sample grid, the guard band (in NDC units) that keeps snapped coordinates in range, and the sub-sample
// precision: vertices snap to 1/2^bits of a sample (RenderOptions::subpixel_bits).
struct Grid {
    int ws, hs;
    float gx, gy;
    int bits;
    int64_t one; // 2^bits
};
using Snapped = std::array<int32_t, 2>;

struct Setup {
    const Draw& draw;
    const std::vector<Snapped>& snapped; // per Draw vertex (valid where !outside(v))
    Chunk& chunk;
    Grid grid;
};

// Twice the signed area in snapped coordinates (y down), positive when the triangle is counter-clockwise on
// screen. Equals the edge function of edge 0 at v[2].
int64_t twice_area(const Tri& t) {
    return int64_t(t.X[2] - t.X[0]) * (t.Y[1] - t.Y[0]) - int64_t(t.X[1] - t.X[0]) * (t.Y[2] - t.Y[0]);
}

Vert lerp(const Vert& a, const Vert& b, float t) {
    auto mix = [t](float p, float q) { return p + t * (q - p); };
    Vert r;
    r.x = mix(a.x, b.x), r.y = mix(a.y, b.y), r.z = mix(a.z, b.z), r.w = mix(a.w, b.w);
    for (int k = 0; k < 3; ++k) r.n[k] = mix(a.n[k], b.n[k]);
    for (int k = 0; k < 2; ++k) r.uv[k] = mix(a.uv[k], b.uv[k]);
    for (int k = 0; k < 4; ++k) r.c[k] = mix(a.c[k], b.c[k]);
    r.s = mix(a.s, b.s);
    return r;
}

// Signed distances to the clip planes: near (z/w <= 1) and the guard band. >= 0 is inside.
float plane_distance(const Vert& v, int plane, const Grid& g) {
    switch (plane) {
    case 0: return v.w - v.z;
    case 1: return v.x + g.gx * v.w;
    case 2: return g.gx * v.w - v.x;
    case 3: return v.y + g.gy * v.w;
    default: return g.gy * v.w - v.y;
    }
}
bool outside(const Vert& v, const Grid& g) { // beyond the near plane or the guard band, or not finite
    // Every vertex that is not outside gets snapped, including those of triangles skipped later as
    // non-finite: an infinite w passes the guard band test (gx · inf = inf), and w = 0 (a point in the
    // eye's plane) passes it for x = y = 0; either way snap() converted NaN to an integer, undefined
    // behaviour (found by fuzz_render).
    return !(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.w) && v.w > 0 && v.z <= v.w &&
             std::abs(v.x) <= g.gx * v.w && std::abs(v.y) <= g.gy * v.w);
}

// Divides by w and snaps to the sub-sample grid (round to nearest). Every triangle sharing a vertex gets the
// same integers from the same floats, which is what makes the fill rule exact across shared edges.
// Kept inside the guard band: clipping huge clip-space coordinates in float can land a vertex far outside
// it (x/w = 1e31), and converting that to an integer is undefined behaviour (found by fuzz_render). For every
// vertex that clipping placed correctly the clamp changes nothing.
Snapped snap(const Vert& v, const Grid& g) {
    double iw = 1.0 / v.w;
    const double x = std::clamp(v.x * iw, -double(g.gx), double(g.gx)), y = std::clamp(v.y * iw, -double(g.gy), double(g.gy));
    return {int32_t(fast_floor((x * 0.5 + 0.5) * g.ws * double(g.one) + 0.5)),
            int32_t(fast_floor((0.5 - y * 0.5) * g.hs * double(g.one) + 0.5))};
}

// Orients and culls one snapped triangle, and keeps it if any sample centre lies in its bounding box.
void emit(Setup& s, const Snapped p[3], const uint32_t idx[3], unsigned edges, bool& culled) {
    Tri t;
    for (int k = 0; k < 3; ++k) t.X[k] = p[k][0], t.Y[k] = p[k][1], t.v[k] = idx[k];
    int64_t area = twice_area(t); // > 0: counter-clockwise as seen, the glTF front face
    if (area == 0) return;
    bool back = (area < 0) != s.draw.flip_winding;
    if (back && !s.draw.double_sided) {
        culled = true;
        return;
    }
    if (area < 0) { // the rasterizer wants positive area: swap v1, v2 (edges 0 and 2 trade places)
        std::swap(t.X[1], t.X[2]), std::swap(t.Y[1], t.Y[2]), std::swap(t.v[1], t.v[2]);
        edges = ((edges & 1) << 2) | (edges & 2) | ((edges >> 2) & 1);
    }
    t.flags = uint8_t(edges | (back ? 8 : 0));
    int32_t minx = std::min({t.X[0], t.X[1], t.X[2]}), maxx = std::max({t.X[0], t.X[1], t.X[2]});
    int32_t miny = std::min({t.Y[0], t.Y[1], t.Y[2]}), maxy = std::max({t.Y[0], t.Y[1], t.Y[2]});
    // Sample x's centre is x·one + one/2; the first centre >= min and the last <= max (floor shifts).
    const int64_t one = s.grid.one;
    const int bits = s.grid.bits;
    t.x0 = std::max(0, int32_t((int64_t(minx) - one / 2 + one - 1) >> bits));
    t.y0 = std::max(0, int32_t((int64_t(miny) - one / 2 + one - 1) >> bits));
    t.x1 = std::min(s.grid.ws - 1, int32_t((int64_t(maxx) - one / 2) >> bits));
    t.y1 = std::min(s.grid.hs - 1, int32_t((int64_t(maxy) - one / 2) >> bits));
    if (t.x0 > t.x1 || t.y0 > t.y1) return; // too small to reach a sample centre
    s.chunk.tris.push_back(t);
}

// Clips a triangle that crosses the near plane or the guard band (Sutherland–Hodgman in clip space) and emits
// the fan of the clipped polygon. Each intersection is computed from the inside towards the outside end, so a
// clipped edge shared by two triangles gets bit-identical vertices in both and the fill rule still holds.
void clip_and_emit(Setup& s, const Vert* const in[3], const uint32_t in_idx[3], bool& culled) {
    struct P {
        Vert v;
        uint32_t idx; // a Draw vertex, or UINT32_MAX for a new one
        bool edge;    // the edge from this vertex to the next lies on a source edge
    };
    P poly[16], next[16];
    int n = 3;
    for (int k = 0; k < 3; ++k) poly[k] = {*in[k], in_idx[k], true};
    for (int plane = 0; plane < 5 && n >= 3; ++plane) {
        int m = 0;
        for (int i = 0; i < n; ++i) {
            const P& a = poly[i];
            const P& b = poly[(i + 1) % n];
            float da = plane_distance(a.v, plane, s.grid), db = plane_distance(b.v, plane, s.grid);
            if (da >= 0) next[m++] = a;
            if ((da >= 0) != (db >= 0)) {
                const P& inside = da >= 0 ? a : b;
                const P& outside = da >= 0 ? b : a;
                float di = plane_distance(inside.v, plane, s.grid), dout = plane_distance(outside.v, plane, s.grid);
                next[m++] = {lerp(inside.v, outside.v, di / (di - dout)), UINT32_MAX, da >= 0 ? false : a.edge};
            }
        }
        std::copy(next, next + m, poly);
        n = m;
    }
    if (n < 3) return;
    // Finite but huge clip coordinates (1e38) overflow the float plane distances, and the intersection
    // parameter becomes inf/inf = NaN: such a triangle is counted with the non-finite ones and skipped rather
    // than snapped from NaN (found by fuzz_render).
    for (int i = 0; i < n; ++i) {
        const Vert& v = poly[i].v;
        if (!(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && v.w > 0 && std::isfinite(v.w))) {
            ++s.chunk.nan;
            return;
        }
    }
    uint32_t base = uint32_t(s.draw.verts.size());
    uint32_t idx[16];
    Snapped snapped[16];
    for (int i = 0; i < n; ++i) {
        snapped[i] = snap(poly[i].v, s.grid);
        if (poly[i].idx != UINT32_MAX) {
            idx[i] = poly[i].idx;
        } else {
            idx[i] = base + uint32_t(s.chunk.extra.size());
            s.chunk.extra.push_back(poly[i].v);
        }
    }
    for (int i = 1; i + 1 < n; ++i) {
        const Snapped p[3] = {snapped[0], snapped[i], snapped[i + 1]};
        uint32_t tri_idx[3] = {idx[0], idx[i], idx[i + 1]};
        unsigned edges = (i == 1 && poly[0].edge ? 1u : 0u) | (poly[i].edge ? 2u : 0u) |
                         (i + 2 == n && poly[n - 1].edge ? 4u : 0u);
        emit(s, p, tri_idx, edges, culled);
    }
}

void setup_chunk(Chunk& ch, const Draw& d, const std::vector<Snapped>& snapped, const Grid& grid, int band_rows, int bands) {
    Setup s{d, snapped, ch, grid};
    ch.tris.reserve(ch.count);
    for (size_t t = ch.first; t < ch.first + ch.count; ++t) {
        const uint32_t idx[3] = {d.tris[3 * t], d.tris[3 * t + 1], d.tris[3 * t + 2]};
        const Vert* v[3] = {&d.verts[idx[0]], &d.verts[idx[1]], &d.verts[idx[2]]};
        bool finite = true;
        for (const Vert* p : v) finite &= std::isfinite(p->x) && std::isfinite(p->y) && std::isfinite(p->z) && std::isfinite(p->w);
        if (!finite) {
            ++ch.nan;
            continue;
        }
        auto all = [&](auto test) { return test(*v[0]) && test(*v[1]) && test(*v[2]); };
        auto any = [&](auto test) { return test(*v[0]) || test(*v[1]) || test(*v[2]); };
        if (all([](const Vert& p) { return p.z > p.w; }) || all([](const Vert& p) { return p.x > p.w; }) ||
            all([](const Vert& p) { return p.x < -p.w; }) || all([](const Vert& p) { return p.y > p.w; }) ||
            all([](const Vert& p) { return p.y < -p.w; }))
            continue; // wholly outside the view
        bool culled = false;
        if (any([&](const Vert& p) { return outside(p, grid); })) {
            clip_and_emit(s, v, idx, culled);
        } else {
            const Snapped p[3] = {snapped[idx[0]], snapped[idx[1]], snapped[idx[2]]};
            emit(s, p, idx, 7, culled);
        }
        ch.culled += culled;
    }
    // Bin into bands (counting sort keeps the draw order inside each band).
    ch.band_start.assign(size_t(bands) + 1, 0);
    for (const Tri& t : ch.tris)
        for (int b = t.y0 / band_rows; b <= t.y1 / band_rows; ++b) ++ch.band_start[size_t(b) + 1];
    for (int b = 0; b < bands; ++b) ch.band_start[size_t(b) + 1] += ch.band_start[size_t(b)];
    ch.band_items.resize(ch.band_start.back());
    std::vector<uint32_t> cursor(ch.band_start.begin(), ch.band_start.end() - 1);
    for (uint32_t i = 0; i < ch.tris.size(); ++i)
        for (int b = ch.tris[i].y0 / band_rows; b <= ch.tris[i].y1 / band_rows; ++b) ch.band_items[cursor[size_t(b)]++] = i;
}

// The samples of one band: premultiplied RGBA in the working space (linear for shaded modes) and reversed
// depth (0 = nothing; larger is nearer).
struct Band {
    int y0 = 0, y1 = 0, width = 0; // sample rows [y0, y1)
    std::vector<float> color, depth;
};

// Shades the samples of one triangle: interpolation, material, alpha mode, depth test, write.
struct Shader {
    const Draw& d;
    const Frame& f;
    Band& band;
    const Vert* v[3];
    const int64_t one; // fixed-point units per sample
    float inv_area, zn[3], iw[3], edge_scale[3];
    // Texture level of detail: screen-space gradients (per output pixel, in texels of level 0) of Q = Σ b_k/w_k
    // and of U = Σ b_k·uv_k/w_k, so that ∂uv/∂x = (∂U/∂x − uv·∂Q/∂x) / Q (the quotient rule on uv = U/Q).
    float gq[2] = {0, 0}, gu[2][2] = {{0, 0}, {0, 0}};
    bool lod = false, back, grey;

    Shader(const Draw& d_, const Frame& f_, Band& b, const Tri& t, const Vert* const vs[3], int64_t one_)
        : d(d_), f(f_), band(b), one(one_) {
        int64_t area = twice_area(t);
        inv_area = float(1.0 / double(area));
        for (int k = 0; k < 3; ++k) {
            v[k] = vs[k];
            iw[k] = 1.0f / v[k]->w;
            zn[k] = v[k]->z * iw[k];
            // 1 / (edge length in fixed units × one): edge function -> distance in samples; 0 = no line here.
            edge_scale[k] = 0;
            if (f.mode == RenderMode::wireframe && ((t.flags >> k) & 1)) {
                int j = (k + 1) % 3;
                edge_scale[k] = float(1.0 / (std::hypot(double(t.X[j] - t.X[k]), double(t.Y[j] - t.Y[k])) * double(one)));
            }
        }
        back = t.flags & 8;
        grey = v[0]->s < 0 || v[1]->s < 0 || v[2]->s < 0;
        lod = d.texture && d.texture->needs_lod();
        if (lod) set_up_lod(t, double(area));
    }

    // b_k = e_{k+1} / area, and e(x, y) = dy·(x − X) − dx·(y − Y) steps by `one` fixed units per sample.
    void set_up_lod(const Tri& t, double area) {
        const MipLevel& l0 = d.texture->levels[0];
        const double per_pixel = double(one) * double(f.ssaa) / area, size[2] = {double(l0.width), double(l0.height)};
        for (int k = 0; k < 3; ++k) {
            const int e = (k + 1) % 3, j = (e + 1) % 3;
            const double db[2] = {double(t.Y[j] - t.Y[e]) * per_pixel, -double(t.X[j] - t.X[e]) * per_pixel};
            for (int a = 0; a < 2; ++a) {
                gq[a] += float(iw[k] * db[a]);
                for (int c = 0; c < 2; ++c) gu[a][c] += float(iw[k] * v[k]->uv[c] * size[c] * db[a]);
            }
        }
    }
    // log2 of the texel footprint of one output pixel (GL's λ); NaN when the gradients are not finite.
    float level_of_detail(const float uv[2], float qs) const {
        const MipLevel& l0 = d.texture->levels[0];
        const float s[2] = {uv[0] * float(l0.width), uv[1] * float(l0.height)};
        float rho2 = 0;
        for (int a = 0; a < 2; ++a) {
            const float du = (gu[a][0] - s[0] * gq[a]) * qs, dv = (gu[a][1] - s[1] * gq[a]) * qs;
            rho2 = std::max(rho2, du * du + dv * dv);
        }
        return 0.5f * std::log2(rho2);
    }

    // e_k: edge function of edge v[k] -> v[k+1], so e_k / area is the barycentric weight of v[k+2].
    void operator()(int x, int y, int64_t e0, int64_t e1, int64_t e2) const {
        float b[3] = {float(e1) * inv_area, float(e2) * inv_area, float(e0) * inv_area};
        float z = b[0] * zn[0] + b[1] * zn[1] + b[2] * zn[2];
        size_t i = size_t(y - band.y0) * size_t(band.width) + size_t(x);
        if (!(z > band.depth[i])) return;
        // Perspective-correct weights of v1 and v2; interpolating v0 + w1·(v1 − v0) + w2·(v2 − v0) keeps a
        // constant attribute exactly constant.
        float q[3] = {b[0] * iw[0], b[1] * iw[1], b[2] * iw[2]};
        float qs = 1.0f / (q[0] + q[1] + q[2]), w1 = q[1] * qs, w2 = q[2] * qs;
        auto at = [&](auto member, int c) {
            float a0 = (v[0]->*member)[c];
            return a0 + w1 * ((v[1]->*member)[c] - a0) + w2 * ((v[2]->*member)[c] - a0);
        };
        float uv[2] = {at(&Vert::uv, 0), at(&Vert::uv, 1)};
        std::array<float, 4> base = d.base_color;
        if (d.texture) {
            auto texel = sample_texture(*d.texture, uv[0], uv[1], lod ? level_of_detail(uv, qs) : 0.0f);
            for (int c = 0; c < 4; ++c) base[size_t(c)] *= texel[size_t(c)];
        }
        for (int c = 0; c < 4; ++c) base[size_t(c)] *= at(&Vert::c, c);
        float alpha = base[3];
        if (d.alpha_mode == AlphaMode::mask && !(alpha >= d.alpha_cutoff)) return;
        // COLOR_0, NORMAL and TEXCOORD come from the file unchecked (only POSITION must be finite): none of
        // their NaNs or 1e38s may reach the image (found by fuzz_render: NaN pixels in normals mode). Alpha is
        // kept to [0, 1], NaN counting as 0; a normal's length is taken in double (1e38 squared overflows a
        // float), and a NaN or zero normal shades as no normal; a non-finite colour channel becomes 0 or 1.
        if (d.alpha_mode != AlphaMode::blend) alpha = 1;
        else alpha = alpha >= 0 ? std::min(alpha, 1.0f) : 0.0f;

        float n[3] = {at(&Vert::n, 0), at(&Vert::n, 1), at(&Vert::n, 2)};
        float nl = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (std::isfinite(nl)) {
            float ns = nl > 0 ? (back ? -1 : 1) / nl : 0.0f;
            for (float& c : n) c *= ns;
        } else {
            const double dl = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
            const double ds = std::isfinite(dl) ? (back ? -1 : 1) / dl : 0.0; // dl > 0 here unless NaN
            for (float& c : n) c = ds != 0 ? float(c * ds) : 0.0f;
        }
        float rgb[3];
        switch (f.mode) {
        case RenderMode::normals:
            for (int c = 0; c < 3; ++c) rgb[c] = 0.5f + 0.5f * n[c];
            break;
        case RenderMode::uv:
            for (int c = 0; c < 2; ++c) rgb[c] = uv[c] == 1.0f ? 1.0f : uv[c] - std::floor(uv[c]);
            rgb[2] = 0;
            break;
        case RenderMode::depth: rgb[0] = rgb[1] = rgb[2] = 1; break; // coloured after the resolve
        case RenderMode::cutoff: rgb[0] = rgb[1] = rgb[2] = d.alpha_mode == AlphaMode::mask ? d.alpha_cutoff : 0.0f; break;
        case RenderMode::attribute: {
            float t = v[0]->s + w1 * (v[1]->s - v[0]->s) + w2 * (v[2]->s - v[0]->s);
            auto heat = viridis(grey ? 0.0f : std::clamp(t, 0.0f, 1.0f));
            for (int c = 0; c < 3; ++c) rgb[c] = grey ? 0.5f : heat[size_t(c)];
            break;
        }
        default: { // shaded, wireframe: Lambert
            float lit = f.ambient + (1 - f.ambient) * std::max(0.0f, n[0] * f.light[0] + n[1] * f.light[1] + n[2] * f.light[2]);
            for (int c = 0; c < 3; ++c) rgb[c] = base[size_t(c)] * lit + d.emissive[size_t(c)];
            if (f.mode == RenderMode::wireframe) {
                float dist = HUGE_VALF;
                int64_t e[3] = {e0, e1, e2};
                for (int k = 0; k < 3; ++k)
                    if (edge_scale[k] > 0) dist = std::min(dist, float(e[k]) * edge_scale[k]);
                float cover = std::clamp(0.5f * float(f.ssaa) + 0.5f - dist, 0.0f, 1.0f); // 1 output pixel wide
                for (float& c : rgb) c += cover * (0.01f - c);
            }
        }
        }
        for (float& c : rgb)
            if (!std::isfinite(c)) c = c > 0 ? 1.0f : 0.0f;
        float* dst = &band.color[4 * i];
        if (d.alpha_mode == AlphaMode::blend) { // "over", premultiplied; blended surfaces leave depth alone
            for (int c = 0; c < 3; ++c) dst[c] = rgb[c] * alpha + dst[c] * (1 - alpha);
            dst[3] = alpha + dst[3] * (1 - alpha);
        } else {
            for (int c = 0; c < 3; ++c) dst[c] = rgb[c];
            dst[3] = 1;
            band.depth[i] = z;
        }
    }
};

// The core loop. Pineda edge functions in 64-bit fixed point, stepped one sample at a time. A sample is
// covered when every edge function is > 0, or == 0 on a top or left edge: subtracting 1 from the others turns
// that into one sign test.
template <class Shade>
void scan(const Tri& t, int row0, int row1, int64_t one, const Shade& shade) {
    int64_t a[3], b[3], bias[3], row[3];
    for (int k = 0; k < 3; ++k) {
        int j = (k + 1) % 3;
        int64_t dx = t.X[j] - t.X[k], dy = t.Y[j] - t.Y[k];
        a[k] = dy, b[k] = -dx; // e(x, y) = a·(x − X_k) + b·(y − Y_k), > 0 inside
        bias[k] = (dy > 0 || (dy == 0 && dx < 0)) ? 0 : 1; // left or top edge (y down, counter-clockwise)
        row[k] = a[k] * (int64_t(t.x0) * one + one / 2 - t.X[k]) + b[k] * (int64_t(row0) * one + one / 2 - t.Y[k]) - bias[k];
    }
    for (int y = row0; y <= row1; ++y) {
        int64_t e[3] = {row[0], row[1], row[2]};
        for (int x = t.x0; x <= t.x1; ++x) {
            if ((e[0] | e[1] | e[2]) >= 0) shade(x, y, e[0] + bias[0], e[1] + bias[1], e[2] + bias[2]);
            for (int k = 0; k < 3; ++k) e[k] += a[k] * one;
        }
        for (int k = 0; k < 3; ++k) row[k] += b[k] * one;
    }
}

// Box-filters the band's samples into output rows; composites the background; encodes.
void resolve(const Band& band, RenderResult& out, const Frame& f) {
    int s = f.ssaa;
    bool srgb = f.mode == RenderMode::shaded || f.mode == RenderMode::wireframe;
    std::array<float, 3> bg{0, 0, 0};
    if (f.background)
        for (int c = 0; c < 3; ++c) bg[size_t(c)] = srgb ? srgb_to_linear((*f.background)[size_t(c)]) : (*f.background)[size_t(c)];
    float norm = 1.0f / float(s * s);
    for (int oy = band.y0 / s; oy < band.y1 / s; ++oy)
        for (int ox = 0; ox < f.width; ++ox) {
            float sum[4] = {0, 0, 0, 0}, zmax = 0;
            for (int sy = 0; sy < s; ++sy)
                for (int sx = 0; sx < s; ++sx) {
                    size_t i = size_t(oy * s + sy - band.y0) * size_t(band.width) + size_t(ox * s + sx);
                    for (int c = 0; c < 4; ++c) sum[c] += band.color[4 * i + size_t(c)];
                    zmax = std::max(zmax, band.depth[i]);
                }
            size_t o = size_t(oy) * size_t(f.width) + size_t(ox);
            out.depth.pixels[o] = zmax > 0 ? float(f.orthographic ? f.far_plane - zmax * (f.far_plane - f.near_plane)
                                                                 : f.near_plane / zmax)
                                           : HUGE_VALF;
            float a = sum[3] * norm, rgb[3];
            for (int c = 0; c < 3; ++c) rgb[c] = a > 0 ? sum[c] * norm / a : 0.0f; // straight alpha
            if (f.background && f.mode != RenderMode::depth) {
                for (int c = 0; c < 3; ++c) rgb[c] = rgb[c] * a + bg[size_t(c)] * (1 - a);
                a = 1;
            }
            float* dst = &out.color.pixels[4 * o];
            for (int c = 0; c < 3; ++c) dst[c] = srgb ? linear_to_srgb(rgb[c]) : rgb[c];
            dst[3] = a;
        }
}

// Depth mode: grey from the resolved depth, 1 at the nearest visible surface down to 0.1 at the farthest.
void colour_depth(RenderResult& out, const Frame& f) {
    float lo = HUGE_VALF, hi = -HUGE_VALF;
    for (float z : out.depth.pixels)
        if (std::isfinite(z)) lo = std::min(lo, z), hi = std::max(hi, z);
    for (size_t i = 0; i < out.depth.pixels.size(); ++i) {
        float z = out.depth.pixels[i], *p = &out.color.pixels[4 * i];
        float grey = std::isfinite(z) && hi > lo ? 1.0f - 0.9f * (z - lo) / (hi - lo) : 1.0f;
        float a = p[3];
        for (int c = 0; c < 3; ++c) p[c] = f.background ? grey * a + (*f.background)[size_t(c)] * (1 - a) : grey;
        if (f.background) p[3] = 1;
    }
}

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

RasterStats rasterize(RenderResult& out, const std::vector<Draw>& draws, const Frame& f) {
    auto t0 = std::chrono::steady_clock::now();
    RasterStats stats;
    int ws = f.width * f.ssaa, hs = f.height * f.ssaa, band_rows = kBandRows * f.ssaa;
    int bands = (hs + band_rows - 1) / band_rows;
    std::vector<Chunk> chunks;
    for (size_t d = 0; d < draws.size(); ++d)
        for (size_t first = 0; first < draws[d].tris.size() / 3; first += kChunk) {
            Chunk c;
            c.draw = d;
            c.first = first;
            c.count = std::min(kChunk, draws[d].tris.size() / 3 - first);
            chunks.push_back(std::move(c));
        }
    Grid grid{ws, hs, float(kGuard / ws), float(kGuard / hs), f.subpixel_bits, int64_t(1) << f.subpixel_bits};
    std::vector<std::vector<Snapped>> snapped(draws.size());
    for (size_t d = 0; d < draws.size(); ++d) {
        snapped[d].resize(draws[d].verts.size());
        tbb::parallel_for(tbb::blocked_range<size_t>(0, draws[d].verts.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t i = r.begin(); i != r.end(); ++i)
                snapped[d][i] = outside(draws[d].verts[i], grid) ? Snapped{0, 0} : snap(draws[d].verts[i], grid);
        });
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i)
            setup_chunk(chunks[i], draws[chunks[i].draw], snapped[chunks[i].draw], grid, band_rows, bands);
    });
    for (const Chunk& c : chunks) stats.nan_triangles += c.nan, stats.culled += c.culled;
    stats.setup_ms = ms_since(t0);

    auto t1 = std::chrono::steady_clock::now();
    out.color = {f.width, f.height, 4, std::vector<float>(size_t(f.width) * size_t(f.height) * 4)};
    out.depth = {f.width, f.height, 1, std::vector<float>(size_t(f.width) * size_t(f.height))};
    tbb::parallel_for(tbb::blocked_range<int>(0, bands, 1), [&](const tbb::blocked_range<int>& r) {
        for (int b = r.begin(); b != r.end(); ++b) {
            Band band;
            band.y0 = b * band_rows;
            band.y1 = std::min(hs, band.y0 + band_rows);
            band.width = ws;
            band.color.assign(size_t(band.y1 - band.y0) * size_t(ws) * 4, 0.0f);
            band.depth.assign(size_t(band.y1 - band.y0) * size_t(ws), 0.0f);
            for (const Chunk& c : chunks) {
                const Draw& d = draws[c.draw];
                for (uint32_t k = c.band_start[size_t(b)]; k < c.band_start[size_t(b) + 1]; ++k) {
                    const Tri& t = c.tris[c.band_items[k]];
                    const Vert* v[3];
                    for (int j = 0; j < 3; ++j)
                        v[j] = t.v[j] < d.verts.size() ? &d.verts[t.v[j]] : &c.extra[t.v[j] - d.verts.size()];
                    scan(t, std::max(t.y0, band.y0), std::min(t.y1, band.y1 - 1), grid.one, Shader(d, f, band, t, v, grid.one));
                }
            }
            resolve(band, out, f);
        }
    });
    if (f.mode == RenderMode::depth) colour_depth(out, f);
    stats.raster_ms = ms_since(t1);
    return stats;
}

} // namespace furrow::render_detail

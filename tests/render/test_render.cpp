// Tests of the verification rasterizer (furrow/render.h). Every exactness claim is checked against an
// analytic answer: pixel centres inside a polygon, ray–plane intersections, the projected area of a sphere.
#include <furrow/render.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numeric>

#include <tbb/global_control.h>

namespace furrow {
namespace {

using Vec3 = std::array<double, 3>;

// A quad in the plane z = `z`, facing +Z (counter-clockwise seen from +Z).
Primitive quad(float x0, float y0, float x1, float y1, float z = 0, int material = -1) {
    Primitive p;
    p.positions = {x0, y0, z, x1, y0, z, x1, y1, z, x0, y1, z};
    p.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    p.uv0 = {0, 1, 1, 1, 1, 0, 0, 0};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = material;
    return p;
}

// One node holding one mesh of these primitives.
Scene scene_of(std::vector<Primitive> prims, std::vector<Material> materials = {}) {
    Scene s;
    s.meshes.push_back(Mesh{"m", std::move(prims), {}, {}});
    s.nodes.push_back(Node{});
    s.nodes[0].mesh = 0;
    s.roots = {0};
    s.materials = std::move(materials);
    return s;
}

// Orthographic view of the rectangle [0,w]×[0,h] of the z = 0 plane, so that world x, y are pixel units
// (y up): the centre of pixel (px, py) is at (px + 0.5, h − py − 0.5).
RenderOptions pixel_view(int w, int h) {
    RenderOptions o;
    o.width = w, o.height = h;
    o.camera.orthographic = true;
    o.camera.eye = Vec3{w / 2.0, h / 2.0, 100};
    o.camera.target = Vec3{w / 2.0, h / 2.0, 0};
    o.camera.ortho_height = h;
    return o;
}

float alpha_at(const RenderResult& r, int x, int y) { return r.color.pixels[4 * (size_t(y) * r.color.width + x) + 3]; }
const float* rgba_at(const RenderResult& r, int x, int y) { return &r.color.pixels[4 * (size_t(y) * r.color.width + x)]; }

Material blend_material(float alpha) {
    Material m;
    m.base_color = {1, 1, 1, alpha};
    m.alpha_mode = AlphaMode::blend;
    m.double_sided = true;
    return m;
}

// A UV sphere with `seg` longitudes and seg / 2 latitudes, outward normals, counter-clockwise outside.
Primitive uv_sphere(double radius, int seg, Vec3 centre = {0, 0, 0}) {
    Primitive p;
    int rings = seg / 2;
    for (int i = 0; i <= rings; ++i)
        for (int j = 0; j <= seg; ++j) {
            double th = M_PI * i / rings, ph = 2 * M_PI * j / seg;
            double n[3] = {std::sin(th) * std::cos(ph), std::cos(th), -std::sin(th) * std::sin(ph)};
            for (int c = 0; c < 3; ++c) {
                p.positions.push_back(float(centre[size_t(c)] + radius * n[c]));
                p.normals.push_back(float(n[c]));
            }
            p.uv0.push_back(float(j) / seg), p.uv0.push_back(float(i) / rings);
        }
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < seg; ++j) {
            uint32_t a = uint32_t(i * (seg + 1) + j), b = a + 1, c = a + uint32_t(seg + 1), d = c + 1;
            if (i > 0) p.indices.insert(p.indices.end(), {a, c, b});
            if (i + 1 < rings) p.indices.insert(p.indices.end(), {b, c, d});
        }
    return p;
}

// A PNG texture from 8-bit RGBA texels.
Image png_image(int w, int h, const std::vector<uint8_t>& rgba) {
    Image im;
    im.mime_type = "image/png";
    im.encoded = encode_png_rgba8(rgba.data(), w, h);
    return im;
}

// The camera basis render_scene builds for eye/target/up, and the ray through a pixel centre.
struct Ray {
    Vec3 origin, dir, forward;
};
Ray pixel_ray(const RenderOptions& o, double px, double py) {
    Vec3 e = *o.camera.eye, t = *o.camera.target, up = o.camera.up;
    Vec3 f{t[0] - e[0], t[1] - e[1], t[2] - e[2]};
    double fl = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    for (double& c : f) c /= fl;
    Vec3 r{f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2], f[0] * up[1] - f[1] * up[0]};
    double rl = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    for (double& c : r) c /= rl;
    Vec3 u{r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    double th = std::tan(o.camera.fov_degrees * M_PI / 360), aspect = double(o.width) / o.height;
    double x = (2 * px / o.width - 1) * th * aspect, y = (1 - 2 * py / o.height) * th;
    Vec3 d;
    for (int c = 0; c < 3; ++c) d[size_t(c)] = f[size_t(c)] + x * r[size_t(c)] + y * u[size_t(c)];
    return {e, d, f};
}

// ---------------------------------------------------------------------------------------------------------
// Exactness
// ---------------------------------------------------------------------------------------------------------

// A closed fan of 97 thin triangles around a centre that sits on a pixel centre, drawn with alpha 0.5 and
// no depth write: a sample covered twice would read 0.75, a gap 0.
TEST(render_scene, TopLeftFillRuleNoGapsNoOverlap) {
    const int W = 128, H = 128, N = 97;
    const double cx = 64.5, cy = 64.5, R = 60;
    Primitive p;
    p.positions = {float(cx), float(cy), 0};
    for (int i = 0; i < N; ++i) {
        double a = 2 * M_PI * i / N;
        // Every 8th rim vertex snapped to a pixel centre, so edges run through sample centres too.
        double x = cx + R * std::cos(a), y = cy + R * std::sin(a);
        if (i % 8 == 0) x = std::floor(x) + 0.5, y = std::floor(y) + 0.5;
        p.positions.insert(p.positions.end(), {float(x), float(y), 0});
    }
    for (int i = 0; i < N; ++i) p.indices.insert(p.indices.end(), {0u, uint32_t(1 + i), uint32_t(1 + (i + 1) % N)});
    Scene s = scene_of({p}, {blend_material(0.5f)});
    s.meshes[0].primitives[0].material = 0;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, pixel_view(W, H)).ok());
    size_t inside = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            float a = alpha_at(r, x, y);
            ASSERT_TRUE(a == 0.0f || a == 0.5f) << "pixel " << x << "," << y << " alpha " << a;
            // Inside the rim polygon (crossing test), and how far from its boundary.
            double px = x + 0.5, py = H - y - 0.5, margin = HUGE_VAL;
            bool in = false;
            for (int i = 0; i < N; ++i) {
                const float* a0 = &p.positions[3 * (1 + i)];
                const float* a1 = &p.positions[3 * (1 + (i + 1) % N)];
                if ((a0[1] > py) != (a1[1] > py) && px < a0[0] + (py - a0[1]) * (a1[0] - a0[0]) / (a1[1] - a0[1])) in = !in;
                double ex = a1[0] - a0[0], ey = a1[1] - a0[1];
                double t = std::clamp(((px - a0[0]) * ex + (py - a0[1]) * ey) / (ex * ex + ey * ey), 0.0, 1.0);
                margin = std::min(margin, std::hypot(px - a0[0] - t * ex, py - a0[1] - t * ey));
            }
            if (!in) margin = -margin;
            if (margin > 1e-3) {
                EXPECT_EQ(a, 0.5f) << "gap at " << x << "," << y;
            } else if (margin < -1e-3) {
                EXPECT_EQ(a, 0.0f) << "outside drawn at " << x << "," << y;
            }
            inside += a > 0;
        }
    EXPECT_GT(inside, size_t(0.95 * M_PI * R * R));
    EXPECT_EQ(alpha_at(r, 64, 63), 0.5f); // the shared centre vertex: exactly one owner
}

// A square whose edges run exactly through sample centres: the samples on its top and left edges are in,
// those on its bottom and right edges are out (D3D / OpenGL convention).
TEST(render_scene, TopLeftFillRuleOwnsTopAndLeftEdges) {
    const int H = 8;
    RenderResult r;
    // World x in [2.5, 5.5], image rows 2..5 (world y = H − row − 0.5).
    ASSERT_TRUE(render_scene(r, scene_of({quad(2.5f, H - 5.5f, 5.5f, H - 2.5f)}), pixel_view(8, H)).ok());
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < 8; ++x)
            EXPECT_EQ(alpha_at(r, x, y), (x >= 2 && x <= 4 && y >= 2 && y <= 4) ? 1.0f : 0.0f) << x << "," << y;
}

// A jittered grid of triangles under a perspective camera: still every covered pixel exactly once.
TEST(render_scene, TopLeftFillRuleHoldsUnderPerspective) {
    Primitive p;
    const int n = 40;
    uint32_t seed = 12345;
    auto jitter = [&] { seed = seed * 1664525u + 1013904223u; return float((seed >> 8) & 0xffff) / 65536.0f - 0.5f; };
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) {
            bool border = i == 0 || j == 0 || i == n || j == n;
            float x = float(j) / n * 2 - 1 + (border ? 0 : jitter() * 0.02f);
            float y = float(i) / n * 2 - 1 + (border ? 0 : jitter() * 0.02f);
            p.positions.insert(p.positions.end(), {x, y, 0});
        }
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            uint32_t a = uint32_t(i * (n + 1) + j), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
            if ((i + j) % 2) p.indices.insert(p.indices.end(), {a, b, d, a, d, c});
            else p.indices.insert(p.indices.end(), {a, b, c, b, d, c});
        }
    p.material = 0;
    RenderOptions o;
    o.width = 160, o.height = 120;
    o.camera.eye = Vec3{0.7, -0.9, 2.2};
    o.camera.target = Vec3{0, 0, 0};
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({p}, {blend_material(0.5f)}), o).ok());
    size_t covered = 0;
    for (float a : silhouette_mask(r.color, 0.0f).pixels) covered += a > 0;
    for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x)
            ASSERT_TRUE(alpha_at(r, x, y) == 0.0f || alpha_at(r, x, y) == 0.5f) << x << "," << y << ": " << alpha_at(r, x, y);
    // No interior gaps: every pixel whose ray hits the square well inside is covered.
    for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x) {
            Ray ray = pixel_ray(o, x + 0.5, y + 0.5);
            double t = -ray.origin[2] / ray.dir[2];
            double hx = ray.origin[0] + t * ray.dir[0], hy = ray.origin[1] + t * ray.dir[1];
            if (std::max(std::abs(hx), std::abs(hy)) < 0.98) {
                EXPECT_EQ(alpha_at(r, x, y), 0.5f) << x << "," << y;
            }
        }
    EXPECT_GT(covered, 1000u);
}

// A floor seen at a grazing angle in uv mode: every pixel's interpolated uv equals the uv of the point its
// ray hits (perspective-correct interpolation; affine interpolation is off by up to ~0.3 here).
TEST(render_scene, PerspectiveCorrectUvAtGrazingAngle) {
    Primitive p;
    // The floor y = 0, x in [-2, 2], z in [-40, 0]; u = (x + 2) / 4, v = −z / 40. Two triangles only.
    p.positions = {-2, 0, 0, 2, 0, 0, 2, 0, -40, -2, 0, -40};
    p.normals = {0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0};
    p.uv0 = {0, 0, 1, 0, 1, 1, 0, 1};
    p.indices = {0, 1, 2, 0, 2, 3};
    RenderOptions o;
    o.width = 160, o.height = 120, o.mode = RenderMode::uv;
    o.camera.eye = Vec3{0.3, 0.4, 1};
    o.camera.target = Vec3{0, 0, -10};
    o.camera.fov_degrees = 60;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({p}), o).ok());
    // Vertices snap to 1/256 pixel, so the exact answer may move by a few 1/512 pixel: the tolerance is that
    // much of the analytic uv's change per pixel (still ~1000× below the error of affine interpolation).
    auto floor_uv = [&](double px, double py) {
        Ray ray = pixel_ray(o, px, py);
        double t = -ray.origin[1] / ray.dir[1];
        return std::array<double, 3>{(ray.origin[0] + t * ray.dir[0] + 2) / 4, -(ray.origin[2] + t * ray.dir[2]) / 40, t};
    };
    size_t checked = 0;
    double worst = 0;
    for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x) {
            auto [u, v, t] = floor_uv(x + 0.5, y + 0.5);
            bool inside = t > 0 && u > 0 && u < 1 && v > 0 && v < 1;
            bool near_edge = t > 0 && (std::min({u, 1 - u, v, 1 - v}) < 0.01 || floor_uv(x + 0.5, y - 0.5)[2] < 0);
            if (near_edge) continue;
            ASSERT_EQ(alpha_at(r, x, y) > 0, inside) << x << "," << y;
            if (!inside) continue;
            auto dx = floor_uv(x + 1.5, y + 0.5), dy = floor_uv(x + 0.5, y + 1.5);
            double step = std::abs(dx[0] - u) + std::abs(dx[1] - v) + std::abs(dy[0] - u) + std::abs(dy[1] - v);
            const float* c = rgba_at(r, x, y);
            double err = std::max(std::abs(c[0] - u), std::abs(c[1] - v));
            EXPECT_LT(err, 1e-5 + step / 64) << x << "," << y;
            worst = std::max(worst, err / (1e-5 + step));
            ++checked;
        }
    EXPECT_GT(checked, 3000u);
    EXPECT_LT(worst, 1.0 / 64);
}

// The same floor with an 8×8 checkerboard texture (nearest): every pixel shows the texel its ray hits.
TEST(render_scene, PerspectiveCorrectCheckerboardTexel) {
    Primitive p;
    p.positions = {-2, 0, 0, 2, 0, 0, 2, 0, -40, -2, 0, -40};
    p.normals = {0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0};
    p.uv0 = {0, 0, 1, 0, 1, 1, 0, 1};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = 0;
    std::vector<uint8_t> texels(8 * 8 * 4);
    for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 8; ++i) {
            uint8_t v = (i + j) % 2 ? 255 : 0;
            for (int c = 0; c < 3; ++c) texels[4 * size_t(j * 8 + i) + size_t(c)] = v;
            texels[4 * size_t(j * 8 + i) + 3] = 255;
        }
    Material m;
    m.base_color_texture.texture = 0;
    Scene s = scene_of({p}, {m});
    s.images.push_back(png_image(8, 8, texels));
    s.samplers.push_back(Sampler{9728, 9728, 10497, 10497});
    s.textures.push_back(Texture{0, 0});
    RenderOptions o;
    o.width = 160, o.height = 120, o.ambient = 1; // unlit: the pixel is the texel
    o.camera.eye = Vec3{0.3, 0.4, 1};
    o.camera.target = Vec3{0, 0, -10};
    o.camera.fov_degrees = 60;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, o).ok());
    EXPECT_TRUE(r.warnings.empty());
    size_t checked = 0, wrong = 0;
    for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x) {
            Ray ray = pixel_ray(o, x + 0.5, y + 0.5);
            double t = -ray.origin[1] / ray.dir[1];
            double u = (ray.origin[0] + t * ray.dir[0] + 2) / 4 * 8, v = -(ray.origin[2] + t * ray.dir[2]) / 40 * 8;
            if (t <= 0 || u <= 0 || u >= 8 || v <= 0 || v >= 8) continue;
            // Skip samples within 1% of a texel border, where float rounding may pick either side.
            if (std::abs(u - std::round(u)) < 0.01 || std::abs(v - std::round(v)) < 0.01) continue;
            float expected = (int(u) + int(v)) % 2 ? 1.0f : 0.0f;
            wrong += std::abs(rgba_at(r, x, y)[0] - expected) > 1e-6f;
            ++checked;
        }
    EXPECT_GT(checked, 3000u);
    EXPECT_EQ(wrong, 0u);
}

// A floor triangle with two vertices behind the camera: clipped at the near plane, so exactly the pixels whose
// rays hit it in front of the near plane are covered, at the right depth.
TEST(render_scene, NearPlaneClipsNotDropsNorExplodes) {
    Primitive p;
    p.positions = {-30, 0, 10, 30, 0, 10, 0, 0, -50};
    p.normals = {0, 1, 0, 0, 1, 0, 0, 1, 0};
    p.indices = {0, 1, 2};
    RenderOptions o;
    o.width = 128, o.height = 96;
    o.camera.eye = Vec3{0, 1, 0};
    o.camera.target = Vec3{0, 0.2, -5};
    o.camera.near_plane = 0.5;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({p}), o).ok());
    size_t covered = 0, mismatched = 0;
    double worst_depth = 0;
    for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x) {
            Ray ray = pixel_ray(o, x + 0.5, y + 0.5);
            double t = -ray.origin[1] / ray.dir[1];
            double hx = ray.origin[0] + t * ray.dir[0], hz = ray.origin[2] + t * ray.dir[2];
            double view_depth = t * (ray.dir[0] * ray.forward[0] + ray.dir[1] * ray.forward[1] + ray.dir[2] * ray.forward[2]);
            // Inside the triangle: the two slanted edges from (±30, 10) to (0, −50).
            double e1 = (hz + 50) - 2 * (hx + 0) * -1, e2 = (hz + 50) - 2 * hx; // z + 50 >= 2|x| ... and z <= 10
            bool inside = t > 0 && hz < 10 && e1 > 0 && e2 > 0 && view_depth > 0.5;
            double slack = std::min({std::abs(e1), std::abs(e2), std::abs(hz - 10), std::abs(view_depth - 0.5)});
            if (t > 0 && slack < 0.05) continue;
            bool drawn = alpha_at(r, x, y) > 0;
            mismatched += drawn != inside;
            covered += drawn;
            if (drawn && inside) worst_depth = std::max(worst_depth, std::abs(r.depth.pixels[size_t(y) * 128 + x] - view_depth) / view_depth);
        }
    EXPECT_EQ(mismatched, 0u);
    EXPECT_GT(covered, 128u * 40);
    EXPECT_LT(worst_depth, 1e-4);
}

// Geometry nearer than the near plane disappears; geometry behind it stays.
TEST(render_scene, NearPlaneRemovesCloserGeometry) {
    RenderOptions o = pixel_view(64, 64);
    o.camera.orthographic = false;
    o.camera.eye = Vec3{0, 0, 1};
    o.camera.target = Vec3{0, 0, 0};
    o.camera.near_plane = 0.5;
    Material red, blue;
    red.base_color = {1, 0, 0, 1}, blue.base_color = {0, 0, 1, 1};
    // A red wall 0.3 in front of the eye (before the near plane) hides nothing; the blue one at 1 shows.
    Scene s = scene_of({quad(-5, -5, 5, 5, 0.7f, 0), quad(-5, -5, 5, 5, 0, 1)}, {red, blue});
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, o).ok());
    const float* c = rgba_at(r, 32, 32);
    EXPECT_EQ(c[0], 0.0f);
    EXPECT_GT(c[2], 0.5f);
    EXPECT_NEAR(r.depth.pixels[32 * 64 + 32], 1.0, 1e-5);
}

TEST(render_scene, DepthTestOrdersSurfacesIndependentlyOfDrawOrder) {
    Material red, blue;
    red.base_color = {1, 0, 0, 1}, blue.base_color = {0, 0, 1, 1};
    RenderOptions o = pixel_view(64, 64);
    RenderResult near_first, far_first;
    // Red at z = 1 (nearer to the eye at z = 100) over the left part, blue at z = 0 everywhere.
    ASSERT_TRUE(render_scene(near_first, scene_of({quad(0, 0, 40, 64, 1, 0), quad(0, 0, 64, 64, 0, 1)}, {red, blue}), o).ok());
    ASSERT_TRUE(render_scene(far_first, scene_of({quad(0, 0, 64, 64, 0, 1), quad(0, 0, 40, 64, 1, 0)}, {red, blue}), o).ok());
    EXPECT_EQ(near_first.rgba8, far_first.rgba8);
    EXPECT_GT(rgba_at(near_first, 20, 32)[0], 0.9f);
    EXPECT_EQ(rgba_at(near_first, 20, 32)[2], 0.0f);
    EXPECT_GT(rgba_at(near_first, 50, 32)[2], 0.9f);
    EXPECT_NEAR(near_first.depth.pixels[32 * 64 + 20], 99.0, 1e-3);
    EXPECT_NEAR(near_first.depth.pixels[32 * 64 + 50], 100.0, 1e-3);
}

TEST(render_scene, MaskCutoffJustBelowAndAbove) {
    auto coverage = [](float alpha, float cutoff) {
        Material m;
        m.base_color = {1, 1, 1, alpha};
        m.alpha_mode = AlphaMode::mask;
        m.alpha_cutoff = cutoff;
        RenderResult r;
        EXPECT_TRUE(render_scene(r, scene_of({quad(8, 8, 24, 24, 0, 0)}, {m}), pixel_view(32, 32)).ok());
        return mask_area(silhouette_mask(r.color));
    };
    EXPECT_EQ(coverage(0.499f, 0.5f), 0u);
    EXPECT_EQ(coverage(0.5f, 0.5f), 256u); // alpha >= cutoff is drawn
    EXPECT_EQ(coverage(0.501f, 0.5f), 256u);
    EXPECT_EQ(coverage(0.0f, 0.0f), 256u);
}

// Texels of alpha 127/255 and 128/255 against a cutoff of 0.5: the left half vanishes, the right is opaque.
TEST(render_scene, MaskCutoffOnTextureAlpha) {
    Material m;
    m.alpha_mode = AlphaMode::mask;
    m.alpha_cutoff = 0.5f;
    m.base_color_texture.texture = 0;
    Scene s = scene_of({quad(0, 0, 32, 32, 0, 0)}, {m});
    s.images.push_back(png_image(2, 1, {255, 255, 255, 127, 255, 255, 255, 128}));
    s.samplers.push_back(Sampler{9728, 9728, 33071, 33071});
    s.textures.push_back(Texture{0, 0});
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, pixel_view(32, 32)).ok());
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) ASSERT_EQ(alpha_at(r, x, y), x < 16 ? 0.0f : 1.0f) << x << "," << y;
}

TEST(render_scene, CullingFollowsDoubleSided) {
    Primitive back = quad(8, 8, 24, 24);
    back.indices = {0, 2, 1, 0, 3, 2}; // clockwise seen from the camera
    Material single, twosided;
    twosided.double_sided = true;
    back.material = 0;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({back}, {single}), pixel_view(32, 32)).ok());
    EXPECT_EQ(mask_area(silhouette_mask(r.color)), 0u);
    EXPECT_EQ(r.culled, 2u);

    RenderResult r2, front;
    ASSERT_TRUE(render_scene(r2, scene_of({back}, {twosided}), pixel_view(32, 32)).ok());
    EXPECT_EQ(mask_area(silhouette_mask(r2.color)), 256u);
    EXPECT_EQ(r2.culled, 0u);
    // The back face is lit with its normal flipped towards the viewer: like the front face with the same
    // normal. Here the stored normal is +Z (towards the eye), so the flipped back face sees −Z and gets ambient.
    ASSERT_TRUE(render_scene(front, scene_of({quad(8, 8, 24, 24, 0, 0)}, {twosided}), pixel_view(32, 32)).ok());
    EXPECT_LT(rgba_at(r2, 16, 16)[0], rgba_at(front, 16, 16)[0]);

    // A mirroring node (negative determinant) flips the winding: the mirrored front face stays visible.
    Scene mirrored = scene_of({quad(-24, 8, -8, 24, 0, 0)}, {single});
    mirrored.nodes[0].scale = {-1, 1, 1};
    RenderResult m;
    ASSERT_TRUE(render_scene(m, mirrored, pixel_view(32, 32)).ok());
    EXPECT_EQ(mask_area(silhouette_mask(m.color)), 256u);
    EXPECT_EQ(m.culled, 0u);
}

// The silhouette of a finely tessellated sphere against the analytic projected disc. On the optical axis the
// sphere's outline is a circle of angular radius asin(R / D); the inscribed polyhedron loses ~1e-4 of it.
TEST(render_scene, SphereSilhouetteMatchesAnalyticArea) {
    const double R = 1, D = 4;
    Scene s = scene_of({uv_sphere(R, 256)});
    RenderOptions o;
    o.width = o.height = 1024;
    o.camera.eye = Vec3{0, 0, D};
    o.camera.target = Vec3{0, 0, 0};
    o.camera.fov_degrees = 40;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, o).ok());
    double focal = o.height / 2.0 / std::tan(o.camera.fov_degrees * M_PI / 360);
    double radius_px = focal * std::tan(std::asin(R / D));
    double expected = M_PI * radius_px * radius_px;
    double got = double(mask_area(silhouette_mask(r.color)));
    EXPECT_NEAR(got / expected, 1.0, 0.005) << got << " vs " << expected;

    // Orthographic: the disc of radius R exactly.
    o.camera.orthographic = true;
    o.camera.ortho_height = 2.5;
    ASSERT_TRUE(render_scene(r, s, o).ok());
    double px = o.height / 2.5;
    EXPECT_NEAR(double(mask_area(silhouette_mask(r.color))) / (M_PI * px * px), 1.0, 0.005);
}

TEST(render_scene, IdenticalBytesForAnyThreadCount) {
    Material blend = blend_material(0.4f), mask;
    blend.base_color = {0.2f, 0.6f, 1.0f, 0.4f};
    mask.alpha_mode = AlphaMode::mask;
    mask.base_color_texture.texture = 0;
    std::vector<uint8_t> texels(16 * 16 * 4);
    for (size_t i = 0; i < texels.size(); ++i) texels[i] = uint8_t((i * 37) % 256);
    Primitive sphere = uv_sphere(1, 128);
    sphere.material = 1;
    Scene s = scene_of({sphere, quad(-1.5f, -1.5f, 1.5f, 1.5f, 0.3f, 0)}, {blend, mask});
    s.images.push_back(png_image(16, 16, texels));
    s.textures.push_back(Texture{0, -1});
    RenderOptions o;
    o.width = 320, o.height = 240, o.ssaa = 2, o.mode = RenderMode::wireframe;
    std::vector<std::vector<uint8_t>> images;
    std::vector<std::vector<float>> depths;
    for (int threads : {1, 2, 3, 8}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
        RenderResult r;
        ASSERT_TRUE(render_scene(r, s, o).ok());
        images.push_back(encode_png_rgba8(r.rgba8.data(), r.color.width, r.color.height));
        depths.push_back(r.depth.pixels);
    }
    for (size_t i = 1; i < images.size(); ++i) {
        EXPECT_EQ(images[i], images[0]) << "thread count run " << i;
        EXPECT_EQ(std::memcmp(depths[i].data(), depths[0].data(), depths[0].size() * sizeof(float)), 0);
    }
}

// ---------------------------------------------------------------------------------------------------------
// Scene semantics: hierarchy, skins, morph targets, materials
// ---------------------------------------------------------------------------------------------------------

// Centroid of the silhouette in pixels.
std::array<double, 2> centroid(const RenderResult& r) {
    double sx = 0, sy = 0, n = 0;
    for (int y = 0; y < r.color.height; ++y)
        for (int x = 0; x < r.color.width; ++x)
            if (alpha_at(r, x, y) > 0.5f) sx += x + 0.5, sy += y + 0.5, n += 1;
    return {sx / n, sy / n};
}

TEST(render_scene, NodeHierarchyComposesTransforms) {
    Scene s = scene_of({quad(-4, -4, 4, 4)});
    s.nodes[0].mesh = -1;
    s.nodes[0].translation = {10, 0, 0};
    s.nodes[0].children = {1};
    Node child;
    child.mesh = 0;
    child.translation = {0, 20, 0};
    s.nodes.push_back(child);
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, pixel_view(64, 64)).ok());
    auto c = centroid(r);
    EXPECT_NEAR(c[0], 10, 1e-9);
    EXPECT_NEAR(c[1], 64 - 20, 1e-9);
}

TEST(render_scene, SkinInBindPoseUsesJointsAndInverseBindMatrices) {
    Primitive p = quad(-4, -4, 4, 4);
    p.joints = std::vector<uint16_t>(16, 0);
    for (int i = 0; i < 4; ++i) p.joints[size_t(4 * i + 1)] = 1;
    p.weights = {0.5f, 0.5f, 0, 0, 0.5f, 0.5f, 0, 0, 0.5f, 0.5f, 0, 0, 0.5f, 0.5f, 0, 0};
    Scene s = scene_of({p});
    s.nodes[0].skin = 0;
    s.nodes[0].translation = {1000, 0, 0}; // a skinned mesh's own node transform is ignored (glTF 3.7.3)
    Node j0, j1;
    j0.translation = {20, 30, 0};
    j1.translation = {40, 30, 0};
    s.nodes.push_back(j0), s.nodes.push_back(j1);
    s.roots = {0, 1, 2};
    Skin skin;
    skin.joints = {1, 2};
    // Joint 1's inverse bind matrix moves by −10 in x: vertices end at 0.5·(20, 30) + 0.5·(30, 30) = (25, 30).
    skin.inverse_bind_matrices = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -10, 0, 0, 1};
    s.skins.push_back(skin);
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, pixel_view(64, 64)).ok());
    auto c = centroid(r);
    EXPECT_NEAR(c[0], 25, 1e-9);
    EXPECT_NEAR(c[1], 64 - 30, 1e-9);
}

TEST(render_scene, MorphTargetsAtDefaultWeights) {
    Primitive p = quad(4, 4, 12, 12);
    MorphTarget up;
    up.position_deltas = {0, 10, 0, 0, 10, 0, 0, 10, 0, 0, 10, 0};
    p.targets = {up};
    Scene s = scene_of({p});
    s.meshes[0].weights = {2};
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, pixel_view(64, 64)).ok());
    EXPECT_NEAR(centroid(r)[1], 64 - 28, 1e-9);
    s.nodes[0].weights = {0.5}; // the node's weights override the mesh's
    ASSERT_TRUE(render_scene(r, s, pixel_view(64, 64)).ok());
    EXPECT_NEAR(centroid(r)[1], 64 - 13, 1e-9);
}

TEST(render_scene, BlendDrawsBackToFrontPerPrimitive) {
    Material nearer = blend_material(0.5f), farther = blend_material(0.5f);
    nearer.base_color = {1, 0, 0, 0.5f};
    farther.base_color = {0, 0, 1, 0.5f};
    RenderOptions o = pixel_view(32, 32);
    o.ambient = 1;
    // Listed nearest first; drawn farthest first: red over (blue over nothing).
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({quad(0, 0, 32, 32, 2, 0), quad(0, 0, 32, 32, 1, 1)}, {nearer, farther}), o).ok());
    const float* c = rgba_at(r, 16, 16);
    EXPECT_FLOAT_EQ(c[3], 0.75f);
    EXPECT_NEAR(c[0], linear_to_srgb(0.5f / 0.75f), 1e-6); // straight alpha: premultiplied 0.5 / 0.75
    EXPECT_NEAR(c[2], linear_to_srgb(0.25f / 0.75f), 1e-6);
}

TEST(render_scene, BaseColorTimesTextureTimesVertexColor) {
    Primitive p = quad(0, 0, 16, 16, 0, 0);
    p.colors = std::vector<float>(16, 0.5f);
    Material m;
    m.base_color = {0.8f, 0.4f, 1.0f, 1.0f};
    m.base_color_texture.texture = 0;
    Scene s = scene_of({p}, {m});
    // One texel of sRGB 188 (linear ≈ 0.5029): the texture is sRGB-decoded before multiplying.
    s.images.push_back(png_image(1, 1, {188, 188, 188, 255}));
    s.textures.push_back(Texture{0, -1});
    RenderOptions o = pixel_view(16, 16);
    o.ambient = 1;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, o).ok());
    float t = srgb_to_linear(188 / 255.0f);
    const float* c = rgba_at(r, 8, 8);
    EXPECT_NEAR(c[0], linear_to_srgb(0.8f * t * 0.5f), 1e-6);
    EXPECT_NEAR(c[1], linear_to_srgb(0.4f * t * 0.5f), 1e-6);
    EXPECT_NEAR(c[2], linear_to_srgb(1.0f * t * 0.5f), 1e-6);
}

// Bilinear filtering happens on linear values, and the wrap modes follow the sampler.
TEST(render_scene, TextureFilteringAndWrapModes) {
    auto render_u = [](int wrap, int filter, float u0, float u1) {
        Primitive p = quad(0, 0, 64, 4, 0, 0);
        p.uv0 = {u0, 1, u1, 1, u1, 0, u0, 0};
        Material m;
        m.base_color_texture.texture = 0;
        Scene s = scene_of({p}, {m});
        s.images.push_back(png_image(2, 1, {0, 0, 0, 255, 255, 255, 255, 255}));
        s.samplers.push_back(Sampler{filter, filter, wrap, wrap});
        s.textures.push_back(Texture{0, 0});
        RenderOptions o = pixel_view(64, 4);
        o.ambient = 1;
        RenderResult r;
        EXPECT_TRUE(render_scene(r, s, o).ok());
        std::vector<float> row;
        for (int x = 0; x < 64; ++x) row.push_back(rgba_at(r, x, 2)[0]);
        return row;
    };
    // Bilinear across [0,1]: pixel 31's centre is at u = 31.5/64, between the texel centres 0.25 and 0.75:
    // linear weight of white = (31.5/64·2 − 0.5) = 0.484375, then sRGB-encoded.
    auto row = render_u(33071, 9729, 0, 1);
    EXPECT_NEAR(row[31], linear_to_srgb(31.5f / 32 - 0.5f), 1e-5);
    EXPECT_EQ(row[0], 0.0f); // clamped below the first texel centre
    EXPECT_EQ(row[63], 1.0f);
    // Nearest over u in [0, 3]: REPEAT gives b w b w b w, MIRRORED_REPEAT b w w b b w, CLAMP b w w w w w.
    auto pattern = [&](int wrap) {
        auto r = render_u(wrap, 9728, 0, 3);
        std::string s;
        for (int k = 0; k < 6; ++k) s += r[size_t(k * 64 / 6 + 5)] > 0.5f ? 'w' : 'b';
        return s;
    };
    EXPECT_EQ(pattern(10497), "bwbwbw");
    EXPECT_EQ(pattern(33648), "bwwbbw");
    EXPECT_EQ(pattern(33071), "bwwwww");
}

// A 64×64-pixel square (pixel_view(64, 64)) showing an n×n texture through a sampler with this minFilter.
Scene textured_square(int n, const std::vector<uint8_t>& rgba, int min_filter) {
    Material m;
    m.base_color_texture.texture = 0;
    Scene s = scene_of({quad(0, 0, 64, 64, 0, 0)}, {m});
    s.images.push_back(png_image(n, n, rgba));
    s.samplers.push_back(Sampler{9729, min_filter, 10497, 10497});
    s.textures.push_back(Texture{0, 0});
    return s;
}

// Mipmaps as a GPU builds and selects them. A texture of n×n texels in alternating black and white columns
// covers a 64×64-pixel square, so every pixel spans n/64 texels and λ = log2(n/64) exactly: at n = 64 the
// base level shows the stripes; at n = 256 (λ = 2) level 2 is uniform grey (linear 0.5: each texel the box
// mean of 4×4 base texels) and LINEAR_MIPMAP_LINEAR and *_MIPMAP_NEAREST both show it; a minFilter without
// mipmaps (NEAREST) samples the base level at the pixel centre (texel 4x + 2, white) and shows no grey at
// all; RenderOptions::mipmaps = false does the same for a mip-mapping sampler.
TEST(render_scene, MipmapLevelFollowsTheTexelFootprint) {
    auto render_stripes = [](int n, int min_filter, bool mipmaps) {
        std::vector<uint8_t> rgba(size_t(n) * size_t(n) * 4, 255);
        for (int y = 0; y < n; ++y)
            for (int x = 1; x < n; x += 2)
                for (int c = 0; c < 3; ++c) rgba[4 * (size_t(y) * size_t(n) + size_t(x)) + size_t(c)] = 0;
        Scene s = textured_square(n, rgba, min_filter);
        RenderOptions o = pixel_view(64, 64);
        o.ambient = 1;
        o.mipmaps = mipmaps;
        RenderResult r;
        EXPECT_TRUE(render_scene(r, s, o).ok());
        float lo = 1, hi = 0;
        for (int y = 0; y < 64; ++y)
            for (int x = 0; x < 64; ++x) lo = std::min(lo, rgba_at(r, x, y)[0]), hi = std::max(hi, rgba_at(r, x, y)[0]);
        return std::pair<float, float>{lo, hi};
    };
    const float grey = linear_to_srgb(0.5f);
    auto [lo0, hi0] = render_stripes(64, 9987, true); // λ = 0: the base level, texel centres: pure stripes
    EXPECT_EQ(lo0, 0.0f);
    EXPECT_EQ(hi0, 1.0f);
    for (int filter : {9987, 9985, 9984}) {
        auto [lo, hi] = render_stripes(256, filter, true);
        EXPECT_NEAR(lo, grey, 1.5f / 255) << filter;
        EXPECT_NEAR(hi, grey, 1.5f / 255) << filter;
    }
    auto [lo_base, hi_base] = render_stripes(256, 9728, true);
    EXPECT_EQ(lo_base, 1.0f);
    EXPECT_EQ(hi_base, 1.0f);
    auto [lo_off, hi_off] = render_stripes(256, 9986, false); // NEAREST_MIPMAP_LINEAR, mipmaps off: base, nearest
    EXPECT_EQ(lo_off, 1.0f);
    EXPECT_EQ(hi_off, 1.0f);
}

// The chain is glGenerateMipmap's: a 128² texture on 64 pixels (λ = 1) shows level 1, each texel the mean of
// 2×2 base texels, averaged in linear light.
TEST(render_scene, MipmapChainBoxFiltersInLinearSpace) {
    std::vector<uint8_t> rgba(128 * 128 * 4, 255);
    for (int y = 0; y < 128; ++y)
        for (int x = 1; x < 128; x += 2) rgba[4 * (size_t(y) * 128 + size_t(x))] = 0; // red channel only
    Scene s = textured_square(128, rgba, 9987);
    RenderOptions o = pixel_view(64, 64);
    o.ambient = 1;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, o).ok());
    // Red averages 1 and 0 in linear light: 0.5, stored sRGB-encoded in 8 bits like the GPU's level, so the
    // output is within one 8-bit step of linear_to_srgb(0.5) (0.735), not 0.5 (averaging encoded values).
    for (int y = 0; y < 64; y += 7)
        for (int x = 0; x < 64; x += 5) {
            EXPECT_NEAR(rgba_at(r, x, y)[0], linear_to_srgb(0.5f), 1.5f / 255) << x << "," << y;
            EXPECT_EQ(rgba_at(r, x, y)[1], 1.0f);
        }
}

TEST(render_scene, LambertWithDirectionalLightAndAmbient) {
    RenderOptions o = pixel_view(16, 16);
    o.light_direction = {0, 0, 1}; // from the viewer: n·l = 1
    o.ambient = 0.25f;
    Material m;
    m.base_color = {0.5f, 0.5f, 0.5f, 1};
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({quad(0, 0, 16, 16, 0, 0)}, {m}), o).ok());
    EXPECT_NEAR(rgba_at(r, 8, 8)[0], linear_to_srgb(0.5f), 1e-6);
    o.light_direction = {1, 0, 0}; // grazing: ambient only
    ASSERT_TRUE(render_scene(r, scene_of({quad(0, 0, 16, 16, 0, 0)}, {m}), o).ok());
    EXPECT_NEAR(rgba_at(r, 8, 8)[0], linear_to_srgb(0.125f), 1e-6);
}

// ---------------------------------------------------------------------------------------------------------
// Modes, views, supersampling
// ---------------------------------------------------------------------------------------------------------

TEST(render_scene, NormalsDepthAndUvModes) {
    Primitive p = quad(0, 0, 32, 32, 0);
    RenderOptions o = pixel_view(32, 32);
    RenderResult r;
    o.mode = RenderMode::normals;
    ASSERT_TRUE(render_scene(r, scene_of({p}), o).ok());
    EXPECT_FLOAT_EQ(rgba_at(r, 5, 5)[0], 0.5f);
    EXPECT_FLOAT_EQ(rgba_at(r, 5, 5)[1], 0.5f);
    EXPECT_FLOAT_EQ(rgba_at(r, 5, 5)[2], 1.0f);
    o.mode = RenderMode::uv;
    ASSERT_TRUE(render_scene(r, scene_of({p}), o).ok());
    EXPECT_NEAR(rgba_at(r, 5, 9)[0], 5.5 / 32, 1e-6);
    EXPECT_NEAR(rgba_at(r, 5, 9)[1], 9.5 / 32, 1e-6); // v = 0 at the top (glTF)
    // Depth mode: a tilted plane; grey falls from 1 (nearest) to 0.1 (farthest), depth is exact.
    Primitive tilted = quad(0, 0, 32, 32);
    for (int i = 0; i < 4; ++i) tilted.positions[size_t(3 * i + 2)] = tilted.positions[size_t(3 * i)] * 0.5f;
    o.mode = RenderMode::depth;
    ASSERT_TRUE(render_scene(r, scene_of({tilted}), o).ok());
    EXPECT_NEAR(r.depth.pixels[10 * 32 + 31], 100 - 31.5 * 0.5, 1e-3);
    EXPECT_NEAR(r.depth.pixels[10 * 32 + 0], 100 - 0.5 * 0.5, 1e-3);
    EXPECT_FLOAT_EQ(rgba_at(r, 31, 10)[0], 1.0f);
    EXPECT_NEAR(rgba_at(r, 0, 10)[0], 0.1f, 1e-5);
}

TEST(render_scene, AttributeHeatMapWithLegend) {
    Primitive p = quad(0, 0, 64, 48);
    p.custom.push_back(CustomAttribute{"_FUR_LENGTH", 1, {2, 4, 4, 2}}); // 2 on the left, 4 on the right
    RenderOptions o = pixel_view(64, 48);
    o.mode = RenderMode::attribute;
    o.attribute = "_FUR_LENGTH";
    o.legend = false;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({p}), o).ok());
    EXPECT_EQ(r.attribute_min, 2.0f);
    EXPECT_EQ(r.attribute_max, 4.0f);
    auto expected = [](float t) {
        const unsigned char v[11][3] = {{0x44, 0x01, 0x54}, {0x48, 0x24, 0x75}, {0x41, 0x44, 0x87}, {0x35, 0x5F, 0x8D},
                                        {0x2A, 0x78, 0x8E}, {0x21, 0x91, 0x8C}, {0x22, 0xA8, 0x84}, {0x44, 0xBF, 0x70},
                                        {0x7A, 0xD1, 0x51}, {0xBD, 0xDF, 0x26}, {0xFD, 0xE7, 0x25}};
        int i = std::min(int(t * 10), 9);
        float f = t * 10 - i;
        return (v[i][1] + f * (v[i + 1][1] - v[i][1])) / 255.0f;
    };
    for (int x : {0, 13, 40, 63}) EXPECT_NEAR(rgba_at(r, x, 20)[1], expected((x + 0.5f) / 64), 1e-5) << x;
    o.legend = true;
    RenderResult with_legend;
    ASSERT_TRUE(render_scene(with_legend, scene_of({p}), o).ok());
    EXPECT_NE(with_legend.rgba8, r.rgba8);
    o.attribute = "_MISSING";
    Status st = render_scene(r, scene_of({p}), o);
    EXPECT_EQ(st.code, StatusCode::invalid_argument);
    EXPECT_NE(st.message.find("_FUR_LENGTH"), std::string::npos) << st.message; // lists what is there
}

TEST(render_scene, WireframeDarkensTriangleEdgesOnly) {
    Material m;
    m.base_color = {1, 1, 1, 1};
    RenderOptions o = pixel_view(32, 32);
    o.ambient = 1;
    RenderResult shaded, wire;
    ASSERT_TRUE(render_scene(shaded, scene_of({quad(0, 0, 32, 32, 0, 0)}, {m}), o).ok());
    o.mode = RenderMode::wireframe;
    ASSERT_TRUE(render_scene(wire, scene_of({quad(0, 0, 32, 32, 0, 0)}, {m}), o).ok());
    EXPECT_LT(rgba_at(wire, 10, 21)[0], 0.2f); // on the diagonal edge (0,0)-(32,32): pixel centre (10.5, 10.5)
    EXPECT_EQ(rgba_at(wire, 20, 20)[0], rgba_at(shaded, 20, 20)[0]);
    EXPECT_EQ(rgba_at(shaded, 10, 21)[0], 1.0f);
}

TEST(render_scene, SupersamplingAveragesCoverage) {
    RenderOptions o = pixel_view(16, 16);
    o.ssaa = 4;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({quad(0, 0, 8.5f, 16)}), o).ok());
    EXPECT_EQ(alpha_at(r, 7, 8), 1.0f);
    EXPECT_EQ(alpha_at(r, 8, 8), 0.5f);
    EXPECT_EQ(alpha_at(r, 9, 8), 0.0f);
    o.background = std::array<float, 3>{0, 0, 0};
    ASSERT_TRUE(render_scene(r, scene_of({quad(0, 0, 8.5f, 16)}), o).ok());
    EXPECT_EQ(alpha_at(r, 9, 8), 1.0f); // a background makes every pixel opaque
}

TEST(render_scene, DefaultViewsFrameTheBoundingBox) {
    Scene s = scene_of({uv_sphere(3, 64, {100, -50, 20})});
    RenderOptions o;
    o.width = 200, o.height = 100;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, o).ok());
    ImageF mask = silhouette_mask(r.color);
    for (int x = 0; x < 200; ++x) EXPECT_EQ(mask.pixels[size_t(x)] + mask.pixels[size_t(99 * 200 + x)], 0.0f);
    for (int y = 0; y < 100; ++y) EXPECT_EQ(mask.pixels[size_t(y * 200)] + mask.pixels[size_t(y * 200 + 199)], 0.0f);
    EXPECT_GT(mask_area(mask), 0.15 * 100 * 100);

    // Orthographic default: top-down, +X right and −Z up in the image. Quads of the z = 0 plane are laid on
    // the ground by (x, y, z) -> (x, 0, −y), a rotation, so they face +Y.
    auto lay_down = [](Primitive p, float height) {
        for (size_t i = 0; i < p.positions.size(); i += 3) {
            float y = p.positions[i + 1];
            p.positions[i + 1] = height, p.positions[i + 2] = -y;
            p.normals[i + 1] = 1, p.normals[i + 2] = 0;
        }
        return p;
    };
    Material red;
    red.base_color = {1, 0, 0, 1};
    // A red marker at +X, −Z (right, up in the image), just above the ground.
    Scene terrain = scene_of({lay_down(quad(-1, -1, 1, 1), 0), lay_down(quad(0.5f, 0.5f, 0.9f, 0.9f, 0, 0), 0.01f)}, {red});
    o = RenderOptions{};
    o.width = o.height = 100;
    o.ambient = 1;
    o.camera.orthographic = true;
    ASSERT_TRUE(render_scene(r, terrain, o).ok());
    EXPECT_NEAR(double(mask_area(silhouette_mask(r.color))), 100 * 100 / (1.02 * 1.02), 250);
    EXPECT_EQ(rgba_at(r, 80, 20)[0], 1.0f); // the marker, top right
    EXPECT_EQ(rgba_at(r, 80, 20)[1], 0.0f);
    EXPECT_GT(rgba_at(r, 25, 75)[1], 0.2f); // grey ground elsewhere
}

// ---------------------------------------------------------------------------------------------------------
// Bad input
// ---------------------------------------------------------------------------------------------------------

TEST(render_scene, RejectsSceneWithoutTriangles) {
    RenderResult r;
    Status s = render_scene(r, Scene{}, {});
    EXPECT_EQ(s.code, StatusCode::invalid_input);
    EXPECT_NE(s.message.find("no triangles"), std::string::npos) << s.message;
    Primitive points;
    points.mode = PrimitiveMode::points;
    points.positions = {0, 0, 0, 1, 1, 1};
    EXPECT_EQ(render_scene(r, scene_of({points}), {}).code, StatusCode::invalid_input);
}

TEST(render_scene, RejectsSizesOutsideRange) {
    RenderResult r;
    Scene s = scene_of({quad(0, 0, 1, 1)});
    for (auto [w, h] : std::vector<std::pair<int, int>>{{0, 10}, {10, 0}, {16385, 10}, {10, 16385}, {-1, 5}}) {
        RenderOptions o;
        o.width = w, o.height = h;
        Status st = render_scene(r, s, o);
        EXPECT_EQ(st.code, StatusCode::invalid_argument) << w << "x" << h;
        EXPECT_NE(st.message.find("16384"), std::string::npos);
    }
    RenderOptions o;
    o.width = o.height = 8;
    o.ssaa = 9;
    EXPECT_EQ(render_scene(r, s, o).code, StatusCode::invalid_argument);
    o.ssaa = 1;
    for (int bits : {0, 9}) {
        o.subpixel_bits = bits;
        EXPECT_EQ(render_scene(r, s, o).code, StatusCode::invalid_argument) << bits;
    }
    o.subpixel_bits = 8;
    o.camera.fov_degrees = 180;
    EXPECT_EQ(render_scene(r, s, o).code, StatusCode::invalid_argument);
}

TEST(render_scene, SkipsAndCountsNanTriangles) {
    Primitive p = quad(0, 0, 32, 32);
    p.positions.insert(p.positions.end(), {NAN, 0, 0, 1, 1, 0, 2, 0, 0});
    p.normals.insert(p.normals.end(), {0, 0, 1, 0, 0, 1, 0, 0, 1});
    p.uv0.insert(p.uv0.end(), {0, 0, 0, 0, 0, 0});
    p.indices.insert(p.indices.end(), {4, 5, 6, 5, 4, 0});
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({p}), pixel_view(32, 32)).ok());
    EXPECT_EQ(r.triangles, 4u);
    EXPECT_EQ(r.nan_triangles, 2u);
    EXPECT_EQ(mask_area(silhouette_mask(r.color)), 32u * 32u);
    ASSERT_EQ(r.warnings.size(), 1u);
    EXPECT_NE(r.warnings[0].find("2 triangles"), std::string::npos);
}

// Finite positions near FLT_MAX (or a bounding box that large, which the automatic framing backs off from)
// overflow to infinite clip coordinates. Such vertices used to be snapped to the sample grid anyway (NaN
// converted to an integer: undefined behaviour, found by fuzz_render; see tests/fuzz/regressions/render).
// Whatever is drawn, the image and its depths stay finite.
TEST(render_scene, HugeFiniteCoordinatesGiveAFiniteImage) {
    const float big = 3.0e38f;
    Primitive huge;
    huge.positions = {big, 0, 0, 0, big, 0, -big, -big, big, 1, 1, -big, big, big, big};
    huge.indices = {0, 1, 2, 0, 3, 4, 2, 3, 1};
    const Scene scene = scene_of({quad(0, 0, 32, 32), huge});
    for (int view = 0; view < 3; ++view) {
        RenderOptions o = view == 0 ? pixel_view(32, 32) : RenderOptions{};
        if (view == 0) o.camera.near_plane = 1;
        if (view > 0) o.width = o.height = 32;
        o.camera.orthographic = view == 2;
        RenderResult r;
        Status st = render_scene(r, scene, o);
        ASSERT_TRUE(st.ok()) << st.message;
        EXPECT_EQ(r.triangles, 5u);
        for (float v : r.color.pixels) ASSERT_TRUE(v >= 0 && v <= 1) << "view " << view;
        for (float d : r.depth.pixels) ASSERT_TRUE(d >= 0) << "view " << view; // +inf where empty, never NaN
    }
}

TEST(render_scene, MissingTextureWarnsOnceAndUsesFactor) {
    Material a, b;
    a.base_color = {0.5f, 0.25f, 1, 1};
    a.base_color_texture.texture = 0;
    b = a;
    Scene s = scene_of({quad(0, 0, 16, 32, 0, 0), quad(16, 0, 32, 32, 0, 1)}, {a, b});
    s.images.push_back(Image{"bark", "image/png", {}, "textures/bark.png"});
    s.textures.push_back(Texture{0, -1});
    RenderOptions o = pixel_view(32, 32);
    o.ambient = 1;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, o).ok());
    ASSERT_EQ(r.warnings.size(), 1u);
    EXPECT_NE(r.warnings[0].find("bark.png"), std::string::npos) << r.warnings[0];
    EXPECT_NEAR(rgba_at(r, 20, 5)[1], linear_to_srgb(0.25f), 1e-6);
}

TEST(render_scene, RejectsOutOfRangeIndices) {
    Primitive p = quad(0, 0, 1, 1);
    p.indices[4] = 7;
    RenderResult r;
    Status s = render_scene(r, scene_of({p}), {});
    EXPECT_EQ(s.code, StatusCode::invalid_input);
    EXPECT_NE(s.message.find("index 7"), std::string::npos) << s.message;
}

TEST(render_scene, FlatShadesPrimitivesWithoutNormals) {
    Primitive p = quad(0, 0, 16, 16);
    p.normals.clear();
    RenderOptions o = pixel_view(16, 16);
    o.mode = RenderMode::normals;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, scene_of({p}), o).ok());
    EXPECT_FLOAT_EQ(rgba_at(r, 3, 3)[2], 1.0f);
    EXPECT_FLOAT_EQ(rgba_at(r, 12, 12)[2], 1.0f);
}

// ---------------------------------------------------------------------------------------------------------
// Metrics
// ---------------------------------------------------------------------------------------------------------

// Cutoff mode writes the front MASK layer's alphaCutoff as a raw grey, 0 on OPAQUE; cutoff_coverage counts
// and weights those pixels.
TEST(render_scene, CutoffModeAndCoverage) {
    Material opaque, mask;
    mask.alpha_mode = AlphaMode::mask;
    mask.alpha_cutoff = 0.25f;
    Scene s = scene_of({quad(0, 0, 8, 8, 0, 0), quad(0, 0, 4, 8, 1, 1)}, {opaque, mask});
    RenderOptions o = pixel_view(16, 8);
    o.mode = RenderMode::cutoff;
    RenderResult r;
    ASSERT_TRUE(render_scene(r, s, o).ok());
    EXPECT_EQ(rgba_at(r, 1, 1)[0], 0.25f); // the MASK quad in front
    EXPECT_EQ(rgba_at(r, 6, 1)[0], 0.0f);  // the opaque one
    EXPECT_EQ(alpha_at(r, 12, 1), 0.0f);   // nothing
    CutoffCoverage c = cutoff_coverage(r.color);
    EXPECT_DOUBLE_EQ(c.covered, 32.0 / 128.0);
    EXPECT_DOUBLE_EQ(c.height, 0.25 * 32.0 / 128.0);
}

TEST(mean_covered_difference, AveragesRgbWhereBothAreCovered) {
    ImageF a{2, 1, 4, {1, 1, 1, 1, 0.5f, 0.5f, 0.5f, 1}}, b{2, 1, 4, {0.5f, 1, 1, 1, 0, 0, 0, 0}};
    EXPECT_DOUBLE_EQ(mean_covered_difference(a, b), 0.5 / 3); // only pixel 0: |1 − 0.5| in one of 3 channels
    EXPECT_TRUE(std::isnan(mean_covered_difference(a, ImageF{1, 1, 4, {0, 0, 0, 1}})));
}

TEST(mask_iou, CountsIntersectionOverUnion) {
    ImageF a{4, 1, 1, {1, 1, 0, 0}}, b{4, 1, 1, {0, 1, 1, 0}}, empty{4, 1, 1, {0, 0, 0, 0}};
    EXPECT_DOUBLE_EQ(mask_iou(a, b), 1.0 / 3);
    EXPECT_DOUBLE_EQ(mask_iou(a, a), 1.0);
    EXPECT_DOUBLE_EQ(mask_iou(empty, empty), 1.0);
    EXPECT_TRUE(std::isnan(mask_iou(a, ImageF{2, 2, 1, {1, 1, 0, 0}})));
}

TEST(mean_absolute_difference, AveragesOverPixelsAndChannels) {
    ImageF a{2, 1, 2, {0, 1, 0.5f, 0.5f}}, b{2, 1, 2, {1, 1, 0.5f, 0}};
    EXPECT_DOUBLE_EQ(mean_absolute_difference(a, b), 1.5 / 4);
    EXPECT_TRUE(std::isnan(mean_absolute_difference(a, ImageF{1, 2, 2, {0, 0, 0, 0}})));
}

TEST(silhouette_mask, ThresholdsTheLastChannel) {
    ImageF rgba{2, 1, 4, {1, 1, 1, 0.2f, 0, 0, 0, 0.9f}};
    ImageF m = silhouette_mask(rgba);
    EXPECT_EQ(m.channels, 1);
    EXPECT_EQ(m.pixels, (std::vector<float>{0, 1}));
    EXPECT_EQ(mask_area(m), 1u);
}

} // namespace
} // namespace furrow

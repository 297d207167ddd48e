// Image-side helpers of the verification rasterizer: the heat-map colours and legend, and the image metrics
// of render.h.
//
// References:
//   Viridis: van der Walt & Smith, matplotlib (2015) — perceptually uniform and readable in greyscale.
//   Legend text: stb_easy_font (S. Barrett, public domain), rasterized here as axis-aligned quads.
#include "render_internal.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <stb_easy_font.h>

namespace furrow {

ImageF silhouette_mask(const ImageF& image, float alpha_threshold) {
    ImageF m{image.width, image.height, 1, {}};
    size_t n = size_t(image.width) * size_t(image.height);
    if (image.channels < 1 || image.pixels.size() != n * size_t(image.channels)) return m;
    m.pixels.resize(n);
    for (size_t i = 0; i < n; ++i)
        m.pixels[i] = image.pixels[i * size_t(image.channels) + size_t(image.channels - 1)] > alpha_threshold ? 1.0f : 0.0f;
    return m;
}

size_t mask_area(const ImageF& mask) {
    return size_t(std::count_if(mask.pixels.begin(), mask.pixels.end(), [](float v) { return v > 0.5f; }));
}

double mask_iou(const ImageF& a, const ImageF& b) {
    if (a.width != b.width || a.height != b.height || a.channels != 1 || b.channels != 1 ||
        a.pixels.size() != b.pixels.size())
        return std::nan("");
    size_t both = 0, either = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) {
        bool x = a.pixels[i] > 0.5f, y = b.pixels[i] > 0.5f;
        both += x && y;
        either += x || y;
    }
    return either ? double(both) / double(either) : 1.0;
}

double mean_absolute_difference(const ImageF& a, const ImageF& b) {
    if (a.width != b.width || a.height != b.height || a.channels != b.channels || a.pixels.size() != b.pixels.size())
        return std::nan("");
    if (a.pixels.empty()) return 0;
    double sum = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) sum += std::abs(double(a.pixels[i]) - double(b.pixels[i]));
    return sum / double(a.pixels.size());
}

double mean_covered_difference(const ImageF& a, const ImageF& b) {
    if (a.width != b.width || a.height != b.height || a.channels != 4 || b.channels != 4 ||
        a.pixels.size() != b.pixels.size())
        return std::nan("");
    double sum = 0;
    size_t n = 0;
    for (size_t i = 0; i + 3 < a.pixels.size(); i += 4) {
        if (!(a.pixels[i + 3] > 0.5f && b.pixels[i + 3] > 0.5f)) continue;
        for (size_t c = 0; c < 3; ++c) sum += std::abs(double(a.pixels[i + c]) - double(b.pixels[i + c]));
        ++n;
    }
    return n ? sum / double(3 * n) : 0.0;
}

CutoffCoverage cutoff_coverage(const ImageF& image) {
    CutoffCoverage r;
    const size_t n = size_t(image.width) * size_t(image.height);
    if (image.channels != 4 || image.pixels.size() != 4 * n || n == 0) return {std::nan(""), std::nan("")};
    for (size_t i = 0; i < n; ++i) {
        const float* p = &image.pixels[4 * i];
        if (!(p[3] > 0.5f) || !(p[0] > 0.5f / 255.0f)) continue;
        r.covered += 1;
        r.height += p[0];
    }
    r.covered /= double(n);
    r.height /= double(n);
    return r;
}

namespace render_detail {

std::array<float, 3> viridis(float t) {
    static constexpr unsigned char stops[11][3] = { // matplotlib viridis at 0, 0.1, ..., 1 (sRGB)
        {0x44, 0x01, 0x54}, {0x48, 0x24, 0x75}, {0x41, 0x44, 0x87}, {0x35, 0x5F, 0x8D},
        {0x2A, 0x78, 0x8E}, {0x21, 0x91, 0x8C}, {0x22, 0xA8, 0x84}, {0x44, 0xBF, 0x70},
        {0x7A, 0xD1, 0x51}, {0xBD, 0xDF, 0x26}, {0xFD, 0xE7, 0x25}};
    float x = std::clamp(t, 0.0f, 1.0f) * 10;
    int i = std::min(int(x), 9);
    float f = x - float(i);
    std::array<float, 3> r;
    for (size_t c = 0; c < 3; ++c) r[c] = (stops[i][c] + f * (stops[i + 1][c] - stops[i][c])) / 255.0f;
    return r;
}

namespace {
// Straight-alpha "over" of one colour onto a pixel.
void blend_pixel(ImageF& img, int x, int y, std::array<float, 3> rgb, float a) {
    if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
    float* p = &img.pixels[4 * (size_t(y) * size_t(img.width) + size_t(x))];
    float out_a = a + p[3] * (1 - a);
    for (int c = 0; c < 3; ++c)
        p[c] = out_a > 0 ? (rgb[size_t(c)] * a + p[c] * p[3] * (1 - a)) / out_a : 0.0f;
    p[3] = out_a;
}
void fill_rect(ImageF& img, int x0, int y0, int x1, int y1, std::array<float, 3> rgb, float a) {
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) blend_pixel(img, x, y, rgb, a);
}
int text_width(const std::string& s) { return stb_easy_font_width(const_cast<char*>(s.c_str())); }
void draw_text(ImageF& img, int x, int y, int scale, const std::string& s) {
    std::vector<char> buffer(300 * (s.size() + 1));
    int quads = stb_easy_font_print(0, 0, const_cast<char*>(s.c_str()), nullptr, buffer.data(), int(buffer.size()));
    for (int q = 0; q < quads; ++q) {
        float corner[2][2];
        for (int k = 0; k < 2; ++k) std::copy_n(reinterpret_cast<const float*>(&buffer[size_t(q * 4 + 2 * k) * 16]), 2, corner[k]);
        fill_rect(img, x + int(corner[0][0]) * scale, y + int(corner[0][1]) * scale, x + int(corner[1][0]) * scale,
                  y + int(corner[1][1]) * scale, {1, 1, 1}, 1);
    }
}
std::string label(float v) {
    char s[32];
    std::snprintf(s, sizeof s, "%.4g", double(v));
    return s;
}
} // namespace

namespace {
struct LegendLayout {
    int k, bar_w, bar_h, margin, text_w, text_h;
    std::string top, bottom;
};
LegendLayout legend_layout(int height, float lo, float hi) {
    LegendLayout l;
    l.k = std::max(1, height / 250); // text and bar scale
    l.bar_w = 10 * l.k, l.bar_h = std::max(16, height / 2), l.margin = 8 * l.k;
    l.top = label(hi), l.bottom = label(lo);
    l.text_w = std::max(text_width(l.top), text_width(l.bottom)) * l.k, l.text_h = 7 * l.k;
    return l;
}
} // namespace

int legend_width(int height, float lo, float hi) {
    LegendLayout l = legend_layout(height, lo, hi);
    return l.bar_w + l.text_w + 3 * l.margin;
}

void draw_legend(ImageF& img, float lo, float hi) {
    LegendLayout l = legend_layout(img.height, lo, hi);
    int k = l.k, margin = l.margin;
    int bar_x = img.width - margin - l.bar_w, bar_y = (img.height - l.bar_h) / 2;
    int panel_x = bar_x - l.text_w - 3 * margin / 2;
    fill_rect(img, panel_x, bar_y - l.text_h - margin, img.width - margin / 2, bar_y + l.bar_h + margin, {0.05f, 0.05f, 0.05f}, 0.7f);
    for (int y = 0; y < l.bar_h; ++y)
        fill_rect(img, bar_x, bar_y + y, bar_x + l.bar_w, bar_y + y + 1, viridis(1.0f - float(y) / float(l.bar_h - 1)), 1);
    draw_text(img, bar_x - margin / 2 - text_width(l.top) * k, bar_y - l.text_h / 2, k, l.top);
    draw_text(img, bar_x - margin / 2 - text_width(l.bottom) * k, bar_y + l.bar_h - l.text_h / 2, k, l.bottom);
}

} // namespace render_detail
} // namespace furrow

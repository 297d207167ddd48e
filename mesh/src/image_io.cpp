// PNG/JPEG decoding and PNG encoding with stb_image / stb_image_write (compiled in tinygltf_impl.cpp).
#include "atomic_file.h"

#include <furrow/mesh.h>
#include <furrow/render.h> // linear_to_srgb
#include <stb_image.h>
#include <stb_image_write.h>

#include <cmath>
#include <fstream>
#include <iterator>

namespace furrow {

Status decode_image(ImageF& out, const uint8_t* data, size_t size) {
    if (size == 0 || size > size_t(INT32_MAX)) return Status::error(StatusCode::invalid_input, "image is empty or too large");
    int w = 0, h = 0, c = 0;
    if (!stbi_info_from_memory(data, int(size), &w, &h, &c))
        return Status::error(StatusCode::invalid_input, std::string("not a readable PNG/JPEG image (") + stbi_failure_reason() + ")");
    if (w <= 0 || h <= 0 || size_t(w) * size_t(h) > (size_t(1) << 28))
        return Status::error(StatusCode::out_of_memory, "image is " + std::to_string(w) + "x" + std::to_string(h) + ", too large");
    ImageF img;
    if (stbi_is_16_bit_from_memory(data, int(size))) {
        stbi_us* px = stbi_load_16_from_memory(data, int(size), &w, &h, &c, 0);
        if (!px) return Status::error(StatusCode::invalid_input, std::string("image decode failed: ") + stbi_failure_reason());
        img.pixels.resize(size_t(w) * size_t(h) * size_t(c));
        for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = float(px[i]) / 65535.0f;
        stbi_image_free(px);
    } else {
        stbi_uc* px = stbi_load_from_memory(data, int(size), &w, &h, &c, 0);
        if (!px) return Status::error(StatusCode::invalid_input, std::string("image decode failed: ") + stbi_failure_reason());
        img.pixels.resize(size_t(w) * size_t(h) * size_t(c));
        for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = float(px[i]) / 255.0f;
        stbi_image_free(px);
    }
    img.width = w;
    img.height = h;
    img.channels = c;
    out = std::move(img);
    return Status::success();
}

Status load_png(ImageF& out, const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return Status::error(StatusCode::io_error, "cannot open image");
    std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
    return decode_image(out, bytes.data(), bytes.size());
}

std::vector<uint8_t> encode_png_rgba8(const uint8_t* rgba, int width, int height) {
    std::vector<uint8_t> out;
    stbi_write_png_to_func(
        [](void* ctx, void* data, int size) {
            auto* v = static_cast<std::vector<uint8_t>*>(ctx);
            v->insert(v->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
        },
        &out, width, height, 4, rgba, width * 4);
    return out;
}

Status save_png(const std::string& path, const ImageF& image, bool srgb_encode) {
    if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 ||
        image.pixels.size() != size_t(image.width) * size_t(image.height) * size_t(image.channels))
        return Status::error(StatusCode::invalid_argument, "image has inconsistent size");
    std::vector<uint8_t> px(image.pixels.size());
    for (size_t i = 0; i < px.size(); ++i) {
        float x = image.pixels[i];
        if (!std::isfinite(x)) x = 0;
        x = std::min(1.0f, std::max(0.0f, x));
        // Alpha (4th channel of RGBA, 2nd of grey+alpha) is never sRGB-encoded.
        bool alpha = (image.channels == 4 && i % 4 == 3) || (image.channels == 2 && i % 2 == 1);
        if (srgb_encode && !alpha) x = linear_to_srgb(x);
        px[i] = uint8_t(std::lround(x * 255.0f));
    }
    std::vector<uint8_t> out;
    stbi_write_png_to_func(
        [](void* ctx, void* data, int size) {
            auto* v = static_cast<std::vector<uint8_t>*>(ctx);
            v->insert(v->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
        },
        &out, image.width, image.height, image.channels, px.data(), image.width * image.channels);
    if (out.empty()) return Status::error(StatusCode::io_error, "PNG encoding failed");
    return detail::atomic_write(path, out.data(), out.size());
}

} // namespace furrow

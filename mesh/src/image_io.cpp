// PNG/JPEG decoding and PNG encoding with stb_image / stb_image_write (compiled in tinygltf_impl.cpp).
#include "document.h"

#include <furrow/mesh.h>
#include <furrow_kernel/atomic_file.h>
#include <furrow_kernel/no_throw.h>
#include <stb_image.h>
#include <stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

namespace furrow {

namespace {

// stb_image 2.27 (Debian 12's libstb) trusts the code counts of a JPEG Huffman table (DHT): 16 counts of up to
// 255 each fill a 257-entry size list and a 256-entry value list, so a corrupt table writes up to 4 KB past
// them (found by fuzz_heightmap; upstream added the same "n > 256" check in stb_image 2.28). The markers are
// walked the way stb_image walks them (ITU-T T.81 §B.1.1: segments carry their length, entropy-coded data
// only holds 0xFF as 0xFF00 or a restart marker RSTn) and every table of every DHT segment is checked.
bool jpeg_huffman_tables_ok(const uint8_t* p, size_t n) {
    size_t i = 2; // after SOI
    while (i + 1 < n) {
        if (p[i] != 0xFF) { // entropy-coded data, or junk stb_image skips the same way
            ++i;
            continue;
        }
        const uint8_t m = p[i + 1];
        if (m == 0xFF) { // fill byte
            ++i;
            continue;
        }
        if (m == 0x00 || m == 0x01 || m == 0xD8 || (m >= 0xD0 && m <= 0xD7)) { // stuffing, TEM, SOI, RSTn
            i += 2;
            continue;
        }
        if (m == 0xD9 || i + 3 >= n) break; // EOI, or a truncated segment (stb_image fails on it by itself)
        const size_t length = size_t(p[i + 2]) << 8 | p[i + 3];
        if (m == 0xC4) {
            // As stb_image reads it: tables while the segment has length left, each read whole even when it
            // runs past the segment (or the file, where stb_image reads zeros).
            long left = long(length) - 2;
            size_t at = i + 4;
            while (left > 0 && at < n) {
                size_t codes = 0;
                for (size_t k = 1; k <= 16 && at + k < n; ++k) codes += p[at + k];
                if (codes > 256) return false;
                left -= long(17 + codes);
                at += 17 + codes;
            }
        }
        i += 2 + length;
    }
    return true;
}

} // namespace

bool mesh_detail::image_dimensions(const uint8_t* data, size_t size, int& width, int& height) {
    if (size == 0 || size > size_t(INT32_MAX)) return false;
    size_t soi = 0;
    while (soi < size && data[soi] == 0xFF) ++soi;
    if (soi > 0 && soi < size && data[soi] == 0xD8 && !jpeg_huffman_tables_ok(data + soi - 1, size - soi + 1)) return false;
    int c = 0;
    if (stbi_info_from_memory(data, int(size), &width, &height, &c)) return true;
    // stb_image refuses a PNG header of more than 2^30 bytes of pixels without saying its size: the IHDR
    // chunk's own (PNG §11.2.2), so that the caller's limit names it.
    static const uint8_t png[] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
    if (size < 24 || std::memcmp(data, png, 8) != 0 || std::memcmp(data + 12, "IHDR", 4) != 0) return false;
    auto be32 = [&](size_t at) { return uint32_t(data[at]) << 24 | uint32_t(data[at + 1]) << 16 | uint32_t(data[at + 2]) << 8 | data[at + 3]; };
    width = int(std::min<uint32_t>(be32(16), INT32_MAX));
    height = int(std::min<uint32_t>(be32(20), INT32_MAX));
    return true;
}

namespace {
Status decode_image_unguarded(ImageF& out, const uint8_t* data, size_t size) {
    if (size == 0 || size > size_t(INT32_MAX)) return Status::error(StatusCode::invalid_input, "image is empty or too large");
    // JPEG as stb_image recognises it: SOI after any number of 0xFF fill bytes (fuzz_heightmap got past a
    // check that wanted FF D8 at byte 0).
    size_t soi = 0;
    while (soi < size && data[soi] == 0xFF) ++soi;
    if (soi > 0 && soi < size && data[soi] == 0xD8 && !jpeg_huffman_tables_ok(data + soi - 1, size - soi + 1))
        return Status::error(StatusCode::invalid_input, "corrupt JPEG: a Huffman table defines more than 256 codes");
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
} // namespace

Status decode_image(ImageF& out, const uint8_t* data, size_t size) {
    return kernel::no_throw("decoding the image", [&] { return decode_image_unguarded(out, data, size); });
}

namespace {
Status load_png_unguarded(ImageF& out, const std::string& path) {
    // A folder opens as an ifstream on Linux and then throws from the read (basic_filebuf::underflow), which
    // reached the CLI as an internal error (exit 3) for `--mask some_folder`: refuse it up front.
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) return Status::error(StatusCode::io_error, "is a directory, not an image");
    std::ifstream in(path, std::ios::binary);
    if (!in) return Status::error(StatusCode::io_error, "cannot open image");
    std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
    return decode_image(out, bytes.data(), bytes.size());
}
} // namespace

Status load_png(ImageF& out, const std::string& path) {
    return kernel::no_throw("reading the image", [&] { return load_png_unguarded(out, path); });
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

namespace {
Status save_png_unguarded(const ImageF& image, const std::string& path, bool srgb_encode) {
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
    return kernel::atomic_write(path, out.data(), out.size());
}
} // namespace

Status save_png(const ImageF& image, const std::string& path, bool srgb_encode) {
    return kernel::no_throw("writing the image", [&] { return save_png_unguarded(image, path, srgb_encode); });
}

} // namespace furrow

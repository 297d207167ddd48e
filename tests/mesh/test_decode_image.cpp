// decode_image: PNG and JPEG only, and corrupt JPEG Huffman tables refused before stb_image sees them.
#include "test_support.h"

#include <furrow/mesh.h>

using namespace furrow;

namespace {

void put32(std::vector<uint8_t>& b, uint32_t v) {
    for (int k = 0; k < 4; ++k) b.push_back(uint8_t(v >> (8 * k)));
}

// A 1 × 1 24-bit BMP (BITMAPINFOHEADER), one red pixel.
std::vector<uint8_t> bmp_1x1() {
    std::vector<uint8_t> b{'B', 'M'};
    put32(b, 58), put32(b, 0), put32(b, 54);
    put32(b, 40), put32(b, 1), put32(b, 1);
    b.insert(b.end(), {1, 0, 24, 0});
    put32(b, 0), put32(b, 4), put32(b, 2835), put32(b, 2835), put32(b, 0), put32(b, 0);
    b.insert(b.end(), {0, 0, 255, 0}); // B G R, padded to 4 bytes
    return b;
}

} // namespace

TEST(decode_image, PngAndJpegOnly) {
    const uint8_t rgba[4] = {255, 0, 0, 255};
    const std::vector<uint8_t> png = encode_png_rgba8(rgba, 1, 1);
    ImageF im;
    ASSERT_TRUE(decode_image(im, png.data(), png.size()).ok());
    EXPECT_EQ(im.width, 1);
    EXPECT_EQ(im.channels, 4);
    EXPECT_EQ(im.pixels[0], 1.0f);
    // stb_image reads BMP too (and GIF, PSD, PIC, PNM, HDR, TGA), with known memory-safety bugs in its
    // Debian 12 version; glTF and the documentation allow PNG and JPEG only, and so does the decoder now.
    const std::vector<uint8_t> bmp = bmp_1x1();
    Status s = decode_image(im, bmp.data(), bmp.size());
    EXPECT_EQ(s.code, StatusCode::invalid_input);
    EXPECT_NE(s.message.find("PNG/JPEG"), std::string::npos) << s.message;
}

// A DHT segment whose 16 code counts add up to more than 256: stb_image 2.27 writes them past its 257-entry
// tables (found by fuzz_heightmap). Refused with its own message before stb_image runs; the same counts
// adding up to 256 are not this error.
TEST(decode_image, JpegHuffmanTableWithMoreThan256CodesIsRefused) {
    auto jpeg = [](uint8_t count) {
        std::vector<uint8_t> b{0xFF, 0xD8, 0xFF, 0xC4};
        const size_t codes = size_t(count) * 16;
        const size_t length = 2 + 17 + codes;
        b.push_back(uint8_t(length >> 8)), b.push_back(uint8_t(length));
        b.push_back(0x00); // DC table 0
        for (int k = 0; k < 16; ++k) b.push_back(count);
        for (size_t k = 0; k < codes; ++k) b.push_back(uint8_t(k));
        b.insert(b.end(), {0xFF, 0xD9});
        return b;
    };
    ImageF im;
    const std::vector<uint8_t> bad = jpeg(17); // 272 codes
    Status s = decode_image(im, bad.data(), bad.size());
    EXPECT_EQ(s.code, StatusCode::invalid_input);
    EXPECT_NE(s.message.find("Huffman"), std::string::npos) << s.message;
    // stb_image skips 0xFF fill bytes before SOI, and so must the check.
    std::vector<uint8_t> filled(40, 0xFF);
    filled.insert(filled.end(), bad.begin() + 1, bad.end());
    s = decode_image(im, filled.data(), filled.size());
    EXPECT_EQ(s.code, StatusCode::invalid_input);
    EXPECT_NE(s.message.find("Huffman"), std::string::npos) << s.message;
    const std::vector<uint8_t> full = jpeg(16); // 256 codes: legal counts (the file is still no image)
    s = decode_image(im, full.data(), full.size());
    EXPECT_EQ(s.code, StatusCode::invalid_input);
    EXPECT_EQ(s.message.find("Huffman"), std::string::npos) << s.message;
}

// Fuzz target: the image readers — load_heightmap (.pfm, and 16-bit .png with its furrow-heightmap text
// chunk; deform/src/heightmap_io.cpp) and decode_image (PNG/JPEG through stb_image; masks, brushes, glTF
// textures).
//
// Input: byte 0 picks the reader (value mod 3: .pfm, .png heightmap, decode_image); the rest is the file.
// load_heightmap takes a path, so the bytes go through a per-process scratch file.
// Properties: a heightmap loads with a Status error or with width × height finite values and a frame that
// is either empty (texel 0) or finite with texel > 0; it saves again in its own format, and a PFM reloads
// bit-identical. A decoded image has 1..4 channels and width × height × channels values in [0, 1].
#include "fuzz_common.h"

#include <furrow/deform.h>

#include <cmath>
#include <cstdio>

using namespace furrow;

namespace {

bool write_file(const std::string& path, const uint8_t* data, size_t size) {
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return false;
    const bool ok = std::fwrite(data, 1, size, f) == size;
    return std::fclose(f) == 0 && ok;
}

bool finite3(const std::array<double, 3>& a) { return std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2]); }

void check_heightmap(const Heightmap& hm) {
    const HeightmapFrame& f = hm.frame;
    FUZZ_CHECK(f.width >= 1 && f.height >= 1 && hm.values.size() == size_t(f.width) * size_t(f.height),
               "heightmap %dx%d with %zu values", f.width, f.height, hm.values.size());
    FUZZ_CHECK(fuzz::finite(hm.values), "a loaded heightmap holds a non-finite value");
    FUZZ_CHECK(f.texel == 0 || (std::isfinite(f.texel) && f.texel > 0), "texel %g", f.texel);
    if (f.texel > 0)
        FUZZ_CHECK(finite3(f.origin) && finite3(f.axis_u) && finite3(f.axis_v) && finite3(f.up), "non-finite frame");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1 || size > 256 * 1024) return 0;
    const int reader = data[0] % 3;
    if (!fuzz::small_image(data + 1, size - 1)) return 0;
    if (reader == 2) {
        ImageF im;
        Status s = decode_image(im, data + 1, size - 1);
        if (!s.ok()) {
            fuzz::rejected("decode_image", s);
            return 0;
        }
        FUZZ_CHECK(im.width >= 1 && im.height >= 1 && im.channels >= 1 && im.channels <= 4, "image %dx%dx%d", im.width,
                   im.height, im.channels);
        FUZZ_CHECK(im.pixels.size() == size_t(im.width) * size_t(im.height) * size_t(im.channels), "pixel count");
        for (float v : im.pixels) FUZZ_CHECK(v >= 0 && v <= 1, "pixel value %g", double(v));
        return 0;
    }
    const std::string ext = reader == 0 ? ".pfm" : ".png";
    const std::string path = fuzz::scratch_path("heightmap" + ext);
    if (!write_file(path, data + 1, size - 1)) return 0;
    Heightmap hm;
    Status s = load_heightmap(hm, path);
    std::remove(path.c_str());
    if (!s.ok()) {
        fuzz::rejected("load_heightmap", s);
        return 0;
    }
    check_heightmap(hm);

    const std::string out = fuzz::scratch_path("heightmap-out" + ext);
    s = save_heightmap(hm, out);
    FUZZ_CHECK(s.ok(), "a loaded heightmap does not save: %s", s.message.c_str());
    Heightmap again;
    s = load_heightmap(again, out);
    std::remove(out.c_str());
    FUZZ_CHECK(s.ok(), "a saved heightmap does not load: %s", s.message.c_str());
    check_heightmap(again);
    FUZZ_CHECK(again.frame.width == hm.frame.width && again.frame.height == hm.frame.height, "size changed on a round trip");
    if (reader == 0)
        for (size_t k = 0; k < hm.values.size(); ++k)
            FUZZ_CHECK(again.values[k] == hm.values[k], "PFM round trip changed texel %zu: %g -> %g", k, double(hm.values[k]),
                       double(again.values[k]));
    return 0;
}

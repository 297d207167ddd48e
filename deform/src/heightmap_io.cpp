// Heightmap files: float32 PFM, or 16-bit grey PNG with its scale recorded.
//
// References: Portable Float Map (P. Debevec's HDRShop format; netpbm "pfm"): "Pf\n<w> <h>\n<scale>\n" then
// float32 rows bottom to top, little-endian when scale < 0. PNG: ISO/IEC 15948 (W3C PNG 2nd edition) —
// IHDR, tEXt, IDAT (zlib, RFC 1950/1951), IEND, CRC-32 per chunk. The PNG encoder writes stored (uncompressed)
// deflate blocks: a heightmap is written once per run, and a dependency on zlib would have to travel with
// the installed package. 8-bit storage is not offered: at a few centimetres of depth, 256 levels show steps
// (field notes). Both files carry the frame as JSON so a later run places the map exactly. They are written
// as meshes and images are (furrow_kernel/atomic_file.h): all or nothing, into an existing folder.
#include "deform_internal.h"

#include <furrow_kernel/atomic_file.h>
#include <furrow_kernel/no_throw.h>

#include <nlohmann/json.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>

namespace furrow {
namespace {

using nlohmann::json;

json frame_json(const HeightmapFrame& f) {
    return json{{"origin", f.origin}, {"axis_u", f.axis_u}, {"axis_v", f.axis_v}, {"up", f.up}, {"texel", f.texel},
                {"width", f.width}, {"height", f.height}};
}

Status frame_from_json(HeightmapFrame& f, const json& j, int width, int height) {
    try {
        // texel 0 is the empty frame of a map that had none (a plain PFM): save_heightmap records it as it is,
        // so it must load back as the same empty frame, to be stretched over the grid it is applied to.
        // (Found by fuzz_heightmap: such a map saved fine and then failed to load.)
        if (j.at("texel").is_number() && j.at("texel").get<double>() == 0.0) {
            f = HeightmapFrame{};
            f.width = width, f.height = height;
            return Status::success();
        }
        auto v3 = [&](const char* k) {
            std::array<double, 3> a = j.at(k).get<std::array<double, 3>>();
            for (double x : a)
                if (!std::isfinite(x)) throw std::runtime_error(std::string(k) + " is not finite");
            return a;
        };
        f.origin = v3("origin"), f.axis_u = v3("axis_u"), f.axis_v = v3("axis_v"), f.up = v3("up");
        f.texel = j.at("texel").get<double>();
        if (!(f.texel > 0) || !std::isfinite(f.texel)) throw std::runtime_error("texel must be > 0");
        f.width = width, f.height = height;
    } catch (const std::exception& e) {
        return Status::error(StatusCode::invalid_input, std::string("bad furrow-heightmap metadata: ") + e.what());
    }
    return Status::success();
}

// ---- PNG -------------------------------------------------------------------------------------------------
uint32_t crc32(const uint8_t* p, size_t n, uint32_t crc = 0) {
    static const auto table = [] {
        std::array<uint32_t, 256> t{};
        for (uint32_t i = 0; i < 256; ++i) {
            uint32_t c = i;
            for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            t[i] = c;
        }
        return t;
    }();
    crc = ~crc;
    for (size_t i = 0; i < n; ++i) crc = table[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
    return ~crc;
}

void put32(std::vector<uint8_t>& o, uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) o.push_back(uint8_t(v >> s));
}

void chunk(std::vector<uint8_t>& o, const char* type, const std::vector<uint8_t>& data) {
    put32(o, uint32_t(data.size()));
    const size_t start = o.size();
    o.insert(o.end(), type, type + 4);
    o.insert(o.end(), data.begin(), data.end());
    put32(o, crc32(&o[start], o.size() - start));
}

std::vector<uint8_t> encode_png16(const std::vector<uint16_t>& px, int w, int h, const std::string& text_key,
                                  const std::string& text) {
    std::vector<uint8_t> o = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    std::vector<uint8_t> ihdr;
    put32(ihdr, uint32_t(w));
    put32(ihdr, uint32_t(h));
    ihdr.insert(ihdr.end(), {16, 0, 0, 0, 0}); // 16-bit, grey, deflate, filter 0, no interlace
    chunk(o, "IHDR", ihdr);
    std::vector<uint8_t> t(text_key.begin(), text_key.end());
    t.push_back(0);
    t.insert(t.end(), text.begin(), text.end());
    chunk(o, "tEXt", t);
    // Raw scanlines: filter byte 0, then big-endian samples.
    std::vector<uint8_t> raw;
    raw.reserve(size_t(h) * (1 + 2 * size_t(w)));
    for (int j = 0; j < h; ++j) {
        raw.push_back(0);
        for (int i = 0; i < w; ++i) {
            uint16_t v = px[size_t(j) * size_t(w) + size_t(i)];
            raw.push_back(uint8_t(v >> 8));
            raw.push_back(uint8_t(v & 0xFF));
        }
    }
    std::vector<uint8_t> z = {0x78, 0x01};
    uint32_t a = 1, b = 0; // Adler-32
    for (uint8_t c : raw) a = (a + c) % 65521, b = (b + a) % 65521;
    size_t pos = 0;
    do {
        const size_t n = std::min<size_t>(65535, raw.size() - pos);
        const bool last = pos + n == raw.size();
        z.push_back(last ? 1 : 0);
        z.push_back(uint8_t(n & 0xFF));
        z.push_back(uint8_t(n >> 8));
        z.push_back(uint8_t(~n & 0xFF));
        z.push_back(uint8_t((~n >> 8) & 0xFF));
        z.insert(z.end(), raw.begin() + long(pos), raw.begin() + long(pos + n));
        pos += n;
    } while (pos < raw.size());
    put32(z, (b << 16) | a);
    chunk(o, "IDAT", z);
    chunk(o, "IEND", {});
    return o;
}

// The text of a tEXt chunk with `key`, or "".
std::string png_text(const std::vector<uint8_t>& bytes, const std::string& key) {
    size_t p = 8;
    while (p + 12 <= bytes.size()) {
        const uint32_t len = (uint32_t(bytes[p]) << 24) | (uint32_t(bytes[p + 1]) << 16) | (uint32_t(bytes[p + 2]) << 8) | bytes[p + 3];
        if (p + 12 + size_t(len) > bytes.size()) break;
        const std::string type(bytes.begin() + long(p + 4), bytes.begin() + long(p + 8));
        if (type == "tEXt") {
            const std::string body(bytes.begin() + long(p + 8), bytes.begin() + long(p + 8 + len));
            const size_t nul = body.find('\0');
            if (nul != std::string::npos && body.substr(0, nul) == key) return body.substr(nul + 1);
        }
        if (type == "IEND") break;
        p += 12 + size_t(len);
    }
    return {};
}

std::string lower_ext(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
    return e;
}

const char* kKey = "furrow-heightmap";

} // namespace

Status save_heightmap(const Heightmap& hm, const std::string& path) {
    return kernel::no_throw("writing the heightmap", [&]() -> Status {
        const int w = hm.frame.width, h = hm.frame.height;
        if (w <= 0 || h <= 0 || hm.values.size() != size_t(w) * size_t(h))
            return Status::error(StatusCode::invalid_argument, "the heightmap is empty or its size does not match its frame");
        const std::string ext = lower_ext(path);
        json meta = frame_json(hm.frame);
        std::vector<uint8_t> bytes;
        if (ext == ".pfm") {
            const std::string header = "Pf\n" + std::to_string(w) + " " + std::to_string(h) + "\n-1.0\n";
            bytes.assign(header.begin(), header.end());
            bytes.reserve(bytes.size() + hm.values.size() * 4 + 512);
            for (int j = h - 1; j >= 0; --j)
                for (int i = 0; i < w; ++i) {
                    float v = hm.at(i, j);
                    uint8_t b[4];
                    std::memcpy(b, &v, 4); // little-endian hosts only (x86-64, AArch64)
                    bytes.insert(bytes.end(), b, b + 4);
                }
            const std::string tail = "\n# " + std::string(kKey) + " " + meta.dump() + "\n";
            bytes.insert(bytes.end(), tail.begin(), tail.end());
        } else if (ext == ".png") {
            float lo = 0, hi = 0;
            for (float v : hm.values) {
                if (!std::isfinite(v)) return Status::error(StatusCode::invalid_argument, "the heightmap holds a non-finite value");
                lo = std::min(lo, v), hi = std::max(hi, v);
            }
            // Zero (untouched snow) is made an exact level, so that a reload can restore it exactly.
            const double scale = hi > lo ? double(hi) - double(lo) : 1.0;
            const double step = scale / 65535.0;
            const long zero = std::lround(-double(lo) / step);
            const double offset = -double(zero) * step;
            meta["offset"] = offset;
            meta["scale"] = scale;
            std::vector<uint16_t> px(hm.values.size());
            for (size_t k = 0; k < px.size(); ++k)
                px[k] = uint16_t(std::clamp(std::lround((double(hm.values[k]) - offset) / step), 0L, 65535L));
            bytes = encode_png16(px, w, h, kKey, meta.dump());
        } else {
            return Status::error(StatusCode::invalid_argument, "heightmap files must end in .pfm (float) or .png (16-bit)");
        }
        return kernel::atomic_write(path, bytes.data(), bytes.size());
    });
}

Status load_heightmap(Heightmap& out, const std::string& path) {
    return kernel::no_throw("reading the heightmap", [&]() -> Status {
        const std::string ext = lower_ext(path);
        // A folder opens as an ifstream and then throws from the read: refuse it here (it was exit 3, internal).
        std::error_code dir_ec;
        if (std::filesystem::is_directory(path, dir_ec))
            return Status::error(StatusCode::io_error, "is a directory, not a heightmap file");
        std::ifstream in(path, std::ios::binary);
        if (!in) return Status::error(StatusCode::io_error, "cannot open the heightmap");
        std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
        Heightmap hm;
        if (ext == ".pfm") {
            // Header: three whitespace-separated tokens after the magic, then exactly one whitespace byte.
            size_t p = 0;
            auto token = [&]() {
                while (p < bytes.size() && std::isspace(bytes[p])) ++p;
                size_t s = p;
                while (p < bytes.size() && !std::isspace(bytes[p])) ++p;
                return std::string(bytes.begin() + long(s), bytes.begin() + long(p));
            };
            const std::string magic = token();
            if (magic != "Pf" && magic != "PF") return Status::error(StatusCode::invalid_input, "not a PFM file (magic '" + magic.substr(0, 8) + "')");
            const int channels = magic == "PF" ? 3 : 1;
            long w = 0, h = 0;
            double scale = 0;
            try {
                w = std::stol(token());
                h = std::stol(token());
                scale = std::stod(token());
            } catch (...) {
                return Status::error(StatusCode::invalid_input, "malformed PFM header");
            }
            ++p; // the single whitespace byte before the raster
            if (w <= 0 || h <= 0 || w > (1 << 20) || h > (1 << 20) || scale == 0)
                return Status::error(StatusCode::invalid_input, "malformed PFM header (size or scale)");
            const size_t need = size_t(w) * size_t(h) * size_t(channels) * 4;
            if (p + need > bytes.size()) return Status::error(StatusCode::invalid_input, "PFM raster is truncated");
            hm.frame.width = int(w), hm.frame.height = int(h);
            hm.values.resize(size_t(w) * size_t(h));
            const bool big_endian = scale > 0;
            for (long r = 0; r < h; ++r)
                for (long i = 0; i < w; ++i) {
                    uint8_t b[4];
                    std::memcpy(b, &bytes[p + ((size_t(r) * size_t(w) + size_t(i)) * size_t(channels)) * 4], 4);
                    if (big_endian) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
                    float v;
                    std::memcpy(&v, b, 4);
                    if (!std::isfinite(v)) return Status::error(StatusCode::invalid_input, "PFM holds a non-finite value");
                    hm.values[size_t(h - 1 - r) * size_t(w) + size_t(i)] = v; // |scale| is not a multiplier in practice
                }
            const std::string tail(bytes.begin() + long(p + need), bytes.end());
            const size_t k = tail.find(std::string("# ") + kKey + " ");
            if (k != std::string::npos) {
                json meta;
                try {
                    meta = json::parse(tail.substr(k + 3 + std::strlen(kKey)));
                } catch (...) {
                    return Status::error(StatusCode::invalid_input, "bad furrow-heightmap metadata in the PFM");
                }
                Status s = frame_from_json(hm.frame, meta, int(w), int(h));
                if (!s.ok()) return s;
            }
        } else if (ext == ".png") {
            ImageF im;
            Status s = decode_image(im, bytes.data(), bytes.size());
            if (!s.ok()) return s;
            const std::string text = png_text(bytes, kKey);
            if (text.empty())
                return Status::error(StatusCode::invalid_input,
                                     "the PNG has no 'furrow-heightmap' text chunk, so its height scale is unknown (write it with "
                                     "furrow stamp --heightmap-out, or use a .pfm)");
            json meta;
            try {
                meta = json::parse(text);
            } catch (...) {
                return Status::error(StatusCode::invalid_input, "bad furrow-heightmap metadata in the PNG");
            }
            s = frame_from_json(hm.frame, meta, im.width, im.height);
            if (!s.ok()) return s;
            double offset = 0, scale = 0;
            try {
                offset = meta.at("offset").get<double>();
                scale = meta.at("scale").get<double>();
            } catch (...) {
                return Status::error(StatusCode::invalid_input, "the furrow-heightmap metadata lacks offset/scale");
            }
            hm.values.resize(size_t(im.width) * size_t(im.height));
            const double half_step = 0.5 * std::abs(scale) / 65535.0;
            for (size_t k = 0; k < hm.values.size(); ++k) {
                const double v = offset + scale * double(im.pixels[k * size_t(im.channels)]);
                hm.values[k] = std::abs(v) < half_step ? 0.0f : float(v); // the zero level is untouched snow
            }
        } else {
            return Status::error(StatusCode::invalid_argument, "heightmap files must end in .pfm (float) or .png (16-bit)");
        }
        out = std::move(hm);
        return Status::success();
    });
}

} // namespace furrow

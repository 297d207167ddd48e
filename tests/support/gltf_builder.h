// Hand-made glTF files for tests: a minimal JSON document with one data-URI buffer, so that a test can
// write exactly the (broken) bytes it needs.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace furrow::test {

inline std::string base64(const std::vector<uint8_t>& in) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    size_t i = 0;
    for (; i + 2 < in.size(); i += 3) {
        uint32_t v = (uint32_t(in[i]) << 16) | (uint32_t(in[i + 1]) << 8) | in[i + 2];
        out += t[v >> 18], out += t[(v >> 12) & 63], out += t[(v >> 6) & 63], out += t[v & 63];
    }
    if (i + 1 == in.size()) {
        uint32_t v = uint32_t(in[i]) << 16;
        out += t[v >> 18], out += t[(v >> 12) & 63], out += "==";
    } else if (i + 2 == in.size()) {
        uint32_t v = (uint32_t(in[i]) << 16) | (uint32_t(in[i + 1]) << 8);
        out += t[v >> 18], out += t[(v >> 12) & 63], out += t[(v >> 6) & 63], out += '=';
    }
    return out;
}

template <class T> void append_bytes(std::vector<uint8_t>& bytes, const std::vector<T>& v) {
    size_t at = bytes.size();
    bytes.resize(at + v.size() * sizeof(T));
    std::memcpy(bytes.data() + at, v.data(), v.size() * sizeof(T));
}

// One triangle-ish primitive: float VEC3 positions then uint16 indices in one buffer. `mode` and the
// numbers are written as given (no validation: that is the point).
struct TinyGltf {
    std::vector<float> positions{0, 0, 0, 1, 0, 0, 0, 1, 0};
    std::vector<uint16_t> indices{0, 1, 2};
    int mode = 4;
    bool min_max = true;
    std::string extra_top_level; // e.g. ,"extensionsRequired":["X"]

    std::string json() const {
        std::vector<uint8_t> bytes;
        append_bytes(bytes, positions);
        size_t pos_bytes = bytes.size();
        append_bytes(bytes, indices);
        while (bytes.size() % 4) bytes.push_back(0);
        size_t n = positions.size() / 3;
        std::string mm;
        if (min_max && n) {
            float lo[3] = {positions[0], positions[1], positions[2]}, hi[3] = {lo[0], lo[1], lo[2]};
            for (size_t i = 0; i < n; ++i)
                for (int k = 0; k < 3; ++k) {
                    lo[k] = std::min(lo[k], positions[i * 3 + size_t(k)]);
                    hi[k] = std::max(hi[k], positions[i * 3 + size_t(k)]);
                }
            auto f = [](float x) { return std::to_string(x); };
            mm = ",\"min\":[" + f(lo[0]) + "," + f(lo[1]) + "," + f(lo[2]) + "],\"max\":[" + f(hi[0]) + "," + f(hi[1]) +
                 "," + f(hi[2]) + "]";
        }
        std::string s = "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":" +
                        std::to_string(mode) +
                        "}]}],"
                        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":" +
                        std::to_string(n) + ",\"type\":\"VEC3\"" + mm +
                        "},"
                        "{\"bufferView\":1,\"componentType\":5123,\"count\":" +
                        std::to_string(indices.size()) +
                        ",\"type\":\"SCALAR\"}],"
                        "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":" +
                        std::to_string(pos_bytes) + "},{\"buffer\":0,\"byteOffset\":" + std::to_string(pos_bytes) +
                        ",\"byteLength\":" + std::to_string(indices.size() * 2) +
                        "}],"
                        "\"buffers\":[{\"byteLength\":" +
                        std::to_string(bytes.size()) + ",\"uri\":\"data:application/octet-stream;base64," +
                        base64(bytes) + "\"}]" + extra_top_level + "}";
        return s;
    }
};

} // namespace furrow::test

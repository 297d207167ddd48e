// STL (binary and ASCII). Not OpenMesh's reader: it drops facets whose corners coincide, and those
// degenerate facets are exactly what `furrow check` must report (Thingi10K 73342 has 20 of them).
// Corners are welded by exact position, as every STL reader does, to give an indexed mesh.
#include "document.h"

#include <charconv>
#include <cmath>
#include <cstring>
#include <map>

namespace furrow {

namespace {
bool next_token(const std::string& s, size_t& at, std::string_view& tok) {
    while (at < s.size() && std::isspace(static_cast<unsigned char>(s[at]))) ++at;
    size_t b = at;
    while (at < s.size() && !std::isspace(static_cast<unsigned char>(s[at]))) ++at;
    tok = std::string_view(s).substr(b, at - b);
    return !tok.empty();
}
} // namespace

Status load_stl_bytes(Scene& out, const std::string& bytes, const LoadOptions& options) {
    std::vector<float> soup; // 9 floats per facet
    bool binary = bytes.size() >= 84 && bytes.compare(0, 5, "solid") != 0;
    if (bytes.size() >= 84 && !binary) { // binary files may start with "solid" too: trust 84 + 50·n
        uint32_t n = 0;
        std::memcpy(&n, bytes.data() + 80, 4);
        binary = size_t(84) + size_t(n) * 50 == bytes.size();
    }
    if (binary) {
        uint32_t n = 0;
        std::memcpy(&n, bytes.data() + 80, 4);
        if (size_t(84) + size_t(n) * 50 > bytes.size())
            return Status::error(StatusCode::invalid_input, "binary STL is truncated: header says " + std::to_string(n) +
                                                                " facets, the file holds " +
                                                                std::to_string((bytes.size() - 84) / 50));
        soup.resize(size_t(n) * 9);
        for (size_t f = 0; f < n; ++f) std::memcpy(&soup[f * 9], bytes.data() + 84 + f * 50 + 12, 36);
    } else {
        size_t at = 0;
        std::string_view tok;
        if (!next_token(bytes, at, tok) || tok != "solid") return Status::error(StatusCode::invalid_input, "not an STL file");
        size_t corners = 0;
        while (next_token(bytes, at, tok)) {
            if (tok != "vertex") continue;
            for (int k = 0; k < 3; ++k) {
                std::string_view num;
                float v = 0;
                if (!next_token(bytes, at, num) ||
                    std::from_chars(num.data(), num.data() + num.size(), v).ec != std::errc())
                    return Status::error(StatusCode::invalid_input, "ASCII STL: bad vertex coordinate '" + std::string(num) + "'");
                soup.push_back(v);
            }
            ++corners;
        }
        if (corners % 3 != 0) return Status::error(StatusCode::invalid_input, "ASCII STL: a facet does not have 3 vertices");
    }
    if (soup.empty()) return Status::error(StatusCode::invalid_input, "STL contains no facets");
    for (float v : soup)
        if (!std::isfinite(v) && !options.allow_non_finite)
            return Status::error(StatusCode::invalid_input, "vertex positions contain NaN or infinite values");
    Primitive p;
    std::map<std::array<float, 3>, uint32_t> index;
    for (size_t c = 0; c < soup.size() / 3; ++c) {
        std::array<float, 3> key{soup[c * 3] + 0.0f, soup[c * 3 + 1] + 0.0f, soup[c * 3 + 2] + 0.0f}; // -0 -> +0
        auto [it, inserted] = index.insert({key, uint32_t(p.positions.size() / 3)});
        if (inserted) p.positions.insert(p.positions.end(), key.begin(), key.end());
        p.indices.push_back(it->second);
    }
    out = make_scene(std::move(p), "mesh");
    if (options.recentre) recentre(out, options.recentre_threshold);
    return Status::success();
}

} // namespace furrow

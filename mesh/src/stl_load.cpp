// STL (binary and ASCII). Not OpenMesh's reader: it drops facets whose corners coincide, and those
// degenerate facets are exactly what `furrow check` must report (Thingi10K 73342 has 20 of them).
// Corners are welded by exact position, as every STL reader does, to give an indexed mesh. The bytes are read
// where load_scene put them (no copy), words split with text_numbers.h's is_space (not the locale's isspace,
// a call per byte), and the corner soup sized once on huge pages: on the generated 19 MB ASCII grid these were
// most of the load (the soup's regrowth copies, the copy of the file, isspace).
#include "document.h"
#include "text_numbers.h"
#include <furrow_kernel/huge_pages.h>

#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <string_view>

namespace furrow {

namespace {
bool next_token(std::string_view s, size_t& at, std::string_view& tok) {
    while (at < s.size() && mesh_detail::is_space(s[at])) ++at;
    size_t b = at;
    while (at < s.size() && !mesh_detail::is_space(s[at])) ++at;
    tok = s.substr(b, at - b);
    return !tok.empty();
}
} // namespace

Status load_stl_bytes(Scene& out, const char* data, size_t size, const LoadOptions& options) {
    const std::string_view bytes(data, size);
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
        kernel::assign_huge(soup, size_t(n) * 9);
        for (size_t f = 0; f < n; ++f) std::memcpy(&soup[f * 9], bytes.data() + 84 + f * 50 + 12, 36);
    } else {
        size_t at = 0;
        std::string_view tok;
        if (!next_token(bytes, at, tok) || tok != "solid") return Status::error(StatusCode::invalid_input, "not an STL file");
        // Room for every vertex the text could hold ("vertex a b c" is at least 12 bytes): sized once, on
        // huge pages, so that push_back never copies and the pages fault once per 2 MiB (untouched ones cost nothing).
        kernel::reserve_huge(soup, bytes.size() / 4 + 9);
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

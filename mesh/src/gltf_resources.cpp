// External resources of a glTF file: which buffers and images are read, from where, and how much.
//
// A glTF file names the other files it is read with (buffer and image URIs), so it chooses what a loader
// reads: `../../../etc/x.png` used to be read and embedded in the output, and every buffer and image was
// read whether or not anything used it (tinygltf 2.7 reads them all while it parses, through its file
// callbacks, with its own URL decoding). The design here, in the order it runs:
//   1. The JSON (the .gltf, or the GLB's JSON chunk) is parsed once with nlohmann-json, the parser tinygltf
//      uses, before tinygltf sees it. The node and primitive counts are checked against their limits.
//   2. What is used is decided on that JSON: an image is used when a texture names it (`source`, or the
//      `source` of a texture extension such as EXT_texture_webp); a buffer when a used image or an accessor
//      furrow reads (mesh attributes, indices and morph targets, inverse bind matrices, animation samplers)
//      lies in one of its buffer views.
//   3. Each used external resource is checked and read: the URI percent-decoded by RFC 3986 §2.1 (a `%` not
//      followed by two hex digits is refused; `+` stays `+`), refused if it holds a NUL byte (raw or %00),
//      then handed to the resolver (LoadOptions::resolver, or confined_file_resolver under the resource
//      root), with what is left of max_resource_bytes. A buffer's byteLength is checked against that budget
//      before anything is read, so a byteLength of 1e12 is refused without trying.
//   4. The JSON is rewritten only when there is something to change: unused images are dropped (texture
//      sources renumbered), so they are neither read nor written; an unused buffer with a URI becomes a
//      1-byte data URI (nothing refers into it; the writer rebuilds buffers anyway); a resolved resource's
//      URI becomes a token that tinygltf's file callbacks (load_gltf_bytes) answer from memory. Every other
//      path tinygltf asks for does not exist, so tinygltf can read nothing on its own, whatever it makes
//      of a URI. The URIs as written are kept for the scene (Image::source_uri) and restored after parsing.
//   An EXT_meshopt_compression fallback buffer is never read (its views are decoded from the compressed
//   bytes): it becomes the 1-byte data URI too, as it may have no data at all.
//   A GLB is rebuilt around the new JSON chunk only when it was rewritten (rare: a GLB with external or
//   unused resources); its binary chunk is copied as it is.
#include "document.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>

namespace furrow {

namespace fs = std::filesystem;
using nlohmann::json;

namespace mesh_detail {

std::string printable_uri(const std::string& uri) {
    static const char hex[] = "0123456789ABCDEF";
    std::string s;
    for (unsigned char c : uri) {
        if (s.size() >= 80) return s + "...";
        if (c < 0x20 || c >= 0x7F || c == '\'') s += {'%', hex[c >> 4], hex[c & 15]};
        else s += char(c);
    }
    return s;
}

Status check_scene_counts(size_t nodes, size_t primitives, const LoadOptions& options) {
    if (nodes > options.max_nodes)
        return Status::error(StatusCode::out_of_memory, "the file has " + std::to_string(nodes) + " nodes, above the limit of " +
                                                            std::to_string(options.max_nodes) + " (LoadOptions::max_nodes raises it)");
    if (primitives > options.max_primitives)
        return Status::error(StatusCode::out_of_memory, "the file has " + std::to_string(primitives) +
                                                            " primitives, above the limit of " +
                                                            std::to_string(options.max_primitives) + " (LoadOptions::max_primitives raises it)");
    return Status::success();
}

} // namespace mesh_detail

namespace {

// The URI's scheme (RFC 3986 §3.1, lower case), or "" for a relative reference.
std::string uri_scheme(const std::string& uri) {
    size_t i = 0;
    while (i < uri.size() && (std::isalnum(static_cast<unsigned char>(uri[i])) || uri[i] == '+' || uri[i] == '-' || uri[i] == '.')) ++i;
    if (i == 0 || i >= uri.size() || uri[i] != ':' || !std::isalpha(static_cast<unsigned char>(uri[0]))) return "";
    std::string s = uri.substr(0, i);
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

// RFC 3986 §2.1 percent-decoding; false on a '%' without two hex digits after it.
bool percent_decode(std::string& out, const std::string& in) {
    auto hex = [](char c) { return std::isxdigit(static_cast<unsigned char>(c)) != 0; };
    auto value = [](char c) { return c <= '9' ? c - '0' : (c | 0x20) - 'a' + 10; };
    out.clear();
    for (size_t i = 0; i < in.size(); ++i) {
        if (in[i] != '%') {
            out += in[i];
            continue;
        }
        if (i + 2 >= in.size() || !hex(in[i + 1]) || !hex(in[i + 2])) return false;
        out += char(value(in[i + 1]) * 16 + value(in[i + 2]));
        i += 2;
    }
    return true;
}

// The path part of a URI for ResourceRequest::path: a file: URI's path (host empty or localhost), the whole
// reference otherwise; percent-decoded.
Status uri_path(std::string& path, const std::string& uri, const std::string& what) {
    std::string rest = uri;
    if (uri_scheme(uri) == "file") {
        rest = uri.substr(5);
        if (rest.rfind("//", 0) == 0) {
            const size_t slash = rest.find('/', 2);
            const std::string host = rest.substr(2, slash == std::string::npos ? std::string::npos : slash - 2);
            if (host != "" && host != "localhost")
                return Status::error(StatusCode::invalid_input, what + " names a file on another host");
            rest = slash == std::string::npos ? "" : rest.substr(slash);
        }
    }
    if (!percent_decode(path, rest))
        return Status::error(StatusCode::invalid_input, what + " has a '%' not followed by two hex digits (RFC 3986)");
    if (uri.find('\0') != std::string::npos || path.find('\0') != std::string::npos)
        return Status::error(StatusCode::invalid_input, what + " contains a NUL byte");
    return Status::success();
}

bool is_external(const json& entry) {
    if (!entry.is_object() || !entry.contains("uri") || !entry["uri"].is_string()) return false;
    return entry["uri"].get_ref<const std::string&>().rfind("data:", 0) != 0;
}

int index_of(const json& o, const char* key) {
    if (!o.is_object() || !o.contains(key) || !o[key].is_number_integer()) return -1;
    const auto v = o[key].get<long long>();
    return v < 0 || v > INT32_MAX ? -1 : int(v);
}

// Elements of array `key` of `o` (none if it is not an array).
const json& array_of(const json& o, const char* key) {
    static const json empty = json::array();
    return o.is_object() && o.contains(key) && o[key].is_array() ? o[key] : empty;
}

// Step 2: the images and buffers the scene uses.
void find_used(const json& j, std::vector<char>& images, std::vector<char>& buffers) {
    images.assign(array_of(j, "images").size(), 0);
    buffers.assign(array_of(j, "buffers").size(), 0);
    auto mark = [](std::vector<char>& v, int i) {
        if (i >= 0 && size_t(i) < v.size()) v[size_t(i)] = 1;
    };
    for (const auto& t : array_of(j, "textures")) {
        mark(images, index_of(t, "source"));
        if (t.is_object() && t.contains("extensions") && t["extensions"].is_object())
            for (const auto& e : t["extensions"]) mark(images, index_of(e, "source"));
    }
    std::set<int> accessors, views;
    auto attributes = [&](const json& a) {
        if (a.is_object())
            for (const auto& v : a)
                if (v.is_number_integer()) accessors.insert(v.get<int>());
    };
    for (const auto& m : array_of(j, "meshes"))
        for (const auto& p : array_of(m, "primitives")) {
            if (p.is_object() && p.contains("attributes")) attributes(p["attributes"]);
            accessors.insert(index_of(p, "indices"));
            for (const auto& t : array_of(p, "targets")) attributes(t);
        }
    for (const auto& s : array_of(j, "skins")) accessors.insert(index_of(s, "inverseBindMatrices"));
    for (const auto& a : array_of(j, "animations"))
        for (const auto& s : array_of(a, "samplers")) accessors.insert({index_of(s, "input"), index_of(s, "output")});
    const json& acc = array_of(j, "accessors");
    for (int a : accessors) {
        if (a < 0 || size_t(a) >= acc.size()) continue;
        const json& x = acc[size_t(a)];
        views.insert(index_of(x, "bufferView"));
        if (x.is_object() && x.contains("sparse") && x["sparse"].is_object())
            for (const char* part : {"indices", "values"})
                if (x["sparse"].contains(part)) views.insert(index_of(x["sparse"][part], "bufferView"));
    }
    const json& img = array_of(j, "images");
    for (size_t i = 0; i < img.size(); ++i)
        if (images[i]) views.insert(index_of(img[i], "bufferView"));
    const json& bv = array_of(j, "bufferViews");
    for (int v : views)
        if (v >= 0 && size_t(v) < bv.size()) {
            mark(buffers, index_of(bv[size_t(v)], "buffer"));
            // EXT_meshopt_compression: the compressed bytes lie in the extension's buffer.
            const json& x = bv[size_t(v)];
            if (x.is_object() && x.contains("extensions") && x["extensions"].is_object() &&
                x["extensions"].contains("EXT_meshopt_compression"))
                mark(buffers, index_of(x["extensions"]["EXT_meshopt_compression"], "buffer"));
        }
}

// An EXT_meshopt_compression fallback buffer: it may hold no data at all (no uri, and in a GLB it is not the
// binary chunk), and furrow decodes the compressed views instead of reading it.
bool is_meshopt_fallback(const json& b) {
    if (!b.is_object() || !b.contains("extensions") || !b["extensions"].is_object()) return false;
    const json& e = b["extensions"];
    return e.contains("EXT_meshopt_compression") && e["EXT_meshopt_compression"].is_object() &&
           e["EXT_meshopt_compression"].value("fallback", false) == true;
}

// Step 3 for one resource: checked, resolved, counted against the budget.
Status read_resource(std::vector<uint8_t>& bytes, const std::string& uri, bool image, int index, size_t length,
                     const ResourceResolver& resolver, size_t& budget) {
    const std::string what = std::string(image ? "image " : "buffer ") + std::to_string(index) + " uri '" +
                             mesh_detail::printable_uri(uri) + "'";
    ResourceRequest r;
    r.uri = uri;
    r.image = image;
    r.index = index;
    r.max_bytes = budget;
    if (Status s = uri_path(r.path, uri, what); !s.ok()) return s;
    auto too_big = [&](size_t n) {
        return Status::error(StatusCode::out_of_memory,
                             what + " is " + std::to_string(n) + " bytes, above the " + std::to_string(budget) +
                                 " bytes left for external resources (LoadOptions::max_resource_bytes raises it)");
    };
    if (length > budget) return too_big(length);
    if (!resolver) return Status::error(StatusCode::not_found, what + " was not found: loaded from memory without a resolver");
    Status s = resolver(bytes, r);
    if (!s.ok()) return Status::error(s.code, what + " " + s.message);
    if (bytes.size() > budget) return too_big(bytes.size());
    budget -= bytes.size();
    return Status::success();
}

// Step 4 for images: drops the unused ones and renumbers the texture sources (an index out of range stays
// out of range, for the loader's own error).
void drop_unused_images(json& j, const std::vector<char>& used) {
    std::vector<int> new_index(used.size(), -1);
    json kept = json::array();
    for (size_t i = 0; i < used.size(); ++i)
        if (used[i]) {
            new_index[i] = int(kept.size());
            kept.push_back(std::move(j["images"][i]));
        }
    const int dropped = int(used.size() - kept.size());
    j["images"] = std::move(kept);
    auto remap = [&](json& o) {
        const int i = index_of(o, "source");
        if (i >= 0) o["source"] = size_t(i) < used.size() ? new_index[size_t(i)] : i - dropped;
    };
    if (!j.contains("textures") || !j["textures"].is_array()) return;
    for (auto& t : j["textures"]) {
        remap(t);
        if (t.is_object() && t.contains("extensions") && t["extensions"].is_object())
            for (auto& e : t["extensions"]) remap(e);
    }
}

// The JSON chunk of a GLB as tinygltf 2.7 checks it (LoadBinaryFromMemory); false if tinygltf would refuse
// the container, which it then reports itself.
bool glb_json_chunk(const uint8_t* data, size_t size, size_t& json_size, size_t& length) {
    if (size < 20 || std::memcmp(data, "glTF", 4) != 0) return false;
    uint32_t version = 0, len = 0, chunk0 = 0, type = 0;
    std::memcpy(&version, data + 4, 4);
    std::memcpy(&len, data + 8, 4);
    std::memcpy(&chunk0, data + 12, 4);
    std::memcpy(&type, data + 16, 4);
    const uint64_t header_and_json = 20ull + chunk0;
    if (version != 2 || type != 0x4E4F534A || chunk0 < 1 || len > size || header_and_json > len || header_and_json % 4)
        return false;
    json_size = chunk0;
    length = len;
    return true;
}

std::vector<uint8_t> rebuilt_glb(const std::string& text, const uint8_t* data, size_t json_size, size_t length) {
    std::string j = text;
    while (j.size() % 4) j.push_back(' ');
    const size_t rest = length - 20 - json_size;
    std::vector<uint8_t> out(20 + j.size() + rest);
    auto u32 = [&out](size_t at, uint32_t v) { std::memcpy(out.data() + at, &v, 4); };
    std::memcpy(out.data(), "glTF", 4);
    u32(4, 2);
    u32(8, uint32_t(out.size()));
    u32(12, uint32_t(j.size()));
    u32(16, 0x4E4F534A);
    std::memcpy(out.data() + 20, j.data(), j.size());
    if (rest) std::memcpy(out.data() + 20 + j.size(), data + 20 + json_size, rest);
    return out;
}

size_t count_primitives(const json& j) {
    size_t n = 0;
    for (const auto& m : array_of(j, "meshes")) n += array_of(m, "primitives").size();
    return n;
}

} // namespace

namespace mesh_detail {

Status prepare_gltf(PreparedGltf& out, const uint8_t* data, size_t size, const ResourceResolver& resolver,
                    const LoadOptions& options) {
    out = PreparedGltf{};
    const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    size_t json_size = size, glb_length = 0;
    if (glb && !glb_json_chunk(data, size, json_size, glb_length)) return Status::success();
    const uint8_t* text = glb ? data + 20 : data;
    json j = json::parse(text, text + json_size, nullptr, false);
    if (!j.is_object()) return Status::success(); // tinygltf reports the syntax error
    if (Status s = check_scene_counts(array_of(j, "nodes").size(), count_primitives(j), options); !s.ok()) return s;

    std::vector<char> used_images, used_buffers;
    find_used(j, used_images, used_buffers);
    bool rewrite = std::count(used_images.begin(), used_images.end(), 0) > 0;
    out.buffer_uris.assign(used_buffers.size(), "");
    out.image_uris.assign(size_t(std::count(used_images.begin(), used_images.end(), 1)), "");
    size_t budget = options.max_resource_bytes;
    for (size_t i = 0; i < used_buffers.size(); ++i) {
        json& b = j["buffers"][i];
        if (is_meshopt_fallback(b)) { // never read: its views are decoded (meshopt_codec.cpp)
            if (b.contains("uri") && b["uri"].is_string()) out.buffer_uris[i] = b["uri"].get<std::string>();
            b = {{"byteLength", 1}, {"uri", "data:application/octet-stream;base64,AA=="}};
            rewrite = true;
            continue;
        }
        if (!b.is_object() || !b.contains("uri")) continue;
        if (!used_buffers[i]) { // nothing refers into it: not read
            if (b["uri"].is_string()) out.buffer_uris[i] = b["uri"].get<std::string>();
            b = {{"byteLength", 1}, {"uri", "data:application/octet-stream;base64,AA=="}};
            rewrite = true;
            continue;
        }
        if (!is_external(b)) continue;
        const std::string uri = b["uri"].get<std::string>();
        const size_t length = b.contains("byteLength") && b["byteLength"].is_number_unsigned() ? b["byteLength"].get<size_t>() : 0;
        std::vector<uint8_t> bytes;
        if (Status s = read_resource(bytes, uri, false, int(i), length, resolver, budget); !s.ok())
            return Status::error(s.code == StatusCode::not_found ? StatusCode::invalid_input : s.code, s.message);
        if (bytes.size() < length)
            return Status::error(StatusCode::invalid_input, "buffer " + std::to_string(i) + " uri '" + printable_uri(uri) +
                                                                "' has " + std::to_string(bytes.size()) +
                                                                " bytes, its byteLength says " + std::to_string(length));
        bytes.resize(length); // glTF 2.0 §3.6.1.1: the file may be longer (padding)
        const std::string token = "furrow-resource-buffer-" + std::to_string(i);
        out.files[token] = std::move(bytes);
        out.buffer_uris[i] = uri;
        b["uri"] = token;
        rewrite = true;
    }
    for (size_t i = 0, kept = 0; i < used_images.size(); ++i) {
        if (!used_images[i]) continue;
        json& im = j["images"][i];
        ++kept;
        if (!is_external(im)) continue;
        const std::string uri = im["uri"].get<std::string>();
        std::vector<uint8_t> bytes;
        Status s = read_resource(bytes, uri, true, int(i), 0, resolver, budget);
        if (s.code == StatusCode::not_found) continue; // tinygltf finds no file: a warning, as before
        if (!s.ok()) return s;
        const std::string token = "furrow-resource-image-" + std::to_string(i);
        out.files[token] = std::move(bytes);
        out.image_uris[kept - 1] = uri;
        im["uri"] = token;
        rewrite = true;
    }
    if (!rewrite) return Status::success();
    drop_unused_images(j, used_images);
    const std::string dumped = j.dump(-1, ' ', false, json::error_handler_t::replace);
    out.bytes = glb ? rebuilt_glb(dumped, data, json_size, glb_length) : std::vector<uint8_t>(dumped.begin(), dumped.end());
    return Status::success();
}

} // namespace mesh_detail

namespace {

// `path` lies in `root` or below it (both canonical): compared component by component, so /data/rootx is not
// under /data/root.
bool is_under(const fs::path& path, const fs::path& root) {
    auto p = path.begin();
    for (auto r = root.begin(); r != root.end(); ++r, ++p) {
        if (r->empty()) continue; // a trailing separator
        if (p == path.end() || *p != *r) return false;
    }
    return true;
}

Status read_confined(std::vector<uint8_t>& bytes, const ResourceRequest& r, const fs::path& root, const fs::path& base) {
    const std::string scheme = uri_scheme(r.uri);
    if (!scheme.empty() && scheme != "file")
        return Status::error(StatusCode::invalid_input, "uses the URI scheme '" + scheme + ":'; furrow reads only files");
    std::error_code ec;
    const fs::path root_c = fs::canonical(root, ec);
    if (ec) return Status::error(StatusCode::io_error, "cannot be read: the resource root " + root.string() + " does not exist");
    const fs::path target = fs::path(r.path).is_absolute() ? fs::path(r.path) : base / r.path;
    const fs::path weak = fs::weakly_canonical(target, ec);
    if (ec || !is_under(weak, root_c))
        return Status::error(StatusCode::invalid_input, "is outside the resource root " + root_c.string());
    const fs::path file = fs::canonical(target, ec);
    if (ec) return Status::error(StatusCode::not_found, "was not found (looked for " + weak.string() + ")");
    if (!is_under(file, root_c)) // cannot differ from `weak` for an existing file; checked again all the same
        return Status::error(StatusCode::invalid_input, "is outside the resource root " + root_c.string());
    if (!fs::is_regular_file(file, ec)) return Status::error(StatusCode::invalid_input, "is not a regular file");
    const auto size = fs::file_size(file, ec);
    if (ec) return Status::error(StatusCode::io_error, "cannot be read");
    if (size > r.max_bytes)
        return Status::error(StatusCode::out_of_memory, "is " + std::to_string(size) + " bytes, above the " +
                                                            std::to_string(r.max_bytes) +
                                                            " bytes left for external resources (LoadOptions::max_resource_bytes raises it)");
    std::ifstream in(file, std::ios::binary);
    bytes.resize(size_t(size));
    if (!in || (size && !in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(size))))
        return Status::error(StatusCode::io_error, "cannot be read");
    return Status::success();
}

} // namespace

ResourceResolver confined_file_resolver(const std::string& root, const std::string& base_dir) {
    return [root = fs::path(root), base = fs::path(base_dir)](std::vector<uint8_t>& bytes, const ResourceRequest& r) {
        return read_confined(bytes, r, root, base);
    };
}

} // namespace furrow

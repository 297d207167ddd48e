// Parsing and strict validation of the colliders file (schema in furrow/deform.h and deform/README.md).
//
// Strict on purpose: a collider file is hand-written or exported by a game tool, and a silently defaulted
// typo ("radious") produces a plausible-looking but wrong imprint that nobody notices. Every error names the
// member it is about, so the CLI's one-line "Error: <file>: <what>" is enough to fix the file.
#include "deform_internal.h"
#include <furrow_kernel/no_throw.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace furrow {
namespace {

using nlohmann::json;

struct Bad {
    std::string message;
};

std::string num_text(const json& v) {
    if (v.is_number()) {
        std::ostringstream s;
        s << v.get<double>();
        return s.str();
    }
    std::string d = v.dump();
    if (d.size() > 40) d = d.substr(0, 37) + "...";
    return d;
}

double finite_number(const json& v, const std::string& where) {
    if (!v.is_number()) throw Bad{where + ": must be a number, got " + num_text(v)};
    double x = v.get<double>();
    if (!std::isfinite(x)) throw Bad{where + ": must be finite, got " + num_text(v)};
    return x;
}

double positive(const json& v, const std::string& where) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) || !(v.get<double>() > 0))
        throw Bad{where + ": must be a finite number > 0, got " + num_text(v)};
    return v.get<double>();
}

double non_negative(const json& v, const std::string& where) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0)
        throw Bad{where + ": must be a finite number >= 0, got " + num_text(v)};
    return v.get<double>();
}

std::array<double, 3> vec3(const json& v, const std::string& where) {
    if (!v.is_array() || v.size() != 3) throw Bad{where + ": must be an array [x, y, z] of 3 numbers"};
    return {finite_number(v[0], where + "[0]"), finite_number(v[1], where + "[1]"), finite_number(v[2], where + "[2]")};
}

const json& required(const json& obj, const char* key, const std::string& where) {
    auto it = obj.find(key);
    if (it == obj.end()) throw Bad{where + ": missing \"" + key + "\""};
    return *it;
}

void check_keys(const json& obj, const std::set<std::string>& allowed, const std::string& where) {
    for (auto it = obj.begin(); it != obj.end(); ++it) {
        const std::string& k = it.key();
        if (!k.empty() && k[0] == '_') continue; // comments and extras
        if (!allowed.count(k)) throw Bad{where + ": unknown key \"" + k + "\""};
    }
}

Collider parse_one(const json& c, size_t index, const std::string& base_dir) {
    const std::string at = "colliders[" + std::to_string(index) + "]";
    if (!c.is_object()) throw Bad{at + ": must be an object"};
    Collider out;
    const json& shape = required(c, "shape", at);
    if (!shape.is_string()) throw Bad{at + ".shape: must be a string"};
    const std::string s = shape.get<std::string>();
    std::set<std::string> keys{"shape", "path", "heading", "time", "name"};
    if (s == "sphere") {
        out.shape = ColliderShape::sphere;
        out.radius = positive(required(c, "radius", at), at + ".radius");
        keys.insert("radius");
    } else if (s == "box") {
        out.shape = ColliderShape::box;
        const json& sz = required(c, "size", at);
        if (!sz.is_array() || sz.size() != 3) throw Bad{at + ".size: a box needs [sx, sy, sz]"};
        for (int k = 0; k < 3; ++k) out.size[size_t(k)] = positive(sz[size_t(k)], at + ".size[" + std::to_string(k) + "]");
        keys.insert("size");
    } else if (s == "capsule") {
        out.shape = ColliderShape::capsule;
        out.radius = positive(required(c, "radius", at), at + ".radius");
        out.length = non_negative(required(c, "length", at), at + ".length");
        if (c.contains("axis")) {
            out.axis = vec3(c["axis"], at + ".axis");
            double n = std::hypot(out.axis[0], out.axis[1], out.axis[2]);
            if (!(n > 0)) throw Bad{at + ".axis: must not be zero"};
            for (double& x : out.axis) x /= n;
        }
        keys.insert({"radius", "length", "axis"});
    } else if (s == "image") {
        out.shape = ColliderShape::image;
        const json& sz = required(c, "size", at);
        if (!sz.is_array() || sz.size() != 2) throw Bad{at + ".size: an image needs [sx, sz] (across, along)"};
        out.size[0] = positive(sz[0], at + ".size[0]");
        out.size[1] = positive(sz[1], at + ".size[1]");
        out.depth = positive(required(c, "depth", at), at + ".depth");
        const json& im = required(c, "image", at);
        if (!im.is_string() || im.get<std::string>().empty()) throw Bad{at + ".image: must be a file name"};
        std::filesystem::path p(im.get<std::string>());
        if (p.is_relative()) p = std::filesystem::path(base_dir) / p;
        out.image_path = p.string();
        auto brush = std::make_shared<ImageF>();
        Status st = load_png(*brush, out.image_path);
        if (!st.ok()) throw Bad{at + ".image: cannot read '" + im.get<std::string>() + "' (" + st.message + ")"};
        if (brush->width < 1 || brush->height < 1 || brush->channels < 1) throw Bad{at + ".image: empty image"};
        out.brush = std::move(brush);
        keys.insert({"size", "depth", "image"});
    } else {
        throw Bad{at + ".shape: unknown shape \"" + s + "\" (expected sphere, box, capsule or image)"};
    }
    if (out.shape != ColliderShape::image) {
        keys.insert("falloff");
        if (c.contains("falloff")) out.falloff = non_negative(c["falloff"], at + ".falloff");
    }
    check_keys(c, keys, at);

    if (c.contains("name")) {
        if (!c["name"].is_string()) throw Bad{at + ".name: must be a string"};
        out.name = c["name"].get<std::string>();
    }
    if (out.name.empty()) out.name = at;

    const json& path = required(c, "path", at);
    if (!path.is_array() || path.empty()) throw Bad{at + ".path: must be a non-empty array of [x, y, z] points"};
    for (size_t k = 0; k < path.size(); ++k) out.path.push_back(vec3(path[k], at + ".path[" + std::to_string(k) + "]"));

    if (c.contains("heading")) {
        const json& h = c["heading"];
        if (h.is_number()) {
            out.heading.push_back(finite_number(h, at + ".heading"));
        } else if (h.is_array()) {
            if (h.size() != 1 && h.size() != path.size())
                throw Bad{at + ".heading: needs 1 or " + std::to_string(path.size()) + " values (one per path point), got " +
                          std::to_string(h.size())};
            for (size_t k = 0; k < h.size(); ++k) out.heading.push_back(finite_number(h[k], at + ".heading[" + std::to_string(k) + "]"));
        } else {
            throw Bad{at + ".heading: must be a number or an array of numbers (degrees)"};
        }
    }
    if (c.contains("time")) {
        const json& t = c["time"];
        if (t.is_number() && path.size() == 1) {
            out.time.push_back(finite_number(t, at + ".time"));
            if (out.time[0] < 0) throw Bad{at + ".time: must be >= 0, got " + num_text(t)};
        } else {
            if (!t.is_array() || t.size() != path.size())
                throw Bad{at + ".time: needs one value per path point (" + std::to_string(path.size()) + ")"};
            for (size_t k = 0; k < t.size(); ++k) {
                double x = finite_number(t[k], at + ".time[" + std::to_string(k) + "]");
                if (x < 0) throw Bad{at + ".time[" + std::to_string(k) + "]: must be >= 0, got " + num_text(t[k])};
                if (k > 0 && x < out.time.back())
                    throw Bad{at + ".time[" + std::to_string(k) + "]: times must not decrease (" + num_text(t[k]) + " < " +
                              num_text(t[k - 1]) + ")"};
                out.time.push_back(x);
            }
        }
    }
    return out;
}

} // namespace

Status parse_colliders(ColliderSet& out, const std::string& text, const std::string& base_dir) {
    return kernel::no_throw("reading the colliders", [&]() -> Status {
        json doc;
        try {
            doc = json::parse(text);
        } catch (const json::exception& e) {
            // nlohmann prefixes "[json.exception.parse_error.101] parse error at line 3, column 5: ..."
            std::string what = e.what();
            auto pos = what.find("] ");
            return Status::error(StatusCode::invalid_input, "malformed JSON: " + (pos == std::string::npos ? what : what.substr(pos + 2)));
        }
        try {
            if (!doc.is_object()) throw Bad{"the document must be an object {\"up\": ..., \"colliders\": [...]}"};
            check_keys(doc, {"up", "colliders"}, "top level");
            ColliderSet set;
            if (doc.contains("up")) {
                set.up = vec3(doc["up"], "up");
                double n = std::hypot(set.up[0], set.up[1], set.up[2]);
                if (!(n > 0)) throw Bad{"up: must not be the zero vector"};
                for (double& x : set.up) x /= n;
            }
            const json& cs = required(doc, "colliders", "top level");
            if (!cs.is_array()) throw Bad{"colliders: must be an array"};
            for (size_t i = 0; i < cs.size(); ++i) set.colliders.push_back(parse_one(cs[i], i, base_dir));
            out = std::move(set);
        } catch (const Bad& b) {
            return Status::error(StatusCode::invalid_input, b.message);
        } catch (const json::exception& e) {
            return Status::error(StatusCode::invalid_input, std::string("unexpected JSON content: ") + e.what());
        }
        return Status::success();
    });
}

Status load_colliders(ColliderSet& out, const std::string& path) {
    return kernel::no_throw("reading the colliders", [&]() -> Status {
        // A folder opens and reads as empty, which was reported as "malformed JSON": say what is wrong.
        std::error_code ec;
        if (std::filesystem::is_directory(path, ec))
            return Status::error(StatusCode::io_error, "is a directory, not a colliders file");
        std::ifstream f(path, std::ios::binary);
        if (!f) return Status::error(StatusCode::io_error, "cannot open the colliders file");
        std::ostringstream ss;
        ss << f.rdbuf();
        if (f.bad()) return Status::error(StatusCode::io_error, "cannot read the colliders file");
        std::filesystem::path dir = std::filesystem::path(path).parent_path();
        return parse_colliders(out, ss.str(), dir.empty() ? "." : dir.string());
    });
}

} // namespace furrow

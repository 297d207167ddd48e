// `furrow bench io`: load + save time per model as a ratio to memcpy of the same bytes, the load throughput
// (MB/s) per format, peak memory, the round-trip error, and `furrow convert` against gltfpack (an optional
// peer, run as a subprocess like furrow itself) on what gltfpack reads. Unless --quick, a generated ~100 MB
// OBJ grid (models/obj_grid.h) is one more row: text meshes of that size are what the loader is for; and the
// same grid as OFF, ASCII PLY and ASCII STL at a fifth of that size, one row each (their readers' MB/s). Then,
// per model and setting (plain, --quantize, --compress), the output's bytes, its round-trip position error in
// % of the diagonal, UV and normal errors, and encode and decode times, with gltfpack at the matching setting
// (-vp 14, -cc -vp 14) beside it as the peer ("peer not installed" without it). gltfpack drops texture
// coordinates no material reads (0.18 has no option to keep them); the table says "dropped" there.
#include "bench_common.h"
#include "data_dirs.h"
#include "cli_common.h"
#include "obj_grid.h"

#include <algorithm>
#include <array>
#include <map>
#include <set>
#include <cmath>
#include <cstring>
#include <unistd.h>
#include <filesystem>
#include <fstream>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

struct IoRow {
    std::string name, format;
    size_t bytes = 0, triangles = 0;
    double load_s = 0, save_s = 0, memcpy_s = 0;
    double convert_s = -1, gltfpack_s = -1; // subprocess wall times; -1 = not run
    double peak_mib = 0;
    double roundtrip_max_error = 0; // max |position difference| after save + reload (object space)
};

// The scene in the vertex order save_scene writes (triangulated, SaveOptions::optimize's order), so that
// vertex i of a reloaded file meets vertex i of the scene.
Scene in_writer_order(Scene scene, Encoding encoding = Encoding::plain) {
    for (Mesh& m : scene.meshes)
        for (Primitive& p : m.primitives) {
            triangulate(p);
            optimize_vertex_order(p, encoding);
        }
    return scene;
}

double max_position_error(const Scene& a, const Scene& b) {
    if (a.meshes.size() != b.meshes.size()) return INFINITY;
    double worst = 0;
    for (size_t m = 0; m < a.meshes.size(); ++m) {
        if (a.meshes[m].primitives.size() != b.meshes[m].primitives.size()) return INFINITY;
        for (size_t p = 0; p < a.meshes[m].primitives.size(); ++p) {
            const auto& x = a.meshes[m].primitives[p].positions;
            const auto& y = b.meshes[m].primitives[p].positions;
            if (x.size() != y.size()) return INFINITY;
            for (size_t i = 0; i < x.size(); ++i) worst = std::max(worst, double(std::abs(x[i] - y[i])));
        }
    }
    return worst;
}

// The format as the loader sees it: ASCII and binary PLY and STL are different parsers.
std::string format_of(const fs::path& file, const std::vector<char>& bytes) {
    const std::string ext = lower_extension(file.string()).substr(1);
    const std::string head(bytes.data(), std::min<size_t>(bytes.size(), 512));
    if (ext == "ply") return head.find("format ascii") != std::string::npos ? "ply ascii" : "ply binary";
    if (ext == "stl") {
        uint32_t n = 0;
        if (bytes.size() >= 84) std::memcpy(&n, bytes.data() + 80, 4);
        const bool binary = bytes.size() >= 84 && (head.rfind("solid", 0) != 0 || size_t(84) + size_t(n) * 50 == bytes.size());
        return binary ? "stl binary" : "stl ascii";
    }
    return ext;
}

// `furrow convert` (this executable) and gltfpack -noq, each a subprocess writing a GLB, on formats gltfpack
// reads. Seconds of wall time, median of `repeat`; -1 when not run.
void bench_convert(IoRow& row, const fs::path& file, const fs::path& tmp, int repeat, bool gltfpack) {
    const std::string ext = lower_extension(file.string());
    if (ext != ".obj" && ext != ".gltf" && ext != ".glb") return;
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    const std::string out = (tmp / "convert.glb").string();
    auto timed = [&](const std::vector<std::string>& argv) {
        int code = 0;
        const double s = median_seconds(repeat, [&] { code |= run_peer(argv); });
        return code == 0 ? s : -1.0;
    };
    if (!ec) row.convert_s = timed({self.string(), "convert", file.string(), "-o", out});
    if (gltfpack) row.gltfpack_s = timed({"gltfpack", "-i", file.string(), "-o", out, "-noq"});
    fs::remove(out, ec);
}

IoRow bench_one(const fs::path& file, const fs::path& tmp, int repeat, bool gltfpack) {
    IoRow row;
    row.name = file.filename().string();
    std::vector<char> bytes;
    {
        std::ifstream in(file, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    row.format = format_of(file, bytes);
    // A .gltf's buffers and images may live in files beside it: the loader reads those bytes too, so the
    // baseline copies them as well.
    if (lower_extension(file.string()) == ".gltf") {
        nlohmann::json doc = nlohmann::json::parse(bytes.begin(), bytes.end(), nullptr, false);
        if (doc.is_object())
            for (const char* key : {"buffers", "images"})
                if (doc.contains(key) && doc[key].is_array())
                    for (const auto& b : doc[key]) {
                        const std::string uri = b.is_object() ? b.value("uri", std::string()) : std::string();
                        if (uri.empty() || uri.rfind("data:", 0) == 0) continue;
                        std::error_code ec;
                        const auto size = fs::file_size(file.parent_path() / uri, ec);
                        if (!ec) bytes.resize(bytes.size() + size_t(size), 0);
                    }
    }
    row.bytes = bytes.size();
    // Baseline: copying the file's bytes once, in memory (median of many, it is short).
    std::vector<char> dst(bytes.size());
    row.memcpy_s = median_seconds(std::max(repeat, 25), [&] {
        std::memcpy(dst.data(), bytes.data(), bytes.size());
        do_not_optimize(dst.data());
    });
    Scene scene;
    PeakMemory peak;
    row.load_s = median_seconds(repeat, [&] {
        Scene s;
        require_ok(load_scene(s, file.string()), file.string());
        scene = std::move(s);
    });
    for (const auto& m : scene.meshes)
        for (const auto& p : m.primitives) row.triangles += p.triangle_count();
    const fs::path out = tmp / (row.name + ".glb");
    row.save_s = median_seconds(repeat, [&] { require_ok(save_scene(scene, out.string()), out.string()); });
    row.peak_mib = peak.peak_mib();
    Scene back;
    require_ok(load_scene(back, out.string()), out.string());
    row.roundtrip_max_error = max_position_error(in_writer_order(scene), back);
    fs::remove(out);
    bench_convert(row, file, tmp, repeat, gltfpack);
    return row;
}


// ---- bytes against error against time, per setting (README "Output size")

// One drawn vertex: world position (double), object-space unit normal, TEXCOORD_0 and TEXCOORD_1 (see
// uv_transforms); has_* say which the primitive carries.
struct Sample {
    std::array<double, 3> p{}, n{};
    std::array<double, 4> uv{}; // u0, v0, u1, v1
    bool has_n = false, has_uv0 = false, has_uv1 = false;
};

// furrow's loader applies a material's KHR_texture_transform to the sets its textures sample
// (mesh/src/texture_transform.cpp). gltfpack also stores a set that no texture of the material samples on the
// material's one box, with no transform to say so: that set's (offset u, v, scale u, v), read from the file's
// JSON of gltfpack's files (.glb or .gltf). Key: (mesh, primitive, set).
using UvTransforms = std::map<std::array<size_t, 3>, std::array<double, 4>>;
UvTransforms uv_transforms(const fs::path& file) {
    UvTransforms out;
    std::ifstream in(file, std::ios::binary);
    std::vector<char> b((std::istreambuf_iterator<char>(in)), {});
    uint32_t length = 0;
    const bool glb = b.size() >= 20 && std::memcmp(b.data(), "glTF", 4) == 0;
    if (glb) std::memcpy(&length, b.data() + 12, 4);
    if (glb && size_t(length) > b.size() - 20) return out;
    const nlohmann::json j = glb ? nlohmann::json::parse(b.begin() + 20, b.begin() + 20 + length, nullptr, false)
                                 : nlohmann::json::parse(b.begin(), b.end(), nullptr, false);
    if (!j.is_object() || !j.contains("meshes") || !j.contains("materials")) return out;
    const std::string generator = j.contains("asset") ? j["asset"].value("generator", "") : "";
    if (generator.rfind("gltfpack", 0) != 0) return out; // furrow's writer quantizes no unsampled set
    // Every texture reference in a material: {"index", "texCoord", "extensions": {"KHR_texture_transform"}}.
    std::vector<std::map<size_t, std::array<double, 4>>> by_material;
    for (const auto& m : j["materials"]) {
        std::map<size_t, std::array<double, 4>> sets;
        std::set<size_t> sampled;
        std::vector<const nlohmann::json*> todo{&m};
        while (!todo.empty()) {
            const nlohmann::json& o = *todo.back();
            todo.pop_back();
            if (!o.is_object()) continue;
            if (o.contains("index")) sampled.insert(o.value("texCoord", size_t(0)));
            if (o.contains("index") && o.contains("extensions") && o["extensions"].contains("KHR_texture_transform")) {
                const auto& t = o["extensions"]["KHR_texture_transform"];
                const auto off = t.value("offset", std::vector<double>{0, 0}), sc = t.value("scale", std::vector<double>{1, 1});
                sets[o.value("texCoord", size_t(0))] = {off[0], off[1], sc[0], sc[1]};
            }
            for (const auto& [k, v] : o.items()) todo.push_back(&v);
        }
        std::map<size_t, std::array<double, 4>> unsampled;
        if (sets.size() == 1)
            for (size_t set = 0; set < 2; ++set)
                if (!sampled.count(set)) unsampled.emplace(set, sets.begin()->second);
        by_material.push_back(unsampled);
    }
    for (size_t mi = 0; mi < j["meshes"].size(); ++mi) {
        const auto& prims = j["meshes"][mi].value("primitives", nlohmann::json::array());
        for (size_t pi = 0; pi < prims.size(); ++pi) {
            const size_t mat = prims[pi].value("material", size_t(~size_t(0)));
            if (mat < by_material.size())
                for (const auto& [set, t] : by_material[mat]) out[{mi, pi, set}] = t;
        }
    }
    return out;
}

// Every drawn mesh vertex (node order, then primitive, then vertex).
std::vector<Sample> samples(const Scene& s, const UvTransforms& transforms = {}) {
    std::vector<Sample> out;
    const auto world = s.world_matrices();
    for (int n : s.drawn_nodes()) {
        const int mi = s.nodes[size_t(n)].mesh;
        if (mi < 0 || size_t(mi) >= s.meshes.size()) continue;
        const auto& m = world[size_t(n)];
        for (size_t pi = 0; pi < s.meshes[size_t(mi)].primitives.size(); ++pi) {
            const Primitive& p = s.meshes[size_t(mi)].primitives[pi];
            std::array<std::array<double, 4>, 2> t{{{0, 0, 1, 1}, {0, 0, 1, 1}}};
            for (size_t set = 0; set < 2; ++set)
                if (auto it = transforms.find({size_t(mi), pi, set}); it != transforms.end()) t[set] = it->second;
            for (size_t v = 0; v < p.vertex_count(); ++v) {
                Sample q;
                const double x = p.positions[v * 3], y = p.positions[v * 3 + 1], z = p.positions[v * 3 + 2];
                q.p = {m[0] * x + m[4] * y + m[8] * z + m[12], m[1] * x + m[5] * y + m[9] * z + m[13],
                       m[2] * x + m[6] * y + m[10] * z + m[14]};
                if ((q.has_n = p.normals.size() == p.positions.size())) {
                    const double l = std::hypot(p.normals[v * 3], p.normals[v * 3 + 1], p.normals[v * 3 + 2]);
                    for (size_t k = 0; k < 3; ++k) q.n[k] = l > 0 ? p.normals[v * 3 + k] / l : 0.0;
                }
                const std::vector<float>* uvs[2] = {&p.uv0, &p.uv1};
                bool* has[2] = {&q.has_uv0, &q.has_uv1};
                for (size_t set = 0; set < 2; ++set)
                    if ((*has[set] = uvs[set]->size() == p.vertex_count() * 2))
                        for (size_t k = 0; k < 2; ++k) q.uv[set * 2 + k] = t[set][k] + t[set][2 + k] * (*uvs[set])[v * 2 + k];
                out.push_back(q);
            }
        }
    }
    return out;
}

double diagonal_of(const std::vector<Sample>& v) {
    std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (const auto& x : v)
        for (size_t k = 0; k < 3; ++k) lo[k] = std::min(lo[k], x.p[k]), hi[k] = std::max(hi[k], x.p[k]);
    return v.empty() ? 0.0 : std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

// The round-trip errors of one output: position (world units), UV (largest |du| or |dv| over both sets, in
// texture-coordinate units) and normal (largest angle, degrees).
struct Errors {
    double position = 0, uv = 0, normal_deg = 0;
    bool uv_dropped = false, normal_dropped = false; // the output lacks what the reference has
};

// The UV and normal differences of a reference vertex `a` and an output vertex `b`.
void attribute_errors(Errors& e, const Sample& a, const Sample& b) {
    e.uv_dropped |= (a.has_uv0 && !b.has_uv0) || (a.has_uv1 && !b.has_uv1);
    e.normal_dropped |= a.has_n && !b.has_n;
    if (a.has_uv0 && b.has_uv0) e.uv = std::max({e.uv, std::abs(a.uv[0] - b.uv[0]), std::abs(a.uv[1] - b.uv[1])});
    if (a.has_uv1 && b.has_uv1) e.uv = std::max({e.uv, std::abs(a.uv[2] - b.uv[2]), std::abs(a.uv[3] - b.uv[3])});
    if (a.has_n && b.has_n) {
        const double c = std::clamp(a.n[0] * b.n[0] + a.n[1] * b.n[1] + a.n[2] * b.n[2], -1.0, 1.0);
        e.normal_deg = std::max(e.normal_deg, std::acos(c) * 180.0 / M_PI);
    }
}

double distance(const Sample& a, const Sample& b) { return std::hypot(a.p[0] - b.p[0], a.p[1] - b.p[1], a.p[2] - b.p[2]); }

// furrow's error: vertex i of the reloaded file against vertex i of the scene in the order the writer gives
// it (triangulated, optimize_vertex_order for the setting's encoding), so nothing is matched by guess.
Errors indexed_errors(const std::vector<Sample>& a, const std::vector<Sample>& b) {
    if (a.size() != b.size()) return {INFINITY, INFINITY, INFINITY};
    Errors e;
    for (size_t i = 0; i < a.size(); ++i) {
        e.position = std::max(e.position, distance(a[i], b[i]));
        attribute_errors(e, a[i], b[i]);
    }
    return e;
}

// The peer's error: gltfpack reorders, welds and merges vertices, so each of its vertices is matched to the
// nearest original vertex (a hash grid of cell `cell`, the 27 cells around); the largest such distance. UV
// and normal errors: against the best of the original vertices at that same nearest distance (a seam's
// copies share a position), so the peer gets the benefit of the doubt.
Errors nearest_errors(const std::vector<Sample>& ref, const std::vector<Sample>& out, double cell) {
    if (ref.empty() || !(cell > 0)) return out.empty() ? Errors{} : Errors{INFINITY, INFINITY, INFINITY};
    auto key = [cell](const std::array<double, 3>& p) {
        return std::array<long long, 3>{(long long)std::floor(p[0] / cell), (long long)std::floor(p[1] / cell), (long long)std::floor(p[2] / cell)};
    };
    std::map<std::array<long long, 3>, std::vector<size_t>> grid;
    for (size_t i = 0; i < ref.size(); ++i) grid[key(ref[i].p)].push_back(i);
    Errors worst;
    std::vector<size_t> ties;
    for (const Sample& p : out) {
        const auto k = key(p.p);
        double best = INFINITY;
        ties.clear();
        for (long long dx = -1; dx <= 1; ++dx)
            for (long long dy = -1; dy <= 1; ++dy)
                for (long long dz = -1; dz <= 1; ++dz) {
                    auto it = grid.find({k[0] + dx, k[1] + dy, k[2] + dz});
                    if (it == grid.end()) continue;
                    for (size_t i : it->second) {
                        const double d = distance(p, ref[i]);
                        if (d < best) best = d, ties.clear();
                        if (d == best) ties.push_back(i);
                    }
                }
        worst.position = std::max(worst.position, std::isfinite(best) ? best : cell);
        // Dropped only when no original at that position matches (a zero-length shell vertex sits on its base).
        Errors best_attr{0, INFINITY, INFINITY, !ties.empty(), !ties.empty()};
        for (size_t i : ties) {
            Errors e;
            attribute_errors(e, ref[i], p);
            const Sample& r = ref[i];
            if (r.has_uv0 == p.has_uv0 && r.has_uv1 == p.has_uv1) best_attr.uv = std::min(best_attr.uv, e.uv);
            if (r.has_n == p.has_n) best_attr.normal_deg = std::min(best_attr.normal_deg, e.normal_deg);
            best_attr.uv_dropped &= e.uv_dropped, best_attr.normal_dropped &= e.normal_dropped;
        }
        worst.uv_dropped |= best_attr.uv_dropped, worst.normal_dropped |= best_attr.normal_dropped;
        if (std::isfinite(best_attr.uv)) worst.uv = std::max(worst.uv, best_attr.uv);
        if (std::isfinite(best_attr.normal_deg)) worst.normal_deg = std::max(worst.normal_deg, best_attr.normal_deg);
    }
    return worst;
}

struct SizeRow {
    std::string model, setting;
    size_t bytes = 0;
    double error_percent = 0; // max |world position change| / world diagonal × 100
    double uv_error = 0, normal_error_deg = 0;
    bool uv_dropped = false, normal_dropped = false;
    double encode_s = 0, decode_s = 0;
    bool peer = false, available = true;
};

Scene load_quiet(const fs::path& f) {
    Scene s;
    require_ok(load_scene(s, f.string()), f.string());
    return s;
}

// One furrow setting: encode (save_scene) and decode (load_scene) times, the file's bytes, the errors
// against the scene in the vertex order this encoding writes.
SizeRow furrow_setting(const Scene& scene, const UvTransforms& source_uv, const std::string& model,
                       const std::string& name, Encoding e, const fs::path& tmp, int repeat, double diag,
                       bool drop_unused_uvs = false) {
    SizeRow r{model, name};
    SaveOptions o;
    o.encoding = e;
    o.drop_unused_uvs = drop_unused_uvs;
    const fs::path out = tmp / (name + ".glb");
    r.encode_s = median_seconds(repeat, [&] { require_ok(save_scene(scene, out.string(), o), out.string()); });
    r.bytes = size_t(fs::file_size(out));
    Scene back;
    r.decode_s = median_seconds(repeat, [&] { back = load_quiet(out); });
    const Errors err = indexed_errors(samples(in_writer_order(scene, e), source_uv), samples(back, uv_transforms(out)));
    r.error_percent = err.position / diag * 100, r.uv_error = err.uv, r.normal_error_deg = err.normal_deg;
    r.uv_dropped = err.uv_dropped, r.normal_dropped = err.normal_dropped;
    fs::remove(out);
    return r;
}

// The peer: gltfpack at the setting that matches --compress (-cc, -vp 14) and --quantize (-vp 14 alone).
SizeRow gltfpack_setting(const fs::path& input, const std::string& model, const std::string& name,
                         const std::vector<std::string>& flags, const fs::path& tmp, int repeat,
                         const std::vector<Sample>& reference, double diag) {
    SizeRow r{model, name};
    r.peer = true;
    const fs::path out = tmp / (name + ".glb");
    std::vector<std::string> argv{"gltfpack", "-i", input.string(), "-o", out.string()};
    argv.insert(argv.end(), flags.begin(), flags.end());
    int code = 0;
    r.encode_s = median_seconds(std::min(repeat, 3), [&] { code = run_peer(argv); });
    if (code != 0 || !fs::exists(out)) {
        r.available = false;
        return r;
    }
    r.bytes = size_t(fs::file_size(out));
    Scene back;
    r.decode_s = median_seconds(repeat, [&] { back = load_quiet(out); });
    const Errors err = nearest_errors(reference, samples(back, uv_transforms(out)), diag * 0.01);
    r.error_percent = err.position / diag * 100, r.uv_error = err.uv, r.normal_error_deg = err.normal_deg;
    r.uv_dropped = err.uv_dropped, r.normal_dropped = err.normal_dropped;
    fs::remove(out);
    return r;
}

std::vector<SizeRow> size_rows(const fs::path& file, const fs::path& tmp, int repeat) {
    const std::string model = file.filename().string();
    const Scene scene = load_quiet(file);
    const UvTransforms source_uv = lower_extension(file.string()) == ".glb" || lower_extension(file.string()) == ".gltf"
                                       ? uv_transforms(file) : UvTransforms{};
    const auto reference = samples(in_writer_order(scene, Encoding::plain), source_uv);
    const double diag = std::max(diagonal_of(reference), 1e-30);
    std::vector<SizeRow> rows;
    rows.push_back(furrow_setting(scene, source_uv, model, "plain", Encoding::plain, tmp, repeat, diag));
    rows.push_back(furrow_setting(scene, source_uv, model, "--quantize", Encoding::quantize, tmp, repeat, diag));
    rows.push_back(furrow_setting(scene, source_uv, model, "--compress", Encoding::compress, tmp, repeat, diag));
    // gltfpack's default: no texture coordinates that no texture samples.
    rows.push_back(furrow_setting(scene, source_uv, model, "--compress --drop-unused-uvs", Encoding::compress, tmp, repeat, diag, true));
    // gltfpack reads glTF only; an OBJ/PLY input goes through furrow's plain GLB first (not timed as its).
    fs::path input = file;
    const std::string ext = lower_extension(file.string());
    if (ext != ".glb" && ext != ".gltf") {
        input = tmp / "peer-input.glb";
        require_ok(save_scene(scene, input.string()), input.string());
    }
    rows.push_back(gltfpack_setting(input, model, "gltfpack -vp 14", {"-vp", "14"}, tmp, repeat, reference, diag));
    rows.push_back(gltfpack_setting(input, model, "gltfpack -cc -vp 14", {"-cc", "-vp", "14"}, tmp, repeat, reference, diag));
    return rows;
}

void print_size_table(const std::vector<SizeRow>& rows, int repeat) {
    Table t({"model", "setting", "bytes", "vs plain", "max error % diag", "max uv error", "max normal deg", "encode ms",
             "decode ms"});
    size_t plain = 0;
    for (const auto& r : rows) {
        if (r.setting == "plain") plain = r.bytes;
        if (!r.available) {
            t.add({r.model, r.setting, "peer not installed", "", "", "", "", "", ""});
            continue;
        }
        t.add({r.model, r.setting, std::to_string(r.bytes), plain ? fmt(double(r.bytes) / double(plain), 3) : "",
               fmt_sci(r.error_percent), r.uv_dropped ? "dropped" : fmt_sci(r.uv_error),
               r.normal_dropped ? "dropped" : fmt(r.normal_error_deg, 2), fmt(r.encode_s * 1e3, 2),
               fmt(r.decode_s * 1e3, 2)});
    }
    std::printf("\nfurrow bench io: output bytes against position error against time, median of %d runs; encode = "
                "save_scene (furrow) or the gltfpack process (peer, median of at most 3); decode = furrow's "
                "load_scene of the output; error = max world-position change after the round trip in %% of the world "
                "diagonal (furrow: vertex by vertex; gltfpack, which welds and reorders: each vertex to its nearest "
                "original); uv error = largest |du|, |dv| of TEXCOORD_0/1 (KHR_texture_transform applied); normal "
                "error = largest angle; gltfpack's against the best original vertex at the matched position; dropped = the "
                "output lacks the attribute)\n",
                repeat);
    t.print();
}

std::string ms_or_dash(double s) { return s < 0 ? "-" : fmt(s * 1e3, 1); }

nlohmann::json row_json(const IoRow& r) {
    const bool peer = r.convert_s > 0 && r.gltfpack_s > 0;
    return {{"model", r.name},
            {"format", r.format},
            {"bytes", r.bytes},
            {"triangles", r.triangles},
            {"load_s", r.load_s},
            {"load_mb_s", r.bytes / r.load_s / 1e6},
            {"save_s", r.save_s},
            {"memcpy_s", r.memcpy_s},
            {"load_over_memcpy", r.load_s / r.memcpy_s},
            {"save_over_memcpy", r.save_s / r.memcpy_s},
            {"peak_mib", r.peak_mib},
            {"roundtrip_max_error", r.roundtrip_max_error},
            {"convert_s", r.convert_s > 0 ? nlohmann::json(r.convert_s) : nlohmann::json()},
            {"gltfpack_s", r.gltfpack_s > 0 ? nlohmann::json(r.gltfpack_s) : nlohmann::json()},
            {"convert_over_gltfpack", peer ? nlohmann::json(r.convert_s / r.gltfpack_s) : nlohmann::json()}};
}

} // namespace

nlohmann::json run_bench_io(const BenchArgs& args, const GlobalFlags& g, bool tables, double generated_mb) {
    std::vector<fs::path> files = collect_bench_inputs(args, {".glb", ".gltf", ".obj", ".ply", ".off", ".stl"});
    if (files.empty() && generated_mb <= 0) throw InputError("bench io", "no input models found (give files or folders)");
    fs::path tmp = fs::temp_directory_path() / ("furrow-bench-" + std::to_string(::getpid()));
    fs::create_directories(tmp);
    const bool gltfpack = on_path("gltfpack");
    std::vector<IoRow> rows;
    std::vector<SizeRow> sizes;
    for (const auto& f : files) {
        info(g, "bench io: " + f.string());
        rows.push_back(bench_one(f, tmp, args.repeat, gltfpack));
        for (SizeRow& r : size_rows(f, tmp, args.repeat)) sizes.push_back(std::move(r));
    }
    if (generated_mb > 0) {
        const int n = models::obj_grid_side_for_bytes(generated_mb * 1e6);
        const fs::path grid = tmp / ("grid_" + std::to_string(n) + ".obj");
        info(g, "bench io: generating " + grid.string());
        if (!models::write_obj_grid(grid.string(), n)) throw InputError(grid.string(), "cannot be written");
        rows.push_back(bench_one(grid, tmp, std::min(args.repeat, 2), gltfpack));
        rows.back().name = "generated " + rows.back().name;
        fs::remove(grid);
        // The same grid as OFF, ASCII PLY, ASCII STL and binary PLY, a fifth of the size: the MB/s of each reader.
        for (const std::string format : {"off", "ply", "stl", "ply binary"}) {
            const bool binary = format == "ply binary";
            const int side = models::text_grid_side_for_bytes(format, generated_mb * 1e6 / 5);
            const fs::path text = tmp / ("grid_" + std::to_string(side) + (binary ? "_binary.ply" : "." + format));
            info(g, "bench io: generating " + text.string());
            const bool written = binary ? models::write_binary_ply_grid(text.string(), side) : models::write_text_grid(text.string(), side, format);
            if (!written) throw InputError(text.string(), "cannot be written");
            rows.push_back(bench_one(text, tmp, std::min(args.repeat, 2), gltfpack));
            rows.back().name = "generated " + rows.back().name;
            fs::remove(text);
        }
    }
    fs::remove_all(tmp);
    nlohmann::json size_json = nlohmann::json::array();
    for (const auto& r : sizes)
        size_json.push_back({{"model", r.model}, {"setting", r.setting}, {"peer", r.peer}, {"available", r.available},
                             {"bytes", r.bytes}, {"max_error_percent_of_diagonal", r.error_percent},
                             {"max_uv_error", r.uv_error}, {"max_normal_error_degrees", r.normal_error_deg},
                             {"uv_dropped", r.uv_dropped}, {"normals_dropped", r.normal_dropped},
                             {"encode_s", r.encode_s}, {"decode_s", r.decode_s}});

    Table t({"model", "format", "input KiB", "triangles", "load ms", "save ms", "memcpy us", "load/memcpy", "save/memcpy",
             "load MB/s", "peak MiB", "roundtrip max|dp|", "convert ms", "gltfpack ms", "convert/gltfpack"});
    nlohmann::json j = nlohmann::json::array();
    std::vector<PlotPoint> points;
    for (const auto& r : rows) {
        const bool peer = r.convert_s > 0 && r.gltfpack_s > 0;
        t.add({r.name, r.format, fmt(r.bytes / 1024.0, 1), std::to_string(r.triangles), fmt(r.load_s * 1e3, 2), fmt(r.save_s * 1e3, 2),
               fmt(r.memcpy_s * 1e6, 2), fmt(r.load_s / r.memcpy_s, 0), fmt(r.save_s / r.memcpy_s, 0),
               fmt(r.bytes / r.load_s / 1e6, 1), fmt(r.peak_mib, 1), fmt_sci(r.roundtrip_max_error), ms_or_dash(r.convert_s),
               ms_or_dash(r.gltfpack_s), peer ? fmt(r.convert_s / r.gltfpack_s, 2) : "-"});
        j.push_back(row_json(r));
        points.push_back({"", "load", r.name, r.load_s, double(r.triangles), r.roundtrip_max_error});
        points.push_back({"", "save (GLB)", r.name, r.save_s, double(r.triangles), r.roundtrip_max_error});
    }
    const std::string peer = gltfpack ? "gltfpack" : "peer not installed";
    if (tables) {
        const std::string generated_runs = generated_mb > 0 ? " (" + std::to_string(std::min(args.repeat, 2)) + " for the generated rows)" : "";
        std::printf("furrow bench io: load and save (GLB) per model, median of %d runs%s; baseline = memcpy of the input's bytes "
                    "(a .gltf with its .bin and image files) in this run; error = max |position change| after save + reload; "
                    "peak MiB = peak resident memory of load + save; convert and gltfpack -noq: wall time of each as a "
                    "subprocess on .obj/.gltf/.glb inputs (gltfpack: %s)\n",
                    args.repeat, generated_runs.c_str(), gltfpack ? "installed" : "peer not installed");
        t.print();
        print_size_table(sizes, args.repeat);
    }
    return {{"bench", "io"}, {"repeat", args.repeat}, {"peer", peer}, {"rows", j}, {"sizes", size_json}, {"plot", plot_json("round-trip max |dp|", points)}};
}

nlohmann::json bench_io_default(const BenchRun& r, const GlobalFlags& g) {
    BenchArgs a;
    if (r.quick) a.inputs = {bundled_models_dir().string()};
    if (r.repeat > 0) a.repeat = r.repeat;
    return run_bench_io(a, g, r.tables, r.quick ? 0 : 100);
}

void register_bench_io(CLI::App& bench, GlobalFlags& g) {
    auto args = std::make_shared<BenchArgs>();
    auto out = std::make_shared<BenchOutput>();
    auto quick = std::make_shared<bool>(false);
    auto generated_mb = std::make_shared<double>(100);
    CLI::App* io = bench.add_subcommand("io", "Load + save time and MB/s per model, peak memory, convert against gltfpack");
    io->add_option("inputs", args->inputs, "Model files or folders (default: models/ and ../shared/corpus)");
    io->add_option("--repeat", args->repeat, "Runs per measurement; the median is reported (default 5)")
        ->check(finite_range(1, 1000));
    io->add_option("--generated-mb", *generated_mb, "Size of the generated OBJ grid row in MB (default 100; 0 = none); the OFF, PLY and STL rows are a fifth of it")
        ->check(finite_range(0, 200));
    io->add_flag("--quick", *quick, "No generated rows");
    add_bench_output_flags(*io, *out);
    io->footer("Examples:\n  furrow bench io\n  furrow bench io --quick\n  furrow bench io ../shared/corpus --repeat 9 --json --plots plots");
    io->callback([args, out, quick, generated_mb, &g] {
        finish_bench(run_bench_io(*args, g, !out->json, *quick ? 0 : *generated_mb), *out, g);
    });
}

} // namespace furrow::cli

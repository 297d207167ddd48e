// `furrow check`: mesh validity report (text or JSON) and --require gates for pipelines.
#include "commands.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace furrow::cli {
namespace {

std::string plural(size_t n, const std::string& one, const std::string& many) {
    return std::to_string(n) + " " + (n == 1 ? one : many);
}

std::string number(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", x);
    return buf;
}

const char* mode_name(PrimitiveMode m) {
    switch (m) {
    case PrimitiveMode::points: return "points";
    case PrimitiveMode::lines: return "lines";
    case PrimitiveMode::triangles: return "triangles";
    }
    return "unknown";
}

struct PrimitiveResult {
    size_t mesh = 0, primitive = 0;
    std::string mesh_name;
    PrimitiveMode mode = PrimitiveMode::triangles;
    CheckReport report;
    std::string label() const {
        return "mesh " + std::to_string(mesh) + (mesh_name.empty() ? "" : " \"" + mesh_name + "\"") + " primitive " +
               std::to_string(primitive);
    }
};

// A requirement returns "" when met, otherwise what failed ("3 boundary edges"). Most look at the total;
// the ones that only make sense per primitive (one component, UVs present) look at each primitive.
struct Requirement {
    const char* name;
    const char* help;
    std::function<std::string(const CheckReport& total, const std::vector<PrimitiveResult>&)> failure;
};

std::string count_failure(size_t n, const char* one, const char* many) { return n ? plural(n, one, many) : ""; }

const std::vector<Requirement>& requirements() {
    static const std::vector<Requirement> list = {
        {"closed", "no boundary edges (every edge has two or more faces) and at least one proper face",
         [](const CheckReport& t, const auto&) -> std::string {
             if (t.boundary_edges) return plural(t.boundary_edges, "boundary edge", "boundary edges");
             return t.closed ? "" : "no faces";
         }},
        {"manifold", "no edge with more than two faces, no vertex whose faces form several fans",
         [](const CheckReport& t, const auto&) -> std::string {
             std::string s;
             if (t.non_manifold_edges) s = plural(t.non_manifold_edges, "non-manifold edge", "non-manifold edges");
             if (t.non_manifold_vertices)
                 s += (s.empty() ? "" : ", ") + plural(t.non_manifold_vertices, "non-manifold vertex", "non-manifold vertices");
             return s;
         }},
        {"oriented", "no interior edge traversed in the same direction by both of its faces",
         [](const CheckReport& t, const auto&) {
             return count_failure(t.inconsistent_edges, "inconsistently oriented edge", "inconsistently oriented edges");
         }},
        {"no-degenerate", "no face that repeats a (welded) vertex",
         [](const CheckReport& t, const auto&) {
             return count_failure(t.degenerate_faces, "degenerate face", "degenerate faces");
         }},
        {"no-zero-area", "no face with area <= 1e-14 x diagonal^2 (degenerate faces included)",
         [](const CheckReport& t, const auto&) {
             return count_failure(t.zero_area_faces, "zero-area face", "zero-area faces");
         }},
        {"no-slivers", "no triangle with an angle below --sliver-angle",
         [](const CheckReport& t, const auto&) { return count_failure(t.slivers, "sliver triangle", "sliver triangles"); }},
        {"no-nan", "no NaN or infinite value in any vertex attribute",
         [](const CheckReport& t, const auto&) { return count_failure(t.nan_values, "NaN/Inf value", "NaN/Inf values"); }},
        {"valid-indices", "every index refers to an existing vertex",
         [](const CheckReport& t, const auto&) {
             return count_failure(t.indices_out_of_range, "index out of range", "indices out of range");
         }},
        {"no-duplicates", "no two vertices with the same position (attribute seams count)",
         [](const CheckReport& t, const auto&) {
             return count_failure(t.duplicate_vertices, "duplicate vertex", "duplicate vertices");
         }},
        {"no-unreferenced", "every vertex is used by the index buffer",
         [](const CheckReport& t, const auto&) {
             return count_failure(t.unreferenced_vertices, "unreferenced vertex", "unreferenced vertices");
         }},
        {"no-valence2", "no interior vertex with only two edges (a fold of the control hull; older subdivision tools mishandle them)",
         [](const CheckReport& t, const auto&) {
             return count_failure(t.valence2_interior_vertices, "interior vertex of valence 2",
                                  "interior vertices of valence 2");
         }},
        {"no-self-intersections", "no intersecting triangle pairs (implies --self-intersections)",
         [](const CheckReport& t, const auto&) -> std::string {
             if (t.self_intersections < 0) return "self-intersections could not be computed";
             return count_failure(size_t(t.self_intersections), "self-intersecting triangle pair",
                                  "self-intersecting triangle pairs");
         }},
        {"single-component", "each triangle primitive is one edge-connected piece",
         [](const CheckReport&, const std::vector<PrimitiveResult>& prims) -> std::string {
             for (const auto& p : prims)
                 if (p.mode == PrimitiveMode::triangles && p.report.components != 1)
                     return plural(p.report.components, "component", "components") + " in " + p.label();
             return "";
         }},
        {"has-uv", "every triangle primitive has TEXCOORD_0",
         [](const CheckReport&, const std::vector<PrimitiveResult>& prims) -> std::string {
             for (const auto& p : prims)
                 if (p.mode == PrimitiveMode::triangles && !p.report.has_uv) return "no TEXCOORD_0 in " + p.label();
             return "";
         }},
        {"uv-in-unit-square", "all TEXCOORD_0 values within [0,1] (no wrapping)",
         [](const CheckReport& t, const auto&) -> std::string {
             if (!t.has_uv) return "";
             if (t.uv_min[0] >= 0 && t.uv_min[1] >= 0 && t.uv_max[0] <= 1 && t.uv_max[1] <= 1) return "";
             return "UVs span [" + number(t.uv_min[0]) + ", " + number(t.uv_min[1]) + "] .. [" +
                    number(t.uv_max[0]) + ", " + number(t.uv_max[1]) + "]";
         }},
    };
    return list;
}

// One line naming what is wrong, for the end of each block (empty when nothing is).
std::string problems(const CheckReport& r) {
    std::vector<std::string> p;
    auto add = [&](size_t n, const char* one, const char* many) {
        if (n) p.push_back(plural(n, one, many));
    };
    add(r.indices_out_of_range, "index out of range", "indices out of range");
    add(r.nan_values, "NaN/Inf value", "NaN/Inf values");
    add(r.non_manifold_edges, "non-manifold edge", "non-manifold edges");
    add(r.non_manifold_vertices, "non-manifold vertex", "non-manifold vertices");
    add(r.inconsistent_edges, "inconsistently oriented edge", "inconsistently oriented edges");
    add(r.degenerate_faces, "degenerate face", "degenerate faces");
    add(r.zero_area_faces, "zero-area face", "zero-area faces");
    add(r.slivers, "sliver", "slivers");
    add(r.valence2_interior_vertices, "interior valence-2 vertex", "interior valence-2 vertices");
    if (r.self_intersections > 0) add(size_t(r.self_intersections), "self-intersecting pair", "self-intersecting pairs");
    add(r.unreferenced_vertices, "unreferenced vertex", "unreferenced vertices");
    std::string s;
    for (const auto& x : p) s += (s.empty() ? "" : ", ") + x;
    return s;
}

std::string text_block(const std::string& title, const CheckReport& r, PrimitiveMode mode, const CheckOptions& o) {
    std::ostringstream out;
    auto line = [&](const char* key, const std::string& value) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "  %-22s ", key);
        out << buf << value << "\n";
    };
    out << title << "\n";
    line("vertices", std::to_string(r.vertices) + " (" + std::to_string(r.welded_vertices) + " unique positions, " +
                         plural(r.duplicate_vertices, "duplicate", "duplicates") + ", " +
                         std::to_string(r.unreferenced_vertices) + " unreferenced)");
    if (mode == PrimitiveMode::triangles) {
        line("faces", std::to_string(r.faces) + " (" + plural(r.triangles, "triangle", "triangles") + ")");
        line("components", std::to_string(r.components));
    }
    line("bounding box", "[" + number(r.bbox_min[0]) + ", " + number(r.bbox_min[1]) + ", " + number(r.bbox_min[2]) +
                             "] .. [" + number(r.bbox_max[0]) + ", " + number(r.bbox_max[1]) + ", " +
                             number(r.bbox_max[2]) + "], diagonal " + number(r.diagonal));
    if (mode == PrimitiveMode::triangles) {
        line("boundary", plural(r.boundary_edges, "edge", "edges") + " in " +
                             plural(r.boundary_loops, "loop", "loops") + (r.closed ? " (closed)" : " (open)"));
        line("non-manifold", plural(r.non_manifold_edges, "edge", "edges") + ", " +
                                 plural(r.non_manifold_vertices, "vertex", "vertices"));
        line("inconsistent edges", std::to_string(r.inconsistent_edges));
        line("degenerate faces", std::to_string(r.degenerate_faces));
        line("zero-area faces", std::to_string(r.zero_area_faces));
        line(("slivers (< " + number(o.sliver_angle_degrees) + " deg)").c_str(), std::to_string(r.slivers));
        line("valence-2 interior", std::to_string(r.valence2_interior_vertices));
        line("self-intersections", r.self_intersections < 0 ? std::string("not computed (--self-intersections)")
                                                            : std::to_string(r.self_intersections) + " triangle pairs");
    }
    line("NaN/Inf values", std::to_string(r.nan_values));
    line("indices out of range", std::to_string(r.indices_out_of_range));
    line("UV (TEXCOORD_0)", r.has_uv ? "[" + number(r.uv_min[0]) + ", " + number(r.uv_min[1]) + "] .. [" +
                                           number(r.uv_max[0]) + ", " + number(r.uv_max[1]) + "]"
                                     : std::string("none"));
    std::string p = problems(r);
    line("problems", p.empty() ? std::string("none") : p);
    return out.str();
}

// Keys in reading order (ordered_json), so that a human skimming the output sees the counts first.
nlohmann::ordered_json to_json(const CheckReport& r) {
    nlohmann::ordered_json j;
    j["vertices"] = r.vertices;
    j["faces"] = r.faces;
    j["triangles"] = r.triangles;
    j["welded_vertices"] = r.welded_vertices;
    j["components"] = r.components;
    j["boundary_edges"] = r.boundary_edges;
    j["boundary_loops"] = r.boundary_loops;
    j["non_manifold_edges"] = r.non_manifold_edges;
    j["non_manifold_vertices"] = r.non_manifold_vertices;
    j["degenerate_faces"] = r.degenerate_faces;
    j["zero_area_faces"] = r.zero_area_faces;
    j["slivers"] = r.slivers;
    j["duplicate_vertices"] = r.duplicate_vertices;
    j["unreferenced_vertices"] = r.unreferenced_vertices;
    j["nan_values"] = r.nan_values;
    j["indices_out_of_range"] = r.indices_out_of_range;
    j["inconsistent_edges"] = r.inconsistent_edges;
    j["valence2_interior_vertices"] = r.valence2_interior_vertices;
    j["self_intersections"] = r.self_intersections < 0 ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(r.self_intersections);
    j["closed"] = r.closed;
    j["manifold"] = r.non_manifold_edges == 0 && r.non_manifold_vertices == 0;
    j["oriented"] = r.inconsistent_edges == 0;
    j["has_uv"] = r.has_uv;
    j["uv_min"] = r.has_uv ? nlohmann::ordered_json(r.uv_min) : nlohmann::ordered_json(nullptr);
    j["uv_max"] = r.has_uv ? nlohmann::ordered_json(r.uv_max) : nlohmann::ordered_json(nullptr);
    j["bbox_min"] = r.bbox_min;
    j["bbox_max"] = r.bbox_max;
    j["diagonal"] = r.diagonal;
    return j;
}

std::string footer() {
    std::string s = "Requirements (--require, comma-separated; each fails with exit code 1):\n";
    for (const auto& r : requirements()) {
        char buf[256];
        std::snprintf(buf, sizeof buf, "  %-22s %s\n", r.name, r.help);
        s += buf;
    }
    s += "\n"
         "Topology is measured after welding vertices by exact position (as a viewer or OpenSubdiv sees the\n"
         "mesh), per primitive, in object space (node transforms are not applied). Polygons count as one face\n"
         "for topology and as their fan triangles for areas, angles and self-intersections.\n"
         "JSON: one object with the totals, \"primitives\" (one object each, same keys) and, with --require,\n"
         "\"requirements\"; self_intersections is null unless computed.\n"
         "\n"
         "Examples:\n"
         "  furrow check bunny.obj\n"
         "  furrow check Fox.glb --json > report.json\n"
         "  furrow check part.stl --require closed,manifold,oriented,no-degenerate\n"
         "  furrow check scan.ply --self-intersections --sliver-angle 5\n"
         "\n"
         "Exit codes: 0 checked (and all requirements met), 1 unreadable input or a failed requirement\n"
         "(one 'Error: <file>: requirement ... failed: ...' line on stderr), 2 bad command line.";
    return s;
}

} // namespace

void run_check(const CheckArgs& a, const GlobalFlags& g) {
    CheckOptions options;
    options.sliver_angle_degrees = a.sliver_angle;
    options.self_intersections = a.self_intersections;
    for (const auto& name : a.require)
        if (name == "no-self-intersections") options.self_intersections = true;

    LoadOptions load = a.load;
    load.recentre = false;        // check the coordinates the file holds
    load.allow_non_finite = true; // NaN/Inf is a finding to report, not a reason to refuse the file
    Scene scene = load_or_throw(a.input, load);
    for (const auto& w : scene.warnings) info(g, "Warning: " + a.input + ": " + w);

    std::vector<PrimitiveResult> results;
    for (size_t m = 0; m < scene.meshes.size(); ++m)
        for (size_t p = 0; p < scene.meshes[m].primitives.size(); ++p) {
            const Primitive& prim = scene.meshes[m].primitives[p];
            results.push_back({m, p, scene.meshes[m].name, prim.mode, check_primitive(prim, options)});
        }
    std::vector<CheckReport> reports;
    for (const auto& r : results) reports.push_back(r.report);
    const CheckReport total = merge_reports(reports);

    std::vector<std::string> required; // in the order given, each once
    for (const auto& name : a.require)
        if (std::find(required.begin(), required.end(), name) == required.end()) required.push_back(name);
    std::vector<std::pair<std::string, std::string>> failed; // name, what
    for (const auto& name : required)
        for (const auto& req : requirements())
            if (name == req.name) {
                std::string what = req.failure(total, results);
                if (!what.empty()) failed.emplace_back(name, what);
            }

    if (a.json) {
        nlohmann::ordered_json j;
        j["file"] = a.input;
        j["options"] = {{"sliver_angle_degrees", options.sliver_angle_degrees},
                        {"self_intersections", options.self_intersections}};
        j.update(to_json(total));
        nlohmann::ordered_json prims = nlohmann::ordered_json::array();
        for (const auto& r : results) {
            nlohmann::ordered_json pj;
            pj["mesh"] = r.mesh;
            pj["mesh_name"] = r.mesh_name;
            pj["primitive"] = r.primitive;
            pj["mode"] = mode_name(r.mode);
            pj.update(to_json(r.report));
            prims.push_back(std::move(pj));
        }
        j["primitives"] = std::move(prims);
        if (!required.empty()) {
            nlohmann::ordered_json reqs = nlohmann::ordered_json::array();
            for (const auto& name : required) {
                nlohmann::ordered_json rj = {{"name", name}, {"passed", true}};
                for (const auto& f : failed)
                    if (f.first == name) rj["passed"] = false, rj["failure"] = f.second;
                reqs.push_back(std::move(rj));
            }
            j["requirements"] = std::move(reqs);
        }
        // Mesh names come from the file: replace invalid UTF-8 rather than fail on it.
        std::printf("%s\n", j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace).c_str());
    } else if (!g.quiet) {
        std::string out = a.input + "\n";
        for (const auto& r : results)
            out += text_block(r.label() + " (" + mode_name(r.mode) + ")", r.report, r.mode, options);
        if (results.size() != 1)
            out += text_block("total (" + plural(results.size(), "primitive", "primitives") + ")", total,
                              PrimitiveMode::triangles, options);
        std::fputs(out.c_str(), stdout);
    }
    std::fflush(stdout);

    if (!failed.empty()) {
        std::string msg;
        for (const auto& f : failed)
            msg += (msg.empty() ? "" : "; ") + ("requirement '" + f.first + "' failed: " + f.second);
        throw InputError(a.input, msg);
    }
}

void register_check(CLI::App& app, GlobalFlags& g) {
    auto args = std::make_shared<CheckArgs>();
    CLI::App* cmd = app.add_subcommand("check", "Report mesh validity: topology, degeneracies, NaNs, UVs, "
                                                "self-intersections; --require makes it a gate");
    cmd->add_option("IN", args->input, "Input mesh (.gltf .glb .obj .ply .off .stl)")->required();
    cmd->add_flag("--json", args->json, "Print one JSON object (totals + \"primitives\") instead of the text report");
    cmd->add_flag("--self-intersections", args->self_intersections,
                  "Also count intersecting triangle pairs (CGAL; slow on large meshes)");
    cmd->add_option("--sliver-angle", args->sliver_angle,
                    "A triangle with an angle below DEG degrees is a sliver (default 1)")
        ->type_name("DEG")
        ->check(finite_range(0.0, 180.0));
    std::vector<std::string> names;
    for (const auto& r : requirements()) names.push_back(r.name);
    cmd->add_option("--require", args->require,
                    "Fail (exit 1) unless the mesh meets these, comma-separated: see the list below")
        ->type_name("NAME,...")
        ->delimiter(',')
        ->check(CLI::IsMember(names).description("")); // the footer lists and explains them
    add_load_flags(*cmd, args->load);
    cmd->footer(footer());
    cmd->callback([args, &g] { run_check(*args, g); });
}

} // namespace furrow::cli

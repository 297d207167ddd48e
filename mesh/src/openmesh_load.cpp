// The former PLY and OFF readers through OpenMesh's (now: ply_load.cpp for ASCII and binary PLY, off_load.cpp,
// obj_load.cpp), reachable from tests only, kept as the oracles their replacements are tested against
// (tests/mesh/test_ply_load.cpp, test_off_load.cpp). The readers feed a recording importer instead of
// a halfedge mesh: a halfedge structure would silently drop or split the non-manifold and degenerate faces
// that `furrow check` must see. Polygons stay polygons (Catmull-Clark wants the quads).
#include "document.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstring>
#include <cmath>
#include <sstream>

namespace furrow {
namespace {

using OpenMesh::EdgeHandle;
using OpenMesh::FaceHandle;
using OpenMesh::HalfedgeHandle;
using OpenMesh::VertexHandle;
using OpenMesh::Vec2f;
using OpenMesh::Vec3d;
using OpenMesh::Vec3f;
using OpenMesh::Vec3uc;
using OpenMesh::Vec4f;
using OpenMesh::Vec4uc;

// Records what a reader reports, with no topology of its own.
class RecordingImporter final : public OpenMesh::IO::BaseImporter, public mesh_detail::ReaderMesh {
public:
    VertexHandle add_vertex(const Vec3f& p) override { return add_vertex(Vec3d(p[0], p[1], p[2])); }
    VertexHandle add_vertex(const Vec3d& p) override {
        points.insert(points.end(), {p[0], p[1], p[2]});
        normals.insert(normals.end(), {0, 0, 0});
        colors.insert(colors.end(), {1, 1, 1, 1});
        vertex_uv.insert(vertex_uv.end(), {0, 0});
        return VertexHandle(int(points.size() / 3 - 1));
    }
    VertexHandle add_vertex() override { return add_vertex(Vec3d(0, 0, 0)); }
    HalfedgeHandle add_edge(VertexHandle, VertexHandle) override { return HalfedgeHandle(); }
    FaceHandle add_face(const VHandles& idx) override {
        face_start.push_back(uint32_t(corners.size()));
        for (auto vh : idx) corners.push_back(uint32_t(vh.idx()));
        corner_uv.resize(corners.size() * 2, 0.0f);
        return FaceHandle(int(face_start.size() - 1));
    }
    FaceHandle add_face(HalfedgeHandle) override { return FaceHandle(); }
    void add_face_texcoords(FaceHandle fh, VertexHandle first, const std::vector<Vec2f>& uv) override {
        if (!fh.is_valid() || size_t(fh.idx()) >= face_start.size()) return;
        size_t begin = face_start[size_t(fh.idx())];
        size_t end = size_t(fh.idx()) + 1 < face_start.size() ? face_start[size_t(fh.idx()) + 1] : corners.size();
        // The reader lists texcoords from the face's first corner on, in corner order.
        (void)first;
        for (size_t k = 0; k < uv.size() && begin + k < end; ++k) {
            corner_uv[(begin + k) * 2] = uv[k][0];
            corner_uv[(begin + k) * 2 + 1] = uv[k][1];
            any_corner_uv = true;
        }
    }
    void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<Vec3f>&) override {}
    void set_face_texindex(FaceHandle, int) override {}
    void set_point(VertexHandle vh, const Vec3f& p) override {
        if (valid(vh)) for (int k = 0; k < 3; ++k) points[size_t(vh.idx()) * 3 + size_t(k)] = p[k];
    }
    void set_halfedge(VertexHandle, HalfedgeHandle) override {}
    void set_normal(VertexHandle vh, const Vec3f& n) override { set_normal(vh, Vec3d(n[0], n[1], n[2])); }
    void set_normal(VertexHandle vh, const Vec3d& n) override {
        if (!valid(vh)) return;
        for (int k = 0; k < 3; ++k) normals[size_t(vh.idx()) * 3 + size_t(k)] = float(n[k]);
        any_normal = true;
    }
    void set_color(VertexHandle vh, const Vec3uc& c) override { set_color(vh, Vec4f(c[0] / 255.f, c[1] / 255.f, c[2] / 255.f, 1)); }
    void set_color(VertexHandle vh, const Vec4uc& c) override {
        set_color(vh, Vec4f(c[0] / 255.f, c[1] / 255.f, c[2] / 255.f, c[3] / 255.f));
    }
    void set_color(VertexHandle vh, const Vec3f& c) override { set_color(vh, Vec4f(c[0], c[1], c[2], 1)); }
    void set_color(VertexHandle vh, const Vec4f& c) override {
        if (!valid(vh)) return;
        for (int k = 0; k < 4; ++k) colors[size_t(vh.idx()) * 4 + size_t(k)] = c[k];
        any_color = true;
    }
    void set_texcoord(VertexHandle vh, const Vec2f& t) override {
        if (!valid(vh)) return;
        vertex_uv[size_t(vh.idx()) * 2] = t[0];
        vertex_uv[size_t(vh.idx()) * 2 + 1] = t[1];
        any_vertex_uv = true;
    }
    void set_status(VertexHandle, const OpenMesh::Attributes::StatusInfo&) override {}
    void set_next(HalfedgeHandle, HalfedgeHandle) override {}
    void set_face(HalfedgeHandle, FaceHandle) override {}
    void request_face_texcoords2D() override {}
    void set_texcoord(HalfedgeHandle, const Vec2f&) override {}
    void set_texcoord(VertexHandle, const Vec3f&) override {}
    void set_texcoord(HalfedgeHandle, const Vec3f&) override {}
    void set_status(HalfedgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
    void set_color(EdgeHandle, const Vec3uc&) override {}
    void set_color(EdgeHandle, const Vec4uc&) override {}
    void set_color(EdgeHandle, const Vec3f&) override {}
    void set_color(EdgeHandle, const Vec4f&) override {}
    void set_status(EdgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
    void set_normal(FaceHandle, const Vec3f&) override {}
    void set_normal(FaceHandle, const Vec3d&) override {}
    void set_color(FaceHandle, const Vec3uc&) override {}
    void set_color(FaceHandle, const Vec4uc&) override {}
    void set_color(FaceHandle, const Vec3f&) override {}
    void set_color(FaceHandle, const Vec4f&) override {}
    void set_status(FaceHandle, const OpenMesh::Attributes::StatusInfo&) override {}
    void add_texture_information(int, std::string) override {}
    size_t n_vertices() const override { return points.size() / 3; }
    size_t n_faces() const override { return face_start.size(); }
    size_t n_edges() const override { return 0; }

private:
    bool valid(VertexHandle vh) const { return vh.is_valid() && size_t(vh.idx()) < points.size() / 3; }
};

// OpenMesh's PLY reader (PLYReader.cc) trusts the file throughout. Its header parser (can_u_read) reads
// tokens until "end_header" and stops early only on a *bad* stream: at the end of the file, or after a count
// that does not convert, the last keyword stays what it was and the loop never ends; a "property" before any
// "element" indexes an empty element list. Its body readers loop over element and list counts without
// looking at the stream: a face claiming 4e9 corners (ASCII text, or an int list count in binary) loops 4e9
// times, and a failed read leaves the previous count in place for every later face; a "texcoord" list on a
// face without corners asserts (Debian builds OpenMesh with assertions on). Found by fuzz_load_scene. The
// reader lives in the shared libOpenMeshCore, so the file is walked here first the way it walks it, and
// refused unless every read would succeed within the file. Stricter than needed in places (one vertex and
// one face element, numbers written plainly). PLY: http://paulbourke.net/dataformats/ply/
struct PlyProperty {
    std::string name;
    bool list = false;
    std::string type, index_type; // value (list entry) type, list count type
};
struct PlyElement {
    std::string name;
    unsigned long long count = 0;
    std::vector<PlyProperty> properties;
};

int ply_type_size(const std::string& t) {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32") return 4;
    if (t == "double" || t == "float64") return 8;
    return 0; // OpenMesh's Unsupported: consumes nothing
}

// The header up to end_header: the format, the elements with their properties, where end_header began
// (before_end) and each element's count against the body's size. `in` is left after end_header.
Status parse_ply_header(std::istringstream& in, std::string& file_type, std::vector<PlyElement>& elements, std::streamoff& before_end,
                        const std::string& bytes) {
    auto bad = [](const std::string& m) { return Status::error(StatusCode::invalid_input, "PLY: " + m); };
    std::string line;
    std::getline(in, line);
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    if (line != "ply" && line != "PLY") return bad("the file does not start with 'ply'");
    std::string keyword;
    float version = 0;
    in >> keyword >> file_type >> version;
    if (in.fail() || keyword != "format") return bad("no valid format line");
    if (file_type != "ascii" && file_type != "binary_little_endian" && file_type != "binary_big_endian")
        return bad("unknown format '" + file_type.substr(0, 24) + "'");
    for (;;) {
        before_end = in.tellg();
        in >> keyword;
        if (in.fail()) return bad("the header has no end_header");
        if (keyword == "end_header") break;
        if (keyword == "comment") {
            std::getline(in, line);
        } else if (keyword == "element") {
            PlyElement e;
            unsigned int count = 0;
            in >> e.name >> count;
            e.count = count;
            elements.push_back(e);
        } else if (keyword == "property") {
            if (elements.empty()) return bad("a property before any element");
            PlyProperty p;
            std::string a, b;
            in >> a;
            if (a == "list") {
                p.list = true;
                in >> p.index_type >> p.type >> p.name;
                if (p.index_type != "uint8" && p.index_type != "uint16" && p.index_type != "uchar" && p.index_type != "int")
                    return bad("unsupported list count type '" + p.index_type.substr(0, 16) + "'");
            } else {
                in >> b;
                // "float x" or "x float": OpenMesh takes whichever word is a type.
                const bool a_type = ply_type_size(a) > 0;
                p.type = a_type ? a : b;
                p.name = a_type ? b : a;
            }
            std::vector<PlyProperty>& props = elements.back().properties;
            // Properties of a face listed before its vertex indices are dropped by OpenMesh (it warns).
            if (elements.back().name == "face" && p.list && (p.name == "vertex_index" || p.name == "vertex_indices"))
                props.clear();
            props.push_back(p);
        }
        if (in.fail()) return bad("malformed " + keyword.substr(0, 16) + " line");
    }
    size_t vertex_elements = 0, face_elements = 0;
    for (const PlyElement& e : elements) vertex_elements += e.name == "vertex", face_elements += e.name == "face";
    if (vertex_elements > 1 || face_elements > 1) return bad("more than one vertex or face element");
    // Every element takes at least one byte of the body (an element of no properties would otherwise loop
    // its count through nothing, here and in OpenMesh).
    const auto header_end = in.tellg();
    const unsigned long long body = header_end < 0 ? 0 : bytes.size() - std::min(bytes.size(), size_t(header_end));
    for (const PlyElement& e : elements)
        if (e.count > body) return bad("an element count of " + std::to_string(e.count) + " is more than the file holds");

    return Status::success();
}

// An ASCII body: OpenMesh reads on from the token after end_header. Numbers it reads must be plain numbers,
// so that each of its reads takes exactly one token and none fails.
Status check_ply_ascii_body(std::istringstream& in, const std::vector<PlyElement>& elements) {
    auto bad = [](const std::string& m) { return Status::error(StatusCode::invalid_input, "PLY: " + m); };
    std::vector<std::string> tokens;
    for (std::string t; in >> t;) tokens.push_back(t);
    size_t at = 0;
    auto unsigned_token = [&](unsigned long long& v) {
        if (at >= tokens.size()) return false;
        const std::string& t = tokens[at++];
        auto r = std::from_chars(t.data(), t.data() + t.size(), v);
        return r.ec == std::errc() && r.ptr == t.data() + t.size() && v <= 0xFFFFFFFFull;
    };
    auto number_token = [&]() {
        if (at >= tokens.size()) return false;
        const std::string& t = tokens[at++];
        double v = 0;
        auto r = std::from_chars(t.data(), t.data() + t.size(), v);
        return !t.empty() && (std::isdigit(static_cast<unsigned char>(t[0])) || t[0] == '-' || t[0] == '.') &&
               r.ec == std::errc() && r.ptr == t.data() + t.size() && std::abs(v) <= 3.4e38;
    };
    for (const PlyElement& e : elements) {
        const bool face = e.name == "face";
        for (unsigned long long i = 0; i < e.count; ++i) {
            unsigned long long corners = 0;
            bool have_corners = false;
            for (const PlyProperty& p : e.properties) {
                if (face && p.list && (p.name == "vertex_index" || p.name == "vertex_indices" || p.name == "texcoord")) {
                    unsigned long long n = 0, v = 0;
                    if (!unsigned_token(n) || n > tokens.size() - at) return bad("a face list count is not valid");
                    if (p.name == "texcoord" && (!have_corners || corners == 0))
                        return bad("face texture coordinates without corners");
                    for (unsigned long long k = 0; k < n; ++k)
                        if (p.name == "texcoord" ? !number_token() : !unsigned_token(v)) return bad("a face holds something other than numbers");
                    if (p.name != "texcoord") corners = n, have_corners = true;
                } else if (at >= tokens.size()) {
                    return bad("the file ends before its last element");
                } else if (!p.list && ply_type_size(p.type) > 0) {
                    if (!number_token()) {
                        std::string what(1, '\''); // appended: GCC 12 warns (-Wrestrict, a false positive) on "'" + std::string&&
                        what += tokens[at - 1].substr(0, 16);
                        return bad(what + "' is not a number");
                    }
                } else {
                    ++at; // read as a word and dropped
                }
            }
        }
        if (face) break; // OpenMesh stops after the faces
    }
    return Status::success();
}

// A binary body: OpenMesh seeks to 12 bytes (14 after "\r\n") past where the end_header token began.
Status check_ply_binary_body(const std::string& bytes, const std::vector<PlyElement>& elements, bool msb, std::streamoff before_end) {
    auto bad = [](const std::string& m) { return Status::error(StatusCode::invalid_input, "PLY: " + m); };
    size_t at = size_t(before_end) + (bytes.compare(size_t(before_end), 2, "\r\n") == 0 ? 14 : 12);
    auto read_count = [&](const std::string& type, unsigned long long& n) {
        const int size = ply_type_size(type);
        if (at + size_t(size) > bytes.size()) return false;
        uint32_t u = 0;
        for (int k = 0; k < size; ++k) u |= uint32_t(uint8_t(bytes[at + size_t(msb ? size - 1 - k : k)])) << (8 * k);
        at += size_t(size);
        n = type == "int" ? uint64_t(uint32_t(int32_t(u))) : u; // OpenMesh stores it in an unsigned int
        return true;
    };
    for (const PlyElement& e : elements) {
        const bool face = e.name == "face";
        if (!face) { // every property one scalar (a list too: OpenMesh consumes one entry-sized value)
            unsigned long long record = 0;
            for (const PlyProperty& p : e.properties) record += unsigned(ply_type_size(p.type));
            if (record && e.count > (bytes.size() - std::min(bytes.size(), at)) / record)
                return bad("element '" + e.name.substr(0, 16) + "' is longer than the file");
            at += size_t(e.count * record);
            continue;
        }
        for (unsigned long long i = 0; i < e.count; ++i) {
            unsigned long long corners = 0;
            bool have_corners = false;
            for (const PlyProperty& p : e.properties) {
                const unsigned long long value = unsigned(ply_type_size(p.type));
                if (p.list && (p.name == "vertex_index" || p.name == "vertex_indices" || p.name == "texcoord")) {
                    unsigned long long n = 0;
                    if (!read_count(p.index_type, n)) return bad("the file ends inside a face");
                    if (p.name == "texcoord" && (!have_corners || corners == 0))
                        return bad("face texture coordinates without corners");
                    if (value && n > (bytes.size() - std::min(bytes.size(), at)) / value)
                        return bad("a face list is longer than the file");
                    if (!value && n > bytes.size()) return bad("a face list count is not valid");
                    at += size_t(n * value);
                    if (p.name != "texcoord") corners = n, have_corners = true;
                } else {
                    at += size_t(value);
                }
                if (at > bytes.size()) return bad("the file ends inside a face");
            }
        }
        break; // OpenMesh stops after the faces
    }
    return Status::success();
}

Status check_ply(const std::string& bytes) {
    std::istringstream in(bytes);
    std::string file_type;
    std::vector<PlyElement> elements;
    std::streamoff before_end = 0;
    if (Status s = parse_ply_header(in, file_type, elements, before_end, bytes); !s.ok()) return s;
    if (file_type == "ascii") return check_ply_ascii_body(in, elements);
    return check_ply_binary_body(bytes, elements, file_type == "binary_big_endian", before_end);
}

// OpenMesh's OFF reader (OFFReader.cc, read_ascii) checks none of its stream reads: without counts in the
// header it loops over an uninitialised vertex count (a 2 GB allocation from an empty file), and a face line
// that fails to read keeps the previous corner count for every remaining face. The file is walked here first
// with the same reads, each checked, so that OpenMesh only ever sees input it reads to the end. Reading from a
// stream, OpenMesh never parses the header keyword (IOManager skips can_u_read for streams), so only the ASCII
// variants whose vertex lines begin with x y z are read correctly: binary and 4D/nD files are refused.
// Found by fuzz_load_scene. OFF: https://segeval.cs.princeton.edu/public/off_format.html
Status check_off(const std::string& bytes) {
    auto bad = [](const std::string& m) { return Status::error(StatusCode::invalid_input, "OFF: " + m); };
    std::istringstream in(bytes);
    std::string header;
    std::getline(in, header);
    std::istringstream words(header);
    std::string keyword, more;
    words >> keyword >> more;
    std::string k = keyword;
    if (k.rfind("ST", 0) == 0) k = k.substr(2);
    if (!k.empty() && k[0] == 'C') k = k.substr(1);
    if (!k.empty() && k[0] == 'N') k = k.substr(1);
    if (k != "OFF") return bad("the first line must be OFF (or STOFF, COFF, NOFF...), not '" + keyword.substr(0, 16) + "'");
    if (more == "BINARY") return Status::error(StatusCode::unsupported, "OFF: binary OFF files are not supported");
    unsigned int nv = 0, nf = 0, ne = 0;
    in >> nv >> nf >> ne;
    if (in.fail()) return bad("no vertex, face and edge counts after the header");
    const auto at = in.tellg();
    const size_t body = at < 0 ? 0 : bytes.size() - std::min(bytes.size(), size_t(at));
    if (nv > body || nf > body) return bad("the counts (" + std::to_string(nv) + " vertices, " + std::to_string(nf) +
                                           " faces) are more than the file holds");
    std::string rest;
    for (unsigned int i = 0; i < nv && !in.eof(); ++i) {
        float x, y, z;
        in >> x >> y >> z;
        if (in.fail()) return bad("vertex " + std::to_string(i) + " is not three numbers");
        std::getline(in, rest);
    }
    for (unsigned int f = 0; f < nf; ++f) {
        unsigned int corners = 0, index = 0;
        in >> corners;
        if (in.fail() || corners > body) return bad("face " + std::to_string(f) + " has no valid corner count");
        for (unsigned int c = 0; c < corners && !in.fail(); ++c) in >> index;
        if (in.fail()) return bad("face " + std::to_string(f) + " has fewer indices than its corner count");
    }
    return Status::success();
}

} // namespace

Status load_openmesh_bytes(Scene& out, const std::string& bytes, const std::string& ext, const LoadOptions& options) {
    // OpenMesh reports problems on its own streams; our caller reports them as one Error line instead.
    ::omerr().disable();
    ::omlog().disable();
    ::omout().disable();
    RecordingImporter rec;
    OpenMesh::IO::Options opt = OpenMesh::IO::Options::VertexTexCoord | OpenMesh::IO::Options::FaceTexCoord |
                                OpenMesh::IO::Options::VertexNormal | OpenMesh::IO::Options::VertexColor;
    const std::string fmt = ext.substr(1);
    Status checked = ext == ".ply" ? check_ply(bytes) : check_off(bytes);
    if (!checked.ok()) return checked;
    std::istringstream in(bytes);
    bool ok = OpenMesh::IO::IOManager().read(in, fmt, rec, opt);
    if (!ok) return Status::error(StatusCode::invalid_input, "could not be parsed as " + fmt + " (OpenMesh reader failed)");
    return mesh_detail::reader_mesh_to_scene(out, rec, options);
}

} // namespace furrow

// OBJ / PLY / OFF loading through OpenMesh's readers. The readers feed a recording importer instead of
// a halfedge mesh: a halfedge structure would silently drop or split the non-manifold and degenerate faces
// that `furrow check` must see. Polygons stay polygons (Catmull-Clark wants the quads).
#include "document.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <charconv>
#include <cstring>
#include <cmath>
#include <map>
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
class RecordingImporter final : public OpenMesh::IO::BaseImporter {
public:
    std::vector<double> points;        // xyz per reader vertex
    std::vector<float> normals;        // xyz per reader vertex (if any reported)
    std::vector<float> colors;         // rgba per reader vertex (if any reported)
    std::vector<float> vertex_uv;      // uv per reader vertex (if any reported)
    std::vector<uint32_t> face_start;  // offset into corners
    std::vector<uint32_t> corners;     // reader vertex indices
    std::vector<float> corner_uv;      // uv per corner, parallel to corners (if faces reported texcoords)
    std::vector<char> corner_has_uv;
    bool any_normal = false, any_color = false, any_vertex_uv = false, any_corner_uv = false;

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
        corner_has_uv.resize(corners.size(), 0);
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
            corner_has_uv[begin + k] = 1;
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

// OpenMesh's OBJ reader parses coordinates as float; re-read the `v` lines in double so that a model
// 1e5 m from the origin keeps its millimetres (the reader's vertex order is the file's `v` order).
void reread_obj_positions_double(const std::string& text, std::vector<double>& points) {
    size_t vi = 0, at = 0;
    while (at < text.size()) {
        size_t end = text.find('\n', at);
        if (end == std::string::npos) end = text.size();
        const char* b = text.data() + at;
        const char* e = text.data() + end;
        while (b < e && (*b == ' ' || *b == '\t')) ++b;
        if (e - b > 2 && b[0] == 'v' && (b[1] == ' ' || b[1] == '\t')) {
            double xyz[3];
            const char* p = b + 2;
            bool ok = true;
            for (double& c : xyz) {
                while (p < e && (*p == ' ' || *p == '\t')) ++p;
                auto r = std::from_chars(p, e, c);
                if (r.ec != std::errc()) { ok = false; break; }
                p = r.ptr;
            }
            if (ok && vi * 3 + 2 < points.size())
                for (int k = 0; k < 3; ++k) points[vi * 3 + size_t(k)] = xyz[k];
            ++vi;
        }
        at = end + 1;
    }
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
    std::string fmt = ext.substr(1);
    std::istringstream in(bytes);
    bool ok = OpenMesh::IO::IOManager().read(in, fmt, rec, opt);
    if (!ok) return Status::error(StatusCode::invalid_input, "could not be parsed as " + fmt + " (OpenMesh reader failed)");
    if (rec.n_vertices() == 0) return Status::error(StatusCode::invalid_input, "contains no vertices");
    if (ext == ".obj") reread_obj_positions_double(bytes, rec.points);

    // Corners become glTF-style vertices: one per distinct (reader vertex, corner uv) pair, so UV seams split.
    Primitive p;
    const bool uv_per_corner = rec.any_corner_uv;
    std::map<std::pair<uint32_t, std::pair<float, float>>, uint32_t> split;
    std::vector<uint32_t> reader_vertex; // new vertex -> reader vertex
    std::vector<float> uvs;
    const size_t nv = rec.n_vertices();
    auto vertex_for = [&](size_t corner) -> uint32_t {
        uint32_t v = rec.corners[corner];
        if (!uv_per_corner) return v;
        std::pair<float, float> uv{rec.corner_uv[corner * 2], rec.corner_uv[corner * 2 + 1]};
        auto [it, inserted] = split.insert({{v, uv}, uint32_t(reader_vertex.size())});
        if (inserted) {
            reader_vertex.push_back(v);
            uvs.push_back(uv.first);
            uvs.push_back(uv.second);
        }
        return it->second;
    };
    size_t dropped = 0, out_of_range = 0;
    for (size_t f = 0; f < rec.face_start.size(); ++f) {
        size_t b = rec.face_start[f], e = f + 1 < rec.face_start.size() ? rec.face_start[f + 1] : rec.corners.size();
        if (e - b < 3) { ++dropped; continue; }
        bool bad = false;
        for (size_t c = b; c < e; ++c) bad |= rec.corners[c] >= nv;
        if (bad) { ++out_of_range; continue; }
        for (size_t c = b; c < e; ++c) p.indices.push_back(vertex_for(c));
        p.face_sizes.push_back(uint32_t(e - b));
    }
    if (out_of_range)
        return Status::error(StatusCode::invalid_input, std::to_string(out_of_range) + " faces reference vertices that do not exist");
    if (!uv_per_corner) {
        reader_vertex.resize(nv);
        for (size_t i = 0; i < nv; ++i) reader_vertex[i] = uint32_t(i);
        if (rec.any_vertex_uv) uvs = rec.vertex_uv;
    }
    // Positions relative to the bbox centre, computed in double (recentre() only sees floats).
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    bool finite = true;
    for (size_t i = 0; i < nv; ++i)
        for (int k = 0; k < 3; ++k) {
            double x = rec.points[i * 3 + size_t(k)];
            if (!std::isfinite(x)) { finite = false; continue; }
            lo[k] = std::min(lo[k], x);
            hi[k] = std::max(hi[k], x);
        }
    if (!finite && !options.allow_non_finite)
        return Status::error(StatusCode::invalid_input, "vertex positions contain NaN or infinite values");
    double centre[3] = {0, 0, 0};
    if (options.recentre && lo[0] <= hi[0]) {
        double diag = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                (hi[2] - lo[2]) * (hi[2] - lo[2]));
        double c[3] = {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
        double dist = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        if (dist > options.recentre_threshold * std::max(diag, 1e-300) || dist > 1e4)
            for (int k = 0; k < 3; ++k) centre[k] = c[k];
    }
    const size_t n = reader_vertex.size();
    p.positions.resize(n * 3);
    for (size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k)
            p.positions[i * 3 + size_t(k)] = float(rec.points[size_t(reader_vertex[i]) * 3 + size_t(k)] - centre[k]);
    if (rec.any_normal) {
        p.normals.resize(n * 3);
        for (size_t i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k) p.normals[i * 3 + size_t(k)] = rec.normals[size_t(reader_vertex[i]) * 3 + size_t(k)];
    }
    if (rec.any_color) {
        p.colors.resize(n * 4);
        for (size_t i = 0; i < n; ++i)
            for (int k = 0; k < 4; ++k) p.colors[i * 4 + size_t(k)] = rec.colors[size_t(reader_vertex[i]) * 4 + size_t(k)];
    }
    if (!uvs.empty()) {
        // OBJ/PLY put v = 0 at the bottom of the image; glTF at the top.
        for (size_t i = 1; i < uvs.size(); i += 2) uvs[i] = 1.0f - uvs[i];
        p.uv0 = std::move(uvs);
    }
    bool all_tris = true;
    for (uint32_t s : p.face_sizes) all_tris &= s == 3;
    if (all_tris) p.face_sizes.clear();
    Scene scene = make_scene(std::move(p), "mesh");
    scene.nodes[0].translation = {centre[0], centre[1], centre[2]};
    if (dropped) scene.warnings.push_back(std::to_string(dropped) + " faces with fewer than 3 distinct corners were dropped by the reader");
    out = std::move(scene);
    return Status::success();
}

} // namespace furrow

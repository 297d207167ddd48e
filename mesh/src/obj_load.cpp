// OBJ in one pass over the bytes, std::from_chars on the buffer: no stream and no string per line. OpenMesh's
// reader (used before) read the file twice through a string stream per line, after a validation pass that
// read it a third time (8 MB/s); this reads 100+ MB/s and gives the same scene for every file it accepted
// (same vertices in the same order, same seam splits, same attributes), with these differences: a line
// ending in '\' continues on the next line (OpenMesh read the '\' as a corner and dropped the face), a
// `vt` line that is not two numbers is refused by line, and faces with fewer than 3 distinct corners are
// reported in a warning instead of vanishing silently.
// Stages:
//  - lines: split at '\n', trimmed of ' ', '\t', '\r' (CRLF files), empty lines and '#' comments skipped, '\'
//    continuations joined. Words are split at any C whitespace (tabs included). Only v, vt, vn, vc and f
//    mean something: o, g, s, usemtl, l, p and the rest are skipped, and mtllib is never opened (furrow
//    reads no materials; OpenMesh read /dev/zero forever).
//  - numbers: read the way a C++ stream reads them (what OpenMesh did, so that a file means the same): the
//    longest [sign] digits [. digits] [e [sign] digits] prefix, which must convert whole ("1e" does not).
//    `v` coordinates in double (a model 1e5 m from the origin keeps its millimetres), refused by line unless
//    three finite numbers that fit a float (OpenMesh skipped such a line and every later vertex shifted
//    by one); three more numbers are a vertex colour. vt/vn/vc in float.
//  - face corners: v, v/t, v//n, v/t/n, negative indices relative to the lines read so far; a corner word
//    that is not a number is skipped, a corner with a '/' must start with a vertex index (OpenMesh asserted).
//    Indices are kept raw: positive ones may name vertices, texcoords and normals later in the file.
//  - attributes, once the whole file is read: per corner the texcoord and normal are set on the vertex,
//    and the face's texcoords on its corners; a face's repeated vertices are removed first and a face left
//    with fewer than 3 is dropped. This keeps OpenMesh's quirks that decide the output of valid files:
//    vertex colours are indexed by vertex number among the lines that had a colour, and a face that
//    repeats a vertex gets its texcoords on the remaining corners in order.
//  - reader_mesh_to_scene: glTF vertices split by corner uv, recentring in double, v flipped.
// OBJ: https://paulbourke.net/dataformats/obj/
#include "document.h"
#include "text_numbers.h"
#include <furrow_kernel/huge_pages.h>

#include <charconv>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace furrow::mesh_detail {
namespace {

struct ObjText {
    std::vector<double> points;               // xyz per `v`
    std::vector<float> colors, uvs, normals;  // rgb per coloured `v` or `vc`; uv per `vt`; xyz per parsed `vn`
    size_t normal_lines = 0;                  // `vn` lines, parsed or not (negative normal indices count them)
    std::vector<uint32_t> face_start;         // into the corner arrays
    std::vector<int> corner_v, corner_t, corner_n; // raw 0-based indices; t, n: -1 = none (sized once seen)
};

Status line_error(size_t line, const char* raw, const char* raw_end, const std::string& what) {
    std::string shown(raw, size_t(std::min<ptrdiff_t>(raw_end - raw, 40)));
    while (!shown.empty() && (shown.back() == '\r' || shown.back() == ' ')) shown.pop_back();
    return Status::error(StatusCode::invalid_input, "OBJ line " + std::to_string(line) + " '" + shown + "': " + what);
}

// A corner's texcoord or normal index into its list, once any corner has one: the list holds -1 (none) for
// the corners before the first index, so that it runs beside corner_v. Inline for the common cases (no list,
// or a list in step with the corners): a call per corner was 1 % of a `convert`.
void start_corner_index(std::vector<int>& list, const std::vector<int>& corner_v, int index) {
    if (list.empty()) kernel::reserve_huge(list, corner_v.capacity());
    list.resize(corner_v.size() - 1, -1);
    list.push_back(index);
}
[[gnu::always_inline]] inline void add_corner_index(std::vector<int>& list, const std::vector<int>& corner_v, int index) {
    if (!list.empty() && list.size() + 1 == corner_v.size()) list.push_back(index);
    else if (index != -1 || !list.empty()) start_corner_index(list, corner_v, index);
}

// A plain corner, read in one pass: v, v/t, v//n or v/t/n with positive indices of at most 9 digits, then a
// space or the line's end (what nearly every file writes). Sets the 0-based indices (-1: none) and returns
// the corner's end; nullptr for anything else, which read_face's general path reads.
const char* plain_corner(const char* p, const char* end, int* index) {
    for (int component = 0; component < 3; ++component) {
        if (component > 0) {
            if (p == end || *p != '/') break;
            ++p;
            if (component == 1 && p < end && *p == '/') continue; // v//n: no texcoord
        }
        uint32_t v = 0;
        int n = 0;
        for (; p < end && is_digit(*p) && n < 9; ++p, ++n) v = v * 10 + uint32_t(*p - '0');
        if (n == 0) return nullptr;
        index[component] = int(v) - 1;
    }
    return p == end || is_space(*p) ? p : nullptr;
}

// The words of an `f` line after the keyword: one corner each.
Status read_face(ObjText& obj, const char* p, const char* end, size_t line) {
    obj.face_start.push_back(uint32_t(obj.corner_v.size()));
    // Negative indices count back from the lines read so far (the same for every corner of the line).
    const long long so_far[3] = {(long long)(obj.points.size() / 3), (long long)(obj.uvs.size() / 2), (long long)obj.normal_lines};
    while (p < end) {
        while (p < end && is_space(*p)) ++p;
        if (int index[3] = {-1, -1, -1}; const char* q = plain_corner(p, end, index)) {
            p = q;
            obj.corner_v.push_back(index[0]);
            add_corner_index(obj.corner_t, obj.corner_v, index[1]);
            add_corner_index(obj.corner_n, obj.corner_v, index[2]);
            continue;
        }
        const char* word = p;
        while (p < end && !is_space(*p)) ++p;
        if (word == p) break;
        int index[3] = {-1, -1, -1};
        bool has_vertex = false;
        const char* q = word;
        for (int component = 0; q < p; ++component) {
            const char* slash = q; // a corner word is a few bytes: a loop, not a memchr call
            while (slash < p && *slash != '/') ++slash;
            IntRead r;
            if (slash < p) {
                r = read_int(q, slash); // a failed read is used as it stands (0, or clamped), as the stream's was
                int checked = 0;
                const char* digits = q < slash && *q == '+' ? q + 1 : q;
                // (a read that succeeded is a number from_chars takes too: asked only when it failed)
                if (component == 0 && (q == slash || (!r.ok && std::from_chars(digits, slash, checked).ec != std::errc())))
                    return Status::error(StatusCode::invalid_input, "OBJ line " + std::to_string(line) + ": face corner '" +
                                                                        std::string(word, size_t(std::min<ptrdiff_t>(p - word, 24))) +
                                                                        "' has no vertex index");
                const bool empty = q == slash;
                q = slash + 1;
                if (empty) continue;
            } else {
                r = read_int(q, p);
                q = p;
                if (!r.ok) continue; // garbage at the end of the corner, or a word that is no corner
            }
            if (component > 2) continue;
            const long long value = r.value < 0 ? so_far[component] + r.value + 1 : r.value;
            index[component] = int(value - 1);
            has_vertex |= component == 0;
        }
        if (!has_vertex) continue;
        obj.corner_v.push_back(index[0]);
        add_corner_index(obj.corner_t, obj.corner_v, index[1]);
        add_corner_index(obj.corner_n, obj.corner_v, index[2]);
    }
    return Status::success();
}

// One logical line (trimmed, continuations joined); raw..raw_end is its first physical line, for messages.
Status read_line(ObjText& obj, const char* p, const char* end, size_t line, const char* raw, const char* raw_end) {
    const char* key = p;
    while (p < end && !is_space(*p)) ++p;
    const size_t length = size_t(p - key);
    const char k0 = key[0], k1 = length == 2 ? key[1] : '\0';
    if (length == 1 && k0 == 'v') {
        double xyz[3];
        for (double& x : xyz)
            if (!p || !(p = read_number(p, end, x)) || !std::isfinite(static_cast<float>(x)))
                return line_error(line, raw, raw_end, "a vertex needs three finite numbers");
        obj.points.insert(obj.points.end(), {xyz[0], xyz[1], xyz[2]});
        float rgb[3];
        for (float& c : rgb) p = p ? read_number(p, end, c) : nullptr;
        if (p) obj.colors.insert(obj.colors.end(), {rgb[0], rgb[1], rgb[2]});
    } else if (k0 == 'v' && k1 == 't') {
        float uv[2];
        for (float& c : uv)
            if (!p || !(p = read_number(p, end, c))) return line_error(line, raw, raw_end, "a texture coordinate needs two numbers");
        obj.uvs.insert(obj.uvs.end(), {uv[0], uv[1]});
    } else if (k0 == 'v' && (k1 == 'n' || k1 == 'c')) {
        float xyz[3];
        for (float& c : xyz) p = p ? read_number(p, end, c) : nullptr;
        std::vector<float>& list = k1 == 'n' ? obj.normals : obj.colors;
        if (p) list.insert(list.end(), {xyz[0], xyz[1], xyz[2]}); // a `vn` that does not read is skipped, but counts
        obj.normal_lines += k1 == 'n';
    } else if (length == 1 && k0 == 'f') {
        return read_face(obj, p, end, line);
    }
    return Status::success();
}

// Every array sized once: the statements counted by their first letters, the corners by the blanks of the `f`
// lines (bounding them by the lines' bytes instead reserved up to 4x the corners, whose pages the save of a
// 1.4 M-triangle grid then paid for: 191 -> 255 ms in bench io).
// Growing them instead copied each array and faulted in fresh pages at every doubling: a fifth of the load.
void reserve(ObjText& obj, const char* text, size_t size) {
    const char* const end = text + size;
    size_t v = 0, vt = 0, vn = 0, f = 0, words = 0;
    for (const char* at = text; at < end;) {
        while (at < end && (*at == ' ' || *at == '\t')) ++at;
        const char* e = static_cast<const char*>(std::memchr(at, '\n', size_t(end - at)));
        if (!e) e = end;
        const char c1 = e - at > 1 ? at[1] : '\n';
        if (at < e && *at == 'v') {
            v += c1 == ' ' || c1 == '\t';
            vt += c1 == 't';
            vn += c1 == 'n';
        } else if (at < e && *at == 'f' && (c1 == ' ' || c1 == '\t')) {
            ++f;
            // A word per blank before it (blanks, not words: a loop the compiler vectorises; a little over
            // with runs of blanks, and a corner past the count only grows the array).
            for (const char* p = at + 1; p < e; ++p) words += size_t(*p == ' ') + size_t(*p == '\t');
        }
        at = e + 1;
    }
    kernel::reserve_huge(obj.points, v * 3);
    kernel::reserve_huge(obj.uvs, vt * 2);
    kernel::reserve_huge(obj.normals, vn * 3);
    kernel::reserve_huge(obj.face_start, f);
    kernel::reserve_huge(obj.corner_v, words);
}

Status read_lines(ObjText& obj, const char* text, size_t size) {
    reserve(obj, text, size);
    const char* const end = text + size;
    std::string joined; // continued lines only
    size_t line = 0;
    for (const char* at = text; at < end;) {
        auto next_line = [&](const char*& b, const char*& e) {
            b = at;
            e = static_cast<const char*>(std::memchr(at, '\n', size_t(end - at)));
            if (!e) e = end;
            at = e < end ? e + 1 : end;
            ++line;
        };
        auto trim = [](const char*& b, const char*& e) {
            while (b < e && (*b == ' ' || *b == '\t' || *b == '\r')) ++b;
            while (e > b && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r')) --e;
        };
        const char *raw, *raw_end;
        next_line(raw, raw_end);
        const size_t first_line = line;
        const char *b = raw, *e = raw_end;
        trim(b, e);
        if (e > b && e[-1] == '\\') {
            joined.assign(b, e - 1);
            for (bool more = true; more && at < end;) {
                const char *nb, *ne;
                next_line(nb, ne);
                trim(nb, ne);
                more = ne > nb && ne[-1] == '\\';
                joined.append(" ").append(nb, more ? ne - 1 : ne);
            }
            b = joined.data(), e = joined.data() + joined.size();
            trim(b, e);
        }
        if (b == e || *b == '#' || is_space(*b)) continue;
        if (Status s = read_line(obj, b, e, first_line, raw, raw_end); !s.ok()) return s;
    }
    return Status::success();
}

// The per-vertex values a face's corners set, in corner order (the last corner to name a vertex wins).
void set_corner_attributes(const ObjText& obj, ReaderMesh& m, size_t c, std::vector<float>& face_uv) {
    const size_t nv = m.vertex_count();
    const int v = obj.corner_v[c];
    const bool vertex_ok = v >= 0 && size_t(v) < nv;
    auto in = [](int i, size_t n) { return i >= 0 && size_t(i) < n; };
    if (vertex_ok && in(v, obj.colors.size() / 3)) {
        if (!m.any_color) kernel::assign_huge(m.colors, nv * 4, 1.0f), m.any_color = true;
        std::copy_n(&obj.colors[size_t(v) * 3], 3, &m.colors[size_t(v) * 4]);
    }
    if (!obj.corner_t.empty() && in(obj.corner_t[c], obj.uvs.size() / 2)) {
        const float* uv = &obj.uvs[size_t(obj.corner_t[c]) * 2];
        face_uv.insert(face_uv.end(), {uv[0], uv[1]});
        if (vertex_ok) {
            if (!m.any_vertex_uv) kernel::assign_huge(m.vertex_uv, nv * 2, 0.0f), m.any_vertex_uv = true;
            std::copy_n(uv, 2, &m.vertex_uv[size_t(v) * 2]);
        }
    }
    if (vertex_ok && !obj.corner_n.empty() && in(obj.corner_n[c], obj.normals.size() / 3)) {
        if (!m.any_normal) kernel::assign_huge(m.normals, nv * 3, 0.0f), m.any_normal = true;
        std::copy_n(&obj.normals[size_t(obj.corner_n[c]) * 3], 3, &m.normals[size_t(v) * 3]);
    }
}

// The faces with their repeated vertices removed (a face left with fewer than 3 is dropped), their
// texcoords on their corners, and the attributes on the vertices.
void to_reader_mesh(ObjText& obj, ReaderMesh& m) {
    m.points = std::move(obj.points);
    const size_t nv = m.vertex_count();
    kernel::reserve_huge(m.corners, obj.corner_v.size());
    kernel::reserve_huge(m.face_start, obj.face_start.size());
    if (!obj.corner_t.empty()) kernel::reserve_huge(m.corner_uv, obj.corner_v.size() * 2);
    std::vector<float> face_uv;
    std::vector<int> distinct;
    for (size_t f = 0; f < obj.face_start.size(); ++f) {
        const size_t b = obj.face_start[f], e = f + 1 < obj.face_start.size() ? obj.face_start[f + 1] : obj.corner_v.size();
        face_uv.clear();
        distinct.clear();
        for (size_t c = b; c < e; ++c) {
            set_corner_attributes(obj, m, c, face_uv);
            if (std::find(distinct.begin(), distinct.end(), obj.corner_v[c]) == distinct.end()) distinct.push_back(obj.corner_v[c]);
        }
        if (distinct.size() < 3) {
            m.dropped_faces += 1;
            continue;
        }
        const size_t start = m.corners.size();
        m.face_start.push_back(uint32_t(start));
        for (int v : distinct) m.corners.push_back(uint32_t(v)); // a negative index becomes one out of range
        if (face_uv.empty()) continue;
        m.any_corner_uv = true;
        m.corner_uv.resize(m.corners.size() * 2, 0.0f);
        std::copy_n(face_uv.begin(), std::min(face_uv.size(), distinct.size() * 2), m.corner_uv.begin() + std::ptrdiff_t(start * 2));
    }
    if (m.any_corner_uv) m.corner_uv.resize(m.corners.size() * 2, 0.0f);
    // Without faces, a point cloud: normals and colours in vertex order when there are enough of them.
    if (m.face_start.empty() && !obj.normals.empty() && obj.normals.size() == nv * 3) m.normals = obj.normals, m.any_normal = true;
    if (m.face_start.empty() && !obj.colors.empty() && obj.colors.size() >= nv * 3) {
        kernel::assign_huge(m.colors, nv * 4, 1.0f), m.any_color = true;
        for (size_t i = 0; i < nv; ++i) std::copy_n(&obj.colors[i * 3], 3, &m.colors[i * 4]);
    }
}

} // namespace
} // namespace furrow::mesh_detail

namespace furrow {

Status load_obj_bytes(Scene& out, const char* text, size_t size, const LoadOptions& options) {
    mesh_detail::ObjText obj;
    if (Status s = mesh_detail::read_lines(obj, text, size); !s.ok()) return s;
    mesh_detail::ReaderMesh mesh;
    mesh_detail::to_reader_mesh(obj, mesh);
    obj = {};
    return mesh_detail::reader_mesh_to_scene(out, mesh, options);
}

} // namespace furrow

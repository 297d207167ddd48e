// OFF in one pass over the bytes, std::from_chars on the buffer (text_numbers.h, shared with the OBJ reader).
// OpenMesh's OFF reader (used before) went through a string stream after a validation pass that walked the
// file with the same stream reads (19 MB/s on the generated grid of `furrow bench io`); this reads the same
// numbers the same way and gives the same scene for every file that path accepted, and refuses what it
// refused, now with the line. OFF: https://segeval.cs.princeton.edu/public/off_format.html
// Stages, each as OpenMesh's read_ascii did it when handed a stream (IOManager then never parses the
// keyword's letters, so C/N/ST files are read as plain OFF: x y z first on each vertex line, the rest ignored):
//  - header: the first line's first word must be OFF with optional ST, C, N prefixes; "OFF BINARY" is not
//    supported, 4OFF/nOFF refused. The rest of that line is skipped (counts on it are not read).
//  - counts: vertices, faces, edges as unsigned numbers anywhere after the first line (any whitespace between);
//    vertex and face counts above the bytes left are refused (OpenMesh allocated them unchecked).
//  - vertices: three floats each (`stream >> float`: they may run over lines), then the rest of the line is
//    skipped. Widened to double for reader_mesh_to_scene (positions stay what float gave, as before).
//  - faces: a corner count, then that many indices, as a stream of numbers (lines do not matter; a face colour
//    after the indices would be read as the next face's count, as OpenMesh did). Indices are unsigned as the
//    stream read them ("-1" is 4294967295): out of range, reader_mesh_to_scene refuses the file; faces with
//    fewer than 3 corners are dropped there and counted in a warning.
//  - end of text: once a read reaches the end of the bytes (the stream's eof), the next read fails, and the
//    vertex loop stops there (a last vertex line without a line end).
#include "document.h"
#include "text_numbers.h"
#include <furrow_kernel/huge_pages.h>

#include <cstring>
#include <string_view>

namespace furrow::mesh_detail {
namespace {

// The bytes as a stream of reads: `eof` once a read has touched the end (as the stream's eofbit), and every
// read after that fails.
struct OffCursor {
    const char* text;
    const char* at;
    const char* end;
    bool eof = false;

    template <class Read> bool read(Read read_one) {
        if (eof) return false;
        const char* p = read_one(at);
        if (!p) {
            eof = true; // a failed read leaves the stream failed: nothing after it is read
            return false;
        }
        at = p;
        eof = at == end;
        return true;
    }
    bool number(float& x) {
        return read([&](const char* p) { return read_number(p, end, x); });
    }
    bool count(uint32_t& n) {
        return read([&](const char* p) { return read_unsigned(p, end, n); });
    }
    void skip_line() { // std::getline: up to and past the next '\n'
        const char* nl = static_cast<const char*>(std::memchr(at, '\n', size_t(end - at)));
        at = nl ? nl + 1 : end;
        eof = eof || !nl;
    }
    Status error(const std::string& what) const {
        return Status::error(StatusCode::invalid_input, "OFF line " + std::to_string(line_of(text, at)) + ": " + what);
    }
};

// The first line: its first word must be [ST][C][N]OFF; a second word BINARY is not supported.
Status read_header(OffCursor& c) {
    const char* nl = static_cast<const char*>(std::memchr(c.at, '\n', size_t(c.end - c.at)));
    const char* line_end = nl ? nl : c.end;
    auto word = [&](const char*& p) {
        while (p < line_end && is_space(*p)) ++p;
        const char* b = p;
        while (p < line_end && !is_space(*p)) ++p;
        return std::string(b, p);
    };
    const char* p = c.at;
    const std::string keyword = word(p), more = word(p);
    std::string_view k = keyword;
    if (k.substr(0, 2) == "ST") k.remove_prefix(2);
    if (!k.empty() && k[0] == 'C') k.remove_prefix(1);
    if (!k.empty() && k[0] == 'N') k.remove_prefix(1);
    if (k != "OFF") {
        std::string what = "OFF: the first line must be OFF (or STOFF, COFF, NOFF...), not '";
        what.append(keyword, 0, 16).append("'");
        return Status::error(StatusCode::invalid_input, what);
    }
    if (more == "BINARY") return Status::error(StatusCode::unsupported, "OFF: binary OFF files are not supported");
    c.skip_line();
    return Status::success();
}

Status read_body(OffCursor& c, ReaderMesh& m) {
    uint32_t nv = 0, nf = 0, ne = 0;
    if (!c.count(nv) || !c.count(nf) || !c.count(ne)) return c.error("no vertex, face and edge counts after the header");
    const size_t body = c.eof ? 0 : size_t(c.end - c.at);
    if (nv > body || nf > body)
        return c.error("the counts (" + std::to_string(nv) + " vertices, " + std::to_string(nf) + " faces) are more than the file holds");
    kernel::reserve_huge(m.points, size_t(nv) * 3);
    for (uint32_t i = 0; i < nv && !c.eof; ++i) {
        float xyz[3];
        for (float& x : xyz)
            if (!c.number(x)) return c.error("vertex " + std::to_string(i) + " is not three numbers");
        m.points.insert(m.points.end(), {double(xyz[0]), double(xyz[1]), double(xyz[2])});
        c.skip_line();
    }
    kernel::reserve_huge(m.face_start, nf);
    kernel::reserve_huge(m.corners, size_t(nf) * 3);
    for (uint32_t f = 0; f < nf; ++f) {
        uint32_t corners = 0, index = 0;
        if (!c.count(corners) || corners > body) return c.error("face " + std::to_string(f) + " has no valid corner count");
        m.face_start.push_back(uint32_t(m.corners.size()));
        for (uint32_t k = 0; k < corners; ++k) {
            if (!c.count(index)) return c.error("face " + std::to_string(f) + " has fewer indices than its corner count");
            m.corners.push_back(index);
        }
    }
    return Status::success();
}

} // namespace
} // namespace furrow::mesh_detail

namespace furrow {

Status load_off_bytes(Scene& out, const char* text, size_t size, const LoadOptions& options) {
    mesh_detail::OffCursor c{text, text, text + size};
    if (Status s = mesh_detail::read_header(c); !s.ok()) return s;
    mesh_detail::ReaderMesh mesh;
    if (Status s = mesh_detail::read_body(c, mesh); !s.ok()) return s;
    return mesh_detail::reader_mesh_to_scene(out, mesh, options);
}

} // namespace furrow

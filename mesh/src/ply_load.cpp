// PLY, ASCII and binary, in one pass over the bytes: ASCII with std::from_chars on the buffer (text_numbers.h, shared
// with the OBJ and OFF readers), binary with memcpy and a byte swap for big endian. PLY is Greg Turk's polygon file
// format (1994: a header of `element <name> <count>` lines, each followed by its `property <type> <name>` / `property
// list <count type> <entry type> <name>` lines, then the elements' records in header order, as text or as each
// value's bytes). http://paulbourke.net/dataformats/ply/
// The former path (openmesh_load.cpp, kept as the oracle of tests/mesh/test_ply_load.cpp) walked the file twice, a
// validation pass and then OpenMesh's PLYReader (ASCII with string streams: 10 MB/s on the generated grid of `furrow
// bench io`; binary from a copy of the file in a std::istringstream: 50 MB/s). This reads the same values the same
// way in one pass, gives the same scene for every file that path accepted, and refuses what it refused, now naming
// the line (ASCII) or the byte and the element row (binary) -- but for one departure:
// a face's texcoord list (MeshLab's per-corner "wedge" uvs, `property list uchar float texcoord`, 2 values per
// corner, often with `property int texnumber` and `comment TextureFile x.png`), which OpenMesh skipped as ONE value,
// misreading the rest of every record (the faces after it read from its numbers).
// Corner uvs (files without a face texcoord list are read exactly as before):
//  - any list named texcoord on the face element, count of any integer type, entries float or double (other entry
//    types refused at the header line), declared after the indices (one before them is dropped with the other face
//    properties, as OpenMesh did): corner k of the face gets (list[2k], list[2k+1]). A count that is not 2 x the
//    face's corners, or a face without corners, refuses the file at the count's line (ASCII) or byte and face row
//    (binary); so do a non-finite binary value and, in ASCII, a token that is not a plain number (the validation
//    pass's rule). Its tokens are those the validation pass read, so the list no longer puts the two passes out of
//    step.
//  - the uvs go to ReaderMesh::corner_uv; reader_mesh_to_scene (shared with the OBJ reader) makes one glTF vertex per
//    distinct (vertex, uv) pair, in the order the faces first use them: a vertex splits only where its corners' uvs
//    differ (a seam), its normal and colour go on every copy, and a vertex no face uses is left out (glTF has no
//    per-corner uvs: every exporter splits so). Where the vertex element also has u/v, the corner uvs win.
// Stages, each as that path did it:
//  - header: `ply`, `format ascii|binary_little_endian|binary_big_endian <version>`, then keywords read as stream
//    words up to `end_header`: comment lines skipped, unknown words ignored, `element` and `property` lines as
//    OpenMesh 9.0 understands them (the type may come before or after the name; x y z, nx ny nz, u/s v/t, red green
//    blue alpha (diffuse_ too) on the vertex; the vertex_index(es) list and colours on the face; everything else,
//    texnumber included, is one word, or in binary one value of its type; a face texcoord list as above). A
//    vertex_indices list drops the face properties declared before it, as OpenMesh did. Refused: no end_header, a
//    property before any element, a list count type OpenMesh does not know (uchar, uint8, uint16 and int are; any
//    integer type for a face texcoord list), two vertex or two face elements, an element count above the bytes left,
//    and (ASCII only) fewer or more than three coordinates.
//  - ASCII body, as OpenMesh's read_ascii read it with `stream >> value` (PlyStream below emulates that stream: its
//    fail and eof bits, a failed read leaving the value as num_get does, later reads doing nothing): elements in
//    header order until the face element; positions, normals and uvs as float; colours as int (or float x 255), cast
//    to a byte; a list that is not a face's indices, and any unknown property, is one word. Each read is also held to
//    the validation pass's rule for its token (a number; a plain unsigned count; the file not ending), so that what
//    it refused is refused here at the token's line.
//  - when a read takes part of a token the validation pass accepted (an int colour written "0.5"), the two passes
//    stop reading the same tokens: the stream is followed on, and the validation pass is then run on its own over the
//    body (validate_tokens) to decide, as before. Only such files pay for a second pass. Where OpenMesh then went on
//    with a variable it had never written (undefined behaviour: its result changed from run to run), the file is
//    refused.
//  - binary body, as OpenMesh's read_binary read it (its PLYReader.cc; the type cases of readValue and readInteger as
//    disassembled from Debian's libOpenMeshCore 9.0, and held to it by the tests): from 12 bytes past where its read
//    of end_header began (14 after "\r\n"); the elements in header order until the faces, each value
//    std::istream::read into a variable of its type. Its readValue into a float takes float and double only (a double
//    is cast to float), its readInteger the integer types only (signed ones sign-extended); for any other type (an
//    int x, a double colour, float indices) the value is 0 and no byte is taken. A float colour is x 255, cast to
//    int, then a byte. A list that is not the face's indices (nor its texcoord list, above) is skipped as one value
//    of its entry type. No dimension check (three coordinates read, a missing one is 0). The validation pass before
//    it skipped each value by the size of its first type word and a face's texcoord list as a list (as read now):
//    where the two take the same bytes for every property (binary_in_step: nearly every file), the reads here hold
//    the validation pass's checks (the file not ending inside a row; a list within the file); otherwise it runs on
//    its own first (validate_binary, a walk over the face counts). A read past the end was OpenMesh's failure.
#include "document.h"
#include "text_numbers.h"
#include <furrow_kernel/huge_pages.h>

#include <algorithm>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace furrow::mesh_detail {
namespace {

// The validation pass's rule for the token a read takes.
enum class Rule : uint8_t { none, number, count };
// What OpenMesh does with a property.
enum class Role : uint8_t { x, y, z, nx, ny, nz, u, v, red, green, blue, alpha, indices, texcoord, word };

// A PLY scalar type as OpenMesh's get_property_type named it (none: no type word).
enum class Scalar : uint8_t { none, i8, u8, i16, u16, i32, u32, f32, f64 };

struct PlyProperty {
    Role role = Role::word;
    Rule rule = Rule::none;    // the validation pass's rule for its (non-list) token
    bool float_colour = false; // a colour typed float/float32: read as float, times 255
    Scalar type = Scalar::none;  // OpenMesh's type of the value (a list's entries)
    Scalar count = Scalar::none; // a list's count type (none: not a list)
    uint8_t read_size = 0;  // binary: the bytes OpenMesh's read of the value (a list entry) takes
    uint8_t check_size = 0; // binary: the bytes the validation pass skips for it (the first type word's size)
};
struct PlyElement {
    std::string name;
    uint32_t count = 0;
    std::vector<PlyProperty> properties;
};
struct PlyHeader {
    bool ascii = false;
    bool msb = false;                 // binary_big_endian
    const char* before_end = nullptr; // where the read of the end_header keyword began (OpenMesh's seek)
    std::vector<PlyElement> elements;
    int dimension = 0; // x, y and z properties of the vertex element (OpenMesh wants exactly 3)
    bool normal = false, uv = false, colour = false;
};

// A token the validation pass accepts as a number: digits written plainly, a finite float.
bool plain_number(const char* b, const char* e) {
    if (b == e || !(is_digit(*b) || *b == '-' || *b == '.')) return false;
    double v = 0;
    const auto r = std::from_chars(b, e, v);
    return r.ec == std::errc() && r.ptr == e && std::abs(v) <= 3.4e38;
}
// A token the validation pass accepts as a list count or index: an unsigned 32-bit number, no sign.
bool plain_count(const char* b, const char* e) {
    unsigned long long v = 0;
    const auto r = std::from_chars(b, e, v);
    return r.ec == std::errc() && r.ptr == e && v <= 0xFFFFFFFFull;
}
bool follows(Rule rule, const char* b, const char* e) {
    return rule == Rule::none || (rule == Rule::number ? plain_number(b, e) : plain_count(b, e));
}

// The bytes as the std::istringstream OpenMesh read: fail and eof bits, and every read after a failure leaves
// its value alone. `sync`: every read so far took exactly one whole token, so they are the validation pass's
// tokens one for one and its rules apply inline; `bad` is the first token (or the end) it refused.
struct PlyStream {
    PlyStream(const char* begin, const char* from, const char* stop) : text(begin), at(from), end(stop) {}
    const char* text;
    const char* at;
    const char* end;
    bool fail = false, eof = false, sync = true;
    const char* bad = nullptr;
    const char* failed_at = nullptr; // the token whose conversion failed the stream
    Rule bad_rule = Rule::none;
    std::string why; // set when a refusal is not a token's rule

    void refuse(const char* where, std::string what) {
        if (!bad) bad = where, why = std::move(what);
    }

    const char* begin_read() { // the sentry: skip whitespace; at the end, fail and eof
        if (fail) return nullptr;
        while (at < end && is_space(*at)) ++at;
        if (at < end) return at;
        fail = eof = true;
        if (sync && !bad) bad = end; // the validation pass wanted another token
        sync = false;
        return nullptr;
    }
    // A read took [b, p) (converted or not). A whole token is held to the rule; part of a token, or a failed
    // conversion, is checked against the rule on the whole token: refused there, or the passes part ways.
    void end_read(const char* b, const char* p, bool ok, Rule rule, bool checked = false) {
        at = p;
        eof = p == end;
        if (!ok && !fail) fail = true, failed_at = b;
        if (!sync || bad) return;
        const bool whole = ok && (p == end || is_space(*p));
        const char* e = p;
        while (e < end && !is_space(*e)) ++e;
        if (!(whole && checked) && !follows(rule, b, e)) bad = b, bad_rule = rule;
        else if (!whole) sync = false;
    }
    void word(Rule rule) {
        if (const char* b = begin_read()) {
            const char* p = b;
            while (p < end && !is_space(*p)) ++p;
            end_read(b, p, true, rule);
        }
    }
    void word(std::string& s) {
        if (const char* b = begin_read()) {
            const char* p = b;
            while (p < end && !is_space(*p)) ++p;
            s.assign(b, p);
            end_read(b, p, true, Rule::none);
        }
    }
    // The number reads return whether they wrote the value (not when the stream had failed or was at its end).
    bool f32(float& v, Rule rule) {
        const char* b = begin_read();
        if (!b) return false;
        if (const char* p = read_number(b, end, v)) {
            // A float that converted is a plain double too, unless it is 0 (maybe a double underflow), out of
            // the validation pass's range, or signed '+'.
            const bool checked = v != 0 && std::abs(v) < 3.39e38f && *b != '+';
            end_read(b, p, true, rule, checked);
            return true;
        }
        const char* p = float_span_end(b, end);
        const std::string span(b, p);
        char* stop = nullptr;
        const float f = std::strtof(span.c_str(), &stop); // num_get: out of range gives +-FLT_MAX, else 0
        v = stop == span.c_str() + span.size() && std::isinf(f) ? std::copysign(FLT_MAX, f) : 0.0f;
        end_read(b, p, false, rule);
        return true;
    }
    bool i32(int& v, Rule rule) {
        const char* b = begin_read();
        if (!b) return false;
        const IntRead r = read_int(b, end); // clamped on overflow, 0 without digits: as num_get
        v = r.value;
        end_read(b, integer_span_end(b, end), r.ok, rule);
        return true;
    }
    bool u32(uint32_t& v, Rule rule) {
        const char* b = begin_read();
        if (!b) return false;
        const char* p = integer_span_end(b, end);
        const bool ok = read_unsigned(b, end, v) != nullptr;
        if (!ok) v = p > b && is_digit(p[-1]) ? UINT32_MAX : 0; // overflow, or no digits
        end_read(b, p, ok, rule);
        return true;
    }
    void line_rest() { // std::getline
        if (fail) return;
        if (at == end) { fail = eof = true; return; }
        const char* nl = static_cast<const char*>(std::memchr(at, '\n', size_t(end - at)));
        at = nl ? nl + 1 : end;
        eof = !nl;
    }
    Status refusal() const {
        if (!why.empty()) return error(bad, why);
        if (bad == end) return error(bad, "the file ends before its last element");
        const char* e = bad;
        while (e < end && !is_space(*e) && e - bad < 24) ++e;
        std::string what(1, '\'');
        what.append(bad, e).append(bad_rule == Rule::count ? "' is not a list count or index" : "' is not a number");
        return error(bad, what);
    }
    Status error(const char* where, const std::string& what) const {
        return Status::error(StatusCode::invalid_input, "PLY line " + std::to_string(line_of(text, where)) + ": " + what);
    }
};

// OpenMesh's get_property_type: the first of these names that either word is ("double float" is a float).
Scalar scalar_of(const std::string& a, const std::string& b) {
    static const std::pair<const char*, Scalar> order[] = {
        {"float32", Scalar::f32}, {"float64", Scalar::f64}, {"float", Scalar::f32}, {"double", Scalar::f64},
        {"int8", Scalar::i8},     {"uint8", Scalar::u8},    {"char", Scalar::i8},   {"uchar", Scalar::u8},
        {"int32", Scalar::i32},   {"uint32", Scalar::u32},  {"int", Scalar::i32},   {"uint", Scalar::u32},
        {"int16", Scalar::i16},   {"uint16", Scalar::u16},  {"short", Scalar::i16}, {"ushort", Scalar::u16}};
    for (const auto& [name, type] : order)
        if (a == name || b == name) return type;
    return Scalar::none;
}
bool is_type(const std::string& t) { return scalar_of(t, t) != Scalar::none; }
uint8_t size_of(Scalar t) {
    static constexpr uint8_t sizes[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
    return sizes[int(t)];
}

// The bytes OpenMesh's read_binary takes for a property: its readValue into a float (coordinates, normals,
// uvs, a float colour) has cases for float and double only, its readInteger (an integer colour, the indices)
// for the integer types only; any other type reads nothing and gives 0. Every other property (a list too) is
// skipped as one value of its type.
uint8_t read_size_of(const PlyProperty& p) {
    const bool is_float = p.type == Scalar::f32 || p.type == Scalar::f64;
    if (p.role <= Role::v) return is_float ? size_of(p.type) : 0;                        // readValue
    if (p.role <= Role::alpha) return p.float_colour ? 4 : is_float ? 0 : size_of(p.type); // either
    if (p.role == Role::indices) return is_float ? 0 : size_of(p.type);                    // readInteger
    return size_of(p.type);
}

// One `property` line (after the keyword) as OpenMesh's can_u_read took it.
Status read_property(PlyStream& s, PlyHeader& h) {
    const char* line = s.at;
    if (h.elements.empty()) return s.error(line, "a property before any element");
    PlyElement& e = h.elements.back();
    const bool vertex = e.name == "vertex", face = e.name == "face";
    PlyProperty p;
    std::string a, b, c;
    s.word(a);
    if (a == "list") {
        s.word(a), s.word(b), s.word(c); // count type, entry type, name
        p.count = scalar_of(a, a);
        p.type = scalar_of(b, b);
        p.check_size = size_of(p.type);
        if (face && c == "texcoord") { // per-corner uvs (MeshLab): any integer count, float or double entries
            if (!s.fail && !(p.count >= Scalar::i8 && p.count <= Scalar::u32))
                return s.error(line, "unsupported list count type '" + a.substr(0, 16) + "'");
            if (!s.fail && p.type != Scalar::f32 && p.type != Scalar::f64)
                return s.error(line, "a texcoord list of '" + b.substr(0, 16) + "' (float or double wanted)");
            p.role = Role::texcoord;
        } else if (!s.fail && a != "uint8" && a != "uint16" && a != "uchar" && a != "int") {
            return s.error(line, "unsupported list count type '" + a.substr(0, 16) + "'");
        } else if (face && (c == "vertex_index" || c == "vertex_indices")) {
            e.properties.clear(); // OpenMesh drops the face properties declared before the indices
            p.role = Role::indices;
        }
        p.read_size = read_size_of(p);
        e.properties.push_back(p);
        return Status::success();
    }
    s.word(b);
    const bool typed = is_type(a) || is_type(b);
    const std::string name = is_type(a) ? b : a;
    p.type = scalar_of(a, b);
    p.rule = typed ? Rule::number : Rule::none;
    p.float_colour = p.type == Scalar::f32;
    const std::string& first_type = is_type(a) ? a : b; // the validation pass's type word
    p.check_size = size_of(scalar_of(first_type, first_type));
    struct Named { bool vertex; const char* name; Role role; };
    static const Named named[] = {{true, "x", Role::x},          {true, "y", Role::y},         {true, "z", Role::z},
                                  {true, "nx", Role::nx},        {true, "ny", Role::ny},       {true, "nz", Role::nz},
                                  {true, "u", Role::u},          {true, "s", Role::u},         {true, "v", Role::v},
                                  {true, "t", Role::v},          {true, "red", Role::red},     {true, "green", Role::green},
                                  {true, "blue", Role::blue},    {true, "diffuse_red", Role::red},
                                  {true, "diffuse_green", Role::green}, {true, "diffuse_blue", Role::blue},
                                  {true, "alpha", Role::alpha},  {false, "red", Role::red},    {false, "green", Role::green},
                                  {false, "blue", Role::blue},   {false, "alpha", Role::alpha}};
    for (const Named& n : named)
        if (typed && (n.vertex ? vertex : face) && name == n.name) p.role = n.role;
    if (vertex) {
        h.dimension += p.role == Role::x || p.role == Role::y || p.role == Role::z;
        h.normal |= p.role == Role::nx || p.role == Role::ny || p.role == Role::nz;
        h.uv |= p.role == Role::u || p.role == Role::v;
        h.colour |= p.role >= Role::red && p.role <= Role::alpha;
    }
    p.read_size = read_size_of(p);
    e.properties.push_back(p);
    return Status::success();
}

// The header up to end_header; `s` is left after it.
Status read_header(PlyStream& s, PlyHeader& h) {
    const char* nl = static_cast<const char*>(std::memchr(s.at, '\n', size_t(s.end - s.at)));
    std::string_view first(s.at, size_t((nl ? nl : s.end) - s.at));
    while (!first.empty() && is_space(first.back())) first.remove_suffix(1);
    if (first != "ply" && first != "PLY") return s.error(s.at, "the file does not start with 'ply'");
    s.line_rest();
    std::string keyword, format;
    float version = 0;
    const char* format_line = s.at;
    s.word(keyword), s.word(format), s.f32(version, Rule::none);
    if (s.fail || keyword != "format") return s.error(format_line, "no valid format line");
    if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
        return s.error(format_line, "unknown format '" + format.substr(0, 24) + "'");
    h.ascii = format == "ascii";
    h.msb = format == "binary_big_endian";
    for (;;) {
        h.before_end = s.at; // std::istream::tellg before the keyword, as OpenMesh took it
        s.word(keyword);
        if (s.fail) return s.error(s.at, "the header has no end_header");
        const char* line = s.at;
        if (keyword == "end_header") break;
        if (keyword == "comment") {
            s.line_rest();
        } else if (keyword == "element") {
            PlyElement e;
            s.word(e.name), s.u32(e.count, Rule::none);
            h.elements.push_back(std::move(e));
        } else if (keyword == "property") {
            if (Status st = read_property(s, h); !st.ok()) return st;
        }
        if (s.fail) return s.error(line, "malformed " + keyword.substr(0, 16) + " line");
    }
    size_t vertex_elements = 0, face_elements = 0;
    for (const PlyElement& e : h.elements) vertex_elements += e.name == "vertex", face_elements += e.name == "face";
    if (vertex_elements > 1 || face_elements > 1) return s.error(s.at, "more than one vertex or face element");
    for (const PlyElement& e : h.elements) // each element takes at least a byte of the body
        if (e.count > size_t(s.end - s.at))
            return s.error(s.at, "an element count of " + std::to_string(e.count) + " is more than the file holds");
    return Status::success();
}

// The validation pass on its own, over the body's tokens (only after the passes parted ways, see above).
Status validate_tokens(const char* text, const char* body, const char* end, const PlyHeader& h) {
    PlyStream s(text, body, end);
    size_t left = 0; // tokens not yet taken
    for (const char* p = body; p < end; ++p) left += !is_space(*p) && (p == body || is_space(p[-1]));
    auto take = [&](Rule rule) {
        s.sync = true;
        s.word(rule);
        --left;
        return !s.bad;
    };
    for (const PlyElement& e : h.elements) {
        const bool face = e.name == "face";
        for (uint32_t i = 0; i < e.count; ++i) {
            uint32_t corners = 0;
            for (const PlyProperty& p : e.properties) {
                if (p.role == Role::indices || p.role == Role::texcoord) {
                    const char* b = s.begin_read();
                    uint32_t n = 0;
                    if (!b || !take(Rule::count)) return s.error(b ? b : end, "a face list count is not valid");
                    std::from_chars(b, s.at, n);
                    if (n > left) return s.error(b, "a face list count is not valid");
                    if (p.role == Role::texcoord && corners == 0) return s.error(b, "face texture coordinates without corners");
                    for (uint32_t k = 0; k < n; ++k)
                        if (!take(p.role == Role::texcoord ? Rule::number : Rule::count)) return s.error(s.bad, "a face holds something other than numbers");
                    if (p.role == Role::indices) corners = n;
                } else if (left == 0) {
                    return s.error(end, "the file ends before its last element");
                } else if (!take(p.rule)) {
                    return s.error(s.bad, "a value is not a number");
                }
            }
        }
        if (face) break;
    }
    return Status::success();
}

// What OpenMesh's read_ascii kept between records: declared once, outside its loops, so that a read that
// does nothing (the stream failed) leaves the last value read; `known` once a value was ever written (before
// that, OpenMesh used an uninitialised variable).
struct Kept {
    uint32_t value = 0;
    bool known = false;
};
struct ReadState {
    float tmp = 0;
    bool tmp_known = false;
    Kept nV, j, k, l, idx;
    std::vector<uint32_t> vh;
    size_t body = 0; // bytes after end_header: no list is longer (below it, the stream ends first)
};

// After a read into a kept variable: refused if OpenMesh went on with a value it never had.
void kept(PlyStream& s, bool wrote, bool& known) {
    if (wrote) known = true;
    else if (!known) s.refuse(s.failed_at ? s.failed_at : s.end, "not read as its property's type; the former reader went on with values it never read");
}
void read_kept(PlyStream& s, Kept& v, Rule rule) { kept(s, s.u32(v.value, rule), v.known); }

// static_cast<int>(x) as x86 does it: out of range gives INT_MIN.
int to_int(float x) { return x >= -2147483648.0f && x < 2147483648.0f ? int(x) : INT_MIN; }

void read_colour(PlyStream& s, const PlyProperty& p, int& c, ReadState& st) {
    if (!p.float_colour) return void(s.i32(c, p.rule));
    kept(s, s.f32(st.tmp, p.rule), st.tmp_known);
    c = to_int(st.tmp * 255.0f);
}

// One vertex as OpenMesh's readers held it: reset for each record, then given to the importer whole.
struct VertexValues {
    float v[3] = {0, 0, 0}, n[3] = {0, 0, 0}, t[2] = {0, 0};
    int c[4] = {0, 0, 0, 255};
};
void reserve_vertices(ReaderMesh& m, const PlyHeader& h, size_t cap) {
    kernel::reserve_huge(m.points, cap * 3);
    if (h.normal) kernel::reserve_huge(m.normals, cap * 3);
    if (h.uv) kernel::reserve_huge(m.vertex_uv, cap * 2);
    if (h.colour) kernel::reserve_huge(m.colors, cap * 4);
}
// set_point, and set_normal / set_texcoord / set_color (a colour cast to bytes) where the header declared them.
void add_vertex(ReaderMesh& m, const PlyHeader& h, const VertexValues& x) {
    m.points.insert(m.points.end(), {double(x.v[0]), double(x.v[1]), double(x.v[2])});
    if (h.normal) m.normals.insert(m.normals.end(), {x.n[0], x.n[1], x.n[2]});
    if (h.uv) m.vertex_uv.insert(m.vertex_uv.end(), {x.t[0], x.t[1]});
    if (h.colour)
        for (int k = 0; k < 4; ++k) m.colors.push_back(float(uint8_t(x.c[k])) / 255.f);
    m.any_normal |= h.normal, m.any_vertex_uv |= h.uv, m.any_color |= h.colour;
}

void read_vertices(PlyStream& s, const PlyElement& e, const PlyHeader& h, ReadState& st, ReaderMesh& m) {
    reserve_vertices(m, h, std::min<size_t>(e.count, st.body / 6 + 1)); // a vertex is at least "0 0 0\n"
    uint32_t i = 0;
    for (; i < e.count && !s.eof && !s.bad; ++i) {
        VertexValues x;
        for (const PlyProperty& p : e.properties) {
            const int r = int(p.role);
            if (p.role <= Role::z) s.f32(x.v[r - int(Role::x)], p.rule);
            else if (p.role <= Role::nz) s.f32(x.n[r - int(Role::nx)], p.rule);
            else if (p.role <= Role::v) s.f32(x.t[r - int(Role::u)], p.rule);
            else if (p.role <= Role::alpha) read_colour(s, p, x.c[r - int(Role::red)], st);
            else s.word(p.rule);
        }
        add_vertex(m, h, x);
    }
    if (i < e.count && !e.properties.empty() && s.sync) s.refuse(s.end, "the file ends before its last element");
}

// A face's corners: a count, then that many indices (three read as j, k, l, as OpenMesh did).
void read_indices(PlyStream& s, ReadState& st, ReaderMesh& m) {
    read_kept(s, st.nV, Rule::count);
    if (st.nV.value == 3) {
        read_kept(s, st.j, Rule::count), read_kept(s, st.k, Rule::count), read_kept(s, st.l, Rule::count);
        st.vh.assign({st.j.value, st.k.value, st.l.value});
    } else {
        // Longer than the file: the validation pass refused it (or, out of step, OpenMesh looped on it).
        if (st.nV.value > st.body)
            return s.refuse(s.at, "a face list count of " + std::to_string(st.nV.value) + " is more than the file holds");
        st.vh.clear();
        for (st.j = {0, true}; st.j.value < st.nV.value && !s.bad; ++st.j.value) {
            read_kept(s, st.idx, Rule::count);
            st.vh.push_back(st.idx.value);
        }
    }
    m.face_start.push_back(uint32_t(m.corners.size()));
    m.corners.insert(m.corners.end(), st.vh.begin(), st.vh.end());
}

bool has_texcoord(const PlyElement& e) {
    const auto texcoord = [](const PlyProperty& p) { return p.role == Role::texcoord; };
    return std::any_of(e.properties.begin(), e.properties.end(), texcoord);
}

const char* const not_numbers = "a face's texcoord list holds something other than numbers";

// One whole token of a face's texcoord list, held to `rule` whether or not the passes are in step (furrow's
// own reading: OpenMesh never read the list); null where the file is refused.
const char* list_token(PlyStream& s, Rule rule) {
    const char* b = s.begin_read();
    s.word(rule);
    if (s.bad) return nullptr;
    if (!b && s.eof) s.refuse(s.end, "the file ends before its last element");
    else if (!b) s.refuse(s.failed_at ? s.failed_at : s.end, "not read as its property's type, before a texcoord list");
    else if (!follows(rule, b, s.at))
        s.refuse(b, rule == Rule::count ? "a texcoord list count is not a count" : not_numbers);
    return s.bad ? nullptr : b;
}

// A face's texcoord list (MeshLab's per-corner uvs): a count of 2 per corner, then u v for each corner in
// order, as the corner uvs of the face just read (`indexed`: this record had the indices list). Its tokens are
// the validation pass's (a count, then that many numbers), so the passes stay in step.
void read_texcoord(PlyStream& s, bool indexed, ReaderMesh& m) {
    if (s.bad) return;
    const char* b = list_token(s, Rule::count);
    if (!b) return;
    uint32_t n = 0;
    std::from_chars(b, s.at, n);
    const size_t corners = indexed ? m.corners.size() - m.face_start.back() : 0;
    if (corners == 0) return s.refuse(b, "face texture coordinates without corners");
    if (n != 2 * corners)
        return s.refuse(b, "a texcoord list of " + std::to_string(n) + " values for a face of " +
                               std::to_string(corners) + " corners (2 per corner wanted)");
    m.corner_uv.resize(m.corners.size() * 2);
    float* uv = m.corner_uv.data() + size_t(m.face_start.back()) * 2;
    for (uint32_t k = 0; k < n; ++k) {
        const char* t = list_token(s, Rule::number);
        if (!t) return;
        if (read_number(t, s.at, uv[k]) != s.at) return s.refuse(t, not_numbers);
    }
    m.any_corner_uv = true;
}

void read_faces(PlyStream& s, const PlyElement& e, ReadState& st, ReaderMesh& m) {
    const size_t cap = std::min<size_t>(e.count, st.body / 8 + 1); // a triangle is at least "3 0 1 2\n"
    kernel::reserve_huge(m.face_start, cap);
    kernel::reserve_huge(m.corners, cap * 3);
    if (has_texcoord(e)) kernel::reserve_huge(m.corner_uv, cap * 6);
    uint32_t i = 0;
    for (; i < e.count && !s.eof && !s.bad; ++i) {
        int c[4] = {0, 0, 0, 255}; // face colours are read and dropped
        bool indexed = false;
        for (const PlyProperty& p : e.properties) {
            if (p.role == Role::indices) read_indices(s, st, m), indexed = true;
            else if (p.role == Role::texcoord) read_texcoord(s, indexed, m);
            else if (p.role >= Role::red && p.role <= Role::alpha) read_colour(s, p, c[int(p.role) - int(Role::red)], st);
            else s.word(p.rule);
        }
    }
    if (i < e.count && !e.properties.empty() && s.sync) s.refuse(s.end, "the file ends before its last element");
}

void read_other(PlyStream& s, const PlyElement& e) {
    uint32_t i = 0;
    for (; i < e.count && !s.eof && !s.bad; ++i)
        for (const PlyProperty& p : e.properties) s.word(p.rule);
    if (i < e.count && !e.properties.empty() && s.sync) s.refuse(s.end, "the file ends before its last element");
}

// The elements in header order, up to and including the faces (OpenMesh stopped there).
Status read_body(PlyStream& s, const PlyHeader& h, ReaderMesh& m) {
    if (h.dimension != 3)
        return s.error(s.at, "the vertex element has " + std::to_string(h.dimension) + " of the x, y, z properties (3 are needed)");
    const char* body = s.at;
    ReadState st;
    st.body = size_t(s.end - s.at);
    for (const PlyElement& e : h.elements) {
        if (s.eof) return s.error(s.end, "the file ends before element '" + e.name.substr(0, 16) + "'");
        if (e.name == "vertex") read_vertices(s, e, h, st, m);
        else if (e.name == "face") read_faces(s, e, st, m);
        else read_other(s, e);
        if (s.bad) return s.refusal();
        if (e.name == "face") break;
    }
    if (!s.sync) return validate_tokens(s.text, body, s.end, h);
    return Status::success();
}

// ---- Binary bodies ----

// A scalar as std::istream::read put it into OpenMesh's variable: the file's bytes, reversed for big endian.
template <class T> T load(const char* p, bool msb) {
    using Bits = std::conditional_t<sizeof(T) == 1, uint8_t, std::conditional_t<sizeof(T) == 2, uint16_t,
                                    std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>>;
    Bits bits;
    std::memcpy(&bits, p, sizeof bits);
    if constexpr (sizeof(T) == 2) bits = msb ? __builtin_bswap16(bits) : bits;
    if constexpr (sizeof(T) == 4) bits = msb ? __builtin_bswap32(bits) : bits;
    if constexpr (sizeof(T) == 8) bits = msb ? __builtin_bswap64(bits) : bits;
    T v;
    std::memcpy(&v, &bits, sizeof v);
    return v;
}
// OpenMesh's readValue into a float: a float, or a double cast to float; any other type gives 0.
float as_float(Scalar t, const char* p, bool msb) {
    return t == Scalar::f32 ? load<float>(p, msb) : t == Scalar::f64 ? float(load<double>(p, msb)) : 0.0f;
}
// OpenMesh's readInteger into an unsigned (or int) variable: signed types sign-extended; a float type gives 0.
uint32_t as_uint(Scalar t, const char* p, bool msb) {
    switch (t) {
    case Scalar::i8: return uint32_t(int32_t(load<int8_t>(p, msb)));
    case Scalar::u8: return load<uint8_t>(p, msb);
    case Scalar::i16: return uint32_t(int32_t(load<int16_t>(p, msb)));
    case Scalar::u16: return load<uint16_t>(p, msb);
    case Scalar::i32:
    case Scalar::u32: return load<uint32_t>(p, msb);
    default: return 0;
    }
}

// The body as OpenMesh read it: `at` is its stream position (an offset: it may start past the end), and a
// read that would pass the end is where it failed (its stream at eof: read_binary returned false).
struct BinaryBody {
    const char* text;
    size_t size, at;
    bool msb;
    bool in_step; // the validation pass reads the same bytes as OpenMesh (else it ran on its own first)
    bool risky;   // out of step, a face's int count may be bytes it never read: the former reader could loop on it

    size_t left() const { return at < size ? size - at : 0; }
    Status error(size_t where, const std::string& what) const {
        return Status::error(StatusCode::invalid_input, "PLY byte " + std::to_string(where) + ", " + what);
    }
    Status past_end(size_t where, const PlyElement& e, size_t row) const {
        return error(where, e.name.substr(0, 16) + " " + std::to_string(row) + ": the file ends inside it" +
                                (risky ? "; the former reader went on with values it never read" : ""));
    }
};

// OpenMesh seeks to 12 bytes past where its read of end_header began (14 when "\r\n" is there): right after
// "\nend_header\n", but a byte later after a comment line or earlier after trailing spaces, as it did.
size_t binary_body_start(const char* text, size_t size, const PlyHeader& h) {
    const size_t before = size_t(h.before_end - text);
    return before + (size - before >= 2 && h.before_end[0] == '\r' && h.before_end[1] == '\n' ? 14 : 12);
}

// Whether the validation pass and OpenMesh take the same bytes for every property up to the faces (a face's
// texcoord list is read as a list by both now).
bool binary_in_step(const PlyHeader& h) {
    for (const PlyElement& e : h.elements) {
        for (const PlyProperty& p : e.properties)
            if (p.read_size != p.check_size) return false;
        if (e.name == "face") break;
    }
    return true;
}

// The validation pass on its own (only when it and OpenMesh part ways, see binary_in_step): each element
// within the file, each face's lists within it, a texcoord list after corners.
Status validate_binary(const BinaryBody& b, const PlyHeader& h, size_t at) {
    for (const PlyElement& e : h.elements) {
        if (e.name != "face") {
            size_t record = 0;
            for (const PlyProperty& p : e.properties) record += p.check_size;
            if (record && e.count > (b.size - std::min(b.size, at)) / record)
                return b.error(at, "element '" + e.name.substr(0, 16) + "': its rows are longer than the file");
            at += size_t(e.count) * record;
            continue;
        }
        for (uint32_t i = 0; i < e.count; ++i) {
            uint32_t corners = 0;
            for (const PlyProperty& p : e.properties) {
                const size_t where = at;
                const std::string row = "face " + std::to_string(i) + ": ";
                if (p.role == Role::indices || p.role == Role::texcoord) {
                    if (size_of(p.count) > b.size - std::min(b.size, at)) return b.error(where, row + "the file ends inside it");
                    const uint32_t n = as_uint(p.count, b.text + at, b.msb);
                    at += size_of(p.count);
                    if (p.role == Role::texcoord && corners == 0) return b.error(where, row + "face texture coordinates without corners");
                    if (p.check_size ? n > (b.size - at) / p.check_size : n > b.size)
                        return b.error(where, row + "a list of " + std::to_string(n) + " is longer than the file");
                    at += size_t(n) * p.check_size;
                    if (p.role == Role::indices) corners = n;
                } else {
                    at += p.check_size;
                }
                if (at > b.size) return b.error(where, row + "the file ends inside it");
            }
        }
        break;
    }
    return Status::success();
}

// Records of fixed size (OpenMesh's read sizes): the vertices, read, or another element, skipped.
Status read_binary_rows(BinaryBody& b, const PlyElement& e, const PlyHeader& h, ReaderMesh& m) {
    size_t record = 0;
    for (const PlyProperty& p : e.properties) record += p.read_size;
    const size_t rows = record ? std::min<size_t>(e.count, b.left() / record) : e.count;
    if (e.name != "vertex") {
        b.at += rows * record;
        return rows < e.count ? b.past_end(b.at, e, rows) : Status::success();
    }
    reserve_vertices(m, h, rows);
    for (size_t i = 0; i < rows; ++i) {
        VertexValues x;
        const char* p = b.text + std::min(b.at, b.size); // past the end only when no property reads
        for (const PlyProperty& q : e.properties) {
            const int r = int(q.role);
            if (q.role <= Role::z) x.v[r - int(Role::x)] = as_float(q.type, p, b.msb);
            else if (q.role <= Role::nz) x.n[r - int(Role::nx)] = as_float(q.type, p, b.msb);
            else if (q.role <= Role::v) x.t[r - int(Role::u)] = as_float(q.type, p, b.msb);
            else if (q.role <= Role::alpha)
                x.c[r - int(Role::red)] = q.float_colour ? to_int(as_float(q.type, p, b.msb) * 255.0f) : int(as_uint(q.type, p, b.msb));
            p += q.read_size;
        }
        add_vertex(m, h, x);
        b.at += record;
    }
    return rows < e.count ? b.past_end(b.at, e, rows) : Status::success();
}

// A face's texcoord list, as read_texcoord: a count of 2 per corner of the face just read (`corners`), then
// u v per corner as float or double (a double cast to float); a value that is not finite is refused.
Status read_binary_texcoord(BinaryBody& b, const PlyProperty& p, const PlyElement& e, uint32_t row, size_t corners,
                            ReaderMesh& m) {
    const size_t where = b.at;
    if (size_of(p.count) > b.left()) return b.past_end(where, e, row);
    const uint32_t n = as_uint(p.count, b.text + b.at, b.msb);
    b.at += size_of(p.count);
    auto refuse = [&](size_t at, const std::string& what) {
        return b.error(at, "face " + std::to_string(row) + ": " + what);
    };
    if (corners == 0) return refuse(where, "face texture coordinates without corners");
    if (n != 2 * corners)
        return refuse(where, "a texcoord list of " + std::to_string(n) + " values for " + std::to_string(corners) +
                                  " corners (2 per corner wanted)");
    if (n > b.left() / p.read_size) return b.past_end(where, e, row);
    m.corner_uv.resize(m.corners.size() * 2);
    float* uv = m.corner_uv.data() + (m.corners.size() - corners) * 2;
    for (uint32_t k = 0; k < n; ++k, b.at += p.read_size) {
        uv[k] = as_float(p.type, b.text + b.at, b.msb);
        if (!std::isfinite(uv[k])) return refuse(b.at, "a texture coordinate is not finite");
    }
    m.any_corner_uv = true;
    return Status::success();
}

// The faces: a count and that many indices for the vertex_indices list, a texcoord list as corner uvs; every
// other property skipped (face colours are dropped).
Status read_binary_faces(BinaryBody& b, const PlyElement& e, ReaderMesh& m) {
    const size_t cap = std::min<size_t>(e.count, b.left() / 4 + 1); // a triangle takes at least 4 bytes
    kernel::reserve_huge(m.face_start, cap);
    kernel::reserve_huge(m.corners, cap * 3);
    if (has_texcoord(e)) kernel::reserve_huge(m.corner_uv, cap * 6);
    for (uint32_t i = 0; i < e.count; ++i) {
        size_t corners = 0; // of this record's indices list
        for (const PlyProperty& p : e.properties) {
            const size_t where = b.at;
            if (p.role == Role::texcoord) {
                if (Status st = read_binary_texcoord(b, p, e, i, corners, m); !st.ok()) return st;
                continue;
            }
            if (p.role != Role::indices) {
                if (p.read_size > b.left()) return b.past_end(where, e, i);
                b.at += p.read_size;
                continue;
            }
            if (size_of(p.count) > b.left()) return b.past_end(where, e, i);
            const uint32_t n = as_uint(p.count, b.text + b.at, b.msb);
            b.at += size_of(p.count);
            // Longer than the file: refused by the validation pass (in step), or a loop of OpenMesh's on
            // values it may never have read (an int count out of step).
            if (p.read_size ? n > b.left() / p.read_size : n > b.size && (b.in_step || b.risky))
                return b.error(where, "face " + std::to_string(i) + ": a list of " + std::to_string(n) + " corners is longer than the file" +
                                          (b.risky ? "; the former reader went on with values it never read" : ""));
            m.face_start.push_back(uint32_t(m.corners.size()));
            const char* q = b.text + b.at;
            for (uint32_t k = 0; k < n; ++k, q += p.read_size) m.corners.push_back(as_uint(p.type, q, b.msb));
            b.at += size_t(n) * p.read_size;
            corners = n;
        }
    }
    return Status::success();
}

// The elements in header order up to and including the faces, as OpenMesh's read_binary read them, after
// the validation pass where the two read different bytes.
Status read_binary_body(const char* text, size_t size, const PlyHeader& h, ReaderMesh& m) {
    BinaryBody b{text, size, binary_body_start(text, size, h), h.msb, binary_in_step(h), false};
    for (const PlyElement& e : h.elements)
        if (e.name == "face")
            for (const PlyProperty& p : e.properties) b.risky |= !b.in_step && p.role == Role::indices && p.count == Scalar::i32;
    if (!b.in_step)
        if (Status st = validate_binary(b, h, b.at); !st.ok()) return st;
    for (const PlyElement& e : h.elements) {
        Status st = e.name == "face" ? read_binary_faces(b, e, m) : read_binary_rows(b, e, h, m);
        if (!st.ok()) return st;
        if (e.name == "face") break;
    }
    return Status::success();
}

} // namespace
} // namespace furrow::mesh_detail

namespace furrow {

Status load_ply_bytes(Scene& out, const char* text, size_t size, const LoadOptions& options) {
    mesh_detail::PlyStream s(text, text, text + size);
    mesh_detail::PlyHeader h;
    if (Status st = mesh_detail::read_header(s, h); !st.ok()) return st;
    mesh_detail::ReaderMesh mesh;
    s.sync = true, s.bad = nullptr; // the header's reads are not the body's tokens
    if (Status st = h.ascii ? mesh_detail::read_body(s, h, mesh) : mesh_detail::read_binary_body(text, size, h, mesh); !st.ok())
        return st;
    return mesh_detail::reader_mesh_to_scene(out, mesh, options);
}

} // namespace furrow

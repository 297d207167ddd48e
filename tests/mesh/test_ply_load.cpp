// The one-pass PLY reader (mesh/src/ply_load.cpp): its refusals name the line or byte; on random PLY files
// (ASCII and binary), valid or broken, without a face texcoord list, it agrees with the former reader (a
// validation pass, then OpenMesh's PLYReader, still reachable as load_openmesh_bytes(".ply")) on what it
// accepts, the scene it gives and what it refuses; and it gives what an independent reading of the written
// numbers gives, a face texcoord list (MeshLab's per-corner uvs, which OpenMesh misread) included.
#include "scene_compare.h"
#include "test_support.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

using namespace furrow;

namespace {

// OpenMesh 9.0's header parser leaves a PropertyInfo's value type uninitialised for a scalar property it does
// not know (neither a coordinate, normal, uv nor colour): whether it then keeps the property is chance (seen:
// the same file read differently from run to run, a face read with a count of garbage). The former reader is
// no oracle for such headers; the new one reads those properties as one word each.
bool former_reader_is_defined(const std::string& text) {
    static const std::set<std::string> types = {"char", "uchar", "int8", "uint8", "short", "ushort", "int16", "uint16",
                                                "int", "uint", "int32", "uint32", "float", "float32", "double", "float64"};
    static const std::set<std::string> vertex = {"x", "y", "z", "nx", "ny", "nz", "u", "v", "s", "t", "red", "green", "blue",
                                                 "alpha", "diffuse_red", "diffuse_green", "diffuse_blue"};
    static const std::set<std::string> face = {"red", "green", "blue", "alpha"};
    std::istringstream in(text.substr(0, text.find("end_header")));
    std::string element, keyword;
    while (in >> keyword) {
        if (keyword == "element") in >> element;
        if (keyword != "property") continue;
        std::string a, b;
        in >> a;
        if (a == "list") continue;
        in >> b;
        const std::string name = types.count(a) ? b : a;
        if (!(element == "vertex" ? vertex : element == "face" ? face : std::set<std::string>{}).count(name)) return false;
    }
    return true;
}

// A file for a failure message: ASCII whole, binary as its header and the size of its body.
std::string shown(const std::string& text) {
    const size_t end = text.find("end_header");
    if (text.find("format ascii") < end || end == std::string::npos) return text;
    return text.substr(0, end + 10) + " [" + std::to_string(text.size() - end - 10) + " more bytes]";
}

// Whether the header declares a list named texcoord on the face element (read as per-corner uvs now; the
// former reader took it as one value and misread the rest of the record).
bool has_face_texcoord(const std::string& text) {
    std::istringstream in(text.substr(0, text.find("end_header")));
    std::string element, keyword, a, b, name;
    while (in >> keyword) {
        if (keyword == "element") in >> element;
        if (keyword == "property" && (in >> a) && a == "list" && (in >> a >> b >> name) && element == "face" && name == "texcoord")
            return true;
    }
    return false;
}

// Both readers on one text: the same verdict, and on success the same scene. A file with a face texcoord list
// has no former-reader oracle (the callers check its direct reading); here it is only held to giving, when
// accepted, one finite uv per vertex.
void expect_same_as_former_reader(const std::string& text) {
    Scene now, before;
    const Status a = test::load_text(now, text, ".ply");
    const bool binary = text.find("format ascii") == std::string::npos;
    if (has_face_texcoord(text)) {
        if (!a.ok() || now.meshes.empty()) return;
        const Primitive& p = now.meshes[0].primitives.at(0);
        if (p.uv0.empty()) return; // no face read (a face element of 0 rows)
        EXPECT_EQ(p.uv0.size() * 3, p.positions.size() * 2);
        EXPECT_TRUE(std::all_of(p.uv0.begin(), p.uv0.end(), [](float x) { return std::isfinite(x); }));
        return;
    }
    // Binary files are compared whatever their header: on the random binary files below, those with unknown
    // properties included, the former reader gave the same as the new one every time.
    if (!binary && !former_reader_is_defined(text)) return;
    // Where OpenMesh went on with a variable it never wrote (undefined: it accepted, refused or ran out of
    // memory by chance), the file is refused now; the former reader is not run on it.
    if (a.message.find("values it never read") != std::string::npos) return;
    // OpenMesh's binary reader writes to std::cerr for each value of a type it cannot read (an int x): hushed.
    std::ostringstream hushed;
    std::streambuf* const cerr = std::cerr.rdbuf(hushed.rdbuf());
    const Status b = load_openmesh_bytes(before, text, ".ply", LoadOptions{});
    std::cerr.rdbuf(cerr);
    ASSERT_EQ(a.code, b.code) << a.message << " | " << b.message << "\n" << shown(text);
    if (!a.ok()) return;
    test::expect_same_reading(now, before, shown(text)); // garbage bytes may be NaN
}

// The direct reading of a file with per-corner uvs, through the index buffer: each corner has the position
// of its file vertex (`xyz`, recentred as the reader does) and the uv written for it (v flipped), and there
// is one vertex per distinct (file vertex, uv) pair: a seam splits a vertex, agreeing uvs do not.
void expect_corners(const Scene& s, const std::vector<float>& xyz, const std::vector<uint32_t>& corners, const std::vector<float>& uv,
                    const std::string& text) {
    const Primitive& p = s.meshes.at(0).primitives.at(0);
    const std::array<double, 3> centre = s.nodes[0].translation;
    ASSERT_EQ(p.indices.size(), corners.size()) << text;
    ASSERT_EQ(p.uv0.size() * 3, p.positions.size() * 2) << text;
    std::set<std::array<float, 3>> pairs;
    for (size_t c = 0; c < corners.size(); ++c) {
        const uint32_t g = p.indices[c], v = corners[c];
        ASSERT_LT(size_t(g) * 3, p.positions.size()) << text;
        for (size_t k = 0; k < 3; ++k) EXPECT_EQ(p.positions[g * 3 + k], float(double(xyz[v * 3 + k]) - centre[k])) << "corner " << c << "\n" << text;
        EXPECT_EQ(p.uv0[g * 2], uv[c * 2]) << "corner " << c << "\n" << text;
        EXPECT_EQ(p.uv0[g * 2 + 1], 1.0f - uv[c * 2 + 1]) << "corner " << c << "\n" << text;
        pairs.insert({float(v), uv[c * 2], uv[c * 2 + 1]});
    }
    EXPECT_EQ(p.positions.size(), pairs.size() * 3) << text;
}

const std::string kTriangleHeader = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
} // namespace

// Each refusal says what and on which line.
TEST(ply_load, RefusalsNameTheLine) {
    const std::string xyz = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    const std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
    const std::string tri = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const std::pair<std::string, const char*> cases[] = {
        {"plx\n", "PLY line 1: the file does not start with 'ply'"},
        {"ply\nformat ascii\n", "PLY line 2: no valid format line"},
        {"ply\nformat utf8 1.0\n", "PLY line 2: unknown format 'utf8'"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "end_hekder\n" + tri, "the header has no end_header"},
        {"ply\nformat ascii 1.0\nproperty float x\n" + xyz + "end_header\n" + tri, "PLY line 3: a property before any element"},
        {"ply\nformat ascii 1.0\nelement vertex three\nend_header\n", "PLY line 3: malformed element line"},
        {"ply\nformat ascii 1.0\n" + xyz + "element face 1\nproperty list float int vertex_indices\nend_header\n" + tri,
         "PLY line 8: unsupported list count type 'float'"},
        {"ply\nformat ascii 1.0\nelement vertex 4000\nproperty float x\nproperty float y\nproperty float z\nend_header\n" + tri,
         "PLY line 7: an element count of 4000 is more than the file holds"},
        {"ply\nformat ascii 1.0\n" + xyz + xyz + "end_header\n" + tri + tri, "more than one vertex or face element"},
        {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n" + face + "end_header\n" + tri,
         "PLY line 8: the vertex element has 2 of the x, y, z properties"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "end_header\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n", "PLY line 11: '" "zero' is not a number"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "end_header\n0 0 0\n1 0 0\n0 1 1e39\n3 0 1 2\n", "PLY line 12: '1e39' is not a number"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n", "PLY line 13: '-2' is not a list count or index"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "end_header\n0 0 0\n1 0 0\n0 1 0\n\n4000000000 0 1 2\n",
         "PLY line 14: a face list count of 4000000000 is more than the file holds"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "PLY line 14: the file ends before its last element"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "property list uchar float texcoord\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 6 0 0 1 0 0 1\n",
         "PLY line 14: face texture coordinates without corners"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "property list uchar float texcoord\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 4 0 0 1 0\n",
         "PLY line 14: a texcoord list of 4 values for a face of 3 corners (2 per corner wanted)"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "property list uchar float texcoord\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 6 0 0\n1 x 0 1\n",
         "PLY line 15: 'x' is not a number"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "property list uchar float texcoord\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 6 0 0 1 0 0\n",
         "PLY line 15: the file ends before its last element"},
        {"ply\nformat ascii 1.0\n" + xyz + "element edge 1\nproperty int a\n" + face + "end_header\n0 0 0\n1 0 0\n0 1 0", "the file ends before element 'edge'"},
        {"ply\nformat ascii 1.0\n" + xyz + face + "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "1 faces reference vertices that do not exist"},
    };
    for (const auto& [text, message] : cases) {
        Scene s;
        const Status st = test::load_text(s, text, ".ply");
        EXPECT_EQ(st.code, StatusCode::invalid_input) << text;
        EXPECT_NE(st.message.find(message), std::string::npos) << st.message << "\n" << text;
        expect_same_as_former_reader(text); // refused by both
    }
}

// What OpenMesh 9.0's ASCII reader did is kept (but for a face's texcoord list, see MeshLabCornerTexcoords): any
// list but its indices is one word, face properties declared before the indices are not in the body, an int
// colour written "0.5" is read as 0 and the ".5" as the next value.
TEST(ply_load, OpenMeshReadingIsKept) {
    const std::string head = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n";
    const std::string quad = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
    Scene s;
    Status st;
    const std::string before = head + "element face 2\nproperty uchar red\nproperty list uchar int vertex_indices\n"
                                      "property list uchar int extra\nend_header\n" + quad + "3 0 1 2 7\n3 0 2 3 1.5\n";
    st = test::load_text(s, before, ".ply");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(s.meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
    expect_same_as_former_reader(before);
    const std::string colour = head + "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
                                      "property list uchar int vertex_indices\nend_header\n0 0 0 255 0 0\n1 0 0 0.5 7 8\n"
                                      "1 1 0 1 2 3\n0 1 0 4 5 6\n3 0 1 2\n";
    expect_same_as_former_reader(colour);
}

// Property: random ASCII PLY text (property order and types, normals, uvs, colours as bytes or floats,
// unknown properties and elements, comments, spacing, line ends, far from the origin or not, a face texcoord
// list or not) gives what a direct reading of the written numbers gives and, without a face texcoord list,
// what the former reader gave; and the same text broken at random (cut short, a character replaced) is
// accepted or refused as the former reader did, with the same scene when accepted.
TEST(ply_load, RandomTextMatchesDirectReadingAndFormerReader) {
    test::Lcg next(1994), tnext(2003); // tnext: the face texcoord lists' own generator
    for (int round = 0; round < 1500; ++round) {
        const size_t nv = 3 + next(12), nf = 1 + next(8);
        const bool crlf = next(4) == 0;
        const double offset = next(4) == 0 ? 1e5 : 0;
        auto space = [&] { return std::string(next(3) ? " " : next(2) ? "\t" : "  "); };
        const std::string eol = crlf ? "\r\n" : "\n";
        // Vertex properties: x y z in a random order among optional normals, uvs, colours and unknowns.
        struct Prop { std::string line; int kind; }; // kind: 0-2 xyz, 3 normal, 4 uv, 5 byte colour, 6 float colour, 7 unknown float, 8 unknown list
        std::vector<Prop> props = {{"float x", 0}, {"float y", 1}, {next(2) ? "double z" : "z float", 2}};
        if (next(3) == 0) props.insert(props.end(), {{"float nx", 3}, {"float ny", 3}, {"float nz", 3}});
        if (next(3) == 0) props.insert(props.end(), {{"float u", 4}, {"float v", 4}});
        if (next(3) == 0) props.insert(props.end(), {{"uchar red", 5}, {"uchar green", 5}, {"uchar blue", 5}});
        else if (next(4) == 0) props.insert(props.end(), {{"float red", 6}, {"float green", 6}, {"float blue", 6}, {"float alpha", 6}});
        if (next(6) == 0) props.push_back({"float quality", 7});
        if (next(5) == 0) props.push_back({"list uchar int flags", 8});
        for (size_t i = props.size(); i > 1; --i) std::swap(props[i - 1], props[next(i)]);
        std::string text = "ply" + eol + "format ascii 1.0" + eol;
        if (next(2)) text += "comment made by a test" + eol;
        if (next(3) == 0) text += "obj_info random" + eol;
        text += "element vertex " + std::to_string(nv) + eol;
        for (const Prop& p : props) text += "property " + p.line + eol;
        const bool edges_first = next(8) == 0;
        if (edges_first) text += "element edge 1" + eol + "property int vertex1" + eol + "property int vertex2" + eol;
        text += "element face " + std::to_string(nf) + eol;
        if (next(8) == 0) text += "property uchar intensity" + eol; // dropped by the indices after it
        text += std::string(next(2) ? "property list uchar int vertex_indices" : "property list uint8 uint vertex_index") + eol;
        const bool face_colour = next(4) == 0;
        // A face texcoord list (MeshLab's per-corner uvs), before or after the face colour, of any count type.
        // Drawn from a generator of their own, so that the files without one are those this test always made.
        const bool face_texcoord = tnext(3) == 0, texcoord_first = tnext(2);
        const std::string texcoord_line = "property list " +
                                          std::string(std::array{"uchar", "char", "short", "ushort", "int", "uint", "uint8", "int16", "uint32"}[tnext(9)]) +
                                          (tnext(2) ? " float" : " double") + " texcoord" + eol;
        if (face_texcoord && texcoord_first) text += texcoord_line;
        if (face_colour) text += "property uchar red" + eol;
        if (face_texcoord && !texcoord_first) text += texcoord_line;
        if (next(8) == 0) text += "element material 1" + eol + "property float shininess" + eol;
        text += (next(4) == 0 ? "comment end" + eol : "") + "end_header" + eol;
        std::vector<float> want_pos;
        for (size_t i = 0; i < nv; ++i) {
            float xyz[3] = {0, 0, 0};
            for (size_t k = 0; k < props.size(); ++k) {
                char b[40];
                const int kind = props[k].kind;
                if (kind <= 2) {
                    std::snprintf(b, sizeof b, "%.9g", offset + (double(next(2000001)) - 1e6) / double(1000 + next(1000)));
                    xyz[kind] = std::stof(b);
                } else if (kind == 5) {
                    std::snprintf(b, sizeof b, "%d", int(next(256)));
                } else if (kind == 8) {
                    std::snprintf(b, sizeof b, "0");
                } else {
                    std::snprintf(b, sizeof b, "%.6g", double(next(20001)) / 10000.0 - (kind == 3 ? 1.0 : 0.0));
                }
                text += (k ? space() : "") + b;
            }
            want_pos.insert(want_pos.end(), {xyz[0], xyz[1], xyz[2]});
            text += eol;
        }
        if (edges_first) text += "0 1" + eol;
        std::vector<uint32_t> want_indices, want_sizes;
        std::vector<float> want_uv; // per corner, as written
        std::vector<std::string> vertex_uv(nv); // a vertex's usual uv; a corner takes another one time in four (a seam)
        for (std::string& uv : vertex_uv) uv = std::to_string(tnext(1001) / 1000.0) + (tnext(2) ? " " : "\t") + std::to_string(tnext(1001) / 1000.0);
        for (size_t f = 0; f < nf; ++f) {
            const size_t n = 3 + next(std::min<size_t>(nv - 2, 3));
            const std::vector<uint32_t> corners = test::distinct_corners(next, nv, n);
            text += std::to_string(n);
            for (uint32_t c : corners) text += space() + std::to_string(c);
            std::string texcoord(1, ' '); // not " " + std::to_string(): a GCC 12 -Wrestrict false positive
            texcoord += std::to_string(2 * n);
            for (uint32_t c : corners) {
                char b[64];
                const float u = float(tnext(1001)) / 1000.0f, v = float(tnext(1001)) / 1000.0f;
                if (tnext(4)) std::snprintf(b, sizeof b, "%s", vertex_uv[c].c_str());
                else std::snprintf(b, sizeof b, "%.9g %.9g", double(u), double(v));
                texcoord += (tnext(2) ? " " : "  ") + std::string(b);
                float uv[2];
                std::istringstream(b) >> uv[0] >> uv[1];
                want_uv.insert(want_uv.end(), {uv[0], uv[1]});
            }
            if (face_texcoord && texcoord_first) text += texcoord;
            if (face_colour) text += space() + std::to_string(next(256));
            if (face_texcoord && !texcoord_first) text += texcoord;
            text += eol;
            want_indices.insert(want_indices.end(), corners.begin(), corners.end());
            want_sizes.push_back(uint32_t(n));
        }
        if (text.find("material") != std::string::npos && next(2)) text += "0.5" + eol;
        Scene s;
        const Status st = test::load_text(s, text, ".ply");
        ASSERT_TRUE(st.ok()) << st.message << "\n" << text;
        const Primitive& p = s.meshes[0].primitives.at(0);
        const bool all_triangles = std::all_of(want_sizes.begin(), want_sizes.end(), [](uint32_t n) { return n == 3; });
        EXPECT_EQ(p.face_sizes, all_triangles ? std::vector<uint32_t>{} : want_sizes) << text;
        if (face_texcoord) {
            expect_corners(s, want_pos, want_indices, want_uv, text);
        } else {
            const std::array<double, 3> centre = s.nodes[0].translation;
            ASSERT_EQ(p.positions.size(), want_pos.size()) << text;
            for (size_t i = 0; i < want_pos.size(); ++i) // recentred in double: exact when not recentred
                EXPECT_EQ(p.positions[i], float(double(want_pos[i]) - centre[i % 3])) << text;
            EXPECT_EQ(p.indices, want_indices) << text;
        }
        expect_same_as_former_reader(text);
        for (int k = 0; k < 6; ++k) { // broken copies
            std::string broken = text;
            if (next(3) == 0) {
                broken.resize(next(broken.size()));
            } else {
                const char swaps[] = {'x', '-', '.', 'e', ' ', '\n', '9', '+', '0', '\0'};
                broken[next(broken.size())] = swaps[next(sizeof swaps)];
            }
            expect_same_as_former_reader(broken);
        }
    }
}

// ---- Binary PLY (binary_little_endian and binary_big_endian) ----
namespace {
// A binary body: each value in its declared type, in the file's byte order.
struct BinaryWriter {
    bool msb = false;
    std::string out;
    template <class T> void put(T v) {
        char b[sizeof v];
        std::memcpy(b, &v, sizeof v);
        if (msb) std::reverse(b, b + sizeof v);
        out.append(b, sizeof v);
    }
    void value(const std::string& type, double x) {
        if (type == "char" || type == "int8") put(int8_t(x));
        else if (type == "uchar" || type == "uint8") put(uint8_t(x));
        else if (type == "short" || type == "int16") put(int16_t(x));
        else if (type == "ushort" || type == "uint16") put(uint16_t(x));
        else if (type == "int" || type == "int32") put(int32_t(x));
        else if (type == "uint" || type == "uint32") put(uint32_t(x));
        else if (type == "float" || type == "float32") put(float(x));
        else if (type == "double" || type == "float64") put(x);
        else ADD_FAILURE() << "no type " << type;
    }
};

std::string binary_format(bool msb) { return msb ? "format binary_big_endian 1.0\n" : "format binary_little_endian 1.0\n"; }

// A triangle: three float vertices, one face (count and index types given).
std::string binary_triangle(bool msb, const std::string& count_type, const std::string& index_type, std::vector<double> corners = {0, 1, 2},
                            double count = 3) {
    std::string text = "ply\n" + binary_format(msb) + "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                       "element face 1\nproperty list " + count_type + " " + index_type + " vertex_indices\nend_header\n";
    BinaryWriter w{msb, {}};
    for (double v : {0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0}) w.value("float", v);
    w.value(count_type, count);
    for (double c : corners) w.value(index_type, c);
    return text + w.out;
}
} // namespace

// Each refusal of a binary body names the byte and the element row.
TEST(ply_load, BinaryRefusalsNameTheByte) {
    for (const bool msb : {false, true}) {
        const std::string tri = binary_triangle(msb, "uchar", "int");
        const size_t body = tri.find("end_header\n") + 11;
        const std::string texcoord = "ply\n" + binary_format(msb) + "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                     "element face 1\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\nend_header\n";
        BinaryWriter w{msb, {}};
        for (int k = 0; k < 9; ++k) w.value("float", k);
        w.value("uchar", 0), w.value("uchar", 2), w.value("float", 0), w.value("float", 1);
        const std::pair<std::string, std::string> cases[] = {
            {tri.substr(0, body + 20), "PLY byte " + std::to_string(body + 12) + ", vertex 1: the file ends inside it"},
            {tri.substr(0, body + 36), "PLY byte " + std::to_string(body + 36) + ", face 0: the file ends inside it"},
            {tri.substr(0, tri.size() - 2), "PLY byte " + std::to_string(body + 36) + ", face 0: a list of 3 corners is longer than the file"},
            {binary_triangle(msb, "int", "int", {0, 1, 2}, -1.0), "PLY byte " + std::to_string(body - 2 + 36) + ", face 0: a list of 4294967295 corners is longer than the file"},
            {binary_triangle(msb, "uchar", "int", {0, 1, 2, 0}, 5), "PLY byte " + std::to_string(body + 36) + ", face 0: a list of 5 corners is longer than the file"},
            {texcoord + w.out, "PLY byte " + std::to_string(texcoord.size() + 37) + ", face 0: face texture coordinates without corners"},
            {binary_triangle(msb, "uchar", "int", {0, 1, 3}), "1 faces reference vertices that do not exist"},
            {binary_triangle(msb, "uchar", "short", {0, -1, 2}), "1 faces reference vertices that do not exist"},
        };
        for (const auto& [text, message] : cases) {
            Scene s;
            const Status st = test::load_text(s, text, ".ply");
            EXPECT_EQ(st.code, StatusCode::invalid_input) << shown(text);
            EXPECT_NE(st.message.find(message), std::string::npos) << st.message << " | wanted " << message << "\n" << shown(text);
            expect_same_as_former_reader(text); // refused by both
        }
        Scene s;
        const Status st = test::load_text(s, tri, ".ply");
        ASSERT_TRUE(st.ok()) << st.message;
        EXPECT_EQ(s.meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 2}));
        EXPECT_EQ(s.meshes[0].primitives[0].positions.size(), 9u);
    }
}

namespace {
// A MeshLab-style file: vertices with normals and byte colours (and u v when `vertex_uv`), faces with
// vertex_indices, a per-corner texcoord list (its count: the uvs given) and texnumber, a TextureFile comment.
// format: 0 ASCII, 1 binary little endian, 2 binary big endian.
struct WedgeMesh {
    std::vector<std::array<float, 3>> xyz;
    std::vector<std::vector<uint32_t>> faces;
    std::vector<std::vector<float>> uv; // per face, u v per corner
    bool vertex_uv = false;
};
float wedge_normal_x(size_t v) { return 0.125f * float(v); }
std::string wedge_ply(const WedgeMesh& m, int format) {
    std::string text = "ply\nformat " + std::string(format == 0 ? "ascii" : format == 1 ? "binary_little_endian" : "binary_big_endian") +
                       " 1.0\ncomment TextureFile tex.png\nelement vertex " + std::to_string(m.xyz.size()) +
                       "\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                       "property uchar red\nproperty uchar green\nproperty uchar blue\n" +
                       (m.vertex_uv ? "property float u\nproperty float v\n" : "") + "element face " + std::to_string(m.faces.size()) +
                       "\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\nproperty int texnumber\nend_header\n";
    BinaryWriter w{format == 2, {}};
    std::ostringstream a;
    auto put = [&](const char* type, double x) {
        if (format) w.value(type, x);
        else a << x << (std::string(type) == "int" ? "\n" : " ");
    };
    for (size_t v = 0; v < m.xyz.size(); ++v) {
        for (float x : m.xyz[v]) put("float", x);
        for (double x : {double(wedge_normal_x(v)), 0.0, 1.0}) put("float", x);
        for (double x : {double(10 * v + 1), 2.0, 3.0}) put("uchar", x);
        if (m.vertex_uv) put("float", 0.875), put("float", 0.875);
        if (!format) a << "\n";
    }
    for (size_t f = 0; f < m.faces.size(); ++f) {
        put("uchar", double(m.faces[f].size()));
        for (uint32_t c : m.faces[f]) put("int", c), a.seekp(-1, std::ios::cur), a << ' ';
        put("uchar", double(m.uv[f].size()));
        for (float x : m.uv[f]) put("float", x);
        put("int", 0); // texnumber
    }
    return text + (format ? w.out : a.str());
}
} // namespace

// MeshLab writes per-corner ("wedge") uvs as a face's `property list uchar float texcoord` (2 per corner) and
// OpenMesh 9.0 read the list as one value (of the brief's two-triangle file it kept one triangle and no uv).
// Read now, in ASCII and binary of either byte order: every face, each corner's position and uv through the
// index buffer, a vertex split where its corners' uvs differ (a seam) and nowhere else, its normal and colour
// on both copies, the corner uvs over the vertex's u v, and a list of the wrong length refused by line or byte.
TEST(ply_load, MeshLabCornerTexcoords) {
    WedgeMesh quad{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}}, {{0, 0, 1, 0, 1, 1}, {0, 0, 1, 1, 0, 1}}, false};
    WedgeMesh seam = quad;
    seam.uv[1] = {0.5f, 0.25f, 1, 1, 0, 1}; // vertex 0: (0, 0) in face 0, (0.5, 0.25) in face 1
    WedgeMesh both = seam;
    both.vertex_uv = true;
    for (int format = 0; format < 3; ++format) {
        for (const auto& [m, vertices] : {std::pair{quad, 4u}, std::pair{seam, 5u}, std::pair{both, 5u}}) {
            const std::string text = wedge_ply(m, format);
            Scene s;
            const Status st = test::load_text(s, text, ".ply");
            ASSERT_TRUE(st.ok()) << st.message << "\n" << shown(text);
            EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
            std::vector<float> xyz, uv;
            std::vector<uint32_t> corners;
            for (const auto& v : m.xyz) xyz.insert(xyz.end(), v.begin(), v.end());
            for (size_t f = 0; f < m.faces.size(); ++f) {
                corners.insert(corners.end(), m.faces[f].begin(), m.faces[f].end());
                uv.insert(uv.end(), m.uv[f].begin(), m.uv[f].end());
            }
            expect_corners(s, xyz, corners, uv, shown(text));
            const Primitive& p = s.meshes[0].primitives[0];
            EXPECT_EQ(p.positions.size(), vertices * 3) << shown(text);
            ASSERT_EQ(p.normals.size(), p.positions.size());
            ASSERT_EQ(p.colors.size(), vertices * 4);
            for (size_t c = 0; c < corners.size(); ++c) { // the file vertex's normal and colour on every copy
                EXPECT_EQ(p.normals[p.indices[c] * 3], wedge_normal_x(corners[c])) << c;
                EXPECT_EQ(p.colors[p.indices[c] * 4], float(10 * corners[c] + 1) / 255.0f) << c;
            }
        }
        WedgeMesh wrong = quad;
        wrong.uv[1].resize(4); // 2 corners' worth on a triangle
        const std::string text = wedge_ply(wrong, format);
        const size_t body = text.find("end_header\n") + 11;
        const std::string where = format == 0 ? "PLY line " + std::to_string(std::count(text.begin(), text.end(), '\n')) + ": "
                                              : "PLY byte " + std::to_string(body + 4 * 27 + 42 + 13) + ", face 1: ";
        Scene s;
        const Status st = test::load_text(s, text, ".ply");
        EXPECT_EQ(st.code, StatusCode::invalid_input);
        EXPECT_NE(st.message.find(where + "a texcoord list of 4 values for "), std::string::npos) << st.message << " | wanted " << where;
        EXPECT_NE(st.message.find("3 corners (2 per corner wanted)"), std::string::npos) << st.message;
        WedgeMesh nan = quad;
        nan.uv[0][3] = std::nanf(""); // face 0, corner 1's v: never a NaN uv
        const std::string nan_text = wedge_ply(nan, format);
        const auto face0_line = std::count(text.begin(), text.end(), '\n') - 1;
        const std::string nan_where = format == 0 ? "PLY line " + std::to_string(face0_line) + ": 'nan' is not a number"
                                                  : "PLY byte " + std::to_string(body + 4 * 27 + 14 + 12) +
                                                        ", face 0: a texture coordinate is not finite";
        const std::string nan_message = test::load_text(s, nan_text, ".ply").message;
        EXPECT_NE(nan_message.find(nan_where), std::string::npos) << nan_message << " | wanted " << nan_where;
        std::string ints = wedge_ply(quad, format);
        ints.replace(ints.find("uchar float texcoord"), 20, "uchar int texcoord");
        const auto line = std::count(ints.begin(), ints.begin() + std::ptrdiff_t(ints.find("texcoord")), '\n') + 1;
        const std::string message = test::load_text(s, ints, ".ply").message;
        EXPECT_NE(message.find("PLY line " + std::to_string(line) + ": a texcoord list of 'int' (float or double wanted)"), std::string::npos) << message;
    }
}

// What OpenMesh 9.0's binary reader did is kept: a coordinate of an integer type, and a colour of type double,
// read nothing and are 0; a double coordinate is cast to float; after a comment as the last header line it starts
// one byte late (it seeks 12 bytes past where the read of end_header began); a header of two coordinates reads z
// as 0. (A face's texcoord list, one float to it, is read as corner uvs now: MeshLabCornerTexcoords.)
TEST(ply_load, BinaryOpenMeshReadingIsKept) {
    for (const bool msb : {false, true}) {
        const std::string head = "ply\n" + binary_format(msb) + "element vertex 3\n";
        const std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
        auto body = [&](const std::vector<std::pair<std::string, double>>& values) {
            BinaryWriter w{msb, {}};
            for (const auto& [type, v] : values) w.value(type, v);
            return w.out;
        };
        // int y: read as 0, taking no bytes, so that the next value is read from y's bytes.
        const std::string int_y = head + "property float x\nproperty int y\nproperty float z\n" + face + "end_header\n" +
                                  body({{"float", 1}, {"float", 2}, {"float", 3}, {"float", 4}, {"float", 5}, {"float", 6},
                                        {"uchar", 3}, {"int", 0}, {"int", 1}, {"int", 2}}) +
                                  std::string(16, '\0'); // the validation pass wants the 4 bytes of each y
        Scene s;
        { const Status st = test::load_text(s, int_y, ".ply"); ASSERT_TRUE(st.ok()) << st.message; }
        expect_same_as_former_reader(int_y);
        const std::string colour = head + "property double x\nproperty double y\nproperty double z\nproperty double red\n"
                                          "property uchar green\nproperty float blue\n" + face + "end_header\n" +
                                   body({{"double", 0.1}, {"double", 0}, {"double", 0}, {"uchar", 200}, {"float", 0.5},
                                         {"double", 1}, {"double", 0}, {"double", 0}, {"uchar", 100}, {"float", 1},
                                         {"double", 0}, {"double", 1}, {"double", 0}, {"uchar", 0}, {"float", 2},
                                         {"uchar", 3}, {"int", 0}, {"int", 1}, {"int", 2}}) +
                                   std::string(24, '\0'); // the validation pass wants the 8 bytes of each red
        ASSERT_TRUE(test::load_text(s, colour, ".ply").ok());
        EXPECT_EQ(s.meshes[0].primitives[0].colors[0], 0.0f);              // red: a double colour is 0
        EXPECT_EQ(s.meshes[0].primitives[0].colors[1], 200.0f / 255.0f); // green
        EXPECT_EQ(s.meshes[0].primitives[0].colors[2], 127.0f / 255.0f); // blue: int(0.5 * 255)
        expect_same_as_former_reader(colour);
        const std::string comment = head + "property float x\nproperty float y\nproperty float z\n" + face + "comment last\nend_header\n" +
                                    "?" + body({{"float", 0}, {"float", 0}, {"float", 0}, {"float", 1}, {"float", 0}, {"float", 0},
                                                {"float", 0}, {"float", 1}, {"float", 0}, {"uchar", 3}, {"int", 0}, {"int", 1}, {"int", 2}});
        ASSERT_TRUE(test::load_text(s, comment, ".ply").ok());
        EXPECT_EQ(s.meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 2}));
        expect_same_as_former_reader(comment);
        const std::string flat = head + "property float x\nproperty float y\n" + face + "end_header\n" +
                                 body({{"float", 0}, {"float", 0}, {"float", 1}, {"float", 0}, {"float", 0}, {"float", 1},
                                       {"uchar", 3}, {"int", 0}, {"int", 1}, {"int", 2}});
        ASSERT_TRUE(test::load_text(s, flat, ".ply").ok());
        expect_same_as_former_reader(flat);
    }
}

// Property: random binary PLY files (either byte order; property order and types, char to double and their
// int8..float64 names; normals, uvs, colours as bytes, floats or other types; unknown properties, lists and
// elements; count and index types; face colours and texcoord lists of any count type, float or double; comments,
// CRLF) give what a direct reading of the written values gives (when OpenMesh read them as written, and the
// corner uvs) and, without a face texcoord list, what the former reader gave; broken copies (cut short, a byte
// replaced, inserted or removed) are accepted or refused as it did, with the same scene.
TEST(ply_load, RandomBinaryMatchesDirectReadingAndFormerReader) {
    test::Lcg next(2026), tnext(2003); // tnext: the face texcoord lists' own generator: the other files are as before
    auto pick = [&](std::initializer_list<const char*> names) { return std::string(names.begin()[next(names.size())]); };
    for (int round = 0; round < 1500; ++round) {
        const bool msb = next(2), crlf = next(6) == 0;
        const std::string eol = crlf ? "\r\n" : "\n";
        bool as_written = true; // OpenMesh reads the values as written (else only the former reader is the oracle)
        const size_t nv = 3 + next(12), nf = 1 + next(8);
        const double offset = next(4) == 0 ? 1e5 : 0;
        // Vertex properties. kind: 0-2 xyz, 3 normal, 4 uv, 5 colour, 6 other scalar, 7 other list.
        struct Prop { std::string type, name; int kind; std::string count; };
        auto coord_type = [&] { return next(12) == 0 ? pick({"int", "short", "uchar"}) : pick({"float", "float32", "double", "float64"}); };
        std::vector<Prop> props = {{coord_type(), "x", 0, ""}, {coord_type(), "y", 1, ""}, {coord_type(), "z", 2, ""}};
        if (next(3) == 0) for (const char* n : {"nx", "ny", "nz"}) props.push_back({pick({"float", "double"}), n, 3, ""});
        if (next(3) == 0) {
            const bool st = next(2);
            props.push_back({pick({"float", "float32"}), st ? "s" : "u", 4, ""});
            props.push_back({pick({"float", "float32"}), st ? "t" : "v", 4, ""});
        }
        if (next(3) == 0) {
            const std::string t = next(6) == 0 ? pick({"double", "ushort", "int", "char"}) : pick({"uchar", "uint8", "float"});
            for (const char* n : {"red", "green", "blue"}) props.push_back({t, n, 5, ""});
            if (next(2)) props.push_back({t, "alpha", 5, ""});
        }
        if (next(4) == 0) props.push_back({pick({"char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "uint16", "int32", "float64"}), "quality", 6, ""});
        if (next(6) == 0) props.push_back({pick({"int", "float", "uchar"}), "flags", 7, pick({"uchar", "int"})});
        for (size_t i = props.size(); i > 1; --i) std::swap(props[i - 1], props[next(i)]);
        std::string head = "ply" + eol + (msb ? "format binary_big_endian 1.0" : "format binary_little_endian 1.0") + eol;
        if (next(2)) head += "comment made by a test" + eol;
        head += "element vertex " + std::to_string(nv) + eol;
        for (const Prop& p : props)
            head += (p.kind == 7 ? "property list " + p.count + " " + p.type + " " + p.name : next(10) ? "property " + p.type + " " + p.name
                                                                                                        : "property " + p.name + " " + p.type) + eol;
        const bool edges_first = next(8) == 0;
        if (edges_first) head += "element edge 1" + eol + "property int vertex1" + eol + "property int vertex2" + eol;
        head += "element face " + std::to_string(nf) + eol;
        if (next(8) == 0) head += "property uchar intensity" + eol; // dropped by the indices after it: not written
        const std::string count_type = pick({"uchar", "uint8", "uint16", "int"});
        const std::string index_type = next(10) == 0 ? pick({"float", "short", "char"}) : pick({"int", "uint", "int32", "uint32", "ushort", "uint16", "uchar"});
        head += "property list " + count_type + " " + index_type + (next(2) ? " vertex_indices" : " vertex_index") + eol;
        const std::string face_colour = next(4) == 0 ? pick({"uchar", "float", "double"}) : "";
        if (!face_colour.empty()) head += "property " + face_colour + " red" + eol;
        const bool texcoord = next(8) == 0;
        const std::string tex_count = std::array{"uchar", "char", "ushort", "short", "int", "uint", "int8", "uint16", "int32"}[tnext(9)];
        const std::string tex_type = tnext(2) ? "float" : "double";
        if (texcoord) head += "property list " + tex_count + " " + tex_type + " texcoord" + eol;
        if (next(8) == 0) head += "element material 1" + eol + "property float shininess" + eol;
        const bool comment_last = next(10) == 0;
        head += (comment_last ? "comment end" + eol : "") + "end_header" + eol;
        // OpenMesh reads a coordinate of an integer type, a double colour or float indices as 0 without taking
        // bytes; a vertex list as one value; a comment shifts the start.
        for (const Prop& p : props)
            as_written &= !(p.kind <= 4 && (p.type == "int" || p.type == "short" || p.type == "uchar")) && p.kind != 7 &&
                          !(p.kind == 5 && p.type == "double");
        as_written &= index_type != "float" && face_colour != "double" && !comment_last;
        BinaryWriter w{msb, {}};
        if (comment_last) w.out += char(next(256));
        std::vector<float> want_pos;
        for (size_t i = 0; i < nv; ++i) {
            for (const Prop& p : props) {
                if (p.kind <= 2) {
                    const double v = offset + (double(next(2000001)) - 1e6) / double(1000 + next(1000));
                    w.value(p.type, v);
                    want_pos.push_back(float(v)); // written as float, or as double and read as float
                } else if (p.kind == 7) {
                    const int n = int(next(3));
                    w.value(p.count, n);
                    for (int k = 0; k < n; ++k) w.value(p.type, double(next(100)));
                } else if (p.kind == 5 && p.type != "float") {
                    w.value(p.type, double(next(256)));
                } else {
                    w.value(p.type, double(next(20001)) / 10000.0 - (p.kind == 3 ? 1.0 : 0.0));
                }
            }
        }
        // want_pos in xyz order (the properties are shuffled)
        std::vector<float> xyz(nv * 3);
        for (size_t i = 0, at = 0; i < nv; ++i)
            for (const Prop& p : props)
                if (p.kind <= 2) xyz[i * 3 + size_t(p.kind)] = want_pos[at++];
        if (edges_first) w.value("int", 0), w.value("int", 1);
        std::vector<uint32_t> want_indices, want_sizes;
        std::vector<float> want_uv; // per corner
        std::vector<double> vertex_uv(nv * 2); // a vertex's usual uv; a corner takes another one time in four (a seam)
        for (double& x : vertex_uv) x = double(tnext(1001)) / 1000.0;
        for (size_t f = 0; f < nf; ++f) {
            const size_t n = 3 + next(std::min<size_t>(nv - 2, 3));
            const std::vector<uint32_t> corners = test::distinct_corners(next, nv, n);
            w.value(count_type, double(n));
            for (uint32_t c : corners) w.value(index_type, c);
            if (!face_colour.empty()) w.value(face_colour, face_colour == "float" ? 0.5 : double(next(256)));
            if (texcoord) {
                w.value(tex_count, double(2 * n));
                for (size_t k = 0; k < 2 * n; ++k) {
                    const double random_uv = double(next(100)) / 100.0 + double(tnext(3)) / 3.0;
                    const double x = tnext(4) ? vertex_uv[corners[k / 2] * 2 + k % 2] : random_uv;
                    w.value(tex_type, x);
                    want_uv.push_back(float(x));
                }
            }
            want_indices.insert(want_indices.end(), corners.begin(), corners.end());
            want_sizes.push_back(uint32_t(n));
        }
        if (head.find("material") != std::string::npos && next(2)) w.value("float", 0.5);
        const std::string text = head + w.out;
        Scene s;
        const Status st = test::load_text(s, text, ".ply");
        if (as_written && texcoord) {
            ASSERT_TRUE(st.ok()) << st.message << "\n" << shown(text);
            expect_corners(s, xyz, want_indices, want_uv, shown(text));
        } else if (as_written) {
            ASSERT_TRUE(st.ok()) << st.message << "\n" << shown(text);
            const Primitive& p = s.meshes[0].primitives.at(0);
            const std::array<double, 3> centre = s.nodes[0].translation;
            ASSERT_EQ(p.positions.size(), xyz.size()) << shown(text);
            for (size_t i = 0; i < xyz.size(); ++i) EXPECT_EQ(p.positions[i], float(double(xyz[i]) - centre[i % 3])) << shown(text);
            EXPECT_EQ(p.indices, want_indices) << shown(text);
            const bool all_triangles = std::all_of(want_sizes.begin(), want_sizes.end(), [](uint32_t n) { return n == 3; });
            EXPECT_EQ(p.face_sizes, all_triangles ? std::vector<uint32_t>{} : want_sizes) << shown(text);
        }
        expect_same_as_former_reader(text);
        for (int k = 0; k < 6; ++k) { // broken copies
            std::string broken = text;
            const size_t at = next(3) ? head.size() + next(broken.size() - head.size()) : next(broken.size());
            switch (next(4)) {
            case 0: broken.resize(next(broken.size())); break;
            case 1: broken.insert(broken.begin() + long(at), char(next(256))); break;
            case 2: broken.erase(at, 1); break;
            default: broken[at] = char(next(256)); break;
            }
            expect_same_as_former_reader(broken);
        }
    }
}

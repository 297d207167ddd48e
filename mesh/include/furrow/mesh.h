// furrow::mesh — core types, scene I/O (glTF 2.0, OBJ/PLY/OFF/STL), topology helpers and validity checks.
//
// Conventions (meshoptimizer style): output buffer first, then pointer + count (+ stride); functions that
// produce elements return their count; errors come back as a Status, never as an exception. No OpenMesh,
// CGAL or OpenSubdiv type crosses this header.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace furrow {

// ---------------------------------------------------------------------------------------------------------
// Status
// ---------------------------------------------------------------------------------------------------------
enum class StatusCode : int {
    ok = 0,
    invalid_input,    // the input data is malformed (bad JSON, index out of range, NaN, truncated file, ...)
    unsupported,      // well-formed but uses something furrow does not handle (a glTF extension, a mode)
    io_error,         // a file could not be opened, read, written or renamed
    invalid_argument, // an option value is out of its documented range
    out_of_memory,    // a size guard refused the request
    not_found,        // a resource a resolver was asked for does not exist (ResourceResolver)
};

struct [[nodiscard]] Status {
    StatusCode code = StatusCode::ok;
    std::string message; // one line, no trailing newline; says what is wrong (the CLI prefixes "Error: <file>: ")

    bool ok() const { return code == StatusCode::ok; }
    static Status success() { return {}; }
    static Status error(StatusCode c, std::string m) { return {c, std::move(m)}; }
};

// ---------------------------------------------------------------------------------------------------------
// Geometry: one primitive = one draw call with one material. All arrays are tightly packed, one entry per
// vertex unless said otherwise; an empty array means "attribute absent".
// ---------------------------------------------------------------------------------------------------------
enum class PrimitiveMode : int { points = 0, lines = 1, triangles = 4 }; // strips/fans/loops are converted on load

struct MorphTarget {
    std::vector<float> position_deltas; // xyz, or empty
    std::vector<float> normal_deltas;   // xyz, or empty
    std::vector<float> tangent_deltas;  // xyz, or empty
};

// An application-specific vertex attribute. glTF requires the name to start with '_' (e.g. "_FUR_LAYER");
// it is written as FLOAT SCALAR/VEC2/VEC3/VEC4.
struct CustomAttribute {
    std::string name;
    int components = 1;        // 1..4
    std::vector<float> values; // components per vertex
};

struct Primitive {
    PrimitiveMode mode = PrimitiveMode::triangles;
    std::vector<float> positions;   // xyz (required)
    std::vector<float> normals;     // xyz
    std::vector<float> tangents;    // xyzw
    std::vector<float> uv0;         // uv (glTF convention: v = 0 at the top of the image)
    std::vector<float> uv1;         // uv
    std::vector<float> colors;      // rgba, linear
    std::vector<uint16_t> joints;   // 4 per vertex (JOINTS_0)
    std::vector<float> weights;     // 4 per vertex (WEIGHTS_0)
    std::vector<MorphTarget> targets;
    std::vector<CustomAttribute> custom;
    // Faces: corner indices concatenated. face_sizes[i] = corners of face i; empty face_sizes means every face
    // is a triangle. Quads and n-gons are kept from formats that have them (OBJ, PLY, OFF), so that
    // Catmull-Clark sees them; glTF output, the rasterizer, shells and stamping triangulate them
    // (triangulate_polygons).
    // For points/lines, indices are the point/segment indices and face_sizes is empty.
    std::vector<uint32_t> indices;
    std::vector<uint32_t> face_sizes;
    int material = -1; // index into Scene::materials, -1 = glTF default material

    size_t vertex_count() const { return positions.size() / 3; }
    size_t face_count() const { return face_sizes.empty() ? indices.size() / 3 : face_sizes.size(); }
    // Number of triangles after triangulation of the faces (s − 2 per face of s >= 3 corners).
    size_t triangle_count() const;
};

// Triangulates polygons given as concatenated corner indices and their sizes: ear clipping in each polygon's
// best-fit plane (valid for non-convex and non-planar polygons, same winding), choosing diagonals that are
// not already edges of the mesh (compared by welded position), so a manifold input stays manifold. A convex
// polygon with no conflicting diagonal gets the fan from its first corner. Faces of fewer than 3 corners are
// dropped; a face with an index out of range or no area, or of more than 1024 corners, is fanned. Writes
// 3 indices per triangle into out and returns the triangle count.
size_t triangulate_polygons(std::vector<uint32_t>& out, const uint32_t* indices, size_t index_count,
                            const uint32_t* face_sizes, size_t face_count, const float* positions, size_t vertex_count);
// Triangulates the faces of a primitive (quads/n-gons) in place with triangulate_polygons; face_sizes
// becomes empty.
void triangulate(Primitive& primitive);

struct Mesh {
    std::string name;
    std::vector<Primitive> primitives;
    std::vector<float> weights; // default morph weights
    // A JSON object save_scene writes as this mesh's glTF `extras` (replacing the source's); empty = the
    // source's extras, if any. Not filled on load (a loaded mesh's extras ride in Scene::document). How a tool
    // hands an engine documented data without a vendor extension (an unregistered extension prefix is a
    // validator warning): `furrow shells --layout instanced` writes {"FURROW_shells": {...}} here.
    std::string extras_json;
};

// ---------------------------------------------------------------------------------------------------------
// Scene: what furrow edits is plain data below; everything else of the source document (skins' extensions,
// animations, cameras, extras, unknown extensions, the asset block) is carried in `document` and written
// back on save. Existing indices must stay valid: tools append nodes/materials/textures/images, they do not
// reorder them.
// ---------------------------------------------------------------------------------------------------------
struct Node {
    std::string name;
    int mesh = -1;
    int skin = -1;
    int camera = -1;
    std::vector<int> children;
    // Local transform: either a matrix (column-major, has_matrix) or TRS. Double so that a recentring offset
    // of 1e5 m keeps its millimetres.
    bool has_matrix = false;
    std::array<double, 16> matrix{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    std::array<double, 3> translation{0, 0, 0};
    std::array<double, 4> rotation{0, 0, 0, 1}; // quaternion x, y, z, w
    std::array<double, 3> scale{1, 1, 1};
    std::vector<double> weights; // morph weights override, or empty

    std::array<double, 16> local_matrix() const; // column-major
};

struct Skin {
    std::string name;
    std::vector<int> joints;                  // node indices
    std::vector<float> inverse_bind_matrices; // 16 per joint, column-major; empty = identity
    int skeleton = -1;
};

enum class AlphaMode : int { opaque = 0, mask = 1, blend = 2 };

struct TextureRef {
    int texture = -1; // index into Scene::textures, -1 = none
    int texcoord = 0; // TEXCOORD_n set
};

// The metallic-roughness core that furrow reads and writes. Other material properties of a loaded material
// (normal/occlusion/emissive textures, extensions, extras) are kept from the source document.
struct Material {
    std::string name;
    std::array<float, 4> base_color{1, 1, 1, 1}; // linear RGBA factor
    TextureRef base_color_texture;
    float metallic = 1.0f;
    float roughness = 1.0f;
    std::array<float, 3> emissive{0, 0, 0};
    AlphaMode alpha_mode = AlphaMode::opaque;
    float alpha_cutoff = 0.5f; // used when alpha_mode == mask
    bool double_sided = false;
};

struct Sampler { // glTF enums; -1 = unset (viewer's choice)
    int mag_filter = -1;
    int min_filter = -1;
    int wrap_s = 10497; // REPEAT
    int wrap_t = 10497;
};

struct Texture {
    int image = -1;
    int sampler = -1;
};

struct Image {
    std::string name;
    std::string mime_type;        // "image/png" or "image/jpeg"
    std::vector<uint8_t> encoded; // the file's bytes (PNG/JPEG); empty if the image could not be read
    std::string source_uri;       // where it came from (informational; output always embeds the bytes)
};

namespace mesh_detail { struct Document; }

struct Scene {
    std::vector<Mesh> meshes;
    std::vector<Node> nodes;
    std::vector<int> roots; // root nodes of the default scene
    std::vector<Material> materials;
    std::vector<Texture> textures;
    std::vector<Sampler> samplers;
    std::vector<Image> images;
    std::vector<Skin> skins;
    std::vector<std::string> warnings; // non-fatal findings of the loader (e.g. a missing texture file)
    std::shared_ptr<const mesh_detail::Document> document; // the rest of the source; null for non-glTF sources

    // The one traversal every module uses (render, shells, tessellate, stamp):
    // The nodes the default scene draws: depth first from `roots` (from every parentless node when `roots` is
    // empty), each node once, children in order. Out-of-range indices and cycles are skipped.
    std::vector<int> drawn_nodes() const;
    // World matrix (column-major) of every node, along drawn_nodes(); nodes not drawn get identity.
    std::vector<std::array<double, 16>> world_matrices() const;
    // Where node n draws its mesh, as one rigid matrix (world = placement × object). glTF 2.0 §3.7.3: a skinned
    // mesh ignores its node's transform and is placed by its joints, world(joint) × inverseBind(joint); in the
    // bind pose every joint gives the same matrix. furrow takes the joint with the largest total weight over
    // the mesh's vertices (the lowest index among equals). Not skinned, or a skin it cannot read: world[n].
    std::array<double, 16> mesh_placement(int n, const std::vector<std::array<double, 16>>& world) const;
};

// ---------------------------------------------------------------------------------------------------------
// I/O. Format by extension: .gltf .glb (read/write), .obj .ply .off .stl (read).
// ---------------------------------------------------------------------------------------------------------

// External resources of a glTF file: a buffer or image `uri` that is not a data URI. The loader reads only
// the ones the scene uses (an image a texture names, a buffer a used accessor or image lies in) and asks a
// resolver for their bytes, one request each.
struct ResourceRequest {
    std::string uri;      // as written in the file, e.g. "tex/a%20b.png" or "file:///srv/a.bin"
    std::string path;     // the URI's path, percent-decoded (RFC 3986 §2.1): "tex/a b.png", "/srv/a.bin";
                          // never holds a NUL byte (such a URI is refused before any resolver sees it)
    bool image = false;   // an image (else a buffer)
    int index = -1;       // its index in the file's images or buffers
    size_t max_bytes = 0; // the most bytes it may have: what LoadOptions::max_resource_bytes leaves
};
// Fills `bytes` and returns success; or returns StatusCode::not_found (a missing image is one warning and
// renders with its material's factor, a missing buffer fails the load); any other error fails the load. The
// message continues the sentence "image 0 uri 'x.png' ...", e.g. "is not in the archive". Called on the
// loading thread, in file order, at most once per resource; never for data URIs.
using ResourceResolver = std::function<Status(std::vector<uint8_t>& bytes, const ResourceRequest& request)>;

// The default resolver of load_scene: reads `request.path` as a file, relative to `base_dir` unless
// absolute (file:// URIs with an empty or "localhost" host are paths), and refuses (invalid_input) a file
// that does not lie under `root` once both are made canonical (std::filesystem::weakly_canonical: `..`,
// `.` and symbolic links resolved), so `../`, absolute paths and symlinks cannot leave the root. Other URI
// schemes (http:, ...) are refused; a folder or device is refused; a missing file is not_found.
ResourceResolver confined_file_resolver(const std::string& root, const std::string& base_dir);

struct LoadOptions {
    bool recentre = true;                // move far-from-origin meshes to their bbox centre (see recentre())
    double recentre_threshold = 1000.0;  // ... when |centre| > threshold × bbox diagonal ... or > 1e4 units
    bool allow_non_finite = false;       // accept NaN/Inf positions (for `furrow check`, which reports them)
    size_t max_file_bytes = size_t(2) << 30; // refuse larger inputs (memory guard)

    // Untrusted input (README "Threat model"). Over a limit, the load fails (out_of_memory) naming the field.
    std::string resource_root;                   // load_scene reads external resources only
                                                 // under this folder; "" = the input file's own folder
    ResourceResolver resolver;                   // reads external resources instead of confined_file_resolver;
                                                 // load_scene_from_memory resolves none without one
    size_t max_resource_bytes = size_t(2) << 30; // all external buffers and images together
    size_t max_image_pixels = size_t(1) << 26;   // width × height of any image (8192²), from
                                                 // its header, before anything decodes it
    size_t max_nodes = size_t(1) << 20;          // nodes of a glTF file (1,048,576)
    size_t max_primitives = size_t(1) << 20;     // primitives over all meshes of a glTF file
};

// How the vertex data of a written glTF is stored (README "Output size: --quantize and --compress").
enum class Encoding : int {
    plain = 0,    // float attributes, uint16/uint32 indices: every glTF 2.0 reader (Blender 3.4 included)
    quantize = 1, // KHR_mesh_quantization (required): integer positions, int8 normals/tangents, uint16 UVs
                  // in [0, 1] (else float), uint8 colours
    compress = 2, // quantize + EXT_meshopt_compression (required, no fallback data): three.js needs its
                  // MeshoptDecoder; Blender 3.4 cannot read it
};

struct SaveOptions {
    bool pretty_json = false; // .gltf only: indent the JSON
    bool optimize = true;     // meshoptimizer's vertex cache order of the triangles, then vertex fetch order of
                              // the vertices (every attribute remapped alike; the vertex count is unchanged);
                              // false keeps the scene's order. Points and lines keep theirs either way.
    Encoding encoding = Encoding::plain;
    // Precision of quantized positions. Each mesh gets a grid: origin = its bounding-box minimum (stored in a
    // node translation, in double, so a mesh far from the origin keeps its precision), step = its largest
    // bounding-box extent / (2^bits − 1); every position moves at most step/2 per axis (with 14 bits,
    // 0.0031 % of the largest extent). Skinned and morphed meshes keep float positions. 0 = 14, gltfpack's
    // -vp default; 1..16 otherwise.
    int position_bits = 0;
    // Leave out the texture-coordinate sets that no texture of the primitive's material samples, as gltfpack
    // does by default. A primitive of a mesh with extras or extensions keeps all of them (a reader of that data,
    // such as the instanced shell layout's FURROW_shells, may read them), and so does one whose material's own
    // extensions sample textures. Set 0 stays when set 1 does (glTF numbers the sets without gaps). Off by
    // default: an engine's own material may read sets the file's does not.
    bool drop_unused_uvs = false;
};
// The bits position_bits = 0 stands for.
inline constexpr int default_position_bits = 14;

Status load_scene(Scene& out, const std::string& path, const LoadOptions& options = {});
// Loads from memory; `extension` is the format, e.g. ".glb". External URIs go to options.resolver; without
// one they are not resolved (a buffer is then an error, an image a warning).
Status load_scene_from_memory(Scene& out, const uint8_t* data, size_t size, const std::string& extension,
                              const LoadOptions& options = {});
// Writes .glb or .gltf (+ .bin beside it, named after the .gltf). Output is written to a temporary file in
// the same folder and renamed into place, so a failure never leaves a half-written file. Validator-clean:
// POSITION min/max, uint16/uint32 indices as needed, images embedded, no dangling references. Accessors with
// the same description over the same bytes are written once and shared (fur shells repeat their base's
// triangles and texture coordinates); a triangle, line or point primitive whose vertex count and indices equal
// those of the primitive written just before it takes that one's vertex order (SaveOptions::optimize).
Status save_scene(const Scene& scene, const std::string& path, const SaveOptions& options = {});

// A scene with one node holding one mesh of one primitive (the shape of an OBJ/STL import).
Scene make_scene(Primitive primitive, const std::string& name = "mesh");

// Recentres every mesh whose bounding-box centre is far from the origin: positions become relative to the
// centre (computed in double) and the centre goes into the translation of the nodes that use the mesh, so
// float32 positions keep their precision. Meshes used by skinned nodes are left alone. Returns the number of
// meshes moved.
size_t recentre(Scene& scene, double threshold = 1000.0);

// Reads a PNG (8/16-bit, any channel count) into floats in [0,1], `channels` per pixel as stored.
// Used for masks and brushes.
struct ImageF {
    int width = 0, height = 0, channels = 0;
    std::vector<float> pixels; // row-major, top row first
};
Status load_png(ImageF& out, const std::string& path);
Status decode_image(ImageF& out, const uint8_t* data, size_t size); // PNG or JPEG bytes
// Writes 8-bit PNG (channels 1..4) from floats in [0,1] (clamped), atomically (temp + rename).
Status save_png(const ImageF& image, const std::string& path, bool srgb_encode = false);
// Encodes 8-bit RGBA bytes (width*height*4) to PNG bytes, deterministic.
std::vector<uint8_t> encode_png_rgba8(const uint8_t* rgba, int width, int height);

// Linear <-> sRGB transfer functions (IEC 61966-2-1), for one channel in [0,1].
float srgb_to_linear(float v);
float linear_to_srgb(float v);

// ---------------------------------------------------------------------------------------------------------
// Topology helpers
// ---------------------------------------------------------------------------------------------------------

// Welds vertices by position: remap[i] = index of the first vertex with the same position (within
// `tolerance`, absolute; 0 = exact bit equality of the float values, with -0 == +0). Returns the number of
// unique positions. Deterministic; O(n log n).
size_t weld_positions(uint32_t* remap, const float* positions, size_t vertex_count, size_t stride_floats = 3,
                      double tolerance = 0.0);

// Angle-weighted vertex pseudo-normals (Thürmer & Wüthrich 1998), accumulated in double over the welded
// vertices so every split copy of a position gets the same normal. Degenerate faces (a repeated vertex, a
// non-finite corner, or an area <= 1e-14 × the square of the face's longest edge) contribute nothing;
// a vertex without a valid face gets (0,0,0) — callers choose a fallback. Triangles only
// (indices.size() multiple of 3). Writes vertex_count normals.
void compute_vertex_normals(float* normals_out, const float* positions, size_t vertex_count,
                            const uint32_t* indices, size_t index_count);

// The vertex order save_scene writes (SaveOptions::optimize), with meshoptimizer: the triangles in vertex
// cache order (meshopt_optimizeVertexCache), then the vertices in the order those triangles first use them
// (meshopt_optimizeVertexFetchRemap), every per-vertex array (attributes, morph deltas, custom attributes)
// permuted alike. Unreferenced vertices are kept, after the others; a triangle keeps its corners' order.
// Only triangle primitives without n-gons; others are left as they are. Deterministic.
// With Encoding::compress the triangles go in meshopt_optimizeVertexCacheStrip's order instead (gltfpack -cc
// does the same): consecutive triangles share an edge more often, so the index codec and the vertex codec's
// deltas need fewer bits, for a few per cent more cache misses. `encoding` = the one given to save_scene.
void optimize_vertex_order(Primitive& primitive, Encoding encoding = Encoding::plain);

// Boundary loops of a triangle mesh over welded positions, found on an OpenMesh halfedge structure; each
// loop as welded vertex indices (first vertex of each position). Faces that would make the mesh non-manifold
// are skipped (counted in *skipped_faces if non-null). Returns the number of loops.
size_t boundary_loops(std::vector<std::vector<uint32_t>>& loops, const float* positions, size_t vertex_count,
                      const uint32_t* indices, size_t index_count, size_t* skipped_faces = nullptr);

// ---------------------------------------------------------------------------------------------------------
// Validity checks (`furrow check`). Topology is measured after welding by exact position, as a viewer
// or an OpenSubdiv refiner would see it.
// ---------------------------------------------------------------------------------------------------------
struct CheckOptions {
    double sliver_angle_degrees = 1.0;     // a triangle with a smaller interior angle is a sliver
    double zero_area_relative = 1e-14;     // area <= this × diagonal² is zero-area
    bool self_intersections = false;       // CGAL Polygon_mesh_processing (slow on big meshes)
};

struct CheckReport {
    size_t vertices = 0, faces = 0, triangles = 0;
    size_t welded_vertices = 0;        // unique positions
    size_t components = 0;             // edge-connected, over welded vertices
    size_t boundary_edges = 0, boundary_loops = 0;
    size_t non_manifold_edges = 0;     // edges with more than 2 faces
    size_t non_manifold_vertices = 0;  // vertices whose faces form more than one fan
    size_t degenerate_faces = 0;       // a (welded) vertex repeated in a face
    size_t zero_area_faces = 0;        // area <= zero_area_relative × diag² (includes degenerate ones)
    size_t slivers = 0;                // min angle < sliver_angle_degrees (non-zero-area triangles)
    size_t duplicate_vertices = 0;     // vertices - welded_vertices
    size_t unreferenced_vertices = 0;
    size_t nan_values = 0;             // NaN or Inf components in any float attribute
    size_t indices_out_of_range = 0;
    size_t inconsistent_edges = 0;     // interior edges whose two faces traverse it in the same direction
    size_t valence2_interior_vertices = 0;
    long long self_intersections = -1; // intersecting face pairs, -1 = not computed
    bool closed = false;               // no boundary edges and at least one face
    bool has_uv = false;
    std::array<float, 2> uv_min{0, 0}, uv_max{0, 0};
    std::array<double, 3> bbox_min{0, 0, 0}, bbox_max{0, 0, 0};
    double diagonal = 0;
};

// Checks one primitive (object space). Never fails on bad data: bad data is what it reports.
CheckReport check_primitive(const Primitive& primitive, const CheckOptions& options = {});
// Sums per-primitive reports (bbox united, closed = all closed, self_intersections summed if computed).
CheckReport merge_reports(const std::vector<CheckReport>& reports);

} // namespace furrow

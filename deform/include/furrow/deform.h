// furrow::deform — deformable snow: colliders raycast to the ground, footprints stamped into a heightmap
// (min-composited, swept along their paths, with a rim and refill), and the ground tessellated where the
// heightmap has detail and displaced along its normals.
//
// Three levels of use:
//   - one call for a whole scene (what `furrow stamp` and `furrow demo` do):
//         furrow::Scene ground;       furrow::load_scene(ground, "models/ground.glb");
//         furrow::ColliderSet set;    furrow::load_colliders(set, "models/colliders.json");
//         furrow::StampOptions o;     o.snow.rim_width = 0.08;
//         furrow::StampReport r;
//         furrow::Status s = furrow::stamp_scene(ground, set, o, &r); // ground is now stamped and displaced
//     or furrow::stamp_files(scene, "models/ground.glb", "models/colliders.json") for the same with defaults;
//   - a SnowField for a game loop: stamp colliders as they move, take the dirty texel rectangle each frame;
//   - a DisplacedGround that re-displaces only the vertices under that rectangle (and renormalises their
//     neighbourhood) in the caller's own vertex buffers.
//
// Conventions. `up` comes from the colliders file (default +y). The heightmap lies in the plane normal to up:
// texel (i, j) sits at frame.origin + i·texel·axis_u + j·texel·axis_v (for up = +y: axis_u = +x, axis_v = +z);
// its value is an offset along up in metres, negative where snow was pressed down, positive on a rim, so
// "deeper wins" is a plain min. Displacement moves a ground point p to p + n·value (n = the undeformed
// ground's welded vertex normal; DisplaceOptions::along_up moves along up instead), i.e. p −= n·depth.
//
// ---------------------------------------------------------------------------------------------------------
// Colliders file (JSON). Keys starting with '_' are ignored anywhere (comments, extras); any other unknown key
// is an error, so a misspelt "radious" is not silently a default.
//   {
//     "up": [0, 1, 0],                          optional, default [0, 1, 0]; any non-zero vector
//     "colliders": [                            required (may be empty)
//       {"shape": "sphere",  "radius": r, "path": [[x, y, z], ...]},
//       {"shape": "box",     "size": [sx, sy, sz], "path": [...]},
//       {"shape": "capsule", "radius": r, "length": l, "path": [...]},
//       {"shape": "image",   "image": "foot.png", "size": [sx, sz], "depth": d, "path": [...]}
//     ]
//   }
// Per collider:
//   shape    "sphere" | "box" | "capsule" | "image"
//   path     [[x, y, z], ...], at least one point: the collider's centre over time (world units, metres)
//   heading  optional: one number, or an array with one number per path point (or a single one for all):
//            degrees about up, 0 = toward axis_v (+z), 90 = toward axis_u (+x), i.e. atan2(dx, dz) of the
//            walking direction. Without it, box, capsule and image follow the path direction (the horizontal
//            direction from the previous to the next point; 0 for a one-point path).
//   time     optional: seconds >= 0, one per path point, non-decreasing. Without it every point is at time 0.
//            Points later than the evaluation time (StampOptions::time) are not stamped yet; refill relaxes
//            older stamps (SnowOptions::refill_rate).
//   name     optional string (used in messages)
//   sphere:  radius > 0.
//   box:     size [sx, sy, sz] > 0: sx across (local x), sy up, sz along the heading (local z). The box stays
//            upright (turned about up only); its bottom face presses the snow.
//   capsule: radius > 0, length >= 0 = distance between the centres of its two end caps; optional "axis"
//            [x, y, z] in the collider's frame (x across the heading, y up, z along it), default [1, 0, 0]:
//            lying across its path, like a dragged log.
//   image:   image = a PNG (8 or 16-bit; grey, or the red channel) relative to the JSON file's folder; size
//            [sx, sz] > 0 is the print's extent across and along the heading; depth > 0. Pixel value v in
//            [0, 1] (white = deepest) presses v × penetration below the local snow surface, where the
//            penetration is depth when the centre sits on the surface (ground height − (centre − depth) in
//            general). The top row (toe) points along the heading; seen from above with the heading up the
//            page, the print is the image unmirrored.
// Sizes, radii, depths must be finite and positive (length >= 0); positions finite. Errors name the
// offending member, e.g. "colliders[3].radius: must be a finite number > 0, got -0.5".
// ---------------------------------------------------------------------------------------------------------
#pragma once

#include <furrow/mesh.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace furrow {

// ---------------------------------------------------------------------------------------------------------
// Colliders
// ---------------------------------------------------------------------------------------------------------
enum class ColliderShape : int { sphere = 0, box, capsule, image };

struct Collider {
    ColliderShape shape = ColliderShape::sphere;
    std::string name;                      // for messages; "colliders[i]" when the file gives none
    double radius = 0.0;                   // sphere, capsule
    double length = 0.0;                   // capsule: distance between the cap centres
    std::array<double, 3> size{0, 0, 0};   // box: sx, sy, sz; image: sx (across), sz (along) in [0], [1]
    double depth = 0.0;                    // image: imprint depth at pixel value 1
    double falloff = 0.0;                  // sphere, box, capsule: width (metres) over which the imprint's
                                           // edge slopes back up to the snow surface, a soft brush: the
                                           // imprint h becomes min over p of h(p)·w(|q − p| / falloff),
                                           // w(x) = 1 − 3x² + 2x³ (smoothstep falling from 1 to 0);
                                           // 0 = the sharp edge of the solid
    std::array<double, 3> axis{1, 0, 0};   // capsule: axis in the collider frame (x across, y up, z along)
    std::shared_ptr<const ImageF> brush;   // image: decoded PNG (channel 0 is used), row 0 = toe
    std::string image_path;                // image: as resolved (informational)
    std::vector<std::array<double, 3>> path; // centre per sample, world space
    std::vector<double> heading;           // degrees per sample, 1 value for all, or empty = path direction
    std::vector<double> time;              // seconds per sample, or empty = all at 0
};

struct ColliderSet {
    std::array<double, 3> up{0, 1, 0};
    std::vector<Collider> colliders;
};

// Parses and validates a colliders document; images are loaded relative to base_dir. Errors: invalid_input
// (malformed JSON, unknown shape or key, bad values, unreadable image) with a message naming the member.
Status parse_colliders(ColliderSet& out, const std::string& json_text, const std::string& base_dir = ".");
Status load_colliders(ColliderSet& out, const std::string& path);

// ---------------------------------------------------------------------------------------------------------
// Heightmap
// ---------------------------------------------------------------------------------------------------------
struct HeightmapFrame {
    std::array<double, 3> origin{0, 0, 0}; // world position of texel (0, 0), at height 0 along up
    std::array<double, 3> axis_u{1, 0, 0}; // unit, columns (i)
    std::array<double, 3> axis_v{0, 0, 1}; // unit, rows (j); axis_v = axis_u × up
    std::array<double, 3> up{0, 1, 0};     // unit
    double texel = 0.0;                    // metres between neighbouring texel centres
    int width = 0, height = 0;             // texels along axis_u, axis_v

    // Texel coordinates (continuous, texel (i, j) at (i, j)) and height along up of a world point.
    std::array<double, 3> to_texel(const double* world) const;
};

// Half-open texel rectangle [x0, x1) × [y0, y1).
struct TexelRect {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    bool empty() const { return x1 <= x0 || y1 <= y0; }
    void unite(const TexelRect& o);
};

struct Heightmap {
    HeightmapFrame frame;
    std::vector<float> values; // width × height, row j = axis_v index, metres along up (negative = down)

    float at(int i, int j) const { return values[size_t(j) * size_t(frame.width) + size_t(i)]; }
    // Bilinear in texel coordinates, 0 outside the grid (the snow there is untouched).
    double sample(double ti, double tj) const;
    // Bilinear at the projection of a world point.
    double sample_world(const double* world) const;
};

// Files: ".pfm" (float32, Portable Float Map, bottom row first = row height-1; furrow appends one line
// "# furrow-heightmap {json}" after the raster with the frame, which plain PFM readers ignore) or ".png"
// (16-bit grey, row 0 at the top, a tEXt chunk "furrow-heightmap" holding the frame and the scale:
// value = offset + scale × sample / 65535). Both are written atomically (temp file + rename).
Status save_heightmap(const Heightmap& heightmap, const std::string& path);
// Loads either format. A PFM without the furrow line gets an empty frame (width/height only, texel 0): it
// is then stretched over whatever grid it is applied to (SnowField::set_base); saved, such a map records
// texel 0 and loads back frame-less. A PNG must carry its scale.
Status load_heightmap(Heightmap& out, const std::string& path);

// ---------------------------------------------------------------------------------------------------------
// SnowField: the stamping state for a game loop or a batch run.
// ---------------------------------------------------------------------------------------------------------
struct SnowOptions {
    std::array<double, 3> up{0, 1, 0};
    double texel = 0.0;          // metres per texel; 0 = from resolution
    int resolution = 1024;       // with texel = 0: texels along the longer side of the ground's extent
    double snow_depth = 0.0;     // no imprint deeper than this (metres); 0 = unlimited
    double rim_width = 0.0;      // metres the rim reaches beyond an imprint; 0 = no rim
    double rim_height = 0.5;     // cosmetic rim (conserve_volume off): fraction of the nearby depth raised
    bool conserve_volume = false; // rim volume = removed volume × (1 − compaction), exactly (needs rim_width,
                                  // which defaults to 8 texels when 0)
    double compaction = 0.3;     // with conserve_volume: fraction of the removed snow compacted, not raised
    double rim_max_height = 1.0; // with conserve_volume: a rim never rises above this × the depth of the
                                 // print it comes from (the deepest imprint nearby; 0 = no limit)...
    double repose_degrees = 40;  // ... nor slopes steeper than the snow's angle of repose (0 or 90 = no
                                 // limit). Where the rim width would break either, the rim widens (up to 4 ×
                                 // the largest collider's half-width beyond rim_width) before it rises
    double refill_rate = 0.0;    // 1/s: a stamp of age a keeps exp(−rate·a) of its depth (and rim)
    double margin = 0.0;         // metres added around the ground's extent
    size_t max_bytes = size_t(1) << 30; // memory guard: refuse a heightmap whose layers need more
};

// The pose of a collider at one sample (what a path point becomes).
struct ColliderPose {
    std::array<double, 3> centre{0, 0, 0};
    double heading_degrees = 0.0;
    double time = 0.0;
};

struct StampStats {
    size_t samples = 0;      // path samples considered (at or before the current time)
    size_t contacts = 0;     // samples whose penetration was > 0
    size_t rays = 0;         // contact ray casts
    size_t missed_rays = 0;  // rays that found no ground below the collider
    size_t stamps = 0;       // shapes or sweeps rasterised
    size_t texels_written = 0; // texel writes that deepened the imprint
    double deepest = 0.0;    // deepest penetration found by a contact ray (metres)
};

// One stamp of a batch (SnowField::stamp over many): `shape` at `pose`, swept from `*previous` where that is set.
struct StampRequest {
    const Collider* shape = nullptr;
    ColliderPose pose;
    const ColliderPose* previous = nullptr;
};

// What one SnowField::update() did, for a frame budget.
struct SnowUpdateStats {
    double rim_seconds = 0;    // recomputing the rim
    double output_seconds = 0; // output = carve + rim over the changed tiles
    size_t rim_texels = 0;     // texels whose rim was recomputed (written)
    size_t rim_windows = 0;    // rim computations (each reads its texels' reach around them)
};

class SnowField {
public:
    SnowField();
    ~SnowField();
    SnowField(SnowField&&) noexcept;
    SnowField& operator=(SnowField&&) noexcept;

    // The ground: world-space triangles. Builds the grid over their extent in the plane normal to up, the
    // undeformed ground height per texel (the highest surface, what a ray from above sees) and the ray-cast
    // tree. Errors: invalid_argument (options), invalid_input (no triangles, NaN), out_of_memory (guard).
    Status create(const float* positions, size_t vertex_count, const uint32_t* indices, size_t index_count,
                  const SnowOptions& options);

    // A starting heightmap (a previous run's output): resampled onto this grid (a frame-less PFM is
    // stretched over it). New stamps are composited with min; the rim only counts what they remove.
    Status set_base(const Heightmap& base);

    // Stamps every sample of a collider with time <= now(), sweeping the shape between consecutive samples;
    // the segment that crosses now() is swept up to it.
    Status add_collider(const Collider& collider, StampStats* stats = nullptr);
    Status add_colliders(const ColliderSet& set, StampStats* stats = nullptr);
    // Runtime: one sample of `shape` (its path, heading and time are ignored), or with `previous` the sweep
    // from previous to pose. Cheap enough to call per collider per frame.
    Status stamp(const Collider& shape, const ColliderPose& pose, const ColliderPose* previous = nullptr,
                 StampStats* stats = nullptr);
    // A frame's stamps in one call (every walker of a crowd): the field is byte for byte the one that calling
    // stamp() for each request in turn leaves, while their contact rays and rasterisation share the threads.
    // Stats are summed (texels_written counts the writes that deepened a texel when they landed, which
    // depends on the order overlapping stamps land in). Errors: invalid_argument (a null shape, or null requests
    // with count > 0), invalid_input (an image collider without a decoded brush); nothing is stamped then.
    Status stamp(const StampRequest* requests, size_t count, StampStats* stats = nullptr);

    // Refill: moves the field's clock to `time` (seconds); with refill_rate > 0 every value decays by
    // exp(−rate·(time − now())). Earlier times are ignored.
    void set_time(double time);
    double now() const;

    // Brings the rim and the output heightmap up to date and returns where the output changed since the last
    // call: disjoint rectangles (empty when nothing changed), so that colliders far apart do not dirty
    // everything between them. Within each 16-texel tile they cover the bounding box of the texels that
    // changed (deepened, or whose rim changed in bits; refill dirties whole tiles), boxes that meet merged.
    // The rim is recomputed over the stamped tiles grown by the rim's reach. A cosmetic rim is local: each
    // texel depends only on the carve within its reach, summed exactly, so incremental updates give the same
    // bytes as one update after the same stamps (without refill,
    // whose decay scales the rim as it is). With conserve_volume each region balances its own removed and
    // raised volume, so a one-shot update is exact and incremental updates keep every recomputed region exact.
    std::vector<TexelRect> update(SnowUpdateStats* stats = nullptr);
    // The output (imprint + rim), as of the last update().
    const Heightmap& heightmap() const;
    // Undeformed ground height per texel (NaN where no ground lies below), same frame.
    const Heightmap& ground() const;
    const HeightmapFrame& frame() const;

    double removed_volume() const; // m³ pressed down relative to the base, as of the last update()
    double raised_volume() const;  // m³ in the rim
    size_t overhang_triangles() const; // ground triangles facing away from up (overhangs, undersides)
    // Ray casts straight down (−up) from each of `count` world points (xyz); writes the hit height along up
    // or NaN. The contact query, exposed for benchmarks and games.
    void cast_down(double* heights_out, const double* points, size_t count) const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

// ---------------------------------------------------------------------------------------------------------
// DisplacedGround: a fixed ground mesh displaced by a heightmap, re-displaced incrementally.
// ---------------------------------------------------------------------------------------------------------
struct DisplaceOptions {
    bool along_up = false;   // move along up instead of the undeformed vertex normal
    bool top_only = false;   // leave vertices below the top surface alone (grounds with overhangs)
    double top_tolerance = 0.0; // with top_only: metres below the top surface still counted as top; 0 = 2 texels
    bool keep_face_terms = true; // keep each triangle's normal terms (48 bytes a triangle), computed by the first
                                 // update() (or a displace_all() on more than one thread), so that an update redoes
                                 // only the faces it moves; false for a one-shot displace_all (no room kept for them,
                                 // the same bits; an update() after a displace_all() computes them all again)
};

// What one DisplacedGround::update() did and where its time went (`furrow bench stamp` section 4 prints it per
// moved point). The counts say how much work a moved point brings; the phases are wall-clock seconds.
struct DisplaceUpdateStats {
    size_t moved = 0;              // welded points under the dirty rectangles (update()'s result)
    size_t shifted = 0;            // of those, the points whose position changed in bits
    size_t faces = 0;              // faces whose terms were recomputed: those around the shifted points
    size_t normals = 0;            // points renormalised and written: the corners of those faces
    double search_seconds = 0;     // finding the points under the rectangles
    double displace_seconds = 0;   // re-displacing them (on one thread, marking around each shifted one too)
    double sweep_seconds = 0;      // finding the faces and points to recompute (on one thread, listing the marks)
    double terms_seconds = 0;      // the faces' terms
    double normals_seconds = 0;    // the points' normals, and writing every copy of each
};

class DisplacedGround {
public:
    DisplacedGround();
    ~DisplacedGround();
    DisplacedGround(DisplacedGround&&) noexcept;
    DisplacedGround& operator=(DisplacedGround&&) noexcept;

    // World-space triangles of the (tessellated) ground, undeformed. Welds by exact position and computes the
    // undeformed normals. The update's indexes (faces per point, points per texel tile) and face terms are built
    // by the first update() (or a displace_all() on more than one thread): a one-shot displacement does not need them. `ground` (SnowField::ground()) is needed only
    // for top_only. Errors: an empty frame (invalid_argument); indices that are not triangles or out of range,
    // a NaN or infinite position (invalid_input).
    Status prepare(const float* positions, size_t vertex_count, const uint32_t* indices, size_t index_count,
                   const HeightmapFrame& frame, const DisplaceOptions& options = {}, const Heightmap* ground = nullptr);

    // Displaces every vertex by `heightmap` and writes all positions and normals (vertex_count × 3 floats
    // each). Returns the number of welded points.
    size_t displace_all(const Heightmap& heightmap, float* positions_out, float* normals_out);
    // Re-displaces only the points whose bilinear footprint meets a dirty rectangle and renormalises the points
    // of the faces around them (exactly those whose normal can change);
    // other entries of the buffers are not touched (they must hold a previous displace_all/update result).
    // Returns the number of welded points moved. The first call after prepare() builds the indexes (an update
    // with no rectangle builds them alone: an engine can do so at load time). `stats`, when given, receives
    // what this call did (the index building of a first call is not in its phases).
    size_t update(const Heightmap& heightmap, const std::vector<TexelRect>& dirty, float* positions_out, float* normals_out,
                  DisplaceUpdateStats* stats = nullptr);
    size_t update(const Heightmap& heightmap, const TexelRect& dirty, float* positions_out, float* normals_out);

    size_t vertex_count() const;
    size_t welded_count() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

// ---------------------------------------------------------------------------------------------------------
// Scene level: `furrow stamp`.
// ---------------------------------------------------------------------------------------------------------
struct StampCamera {
    std::array<double, 3> eye{0, 0, 0};
    double fov_degrees = 45.0;
    int viewport_height = 1080;
    double pixel_error = 1.0; // allowed screen-space error; the world error target grows with distance
};

struct StampOptions {
    SnowOptions snow;                     // snow.up is taken from the ColliderSet
    std::optional<double> time;           // evaluation time (s); default = the latest sample time
    double max_error = 0.0;               // allowed deviation of the displaced mesh from the heightmap
                                          // surface (metres); 0 = a quarter texel
    std::optional<StampCamera> camera;    // error target max(max_error, pixel_error × distance / focal length):
                                          // far imprints coarser, near ones as max_error asks
    bool tessellate = true;               // false: displace the ground's own vertices only
    int max_rate = 64;                    // segments per edge in each of the two tessellation passes, 1..4096
    size_t max_triangles = 0;             // > 0: tessellation rates scaled down to fit
    bool along_up = false;                // displacement direction (see DisplaceOptions)
    const Heightmap* base = nullptr;      // a starting heightmap (a previous run's output)
};

struct StampReport {
    StampStats stats;
    bool changed = false;          // false: nothing touched the ground; the scene was left as it was
    HeightmapFrame frame;
    double removed_volume = 0, raised_volume = 0; // m³
    double max_depth = 0, max_rim = 0;            // deepest imprint, highest rim (m)
    size_t meshes = 0, primitives = 0;            // deformed
    size_t triangles_in = 0, triangles_out = 0;
    size_t welded_points = 0, displaced_points = 0;
    size_t overhang_triangles = 0;
    double stamp_seconds = 0, tessellate_seconds = 0, displace_seconds = 0;
    std::vector<std::string> warnings;
};

// Stamps `colliders` into a heightmap over the scene's triangles (world space; every node that draws a mesh),
// tessellates the meshes where the heightmap has detail (furrow::tessellate, bilinear scheme: the ground's
// shape is kept), displaces them and recomputes normals on welded positions. Materials, nodes, UVs (and other
// attributes present on every primitive of a mesh) are kept; tangents are dropped (a warning says so); a mesh
// drawn by several nodes is copied per node. Skinned or morphed meshes are displaced without tessellation.
// When no collider touches the ground (and no base is given) the scene is left unchanged (report.changed =
// false). heightmap_out, if given, receives the output heightmap. A triangle index out of range or a NaN or
// infinite vertex position is an invalid_input error.
Status stamp_scene(Scene& scene, const ColliderSet& colliders, const StampOptions& options,
                   StampReport* report = nullptr, Heightmap* heightmap_out = nullptr);

// The demo's one-liner: loads the ground and the colliders file, stamps with `options`.
Status stamp_files(Scene& out, const std::string& ground_path, const std::string& colliders_path,
                   const StampOptions& options = {}, StampReport* report = nullptr);

// World-space triangles of every mesh node of a scene (the ground as stamp_scene sees it), as positions
// relative to `origin`: they are formed in double and rounded to float only after the origin is taken off,
// so a ground at 1e5..1e7 m keeps its precision when `origin` is near it (see ground_origin).
void scene_triangles(std::vector<float>& positions, std::vector<uint32_t>& indices, const Scene& scene,
                     const std::array<double, 3>& origin = {0, 0, 0});

// The origin stamp_scene works relative to: the centre of the ground's world bounding box when the ground
// lies further from the world origin than its own diagonal, else (0, 0, 0).
std::array<double, 3> ground_origin(const Scene& scene);

} // namespace furrow

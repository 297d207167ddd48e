// furrow::shapes — procedural meshes for tests, benchmarks and the sample assets in models/.
//
// Every function returns one furrow::Primitive (mode triangles, material -1) and is deterministic: the same
// arguments give the same bytes on every run and thread count. Vertex and face counts are part of the
// contract and stated per shape below (tests assert them). Conventions shared by all shapes:
//   - y is up; right-handed; faces are counter-clockwise seen from outside (glTF front faces);
//   - normals are unit length (analytic where the shape has a closed form);
//   - uv0 follows glTF (v = 0 at the top row of the image) and a texture appears unmirrored seen from
//     outside; every UV lies in [0,1];
//   - a UV seam is made of split vertices whose positions are bit-identical copies, so welding by exact
//     position (weld_positions with tolerance 0, or check_primitive) closes the shape;
//   - integer arguments below their minimum are raised to it, above their maximum lowered to it.
//     Sizes and radii are used as given (a negative size mirrors the shape and flips its winding).
#pragma once

#include <furrow/mesh.h>

#include <array>

namespace furrow::shapes {

// Latitude-longitude sphere of `radius` centred at the origin, poles on ±y.
// segments >= 3 (around y, max 16384), rings >= 2 (pole to pole, max 16384).
// Grid vertex (i, j), i = 0..segments, j = 1..rings-1: u = i/segments, v = j/rings, polar angle
// theta = pi*v from +y, azimuth phi = 2*pi*u; direction (-sin(theta)sin(phi), cos(theta), -sin(theta)cos(phi)),
// so the seam (u = 0 and u = 1, bit-identical copies) runs down the back (-z) and u grows counter-clockwise
// seen from +y. Each pole has one vertex per segment at u = (i + 0.5)/segments (v = 0 resp. 1), so pole
// triangles get an undistorted UV; all copies of a pole are bit-identical.
//   vertices  = (rings - 1) * (segments + 1) + 2 * segments
//   triangles = 2 * segments * (rings - 1)      (welded: (rings - 1) * segments + 2 vertices, closed)
// Order: top pole row, then rings 1..rings-1 (i fastest), then the bottom pole row; triangles ring by ring
// from the top.
Primitive uv_sphere(float radius, int segments, int rings);

// Geodesic sphere: a regular icosahedron whose triangles are split 4:1 `subdivisions` times (0..9), new
// vertices pushed to the sphere. Welded (no seam, every vertex unique), so uv0 is empty: it is the
// seam-free reference mesh with near-uniform triangles.
//   vertices  = 10 * 4^s + 2
//   triangles = 20 * 4^s
// The icosahedron is the one of A. Kahler, "Creating an icosphere mesh in code" (2009): 12 vertices
// (±1, ±t, 0), (0, ±1, ±t), (±t, 0, ±1), t = golden ratio; midpoints are shared per edge.
Primitive icosphere(float radius, int subdivisions);

// Flat rectangle in the XZ plane (y = 0, normal +y) centred at the origin, nx × nz cells (each 1..16384),
// every cell split into two triangles along the same diagonal.
// Vertex (i, j) = index j*(nx + 1) + i at x = size_x*(i/nx - 0.5), z = size_z*(j/nz - 0.5), uv = (i/nx, j/nz)
// (seen from above with -z at the top of the view, the image is upright and unmirrored).
//   vertices  = (nx + 1) * (nz + 1)
//   triangles = 2 * nx * nz   (cell (i, j) -> [a, b, c] and [a, c, d] with a = (i, j), b = (i, j+1),
//                              c = (i+1, j+1), d = (i+1, j); cells row by row, i fastest)
// Open: 2 * (nx + nz) boundary edges.
Primitive grid(float size_x, float size_z, int nx, int nz);

// The same vertices as grid() with one quad per cell kept as a polygon face: face_sizes = {4, 4, ...},
// corners [a, b, c, d] as above, so triangulate() turns it into exactly grid()'s triangles. The input shape
// for Catmull-Clark (all interior vertices of valence 4).
//   vertices = (nx + 1) * (nz + 1),  faces = nx * nz quads,  triangles = 2 * nx * nz
Primitive quad_grid(float size_x, float size_z, int nx, int nz);

// Axis-aligned box centred at the origin.
// split_faces = true (like Khronos' BoxTextured): 24 vertices, 4 per face, with the face normal and a full
//   [0,1]² UV per face, upright seen from outside (side faces: v = 0 at +y; top: v = 0 at -z; bottom:
//   v = 0 at +z). Faces in the order +x, -x, +y, -y, +z, -z; 12 triangles. Welded: 8 vertices, closed.
// split_faces = false: 8 welded corner vertices, corner i at (±x, ±y, ±z) with the sign of bit 0/1/2 of i
//   (set = +), normal = the normalised corner direction sign vector; no uv0 (a welded box has no UV
//   layout). 12 triangles, closed.
Primitive box(float size_x, float size_y, float size_z, bool split_faces = true);

// Ring torus around the y axis: tube centre circle of `major_radius` in the XZ plane, tube `minor_radius`.
// segments (around y) >= 3, sides (around the tube) >= 3, each at most 16384.
// Vertex (i, j) = index j*(segments + 1) + i: u = i/segments, v = j/sides, azimuth phi = 2*pi*u (seam at -z
// as for uv_sphere), tube angle psi = 2*pi*v from the outer equator going down, then inside, then over
// the top. Two seams (u = 0/1 and v = 0/1, bit-identical copies); analytic normals.
//   vertices  = (segments + 1) * (sides + 1)
//   triangles = 2 * segments * sides        (welded: segments * sides vertices, closed, genus 1)
Primitive torus(float major_radius, float minor_radius, int segments, int sides);

// ---------------------------------------------------------------------------------------------------------
// The creature: a round, plush-like quadruped (body, head, snout, nose, eyes, two ears, four splayed legs
// with paws, a tail) defined as a smooth union of implicit primitives (signed-distance functions after
// I. Quilez: spheres, approximate ellipsoids, round cones, polynomial smooth minimum). It is sampled
// radially from a centre inside the body on the uv_sphere() grid: vertex (u, v) sits where the ray from
// the centre in uv_sphere's direction for (u, v) leaves the surface for the last time. A radial graph is
// always an embedded closed surface, so the mesh is closed and manifold after welding for any resolution;
// the parts are placed along rays from the centre so that the surface is (nearly) star-shaped and the
// sampling is faithful. Normals are the normalised gradient of the implicit function (identical on all
// copies of a seam or pole vertex).
// Units are metres: it faces +z (left = +x), stands on y = 0 (paw soles within 1 mm of it), is 1.05 m tall to
// the ear tips, 1.26 m long from tail to nose and 0.72 m wide, symmetric about x = 0. UVs are uv_sphere's: seam down the back and under the belly (-z, through the
// tail), the face at u ~ 0.5, the back at small v.
//   vertices and triangles: as uv_sphere(…, segments, rings); defaults give 16128 triangles.
Primitive creature(int segments = 128, int rings = 64);

// The point that creature() places at uv (u, v) in [0,1]² and its unit normal: lets a generator paint a
// texture or a mask in the creature's UV space (texel centre -> surface point -> colour).
struct SurfacePoint {
    std::array<float, 3> position{0, 0, 0};
    std::array<float, 3> normal{0, 1, 0};
};
SurfacePoint creature_surface(float u, float v);

// Named feature points of the creature (object space, metres), for painting masks and textures.
struct CreatureLandmarks {
    std::array<float, 3> nose_tip;            // front-most point of the nose
    float nose_radius;
    std::array<float, 3> eye_left, eye_right; // eye centres on the head surface (left = +x side)
    float eye_radius;
    std::array<std::array<float, 3>, 4> paws; // paw centres: front left, front right, back left, back right
    float paw_radius;
    std::array<std::array<float, 3>, 2> ear_tips; // left, right
    std::array<float, 3> head_centre;
    float head_radius;
    std::array<float, 3> tail_centre;
    std::array<float, 3> centre; // the centre the surface is sampled from (inside the body)
};
const CreatureLandmarks& creature_landmarks();

} // namespace furrow::shapes

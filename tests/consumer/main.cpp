// Links furrow as an engine would, through find_package(furrow) against an installed copy, and calls every
// module once through its public header only: mesh (check, shapes, save), tessellate (plain arrays in,
// triangles out), shells (fur on a scene), deform (a SnowField stamped by a collider, a DisplacedGround
// re-displaced from it) and render (the furry scene drawn). Each step checks a property of its result, so a
// module that links but does nothing fails here. Argument: an output folder for the GLB (optional).
#include <furrow/deform.h>
#include <furrow/mesh.h>
#include <furrow/render.h>
#include <furrow/shapes.h>
#include <furrow/shells.h>
#include <furrow/tessellate.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace {

int fail(const char* step, const std::string& what) {
    std::fprintf(stderr, "consumer: %s: %s\n", step, what.c_str());
    return 1;
}

// mesh: a triangle's check report.
int check_a_triangle() {
    furrow::Primitive tri;
    tri.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    tri.indices = {0, 1, 2};
    furrow::CheckReport r = furrow::check_primitive(tri);
    if (r.triangles != 1 || r.boundary_edges != 3) return fail("check_primitive", "unexpected report");
    return 0;
}

// tessellate: a 2 × 2 quad grid (Catmull-Clark's own input) at uniform rate 4: each quad becomes 4 × 4 quads,
// 2 triangles each, and the flat cage stays flat and inside its square.
int tessellate_a_quad_grid() {
    furrow::Primitive cage = furrow::shapes::quad_grid(1, 1, 2, 2);
    furrow::TessellateInput in;
    in.positions = cage.positions.data();
    in.vertex_count = cage.vertex_count();
    in.indices = cage.indices.data();
    in.index_count = cage.indices.size();
    in.face_sizes = cage.face_sizes.data();
    in.face_count = cage.face_sizes.size();
    furrow::TessellateOptions o;
    o.rates.uniform = 4;
    furrow::TessellateOutput out;
    if (furrow::Status s = furrow::tessellate(out, in, o); !s.ok()) return fail("tessellate", s.message);
    if (out.indices.size() != 4 * 4 * 4 * 2 * 3) return fail("tessellate", std::to_string(out.indices.size() / 3) + " triangles");
    for (size_t v = 0; v < out.positions.size() / 3; ++v)
        if (!(std::abs(out.positions[3 * v + 1]) < 1e-6f) || !(std::abs(out.positions[3 * v]) < 0.5f + 1e-6f) ||
            !(std::abs(out.positions[3 * v + 2]) < 0.5f + 1e-6f))
            return fail("tessellate", "a point off the square");
    return 0;
}

// shells + render + save: fur on a sphere, drawn and written.
int fur_on_a_sphere(const char* folder) {
    furrow::Scene scene = furrow::make_scene(furrow::shapes::uv_sphere(1.0f, 32, 16), "sphere");
    furrow::FurOptions fo;
    fo.shells.layers = 8;
    fo.shells.length = 0.2;
    furrow::FurReport fr;
    if (furrow::Status s = furrow::add_fur_shells(scene, fo, &fr); !s.ok()) return fail("add_fur_shells", s.message);
    if (fr.primitives != 1 || fr.shell_triangles < 8 * fr.base_triangles / 2)
        return fail("add_fur_shells", "fewer shell triangles than layers × base");

    furrow::RenderOptions ro;
    ro.width = 96;
    ro.height = 72;
    furrow::RenderResult rr;
    if (furrow::Status s = furrow::render_scene(rr, scene, ro); !s.ok()) return fail("render_scene", s.message);
    const size_t covered = furrow::mask_area(furrow::silhouette_mask(rr.color));
    if (covered < 96 * 72 / 10 || covered == size_t(96 * 72)) return fail("render_scene", "no silhouette in the frame");

    if (folder) {
        const std::string path = std::string(folder) + "/furry_sphere.glb";
        if (furrow::Status s = furrow::save_scene(scene, path); !s.ok()) return fail(path.c_str(), s.message);
    }
    return 0;
}

// deform: a sphere pressed into a 4 m flat ground, then the ground displaced by the result.
int snow_on_a_grid() {
    furrow::Primitive g = furrow::shapes::grid(4, 4, 32, 32);
    furrow::SnowOptions so;
    so.resolution = 128;
    furrow::SnowField field;
    if (furrow::Status s = field.create(g.positions.data(), g.vertex_count(), g.indices.data(), g.indices.size(), so); !s.ok())
        return fail("SnowField::create", s.message);
    furrow::Collider ball;
    ball.shape = furrow::ColliderShape::sphere;
    ball.radius = 0.5;
    furrow::ColliderPose pose;
    pose.centre = {0, 0.3, 0}; // 0.2 m into the snow
    if (furrow::Status s = field.stamp(ball, pose); !s.ok()) return fail("SnowField::stamp", s.message);
    furrow::ColliderPose later = pose;
    later.centre[0] = 1;
    const furrow::StampRequest crowd[] = {{&ball, later, &pose}}; // a frame's walkers in one call
    if (furrow::Status s = field.stamp(crowd, 1); !s.ok()) return fail("SnowField::stamp (batch)", s.message);
    const std::vector<furrow::TexelRect> dirty = field.update();
    if (dirty.empty() || !(field.removed_volume() > 0)) return fail("SnowField::update", "nothing was pressed");

    furrow::DisplacedGround ground;
    if (furrow::Status s = ground.prepare(g.positions.data(), g.vertex_count(), g.indices.data(), g.indices.size(), field.frame());
        !s.ok())
        return fail("DisplacedGround::prepare", s.message);
    std::vector<float> positions(3 * g.vertex_count()), normals(3 * g.vertex_count());
    ground.displace_all(field.heightmap(), positions.data(), normals.data());
    float lowest = 0;
    for (size_t v = 0; v < g.vertex_count(); ++v) lowest = std::min(lowest, positions[3 * v + 1]);
    if (!(lowest < -0.1f && lowest > -0.21f)) return fail("DisplacedGround::displace_all", "the print is not 0.2 m deep");
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    if (int e = check_a_triangle()) return e;
    if (int e = tessellate_a_quad_grid()) return e;
    if (int e = fur_on_a_sphere(argc > 1 ? argv[1] : nullptr)) return e;
    if (int e = snow_on_a_grid()) return e;
    std::printf("consumer ok\n");
    return 0;
}

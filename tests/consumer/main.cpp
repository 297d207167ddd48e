// Links furrow as an engine would: builds a mesh in plain arrays, checks it, writes a GLB.
#include <furrow/deform.h>
#include <furrow/mesh.h>
#include <furrow/shells.h>
#include <furrow/tessellate.h>

#include <cstdio>

int main(int argc, char** argv) {
    furrow::Primitive tri;
    tri.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    tri.indices = {0, 1, 2};
    furrow::CheckReport r = furrow::check_primitive(tri);
    if (r.triangles != 1 || r.boundary_edges != 3) {
        std::fprintf(stderr, "unexpected check report\n");
        return 1;
    }
    if (argc > 1) {
        furrow::Status s = furrow::save_scene(furrow::make_scene(tri, "triangle"), argv[1]);
        if (!s.ok()) {
            std::fprintf(stderr, "Error: %s: %s\n", argv[1], s.message.c_str());
            return 1;
        }
    }
    std::printf("consumer ok\n");
    return 0;
}

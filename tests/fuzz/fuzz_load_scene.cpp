// Fuzz target: every mesh loader behind load_scene_from_memory (glTF JSON and GLB through tinygltf and our
// accessor decoding; OBJ/PLY/OFF through OpenMesh's readers; STL our own), then the checks and the writer on
// whatever loaded.
//
// Input: byte 0 picks the format (value mod 6: .glb .gltf .obj .ply .off .stl); its bit 3 sets
// allow_non_finite, bit 4 clears recentre. The rest is the file.
// Properties: a load either fails with a Status or gives a consistent scene (fuzz::check_scene);
// check_primitive never fails; a loaded finite scene saves as .glb (or refuses with a Status) and what was
// saved loads again with the same meshes and vertex counts.
#include "fuzz_common.h"

#include <cstdio>

using namespace furrow;

namespace {
const char* const kExtensions[] = {".glb", ".gltf", ".obj", ".ply", ".off", ".stl"};
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1 || size > 256 * 1024) return 0; // bigger inputs only slow the search down
    const uint8_t mode = data[0];
    LoadOptions lo;
    lo.allow_non_finite = mode & 0x08;
    lo.recentre = !(mode & 0x10);
    Scene scene;
    Status s = load_scene_from_memory(scene, data + 1, size - 1, kExtensions[mode % 6], lo);
    if (!s.ok()) {
        fuzz::rejected("load_scene_from_memory", s);
        return 0;
    }
    fuzz::check_scene(scene, lo.allow_non_finite);

    size_t triangles = 0;
    for (const Mesh& m : scene.meshes)
        for (const Primitive& p : m.primitives) triangles += p.mode == PrimitiveMode::triangles ? p.triangle_count() : 0;
    if (triangles <= 20000)
        for (const Mesh& m : scene.meshes)
            for (const Primitive& p : m.primitives) {
                CheckReport r = check_primitive(p);
                FUZZ_CHECK(r.vertices == p.vertex_count(), "check_primitive counted %zu vertices of %zu", r.vertices,
                           p.vertex_count());
                FUZZ_CHECK(r.indices_out_of_range == 0, "check_primitive found %zu indices out of range after a load",
                           r.indices_out_of_range);
            }

    if (lo.allow_non_finite) return 0; // the writer refuses NaN positions, by design
    const std::string path = fuzz::scratch_path("load_scene.glb");
    Status w = save_scene(scene, path);
    if (!w.ok()) {
        std::remove(path.c_str());
        fuzz::rejected("save_scene", w);
        return 0;
    }
    Scene again;
    LoadOptions keep;
    keep.recentre = false; // compare like with like: the first load already recentred
    Status r = load_scene(again, path, keep);
    std::remove(path.c_str());
    FUZZ_CHECK(r.ok(), "a scene furrow saved does not load again: %s", r.message.c_str());
    fuzz::check_scene(again, false);
    FUZZ_CHECK(again.meshes.size() == scene.meshes.size(), "%zu meshes saved, %zu loaded", scene.meshes.size(),
               again.meshes.size());
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        FUZZ_CHECK(again.meshes[m].primitives.size() == scene.meshes[m].primitives.size(), "mesh %zu: primitive count", m);
        for (size_t p = 0; p < scene.meshes[m].primitives.size(); ++p)
            FUZZ_CHECK(again.meshes[m].primitives[p].vertex_count() == scene.meshes[m].primitives[p].vertex_count(),
                       "mesh %zu primitive %zu: %zu vertices saved, %zu loaded", m, p,
                       scene.meshes[m].primitives[p].vertex_count(), again.meshes[m].primitives[p].vertex_count());
    }
    return 0;
}

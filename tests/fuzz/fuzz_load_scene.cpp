// Fuzz target: every mesh loader behind load_scene_from_memory (glTF JSON and GLB through tinygltf and our
// accessor decoding; PLY (ASCII and binary), OBJ, OFF and STL our own), then the checks and the writer on
// whatever loaded.
//
// Input: byte 0 picks the format (value mod 6: .glb .gltf .obj .ply .off .stl); its bit 3 sets
// allow_non_finite, bit 4 clears recentre. The rest is the file. With bit 5 set, the file is a .glb (bit 0
// clear) or .gltf (bit 0 set) written into a scratch resource root and loaded from there with load_scene and
// its default, confined resolver (README "Threat model"): the root holds data.bin (a triangle's 36 bytes),
// tex.png, link.png and link.bin (symbolic links out of the root); outside it lie secret.png and
// secret.bin. Property: nothing of the secrets reaches the scene.
// Properties: a load either fails with a Status or gives a consistent scene (fuzz::check_scene);
// check_primitive never fails; a loaded finite scene saves as .glb (or refuses with a Status) and what was
// saved loads again with the same meshes and vertex counts.
#include "fuzz_common.h"

#include <cstdio>
#include <filesystem>

using namespace furrow;

namespace {
const char* const kExtensions[] = {".glb", ".gltf", ".obj", ".ply", ".off", ".stl"};

constexpr float kSecretValue = 7777.25f; // every float of secret.bin; no resource inside the root holds it

std::vector<uint8_t> png_1x1(uint8_t r, uint8_t g, uint8_t b) {
    const uint8_t rgba[4] = {r, g, b, 255};
    return encode_png_rgba8(rgba, 1, 1);
}

void write_file(const std::string& path, const std::vector<uint8_t>& bytes) {
    FILE* f = std::fopen(path.c_str(), "wb");
    FUZZ_CHECK(f != nullptr, "cannot write %s", path.c_str());
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
}

// The scratch folders (made once per process): <scratch>/root/ is the resource root, the secrets beside it.
std::string resource_root() {
    static const std::string root = [] {
        const std::string top = fuzz::scratch_path("resources");
        std::filesystem::create_directories(top + "/root");
        const float tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
        write_file(top + "/root/data.bin", std::vector<uint8_t>(reinterpret_cast<const uint8_t*>(tri),
                                                                reinterpret_cast<const uint8_t*>(tri) + sizeof(tri)));
        write_file(top + "/root/tex.png", png_1x1(10, 20, 30));
        const std::vector<float> secret(9, kSecretValue);
        write_file(top + "/secret.bin", std::vector<uint8_t>(reinterpret_cast<const uint8_t*>(secret.data()),
                                                             reinterpret_cast<const uint8_t*>(secret.data()) + 36));
        write_file(top + "/secret.png", png_1x1(200, 100, 50));
        std::error_code ec;
        std::filesystem::create_symlink("../secret.png", top + "/root/link.png", ec);
        std::filesystem::create_symlink("../secret.bin", top + "/root/link.bin", ec);
        return top + "/root";
    }();
    return root;
}

Status load_from_root(Scene& scene, const uint8_t* data, size_t size, bool gltf, const LoadOptions& lo) {
    const std::string path = resource_root() + (gltf ? "/in.gltf" : "/in.glb");
    write_file(path, std::vector<uint8_t>(data, data + size));
    Status s = load_scene(scene, path, lo);
    std::remove(path.c_str());
    static const std::vector<uint8_t> secret_png = png_1x1(200, 100, 50);
    for (const Image& im : scene.images) FUZZ_CHECK(im.encoded != secret_png, "an image outside the resource root was read");
    for (const Mesh& m : scene.meshes)
        for (const Primitive& p : m.primitives)
            for (float x : p.positions) FUZZ_CHECK(x != kSecretValue, "a buffer outside the resource root was read");
    for (const Node& n : scene.nodes) // recentring moves a constant triangle into its node
        for (double t : n.translation) FUZZ_CHECK(float(t) != kSecretValue, "a buffer outside the resource root was read");
    return s;
}
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1 || size > 256 * 1024) return 0; // bigger inputs only slow the search down
    const uint8_t mode = data[0];
    LoadOptions lo;
    lo.allow_non_finite = mode & 0x08;
    lo.recentre = !(mode & 0x10);
    Scene scene;
    Status s = mode & 0x20 ? load_from_root(scene, data + 1, size - 1, mode & 1, lo)
                           : load_scene_from_memory(scene, data + 1, size - 1, kExtensions[mode % 6], lo);
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

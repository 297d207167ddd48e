// models/: the committed sample assets are exactly what the generator makes (regenerated here into a temp
// folder and compared byte for byte), each is under 1 MB, loads, and is what the demo and the issues expect
// (closed textured creature with a fur mask that has zero regions, terrain patch, boot-print brush, colliders
// placed on the ground).
//
// The generator's code is models/generators.h, included here so that the test runs the very functions that
// models/generate_models.cpp runs, in-process, whatever the build layout.
#include "../../models/generators.h"

#include "test_support.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>

using namespace furrow;
namespace fs = std::filesystem;
using furrow::test::models_dir;

namespace {

// Bilinear-free lookup: the texel under a UV (clamped), as a shader with nearest filtering would.
float texel(const ImageF& img, float u, float v, int channel = 0) {
    int x = std::clamp(int(u * float(img.width)), 0, img.width - 1);
    int y = std::clamp(int(v * float(img.height)), 0, img.height - 1);
    return img.pixels[(size_t(y) * size_t(img.width) + size_t(x)) * size_t(img.channels) + size_t(channel)];
}

// Height of the ground mesh under (x, z): the grid cell's triangle, interpolated, exactly as drawn
// (cells split along the (i, j)-(i+1, j+1) diagonal as shapes::grid documents).
double mesh_height(const Primitive& g, int cells, double size, double x, double z) {
    double fx = (x / size + 0.5) * cells, fz = (z / size + 0.5) * cells;
    int i = std::clamp(int(std::floor(fx)), 0, cells - 1), j = std::clamp(int(std::floor(fz)), 0, cells - 1);
    fx -= i, fz -= j;
    auto h = [&](int a, int b) { return double(g.positions[(size_t(b) * size_t(cells + 1) + size_t(a)) * 3 + 1]); };
    double ha = h(i, j), hb = h(i, j + 1), hc = h(i + 1, j + 1), hd = h(i + 1, j);
    return fz >= fx ? ha + fz * (hb - ha) + fx * (hc - hb) : ha + fx * (hd - ha) + fz * (hc - hd);
}

} // namespace

TEST(models, GeneratorReproducesCommittedFilesByteIdentically) {
    const fs::path dir = furrow::test::temp_dir();
    Status st = models::generate_all(dir);
    ASSERT_TRUE(st.ok()) << st.message;
    for (const std::string& name : models::model_files()) {
        SCOPED_TRACE(name);
        ASSERT_TRUE(fs::exists(models_dir() / name)) << "not committed: models/" << name;
        std::vector<uint8_t> fresh = furrow::test::read_bytes(dir / name);
        std::vector<uint8_t> committed = furrow::test::read_bytes(models_dir() / name);
        size_t first_difference = 0;
        while (first_difference < std::min(fresh.size(), committed.size()) &&
               fresh[first_difference] == committed[first_difference])
            ++first_difference;
        EXPECT_TRUE(fresh == committed)
            << "models/" << name << " differs from the generator's output (" << committed.size() << " vs "
            << fresh.size() << " bytes, first difference at byte " << first_difference
            << "); if the change is intended, regenerate: see models/README.md";
    }
}

TEST(models, EveryFileUnderOneMegabyte) {
    for (const std::string& name : models::model_files()) {
        ASSERT_TRUE(fs::exists(models_dir() / name)) << name;
        EXPECT_LT(fs::file_size(models_dir() / name), 1000000u) << name;
    }
}

TEST(models, ReadmeMentionsEveryAsset) {
    std::vector<uint8_t> bytes = furrow::test::read_bytes(models_dir() / "README.md");
    std::string readme(bytes.begin(), bytes.end());
    for (const std::string& name : models::model_files()) EXPECT_NE(readme.find(name), std::string::npos) << name;
}

TEST(models, CreatureIsClosedTexturedAndValid) {
    Scene scene;
    Status st = load_scene(scene, (models_dir() / "creature.glb").string());
    ASSERT_TRUE(st.ok()) << st.message;
    ASSERT_EQ(scene.meshes.size(), 1u);
    ASSERT_EQ(scene.meshes[0].primitives.size(), 1u);
    const Primitive& p = scene.meshes[0].primitives[0];
    EXPECT_EQ(p.triangle_count(), 16128u);
    EXPECT_EQ(p.normals.size(), p.positions.size());
    EXPECT_EQ(p.uv0.size(), p.vertex_count() * 2);
    CheckReport r = check_primitive(p);
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.degenerate_faces, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_GT(r.duplicate_vertices, 0u) << "the UV seam splits vertices";
    EXPECT_GE(r.uv_min[0], 0.0f);
    EXPECT_LE(r.uv_max[0], 1.0f);
    EXPECT_GE(r.uv_min[1], 0.0f);
    EXPECT_LE(r.uv_max[1], 1.0f);
    // Material with an embedded PNG base-colour texture of the documented size.
    ASSERT_EQ(p.material, 0);
    ASSERT_EQ(scene.materials.size(), 1u);
    const Material& m = scene.materials[0];
    ASSERT_GE(m.base_color_texture.texture, 0);
    const Texture& t = scene.textures[size_t(m.base_color_texture.texture)];
    ASSERT_GE(t.image, 0);
    const Image& image = scene.images[size_t(t.image)];
    EXPECT_EQ(image.mime_type, "image/png");
    ImageF albedo;
    ASSERT_TRUE(decode_image(albedo, image.encoded.data(), image.encoded.size()).ok());
    EXPECT_EQ(albedo.width, models::creature_texture_width);
    EXPECT_EQ(albedo.height, models::creature_texture_height);
    EXPECT_VALID_GLTF(models_dir() / "creature.glb");
}

TEST(models, FurMaskHasZeroShortAndLongRegions) {
    ImageF mask;
    ASSERT_TRUE(load_png(mask, (models_dir() / "creature_fur_mask.png").string()).ok());
    EXPECT_EQ(mask.channels, 1);
    EXPECT_EQ(mask.width, models::creature_texture_width);
    EXPECT_EQ(mask.height, models::creature_texture_height);
    size_t zeros = 0;
    float hi = 0;
    for (float v : mask.pixels) zeros += v == 0.0f, hi = std::max(hi, v);
    EXPECT_GT(zeros, 100u) << "zero-mask regions (nose, eyes) must exist";
    EXPECT_LT(zeros, mask.pixels.size() / 20);
    EXPECT_EQ(hi, 1.0f);

    // Sample the mask where the creature's vertices nearest to landmarks sit in UV space.
    Primitive c = shapes::creature(models::creature_segments, models::creature_rings);
    auto uv_nearest = [&](const std::array<float, 3>& target) {
        size_t best = 0;
        double best_d = 1e9;
        for (size_t i = 0; i < c.vertex_count(); ++i) {
            double d = std::hypot(c.positions[i * 3] - target[0], c.positions[i * 3 + 1] - target[1],
                                  c.positions[i * 3 + 2] - target[2]);
            if (d < best_d) best_d = d, best = i;
        }
        return std::array<float, 2>{c.uv0[best * 2], c.uv0[best * 2 + 1]};
    };
    const auto& L = shapes::creature_landmarks();
    auto nose = uv_nearest(L.nose_tip);
    EXPECT_EQ(texel(mask, nose[0], nose[1]), 0.0f) << "no fur on the nose";
    auto eye = uv_nearest(L.eye_left);
    EXPECT_EQ(texel(mask, eye[0], eye[1]), 0.0f) << "no fur on the eyes";
    auto paw = uv_nearest({L.paws[0][0], 0.0f, L.paws[0][2]});
    EXPECT_LT(texel(mask, paw[0], paw[1]), 0.4f) << "short fur on the paws";
    // The back: top of the body, at the top pole row.
    EXPECT_GT(texel(mask, 0.25f, 0.05f), 0.9f) << "long fur on the back";
}

TEST(models, GroundIsTwentyMetreTerrainPatch) {
    Scene scene;
    Status st = load_scene(scene, (models_dir() / "ground.glb").string());
    ASSERT_TRUE(st.ok()) << st.message;
    ASSERT_EQ(scene.meshes.size(), 1u);
    const Primitive& g = scene.meshes[0].primitives[0];
    EXPECT_EQ(g.vertex_count(), 65u * 65u);
    EXPECT_EQ(g.triangle_count(), 2u * 64u * 64u);
    CheckReport r = check_primitive(g);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.boundary_loops, 1u);
    EXPECT_EQ(r.boundary_edges, 4u * 64u);
    EXPECT_NEAR(r.bbox_min[0], -10.0, 1e-6);
    EXPECT_NEAR(r.bbox_max[0], 10.0, 1e-6);
    EXPECT_NEAR(r.bbox_min[2], -10.0, 1e-6);
    EXPECT_NEAR(r.bbox_max[2], 10.0, 1e-6);
    EXPECT_GT(r.bbox_max[1] - r.bbox_min[1], 0.2) << "hills";
    EXPECT_LT(r.bbox_max[1] - r.bbox_min[1], 1.2) << "gentle";
    EXPECT_EQ(r.uv_min[0], 0.0f);
    EXPECT_EQ(r.uv_max[0], 1.0f);
    for (size_t i = 1; i < g.normals.size(); i += 3) ASSERT_GT(g.normals[i], 0.8f) << "gentle slopes, facing up";
    ASSERT_EQ(scene.materials.size(), 1u);
    const Material& snow = scene.materials[0];
    EXPECT_EQ(snow.metallic, 0.0f);
    for (int k = 0; k < 3; ++k) EXPECT_GT(snow.base_color[size_t(k)], 0.85f) << "snow-white";
    EXPECT_VALID_GLTF(models_dir() / "ground.glb");
}

TEST(models, FootprintIsBootSoleWithToeAtTop) {
    ImageF f;
    ASSERT_TRUE(load_png(f, (models_dir() / "footprint.png").string()).ok());
    EXPECT_EQ(f.channels, 1);
    EXPECT_EQ(f.width, models::footprint_width);
    EXPECT_EQ(f.height, models::footprint_height);
    // Corners are untouched snow; ball of the foot and heel are deep; the waist is narrower than the ball.
    EXPECT_EQ(texel(f, 0.01f, 0.01f), 0.0f);
    EXPECT_EQ(texel(f, 0.99f, 0.99f), 0.0f);
    EXPECT_GT(texel(f, 0.5f, 0.3f), 0.7f);
    EXPECT_GT(texel(f, 0.5f, 0.8f), 0.7f);
    auto width_at = [&](float v) {
        int n = 0;
        for (int x = 0; x < f.width; ++x) n += texel(f, (x + 0.5f) / float(f.width), v) > 0.3f;
        return n;
    };
    EXPECT_GT(width_at(0.3f), width_at(0.6f));
    EXPECT_GT(width_at(0.3f), width_at(0.8f)) << "the ball of the foot (toward the top) is wider than the heel";
    // Symmetric left/right, so one brush serves both feet.
    for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width / 2; ++x)
            ASSERT_EQ(f.pixels[size_t(y * f.width + x)], f.pixels[size_t(y * f.width + f.width - 1 - x)]);
}

TEST(models, CollidersFollowIssueSchemaAndSitOnGround) {
    std::vector<uint8_t> bytes = furrow::test::read_bytes(models_dir() / "colliders.json");
    nlohmann::json j = nlohmann::json::parse(bytes.begin(), bytes.end());
    EXPECT_EQ(j["up"], nlohmann::json::array({0, 1, 0}));
    ASSERT_TRUE(j["colliders"].is_array());

    Scene ground;
    ASSERT_TRUE(load_scene(ground, (models_dir() / "ground.glb").string()).ok());
    const Primitive& g = ground.meshes[0].primitives[0];

    std::map<std::string, int> shapes_seen;
    std::vector<std::array<double, 4>> prints; // x, z, heading, side
    for (const auto& c : j["colliders"]) {
        std::string shape = c.at("shape");
        ++shapes_seen[shape];
        ASSERT_TRUE(c.at("path").is_array());
        ASSERT_FALSE(c["path"].empty());
        for (const auto& p : c["path"]) {
            ASSERT_EQ(p.size(), 3u);
            double x = p[0], y = p[1], z = p[2];
            EXPECT_LT(std::abs(x), 10.0);
            EXPECT_LT(std::abs(z), 10.0);
            double ground_y = mesh_height(g, models::ground_cells, models::ground_size, x, z);
            if (shape == "image") {
                EXPECT_NEAR(y, ground_y, 1e-3) << "a footprint sits on the snow surface";
            } else if (shape == "sphere") {
                double r = c.at("radius");
                EXPECT_GT(ground_y, y - r) << "the ball touches the snow";
                EXPECT_LT(ground_y, y) << "the ball's centre is above the snow";
            } else if (shape == "box") {
                double half = double(c.at("size")[1]) / 2;
                EXPECT_GT(ground_y, y - half);
                EXPECT_LT(ground_y, y + half);
            } else if (shape == "capsule") {
                double r = c.at("radius");
                EXPECT_GT(ground_y, y - r);
                EXPECT_GT(double(c.at("length")), 0.0);
            }
        }
        if (c.contains("heading")) {
            EXPECT_EQ(c["heading"].size(), c["path"].size()) << "one heading per path point";
        }
        if (shape == "image") {
            EXPECT_EQ(c.at("image"), "footprint.png");
            EXPECT_TRUE(fs::exists(models_dir() / std::string(c["image"])));
            EXPECT_EQ(c.at("size").size(), 2u);
            EXPECT_GT(double(c.at("depth")), 0.0);
            prints.push_back({double(c["path"][0][0]), double(c["path"][0][2]), double(c.at("heading")[0]), 0.0});
        }
    }
    EXPECT_GE(shapes_seen["image"], 10);
    EXPECT_EQ(shapes_seen["sphere"], 1);
    EXPECT_EQ(shapes_seen["box"], 1);
    EXPECT_EQ(shapes_seen["capsule"], 1);

    // The trail: prints alternate left/right of the walking direction and point where the walker goes.
    for (size_t k = 0; k + 2 < prints.size(); ++k) {
        double dx = prints[k + 2][0] - prints[k][0], dz = prints[k + 2][1] - prints[k][1]; // same foot, next step
        double heading = std::atan2(dx, dz) * 180 / std::numbers::pi;
        EXPECT_NEAR(heading, prints[k][2], 15.0) << "print " << k;
        double sx = prints[k + 1][0] - prints[k][0], sz = prints[k + 1][1] - prints[k][1];
        // Cross product of the walking direction and the step to the other foot: > 0 when that foot is on
        // the walker's right, as it is after a left print (the trail starts with the left foot).
        double side = dx * sz - dz * sx;
        EXPECT_EQ(side > 0, k % 2 == 0) << "print " << k << ": feet must alternate";
    }
}

TEST(models, SceneJsonNamesExistingFiles) {
    std::vector<uint8_t> bytes = furrow::test::read_bytes(models_dir() / "scene.json");
    nlohmann::json j = nlohmann::json::parse(bytes.begin(), bytes.end());
    for (const char* key : {"model", "fur_mask"}) EXPECT_TRUE(fs::exists(models_dir() / std::string(j["creature"][key])));
    for (const char* key : {"ground", "colliders"}) EXPECT_TRUE(fs::exists(models_dir() / std::string(j["snow"][key])));
    for (const char* part : {"creature", "snow"}) {
        EXPECT_EQ(j[part]["camera"]["eye"].size(), 3u);
        EXPECT_EQ(j[part]["camera"]["target"].size(), 3u);
    }
}

// `furrow render`: outputs, exit codes, atomic writes.
#include "test_support.h"

#include <furrow/render.h>

#include <fstream>

namespace furrow {
namespace {

namespace fs = std::filesystem;
using test::run_furrow;

// Two quads (a small scene with a hierarchy-free node) written as .glb.
fs::path write_quads(const fs::path& dir) {
    Primitive p;
    p.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 0, -1, 3, 0, -1, 3, 1, -1, 2, 1, -1};
    p.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    p.indices = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
    p.custom.push_back(CustomAttribute{"_FUR_LENGTH", 1, {0, 1, 2, 3, 4, 5, 6, 7}});
    fs::path file = dir / "quads.glb";
    EXPECT_TRUE(save_scene(make_scene(p), file.string()).ok());
    return file;
}

ImageF read_png(const fs::path& file) {
    ImageF im;
    EXPECT_TRUE(load_png(im, file.string()).ok()) << file;
    return im;
}

TEST(furrow_render, WritesRgbaPngOfRequestedSize) {
    fs::path dir = test::temp_dir(), in = write_quads(dir);
    auto r = run_furrow({"render", in.string(), "-o", (dir / "out.png").string(), "--size", "64x48"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    ImageF im = read_png(dir / "out.png");
    EXPECT_EQ(im.width, 64);
    EXPECT_EQ(im.height, 48);
    EXPECT_EQ(im.channels, 4);
    size_t area = mask_area(silhouette_mask(im));
    EXPECT_GT(area, 300u);
    EXPECT_LT(area, 64u * 48u); // a transparent background around the quads
    EXPECT_EQ(test::list_dir(dir), (std::vector<std::string>{"out.png", "quads.glb"}));

    r = run_furrow({"render", in.string(), "-o", (dir / "bg.png").string(), "--size", "64x48", "--background", "1,1,1",
                    "--ssaa", "2", "--ortho"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(mask_area(silhouette_mask(read_png(dir / "bg.png"))), 64u * 48u);
}

TEST(furrow_render, EveryModeRuns) {
    fs::path dir = test::temp_dir(), in = write_quads(dir);
    for (std::string mode : {"shaded", "normals", "uv", "depth", "wireframe"}) {
        auto r = run_furrow({"render", in.string(), "-o", (dir / (mode + ".png")).string(), "--size", "32x32", "--mode", mode});
        EXPECT_EQ(r.exit_code, 0) << mode << ": " << r.err;
    }
    auto r = run_furrow({"render", in.string(), "-o", (dir / "attr.png").string(), "--size", "96x64", "--attribute", "_FUR_LENGTH"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    r = run_furrow({"render", in.string(), "-o", (dir / "attr.png").string(), "--attribute", "_NOPE"});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find("_FUR_LENGTH"), std::string::npos) << r.err;
}

TEST(furrow_render, IdenticalBytesForAnyThreadCount) {
    fs::path dir = test::temp_dir(), in = write_quads(dir);
    auto a = run_furrow({"-j", "1", "render", in.string(), "-o", (dir / "a.png").string(), "--ssaa", "2", "--mode", "wireframe"});
    auto b = run_furrow({"-j", "2", "render", in.string(), "-o", (dir / "b.png").string(), "--ssaa", "2", "--mode", "wireframe"});
    ASSERT_EQ(a.exit_code, 0) << a.err;
    ASSERT_EQ(b.exit_code, 0) << b.err;
    EXPECT_EQ(test::read_bytes(dir / "a.png"), test::read_bytes(dir / "b.png"));
}

TEST(furrow_render, DepthOutWritesFloatImage) {
    fs::path dir = test::temp_dir(), in = write_quads(dir);
    auto r = run_furrow({"render", in.string(), "-o", (dir / "d.png").string(), "--mode", "depth", "--size", "40x30",
                         "--depth-out", (dir / "d.pfm").string()});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    auto bytes = test::read_bytes(dir / "d.pfm");
    std::string header = "Pf\n40 30\n-1.0\n";
    ASSERT_EQ(bytes.size(), header.size() + 40 * 30 * 4);
    EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + long(header.size())), header);
    size_t finite = 0;
    for (size_t i = header.size(); i < bytes.size(); i += 4) {
        float v;
        std::memcpy(&v, &bytes[i], 4);
        finite += std::isfinite(v);
        EXPECT_TRUE(!std::isfinite(v) || v > 0);
    }
    EXPECT_GT(finite, 50u);
}

TEST(furrow_render, UsageErrorsExitTwo) {
    fs::path dir = test::temp_dir(), in = write_quads(dir);
    std::string out = (dir / "o.png").string();
    for (std::vector<std::string> extra : std::vector<std::vector<std::string>>{
             {"--size", "0x10"}, {"--size", "16385x10"}, {"--ssaa", "9"}, {"--mode", "attribute"},
             {"--mode", "bogus"}, {"--background", "2,0,0"}, {"--attribute", "_A", "--mode", "uv"},
             {"--ortho-height", "3"}}) {
        std::vector<std::string> args{"render", in.string(), "-o", out};
        args.insert(args.end(), extra.begin(), extra.end());
        auto r = run_furrow(args);
        EXPECT_EQ(r.exit_code, 2) << extra[0] << " " << extra[1] << ": " << r.err;
    }
    auto r = run_furrow({"render", in.string(), "-o", (dir / "o.jpg").string()});
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(test::list_dir(dir), std::vector<std::string>{"quads.glb"});
}

TEST(furrow_render, BadInputExitsOneWithOneErrorLine) {
    fs::path dir = test::temp_dir(), in = write_quads(dir);
    // A missing input.
    auto r = run_furrow({"render", (dir / "missing.glb").string(), "-o", (dir / "o.png").string()});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.err.rfind("Error: " + (dir / "missing.glb").string() + ": ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1);
    // A scene without triangles.
    Primitive points;
    points.mode = PrimitiveMode::points;
    points.positions = {0, 0, 0, 1, 1, 1};
    ASSERT_TRUE(save_scene(make_scene(points), (dir / "points.glb").string()).ok());
    r = run_furrow({"render", (dir / "points.glb").string(), "-o", (dir / "o.png").string()});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find("no triangles"), std::string::npos) << r.err;
    // An unwritable output: nothing is left behind.
    r = run_furrow({"render", in.string(), "-o", (dir / "no_such_dir" / "o.png").string()});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.err.rfind("Error: " + (dir / "no_such_dir" / "o.png").string() + ": ", 0), 0u) << r.err;
    // The output is the input.
    fs::path png = dir / "same.png";
    test::write_bytes(png, {1, 2, 3});
    r = run_furrow({"render", png.string(), "-o", png.string()});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(test::read_bytes(png), (std::vector<uint8_t>{1, 2, 3}));
    EXPECT_EQ(test::list_dir(dir), (std::vector<std::string>{"points.glb", "quads.glb", "same.png"}));
}

// A glTF whose texture file is missing renders with the factor and says so.
TEST(furrow_render, MissingTextureWarnsAndRenders) {
    fs::path dir = test::temp_dir();
    Primitive p;
    p.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    p.uv0 = {0, 0, 1, 0, 0, 1};
    p.indices = {0, 1, 2};
    p.material = 0;
    Scene s = make_scene(p);
    Material m;
    m.base_color_texture.texture = 0;
    m.double_sided = true;
    s.materials.push_back(m);
    s.textures.push_back(Texture{0, -1});
    std::vector<uint8_t> texel{255, 0, 0, 255};
    s.images.push_back(Image{"t", "image/png", encode_png_rgba8(texel.data(), 1, 1), ""});
    ASSERT_TRUE(save_scene(s, (dir / "tex.gltf").string()).ok());
    // Point the image at a file that does not exist.
    std::ifstream f(dir / "tex.gltf");
    std::string json((std::istreambuf_iterator<char>(f)), {});
    size_t at = json.find("\"images\"");
    ASSERT_NE(at, std::string::npos) << json;
    size_t open = json.find('{', at), close = json.find('}', open);
    json.replace(open, close - open + 1, "{\"uri\":\"gone.png\"}");
    test::write_text(dir / "tex.gltf", json);
    auto r = run_furrow({"render", (dir / "tex.gltf").string(), "-o", (dir / "o.png").string(), "--size", "32x32"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("Warning"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("gone.png"), std::string::npos) << r.err;
    EXPECT_GT(mask_area(silhouette_mask(read_png(dir / "o.png"))), 50u);
}

TEST(furrow_render, HelpShowsExamples) {
    auto r = run_furrow({"render", "--help"});
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.out.find("Examples:"), std::string::npos);
    EXPECT_NE(r.out.find("--attribute"), std::string::npos);
}

} // namespace
} // namespace furrow

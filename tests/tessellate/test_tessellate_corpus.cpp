// furrow::tessellate on the shared corpus: watertight in -> watertight out, boundaries scale with the rate,
// repair of the broken models, the irregular spot cage against Far, validator-clean scenes.
#include "bfr_oracle.h"
#include "osd_reference.h"
#include "tess_test_util.h"
#include "test_support.h"

#include <furrow/tessellate.h>

#include <tbb/global_control.h>

using namespace furrow;
using namespace furrow::test;

namespace {

Scene load(const std::string& relative) {
    Scene s;
    Status st = load_scene(s, corpus(relative).string());
    EXPECT_TRUE(st.ok()) << relative << ": " << st.message;
    return s;
}

CheckReport scene_report(const Scene& s) {
    std::vector<CheckReport> r;
    for (const auto& m : s.meshes)
        for (const auto& p : m.primitives)
            if (p.mode == PrimitiveMode::triangles) r.push_back(check_primitive(p));
    return merge_reports(r);
}

// A camera one bounding-box diagonal in front of the model (+z), so that rates vary across it.
TessellateOptions view_options(const Scene& s, SubdivisionScheme scheme) {
    CheckReport r = scene_report(s);
    TessellateOptions o;
    o.surface.scheme = scheme;
    std::array<double, 3> c{(r.bbox_min[0] + r.bbox_max[0]) / 2, (r.bbox_min[1] + r.bbox_max[1]) / 2,
                            (r.bbox_min[2] + r.bbox_max[2]) / 2};
    o.rates.camera = TessellationCamera{{c[0], c[1], c[2] + r.diagonal}, 45, 720};
    o.rates.pixel_error = 8;
    o.rates.screen_error = 0.5;
    o.rates.max_rate = 8;
    return o;
}

} // namespace

// Closed models (and 73342 once repaired) stay closed, manifold, consistently oriented, without zero-area
// triangles, under view-dependent (mixed) rates.
TEST(tessellate_corpus, ClosedModelsStayWatertight) {
    struct Case {
        const char* file;
        SubdivisionScheme scheme;
    };
    for (const Case& c : {Case{"spot/spot_control_mesh.obj", SubdivisionScheme::catmark},
                          Case{"spot/spot_quadrangulated.obj", SubdivisionScheme::catmark},
                          Case{"spot/spot_triangulated.obj", SubdivisionScheme::loop},
                          Case{"bunny_closed/bunny.off", SubdivisionScheme::loop},
                          Case{"bunny_closed/bunny.off", SubdivisionScheme::catmark},
                          Case{"duck/Duck.glb", SubdivisionScheme::loop},
                          Case{"fox/Fox.glb", SubdivisionScheme::catmark},
                          Case{"box_textured/BoxTextured.gltf", SubdivisionScheme::bilinear},
                          Case{"thingi10k_73342/73342.stl", SubdivisionScheme::loop}}) {
        Scene s = load(c.file);
        TessellateOptions o = view_options(s, c.scheme);
        SceneTessellateReport rep;
        Status st = tessellate_scene(s, o, &rep);
        ASSERT_TRUE(st.ok()) << c.file << ": " << st.message;
        EXPECT_GT(rep.triangles_out, rep.triangles_in) << c.file;
        if (c.scheme != SubdivisionScheme::bilinear) { // the box is small on screen only in its own eyes
            EXPECT_GT(rep.totals.max_rate, rep.totals.min_rate) << c.file;
        }
        CheckReport r = scene_report(s);
        EXPECT_EQ(r.boundary_edges, 0u) << c.file;
        EXPECT_EQ(r.non_manifold_edges, 0u) << c.file;
        EXPECT_EQ(r.inconsistent_edges, 0u) << c.file;
        EXPECT_EQ(r.zero_area_faces, 0u) << c.file;
        EXPECT_EQ(r.nan_values, 0u) << c.file;
    }
}

// 73342: 20 degenerate triangles dropped, the faces oriented against their neighbours flipped; nothing left
// for the linear fallback.
TEST(tessellate_corpus, BrokenStlRepaired) {
    Scene s = load("thingi10k_73342/73342.stl");
    TessellateOptions o = uniform_options(SubdivisionScheme::loop, 2);
    SceneTessellateReport rep;
    ASSERT_TRUE(tessellate_scene(s, o, &rep).ok());
    EXPECT_EQ(rep.totals.dropped_faces, 20u);
    EXPECT_GT(rep.totals.flipped_faces, 0u);
    EXPECT_EQ(rep.totals.linear_faces, 0u);
    EXPECT_EQ(rep.triangles_out, (420u - 20u) * 4u);
    // Strict mode refuses instead.
    o.surface.refuse_bad_topology = true;
    Scene again = load("thingi10k_73342/73342.stl");
    Status st = tessellate_scene(again, o);
    EXPECT_EQ(st.code, StatusCode::invalid_input);
    EXPECT_NE(st.message.find("degenerate"), std::string::npos) << st.message;
}

// Open models: every boundary edge is cut into exactly `rate` boundary edges (no crack adds any, no repair
// removes any). Suzanne also has two bowtie vertices and a valence-2 vertex (on the limit surface, not linear).
TEST(tessellate_corpus, OpenBoundariesScaleWithRate) {
    struct Case {
        const char* file;
        SubdivisionScheme scheme;
        int rate;
    };
    for (const Case& c : {Case{"suzanne/suzanne.obj", SubdivisionScheme::catmark, 3},
                          Case{"torus/torus.obj", SubdivisionScheme::loop, 3},
                          Case{"alligator/alligator.obj", SubdivisionScheme::loop, 2},
                          Case{"terrain/terrain.glb", SubdivisionScheme::bilinear, 2},
                          Case{"stanford_bunny_scan/stanford-bunny.obj", SubdivisionScheme::loop, 2}}) {
        Scene s = load(c.file);
        const CheckReport before = scene_report(s);
        SceneTessellateReport rep;
        ASSERT_TRUE(tessellate_scene(s, uniform_options(c.scheme, c.rate), &rep).ok()) << c.file;
        const CheckReport after = scene_report(s);
        EXPECT_EQ(after.boundary_edges, before.boundary_edges * size_t(c.rate)) << c.file;
        EXPECT_EQ(after.non_manifold_edges, 0u) << c.file;
        EXPECT_EQ(after.inconsistent_edges, 0u) << c.file;
        EXPECT_EQ(after.zero_area_faces, 0u) << c.file;
    }
    Scene suzanne = load("suzanne/suzanne.obj");
    SceneTessellateReport rep;
    ASSERT_TRUE(tessellate_scene(suzanne, uniform_options(SubdivisionScheme::catmark, 2), &rep).ok());
    EXPECT_EQ(rep.totals.split_vertices, 2u);
    EXPECT_EQ(rep.totals.valence2_vertices, 1u);
    EXPECT_EQ(rep.totals.linear_faces, 0u);
}

// Spot's Catmull-Clark cage (triangles, quads, pentagons, 80 extraordinary vertices) against Far's uniform
// refinement + limit projection: the same points within 1e-5 of the diagonal (accuracy 6 near the EVs).
TEST(tessellate_corpus, SpotCageMatchesFarLimit) {
    Scene s = load("spot/spot_control_mesh.obj");
    const Primitive w = welded(s.meshes[0].primitives[0]);
    const double diag = diagonal_of(w.positions);
    for (int level : {1, 2, 3}) {
        TessellateOptions o = uniform_options(SubdivisionScheme::catmark, 1 << level);
        o.surface.accuracy = 6;
        TessellateOutput t = run_tessellate(w, o);
        auto ours = unique_points(t.positions);
        auto reference = far_limit_points(w.positions, w.indices, w.face_sizes, OpenSubdiv::Sdc::SCHEME_CATMARK, level);
        EXPECT_EQ(ours.size(), reference.size()) << level;
        EXPECT_LE(max_nearest_distance(ours, reference), 1e-5 * diag) << level;
        EXPECT_LE(max_nearest_distance(reference, ours), 1e-5 * diag) << level;
    }
}

// Whole scenes written after tessellation pass the Khronos validator: skin (fox), node matrices (duck),
// embedded textures and split UVs (box).
TEST(tessellate_corpus, TessellatedScenesAreValidatorClean) {
    const auto dir = temp_dir();
    for (const char* file : {"fox/Fox.glb", "duck/Duck.glb", "box_textured/BoxTextured.gltf"}) {
        Scene s = load(file);
        const size_t nodes = s.nodes.size(), materials = s.materials.size(), skins = s.skins.size();
        ASSERT_TRUE(tessellate_scene(s, view_options(s, SubdivisionScheme::catmark)).ok()) << file;
        EXPECT_EQ(s.nodes.size(), nodes);
        EXPECT_EQ(s.materials.size(), materials);
        EXPECT_EQ(s.skins.size(), skins);
        const auto out = dir / (std::filesystem::path(file).stem().string() + ".glb");
        ASSERT_TRUE(save_scene(s, out.string()).ok());
        EXPECT_VALID_GLTF(out);
    }
}

// The same bytes for 1 and 2 threads on a real model with seams and irregular vertices.
TEST(tessellate_corpus, DeterministicOnDuck) {
    Scene a = load("duck/Duck.glb"), b = a;
    TessellateOptions o = view_options(a, SubdivisionScheme::loop);
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        ASSERT_TRUE(tessellate_scene(a, o).ok());
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        ASSERT_TRUE(tessellate_scene(b, o).ok());
    }
    const Primitive &pa = a.meshes[0].primitives[0], &pb = b.meshes[0].primitives[0];
    EXPECT_EQ(pa.positions, pb.positions);
    EXPECT_EQ(pa.normals, pb.normals);
    EXPECT_EQ(pa.uv0, pb.uv0);
    EXPECT_EQ(pa.indices, pb.indices);
}

// Real quad and triangle meshes (extraordinary vertices, UV seams, small faces): every shared normal near the
// faces' float average (within the float derivatives' own disagreement) and no further from the exact normal
// than that average is. (Positions: the harness comparison of the tess-share branch found them bit-identical;
// the oracle's bit-for-bit check applies to the generated meshes of test_tessellate_bfr_oracle.cpp.)
TEST(tessellate_corpus, SharedNormalsMatchFreshBfrSurfaces) {
    struct Case {
        const char* file;
        SubdivisionScheme scheme;
        int rate;
    };
    for (const Case& c : {Case{"spot/spot_quadrangulated.obj", SubdivisionScheme::catmark, 4},
                          Case{"spot/spot_triangulated.obj", SubdivisionScheme::loop, 3}}) {
        SCOPED_TRACE(c.file);
        Scene s = load(c.file);
        ASSERT_FALSE(s.meshes.empty());
        const double worst = expect_normals_average_faces(s.meshes[0].primitives[0], c.scheme, c.rate, 1e-4);
        std::printf("%s, rate %d: largest angle to the faces' average %.3g rad\n", c.file, c.rate, worst);
    }
}

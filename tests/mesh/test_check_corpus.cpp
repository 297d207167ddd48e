// check_primitive on real models (../shared/corpus) against the numbers published in its MANIFEST.md.
//
// The MANIFEST welds by exact position (as check_primitive does) but measures glTF in world space and
// counts only "properly crossing" triangle pairs that share no vertex. So: topological counts are compared
// everywhere (welding commutes with node transforms); lengths only where the node transform is known;
// self-intersections only where both definitions give 0 (CGAL also counts touching and coplanar-overlapping
// pairs and pairs that share a vertex but meet elsewhere, e.g. 26 vs 14 on the spot cage).
#include "test_support.h"

#include <cmath>
#include <fstream>
#include <sstream>

using namespace furrow;
using namespace furrow::test;

namespace {

// The whole file, all primitives merged (every corpus model has one mesh primitive; merging keeps the
// test honest should a loader ever split one).
CheckReport check_file(const std::string& relative, bool self_intersections = false) {
    Scene scene;
    LoadOptions load;
    load.recentre = false;
    load.allow_non_finite = true;
    Status s = load_scene(scene, corpus(relative).string(), load);
    EXPECT_TRUE(s.ok()) << relative << ": " << s.message;
    CheckOptions options;
    options.self_intersections = self_intersections;
    std::vector<CheckReport> reports;
    for (const auto& m : scene.meshes)
        for (const auto& p : m.primitives) reports.push_back(check_primitive(p, options));
    return merge_reports(reports);
}

// An ASCII STL read as the raw triangle soup it is (3 vertices per facet, nothing merged or dropped), to
// measure check_primitive independently of any loader.
Primitive read_ascii_stl(const std::string& relative) {
    std::ifstream in(corpus(relative));
    Primitive p;
    std::string word;
    while (in >> word)
        if (word == "vertex") {
            float x = 0, y = 0, z = 0;
            in >> x >> y >> z;
            p.indices.push_back(uint32_t(p.positions.size() / 3));
            p.positions.insert(p.positions.end(), {x, y, z});
        }
    return p;
}

void expect_closed_manifold(const CheckReport& r) {
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.boundary_edges, 0u);
    EXPECT_EQ(r.boundary_loops, 0u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_EQ(r.degenerate_faces, 0u);
    EXPECT_EQ(r.zero_area_faces, 0u);
    EXPECT_EQ(r.components, 1u);
}

// Boundary loops of the merged triangles through OpenMesh, to cross-check check_primitive's fan-based count.
size_t halfedge_loops(const std::string& relative) {
    Scene scene;
    LoadOptions load;
    load.recentre = false;
    EXPECT_TRUE(load_scene(scene, corpus(relative).string(), load).ok());
    Primitive p = scene.meshes.at(0).primitives.at(0);
    triangulate(p);
    std::vector<std::vector<uint32_t>> loops;
    return boundary_loops(loops, p.positions.data(), p.vertex_count(), p.indices.data(), p.indices.size());
}

} // namespace

// spot_triangulated.obj: V=2930 (after welding UV-split vertices), 5856 triangles, closed genus-0 manifold,
// min angle 10.2°, 0 intersecting pairs.
TEST(check_corpus, SpotTriangulated) {
    CheckReport r = check_file("spot/spot_triangulated.obj", true);
    expect_closed_manifold(r);
    EXPECT_EQ(r.welded_vertices, 2930u);
    EXPECT_EQ(r.faces, 5856u);
    EXPECT_EQ(r.slivers, 0u);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_TRUE(r.has_uv);
    EXPECT_NEAR(r.diagonal, 2.588, 1e-3);
}

// spot_quadrangulated.obj: 2928 quads (one face each for topology, two triangles each for geometry).
TEST(check_corpus, SpotQuadrangulated) {
    CheckReport r = check_file("spot/spot_quadrangulated.obj", true);
    expect_closed_manifold(r);
    EXPECT_EQ(r.welded_vertices, 2930u);
    EXPECT_EQ(r.faces, 2928u);
    EXPECT_EQ(r.triangles, 5856u);
    EXPECT_EQ(r.self_intersections, 0);
}

// spot_control_mesh.obj: the mixed-polygon cage, 188 positions, 180 faces, closed. (Its fan triangles
// include 4 slivers below 1° and CGAL finds 26 intersecting pairs; the MANIFEST measures angles on the
// cage's triangles only and counts 14 proper crossings, so neither is compared.)
TEST(check_corpus, SpotControlMesh) {
    CheckReport r = check_file("spot/spot_control_mesh.obj");
    expect_closed_manifold(r);
    EXPECT_EQ(r.welded_vertices, 188u);
    EXPECT_EQ(r.faces, 180u);
    EXPECT_EQ(r.triangles, 4u + 2u * 160u + 3u * 16u);
}

// bunny.off: closed, 3485 vertices, 6966 triangles, min angle 2.74°, no intersections.
TEST(check_corpus, BunnyClosed) {
    CheckReport r = check_file("bunny_closed/bunny.off", true);
    expect_closed_manifold(r);
    EXPECT_EQ(r.welded_vertices, 3485u);
    EXPECT_EQ(r.faces, 6966u);
    EXPECT_EQ(r.slivers, 0u);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_NEAR(r.diagonal, 0.2504, 1e-4);
}

// stanford-bunny.obj: 223 boundary edges in 5 loops, one component, one needle below 1°, 0 intersections.
TEST(check_corpus, StanfordBunnyScan) {
    CheckReport r = check_file("stanford_bunny_scan/stanford-bunny.obj", true);
    EXPECT_EQ(r.welded_vertices, 35947u);
    EXPECT_EQ(r.faces, 69451u);
    EXPECT_EQ(r.boundary_edges, 223u);
    EXPECT_EQ(r.boundary_loops, 5u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_EQ(r.zero_area_faces, 0u);
    EXPECT_EQ(r.slivers, 1u);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_FALSE(r.closed);
    EXPECT_EQ(halfedge_loops("stanford_bunny_scan/stanford-bunny.obj"), 5u);
}

// suzanne.obj: 505 positions (507 written), 500 faces, 42 boundary edges in 4 loops, the 2 duplicated
// positions become 2 bowtie vertices, no non-manifold edge.
TEST(check_corpus, Suzanne) {
    CheckReport r = check_file("suzanne/suzanne.obj");
    EXPECT_EQ(r.welded_vertices, 505u);
    EXPECT_EQ(r.faces, 500u);
    EXPECT_EQ(r.boundary_edges, 42u);
    EXPECT_EQ(r.boundary_loops, 4u);
    EXPECT_EQ(r.non_manifold_vertices, 2u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.zero_area_faces, 0u);
}

// torus.obj: the closed torus plus one stray triangle: 2 components, 9 boundary edges in 3 loops.
TEST(check_corpus, TorusWithStrayTriangle) {
    CheckReport r = check_file("torus/torus.obj", true);
    EXPECT_EQ(r.welded_vertices, 2051u);
    EXPECT_EQ(r.faces, 4095u);
    EXPECT_EQ(r.components, 2u);
    EXPECT_EQ(r.boundary_edges, 9u);
    EXPECT_EQ(r.boundary_loops, 3u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_EQ(halfedge_loops("torus/torus.obj"), 3u);
}

// Fox.glb: fully unwelded (1728 vertices for 576 triangles) welds into a closed manifold of 290 positions;
// min angle 1.49° (no sliver below 1°), no intersections.
TEST(check_corpus, Fox) {
    CheckReport r = check_file("fox/Fox.glb", true);
    expect_closed_manifold(r);
    EXPECT_EQ(r.vertices, 1728u);
    EXPECT_EQ(r.welded_vertices, 290u);
    EXPECT_EQ(r.faces, 576u);
    EXPECT_EQ(r.slivers, 0u);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_TRUE(r.has_uv);
}

// Duck: 2399 vertices weld into a closed manifold of 2108. Checked in object space: the root node's 0.01
// scale is not applied, so the diagonal is 100× the MANIFEST's world-space 2.538. Both packagings agree.
TEST(check_corpus, Duck) {
    CheckReport glb = check_file("duck/Duck.glb");
    CheckReport gltf = check_file("duck/Duck.gltf");
    for (const CheckReport& r : {glb, gltf}) {
        expect_closed_manifold(r);
        EXPECT_EQ(r.vertices, 2399u);
        EXPECT_EQ(r.welded_vertices, 2108u);
        EXPECT_EQ(r.faces, 4212u);
        EXPECT_EQ(r.slivers, 0u);
        EXPECT_NEAR(r.diagonal, 253.8, 0.5);
    }
    EXPECT_EQ(glb.diagonal, gltf.diagonal);
    EXPECT_EQ(glb.uv_max, gltf.uv_max);
}

// BoxTextured.gltf: 24 vertices = 6 separate quads until welded into a closed cube of 8 positions.
TEST(check_corpus, BoxTextured) {
    CheckReport r = check_file("box_textured/BoxTextured.gltf", true);
    expect_closed_manifold(r);
    EXPECT_EQ(r.vertices, 24u);
    EXPECT_EQ(r.welded_vertices, 8u);
    EXPECT_EQ(r.duplicate_vertices, 16u);
    EXPECT_EQ(r.faces, 12u);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_TRUE(r.has_uv);
    EXPECT_NEAR(r.diagonal, std::sqrt(3.0), 1e-6);
}

// terrain.glb: one open rim of 346 edges, 15885 positions (16247 stored), 12 slivers below 1°.
TEST(check_corpus, Terrain) {
    CheckReport r = check_file("terrain/terrain.glb");
    EXPECT_EQ(r.vertices, 16247u);
    EXPECT_EQ(r.welded_vertices, 15885u);
    EXPECT_EQ(r.faces, 31422u);
    EXPECT_EQ(r.boundary_edges, 346u);
    EXPECT_EQ(r.boundary_loops, 1u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.inconsistent_edges, 0u);
    EXPECT_EQ(r.zero_area_faces, 0u);
    EXPECT_EQ(r.slivers, 12u);
}

// 73342.stl read as the raw soup it is (1260 vertices, 420 facets): 202 positions, 12 non-manifold edges,
// 20 degenerate (and so zero-area) faces, 20 inconsistently oriented edges, otherwise closed.
TEST(check_corpus, Thingi73342RawSoup) {
    Primitive p = read_ascii_stl("thingi10k_73342/73342.stl");
    ASSERT_EQ(p.vertex_count(), 1260u);
    CheckReport r = check_primitive(p, CheckOptions{1.0, 1e-14, true});
    EXPECT_EQ(r.welded_vertices, 202u);
    EXPECT_EQ(r.faces, 420u);
    EXPECT_EQ(r.non_manifold_edges, 12u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.degenerate_faces, 20u);
    EXPECT_EQ(r.zero_area_faces, 20u);
    EXPECT_EQ(r.inconsistent_edges, 20u);
    EXPECT_EQ(r.boundary_edges, 0u);
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.slivers, 0u);
    EXPECT_EQ(r.self_intersections, 0);
}

// The same file through load_scene: the STL reader keeps every facet, degenerate ones included, so the
// findings are the raw soup's.
TEST(check_corpus, Thingi73342Loaded) {
    CheckReport r = check_file("thingi10k_73342/73342.stl");
    EXPECT_EQ(r.welded_vertices, 202u);
    EXPECT_EQ(r.boundary_edges, 0u);
    EXPECT_EQ(r.inconsistent_edges, 20u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.faces, 420u);
    EXPECT_EQ(r.non_manifold_edges, 12u);
    EXPECT_EQ(r.degenerate_faces, 20u);
    EXPECT_EQ(r.zero_area_faces, 20u);
}

// 70375.stl: a 1 mm plate, open with 12 boundary edges in 2 loops, 4 triangles below 1°.
TEST(check_corpus, Thingi70375) {
    CheckReport r = check_file("thingi10k_70375/70375.stl");
    EXPECT_EQ(r.welded_vertices, 24u);
    EXPECT_EQ(r.faces, 40u);
    EXPECT_EQ(r.boundary_edges, 12u);
    EXPECT_EQ(r.boundary_loops, 2u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.slivers, 4u);
}

// alligator.obj: a flat sheet (z = 0 everywhere), one rim of 433 edges, good triangles (min angle 30°).
TEST(check_corpus, Alligator) {
    CheckReport r = check_file("alligator/alligator.obj", true);
    EXPECT_EQ(r.welded_vertices, 3208u);
    EXPECT_EQ(r.faces, 5981u);
    EXPECT_EQ(r.boundary_edges, 433u);
    EXPECT_EQ(r.boundary_loops, 1u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    EXPECT_EQ(r.zero_area_faces, 0u);
    EXPECT_EQ(r.slivers, 0u);
    EXPECT_EQ(r.self_intersections, 0);
    EXPECT_EQ(r.bbox_min[2], 0.0);
    EXPECT_EQ(r.bbox_max[2], 0.0);
    EXPECT_EQ(halfedge_loops("alligator/alligator.obj"), 1u);
}

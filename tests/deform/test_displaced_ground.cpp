// DisplacedGround: displacement once per welded point, incremental updates equal to a full pass.
#include "deform_test_util.h"
#include "test_support.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <random>

#include <tbb/global_control.h>

using namespace furrow;
using namespace furrow::test;

namespace {

struct Prepared {
    Primitive ground;
    SnowField field;
    DisplacedGround dg;
};

void prepare(Prepared& p, const DisplaceOptions& o = {}) {
    SnowOptions so;
    so.texel = 0.02;
    so.rim_width = 0.06;
    p.field = make_field(p.ground, so);
    Status s = p.dg.prepare(p.ground.positions.data(), p.ground.vertex_count(), p.ground.indices.data(), p.ground.indices.size(),
                            p.field.frame(), o, &p.field.ground());
    ASSERT_TRUE(s.ok()) << s.message;
}

// A hill of n x n cells, prepared and displaced whole by its field's heightmap into pos and nor.
void displaced_hill(Prepared& p, int n, std::vector<float>& pos, std::vector<float>& nor) {
    p.ground = hill_ground(4, n);
    prepare(p);
    pos.assign(p.ground.positions.size(), 0.0f), nor.assign(p.ground.positions.size(), 0.0f);
    p.field.update();
    p.dg.displace_all(p.field.heightmap(), pos.data(), nor.data());
}

// pos and nor are, bit for bit, what a fresh object's full pass writes for p's ground and heightmap.
void expect_full_pass_bits(const Prepared& p, const std::vector<float>& pos, const std::vector<float>& nor) {
    DisplacedGround fresh;
    ASSERT_TRUE(fresh.prepare(p.ground.positions.data(), p.ground.vertex_count(), p.ground.indices.data(), p.ground.indices.size(),
                              p.field.frame())
                    .ok());
    std::vector<float> full_pos(pos.size()), full_nor(nor.size());
    fresh.displace_all(p.field.heightmap(), full_pos.data(), full_nor.data());
    EXPECT_EQ(pos, full_pos);
    EXPECT_EQ(nor, full_nor);
}

} // namespace

TEST(DisplacedGround, IncrementalUpdatesEqualAFullPass) {
    Prepared p;
    std::vector<float> pos, nor;
    displaced_hill(p, 100, pos, nor);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> U(-1.6, 1.6);
    size_t moved_total = 0;
    for (int frame = 0; frame < 20; ++frame) {
        const double x = U(rng), z = U(rng);
        ASSERT_TRUE(p.field.stamp(sphere(0.15, {}), ColliderPose{{x, hill_height(x, z) + 0.1, z}, 0, 0}).ok());
        const auto r = p.field.update();
        const size_t moved = p.dg.update(p.field.heightmap(), r, pos.data(), nor.data());
        EXPECT_GT(moved, 0u);
        EXPECT_LT(moved, p.dg.welded_count() / 4);
        moved_total += moved;
    }
    expect_full_pass_bits(p, pos, nor);
    EXPECT_GT(moved_total, 100u);
}

// Stamps on the ground's edges and corners, where a point's faces do not close around it: a neighbour it
// shares one face with is that face's next corner or its previous one, not both, and an update must renormalise
// it either way (the update's sweep marks both; with the next corners alone this test fails).
TEST(DisplacedGround, IncrementalUpdatesAtTheGroundsEdgesEqualAFullPass) {
    Prepared p;
    std::vector<float> pos, nor;
    displaced_hill(p, 100, pos, nor);
    const double e = 1.98;
    size_t shifted_total = 0;
    for (const auto& [x, z] : std::vector<std::pair<double, double>>{{-e, 0.3}, {e, -0.4}, {0.2, -e}, {-0.5, e}, {-e, -e}, {e, e}, {e, -e}, {-e, e}}) {
        ASSERT_TRUE(p.field.stamp(sphere(0.15, {}), ColliderPose{{x, hill_height(x, z) + 0.1, z}, 0, 0}).ok());
        DisplaceUpdateStats st;
        (void)p.dg.update(p.field.heightmap(), p.field.update(), pos.data(), nor.data(), &st);
        EXPECT_GT(st.shifted, 0u) << x << " " << z;
        shifted_total += st.shifted;
        expect_full_pass_bits(p, pos, nor);
    }
    EXPECT_GT(shifted_total, 50u);
}

// DisplaceUpdateStats accounts for what an update did: its moved count is the result; the shifted points are
// those whose buffer entries changed; every corner of a recomputed face is renormalised; the same rectangles
// again, with nothing changed, shift nothing and recompute nothing.
TEST(DisplacedGround, UpdateStatsCountTheWorkDone) {
    Prepared p;
    std::vector<float> pos, nor;
    displaced_hill(p, 100, pos, nor);
    ASSERT_TRUE(p.field.stamp(sphere(0.15, {}), ColliderPose{{0.3, hill_height(0.3, -0.2) + 0.1, -0.2}, 0, 0}).ok());
    const auto r = p.field.update();
    const std::vector<float> before = pos;
    DisplaceUpdateStats st;
    const size_t moved = p.dg.update(p.field.heightmap(), r, pos.data(), nor.data(), &st);
    EXPECT_EQ(st.moved, moved);
    EXPECT_GT(st.shifted, 0u);
    EXPECT_LT(st.shifted, st.moved); // a dirty rectangle is not dirty everywhere
    // Only a shifted point's vertex can change in the buffer (the hill has no seams: a vertex per point); not
    // every one does, a change in double may round to the same float.
    ASSERT_EQ(p.dg.welded_count(), p.dg.vertex_count());
    size_t changed = 0;
    for (size_t v = 0; 3 * v < pos.size(); ++v)
        changed += !std::equal(&pos[3 * v], &pos[3 * v] + 3, &before[3 * v]);
    EXPECT_GT(changed, 0u);
    EXPECT_LE(changed, st.shifted);
    EXPECT_GT(st.faces, 0u);
    EXPECT_GE(st.normals, st.shifted);
    for (double s : {st.search_seconds, st.displace_seconds, st.sweep_seconds, st.terms_seconds, st.normals_seconds}) EXPECT_GE(s, 0.0);
    DisplaceUpdateStats again;
    EXPECT_EQ(p.dg.update(p.field.heightmap(), r, pos.data(), nor.data(), &again), moved);
    EXPECT_EQ(again.moved, moved);
    EXPECT_EQ(again.shifted, 0u);
    EXPECT_EQ(again.faces, 0u);
    EXPECT_EQ(again.normals, 0u);
    expect_full_pass_bits(p, pos, nor);
}

// keep_face_terms = false (the one-shot path of `furrow stamp`, which keeps no per-face cache) gives the same
// bits as the cached path, in displace_all and in the updates that follow it.
TEST(DisplacedGround, WithoutTheFaceTermCacheTheSameBits) {
    Prepared cached, lean;
    cached.ground = lean.ground = hill_ground(4, 60);
    prepare(cached);
    DisplaceOptions o;
    o.keep_face_terms = false;
    prepare(lean, o);
    const size_t n = cached.ground.positions.size();
    std::vector<float> pa(n), na(n), pb(n), nb(n);
    for (Prepared* p : {&cached, &lean}) {
        ASSERT_TRUE(p->field.add_collider(sphere(0.3, {{0.2, hill_height(0.2, 0.1) + 0.1, 0.1}})).ok());
        p->field.update();
    }
    cached.dg.displace_all(cached.field.heightmap(), pa.data(), na.data());
    lean.dg.displace_all(lean.field.heightmap(), pb.data(), nb.data());
    EXPECT_EQ(pa, pb);
    EXPECT_EQ(na, nb);
    size_t moved = 0;
    for (size_t i = 1; i < n; i += 3) moved += pa[i] != cached.ground.positions[i];
    EXPECT_GT(moved, 10u); // the collider moved points: the normals compared are not all the rest's
    for (Prepared* p : {&cached, &lean}) {
        ASSERT_TRUE(p->field.stamp(sphere(0.15, {}), ColliderPose{{-0.5, hill_height(-0.5, 0.4) + 0.1, 0.4}, 0, 0}).ok());
    }
    const auto ra = cached.field.update(), rb = lean.field.update();
    EXPECT_GT(cached.dg.update(cached.field.heightmap(), ra, pa.data(), na.data()), 0u);
    EXPECT_GT(lean.dg.update(lean.field.heightmap(), rb, pb.data(), nb.data()), 0u);
    EXPECT_EQ(pa, pb);
    EXPECT_EQ(na, nb);
}

// An update() straight after prepare(), with no displace_all() before it, starts from the rest positions:
// the points it does not move keep them (prepare() leaves the current positions unwritten, and the first update
// copies the rest positions in; displace_all() writes them all without that copy). The reference moves every
// point by a zero heightmap first, which leaves every position at its rest bits; both then take the same
// stamp, into buffers holding that zero pass. With and without the face-term cache.
TEST(DisplacedGround, AnUpdateStraightAfterPrepareStartsFromTheRestPositions) {
    for (bool keep : {true, false}) {
        DisplaceOptions o;
        o.keep_face_terms = keep;
        Prepared ref, direct;
        ref.ground = direct.ground = hill_ground(4, 40);
        prepare(ref, o);
        prepare(direct, o);
        ASSERT_TRUE(ref.field.stamp(sphere(0.3, {}), ColliderPose{{0.2, hill_height(0.2, 0.1) + 0.1, 0.1}, 0, 0}).ok());
        const std::vector<TexelRect> dirty = ref.field.update();
        ASSERT_FALSE(dirty.empty());
        Heightmap zero = ref.field.heightmap();
        std::fill(zero.values.begin(), zero.values.end(), 0.0f);
        std::vector<float> pos(ref.ground.positions.size(), -1.0f), nor(pos.size(), -1.0f);
        ref.dg.displace_all(zero, pos.data(), nor.data());
        EXPECT_EQ(pos, ref.ground.positions); // the zero pass left every point where it was
        std::vector<float> direct_pos = pos, direct_nor = nor;
        const size_t moved = ref.dg.update(ref.field.heightmap(), dirty, pos.data(), nor.data());
        EXPECT_GT(moved, 10u);
        EXPECT_EQ(direct.dg.update(ref.field.heightmap(), dirty, direct_pos.data(), direct_nor.data()), moved);
        EXPECT_EQ(direct_pos, pos);
        EXPECT_EQ(direct_nor, nor);
        EXPECT_NE(pos, ref.ground.positions); // the stamp moved points
    }
}

// prepare() on a prepared ground takes over its old storage when the new mesh fits in it and needs at least
// half of it (no page faults: see Arena in displaced_ground.cpp). Each re-prepare, into the old block or a new
// one, with and without the face-term cache, gives the bits of a fresh object, in displace_all and in an
// update after it.
TEST(DisplacedGround, RePrepareGivesTheBitsOfAFreshObject) {
    struct Case {
        Prepared p;
        Heightmap before, after; // a collider's imprint, then a second stamp
        std::vector<TexelRect> dirty;
    };
    Case big, small;
    big.p.ground = hill_ground(4, 100);
    small.p.ground = hill_ground(4, 50);
    for (Case* c : {&big, &small}) {
        prepare(c->p);
        ASSERT_TRUE(c->p.field.add_collider(sphere(0.3, {{0.2, hill_height(0.2, 0.1) + 0.1, 0.1}})).ok());
        c->p.field.update();
        c->before = c->p.field.heightmap();
        ASSERT_TRUE(c->p.field.stamp(sphere(0.15, {}), ColliderPose{{-0.5, hill_height(-0.5, 0.4) + 0.1, 0.4}, 0, 0}).ok());
        c->dirty = c->p.field.update();
        c->after = c->p.field.heightmap();
    }
    auto run = [](DisplacedGround& dg, const Case& c, const DisplaceOptions& o, std::vector<float>& pos, std::vector<float>& nor) {
        const Primitive& g = c.p.ground;
        ASSERT_TRUE(dg.prepare(g.positions.data(), g.vertex_count(), g.indices.data(), g.indices.size(), c.p.field.frame(), o).ok());
        pos.assign(g.positions.size(), -1.0f);
        nor.assign(g.positions.size(), -1.0f);
        dg.displace_all(c.before, pos.data(), nor.data());
        EXPECT_GT(dg.update(c.after, c.dirty, pos.data(), nor.data()), 0u);
    };
    DisplaceOptions lean;
    lean.keep_face_terms = false;
    DisplacedGround reused; // prepared in turn on each case below: it takes over its block from big to big,
                            // small to small and to small without the cache, and not from big to small (4x)
    const std::vector<std::pair<const Case*, DisplaceOptions>> order = {{&big, {}},    {&big, {}},   {&small, {}},
                                                                        {&small, {}},  {&small, lean}, {&big, lean}};
    for (const auto& [c, o] : order) {
        std::vector<float> pos, nor, fresh_pos, fresh_nor;
        run(reused, *c, o, pos, nor);
        DisplacedGround fresh;
        run(fresh, *c, o, fresh_pos, fresh_nor);
        EXPECT_EQ(reused.welded_count(), fresh.welded_count());
        EXPECT_EQ(pos, fresh_pos);
        EXPECT_EQ(nor, fresh_nor);
        size_t moved = 0;
        for (size_t i = 1; i < pos.size(); i += 3) moved += pos[i] != c->p.ground.positions[i];
        EXPECT_GT(moved, 10u); // the heightmaps moved points: the normals compared are not all the rest's
    }
}

TEST(DisplacedGround, SeamCopiesMoveTogether) {
    Prepared p;
    p.ground = seam_ground(4, 40);
    prepare(p);
    ASSERT_TRUE(p.field.add_collider(sphere(0.4, {{0.0, 0.3, -1}, {0.0, 0.3, 1}})).ok()); // along the seam
    p.field.update();
    const size_t n = p.ground.positions.size();
    std::vector<float> pos(n), nor(n);
    p.dg.displace_all(p.field.heightmap(), pos.data(), nor.data());
    EXPECT_EQ(p.dg.welded_count(), size_t(41 * 41));
    // Every seam copy has exactly the position and normal of its original.
    const size_t grid = 41 * 41;
    size_t moved = 0;
    for (size_t c = grid; c < p.ground.vertex_count(); ++c) {
        const size_t j = c - grid, v = j * 41 + 20;
        for (int d = 0; d < 3; ++d) {
            EXPECT_EQ(pos[3 * c + size_t(d)], pos[3 * v + size_t(d)]);
            EXPECT_EQ(nor[3 * c + size_t(d)], nor[3 * v + size_t(d)]);
        }
        moved += pos[3 * v + 1] < -0.01f;
    }
    EXPECT_GT(moved, 10u);
    // Welded, the displaced mesh is still one open sheet with one boundary.
    Primitive out = p.ground;
    out.positions = pos;
    out.normals = nor;
    CheckReport r = check_primitive(out);
    EXPECT_EQ(r.boundary_loops, 1u);
    EXPECT_EQ(r.non_manifold_edges, 0u);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.boundary_edges, size_t(4 * 40));
}

TEST(DisplacedGround, AlongUpMatchesTheHeightmapExactly) {
    Prepared p;
    p.ground = hill_ground(4, 80);
    DisplaceOptions o;
    o.along_up = true;
    prepare(p, o);
    ASSERT_TRUE(p.field.add_collider(sphere(0.3, {{0.5, hill_height(0.5, 0.5) + 0.2, 0.5}})).ok());
    p.field.update();
    const size_t n = p.ground.positions.size();
    std::vector<float> pos(n), nor(n);
    p.dg.displace_all(p.field.heightmap(), pos.data(), nor.data());
    for (size_t v = 0; v < p.ground.vertex_count(); ++v) {
        EXPECT_EQ(pos[3 * v], p.ground.positions[3 * v]);
        EXPECT_EQ(pos[3 * v + 2], p.ground.positions[3 * v + 2]);
        const double q[3] = {p.ground.positions[3 * v], 0, p.ground.positions[3 * v + 2]};
        EXPECT_NEAR(pos[3 * v + 1] - p.ground.positions[3 * v + 1], p.field.heightmap().sample_world(q), 1e-6);
        const double len = std::hypot(nor[3 * v], nor[3 * v + 1], nor[3 * v + 2]);
        EXPECT_NEAR(len, 1.0, 1e-6);
    }
}

TEST(DisplacedGround, NormalsAreThoseOfTheMeshLibrary) {
    Prepared p;
    p.ground = hill_ground(4, 60);
    prepare(p);
    ASSERT_TRUE(p.field.add_collider(box({0.5, 0.3, 0.5}, 10, {{-0.4, hill_height(-0.4, 0.2) + 0.1, 0.2}})).ok());
    p.field.update();
    const size_t n = p.ground.positions.size();
    std::vector<float> pos(n), nor(n), ref(n);
    p.dg.displace_all(p.field.heightmap(), pos.data(), nor.data());
    compute_vertex_normals(ref.data(), pos.data(), p.ground.vertex_count(), p.ground.indices.data(), p.ground.indices.size());
    for (size_t k = 0; k < n; ++k) EXPECT_NEAR(nor[k], ref[k], 1e-5);
}

// A point's normal sums its faces' terms in the input's triangle order, whatever numbering prepare() gives
// the welded points (today: order of first appearance): the output cannot depend on how the input's
// vertices are numbered. The same mesh with its vertices shuffled (the triangles in the same order) gives,
// vertex for vertex, the same bits, in displace_all and in an update. (Checked to fail with the points
// numbered by heightmap tile and each point's faces listed in that internal order.)
TEST(DisplacedGround, OutputDoesNotDependOnTheVertexNumbering) {
    Prepared a, b;
    a.ground = hill_ground(4, 60);
    b.ground = a.ground;
    const size_t V = a.ground.vertex_count();
    std::vector<uint32_t> to(V); // a vertex's number in b
    std::iota(to.begin(), to.end(), 0u);
    std::shuffle(to.begin(), to.end(), std::mt19937(5));
    for (size_t v = 0; v < V; ++v)
        for (int d = 0; d < 3; ++d) b.ground.positions[3 * size_t(to[v]) + size_t(d)] = a.ground.positions[3 * v + size_t(d)];
    for (uint32_t& i : b.ground.indices) i = to[i];
    prepare(a);
    prepare(b);
    std::vector<float> pa(3 * V), na(3 * V), pb(3 * V), nb(3 * V);
    auto same = [&] {
        size_t differ = 0;
        for (size_t v = 0; v < V; ++v)
            for (int d = 0; d < 3; ++d)
                differ += pa[3 * v + size_t(d)] != pb[3 * size_t(to[v]) + size_t(d)] || na[3 * v + size_t(d)] != nb[3 * size_t(to[v]) + size_t(d)];
        return differ;
    };
    for (Prepared* p : {&a, &b}) {
        ASSERT_TRUE(p->field.add_collider(sphere(0.3, {{0.2, hill_height(0.2, 0.1) + 0.1, 0.1}})).ok());
        p->field.update();
    }
    a.dg.displace_all(a.field.heightmap(), pa.data(), na.data());
    b.dg.displace_all(b.field.heightmap(), pb.data(), nb.data());
    EXPECT_EQ(same(), 0u);
    for (Prepared* p : {&a, &b})
        ASSERT_TRUE(p->field.stamp(sphere(0.15, {}), ColliderPose{{-0.5, hill_height(-0.5, 0.4) + 0.1, 0.4}, 0, 0}).ok());
    const auto ra = a.field.update(), rb = b.field.update();
    EXPECT_GT(a.dg.update(a.field.heightmap(), ra, pa.data(), na.data()), 0u);
    EXPECT_GT(b.dg.update(b.field.heightmap(), rb, pb.data(), nb.data()), 0u);
    EXPECT_EQ(same(), 0u);
}

TEST(DisplacedGround, TopOnlyLeavesTheUndersideAlone) {
    // A flat ground with a small roof above it: stamping the roof region must not move the floor below.
    Primitive g = flat_ground(4, 40);
    const uint32_t b = uint32_t(g.vertex_count());
    // Roof at y = 0.5 over [-0.5, 0.5]², facing up, stamped by a sphere resting on it.
    g.positions.insert(g.positions.end(), {-0.5f, 0.5f, -0.5f, -0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, -0.5f});
    g.indices.insert(g.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
    Prepared p;
    p.ground = g;
    DisplaceOptions o;
    o.top_only = true;
    prepare(p, o);
    ASSERT_TRUE(p.field.add_collider(sphere(0.2, {{0, 0.65, 0}})).ok());
    p.field.update();
    std::vector<float> pos(g.positions.size()), nor(g.positions.size());
    p.dg.displace_all(p.field.heightmap(), pos.data(), nor.data());
    for (size_t v = 0; v < b; ++v) EXPECT_EQ(pos[3 * v + 1], 0.0f) << v; // the floor under the roof is untouched
}


// On one thread a full pass keeps no face terms (the first update computes them all): an update that follows
// an update, then a full pass of another heightmap, must start from that heightmap's terms, not the older
// ones it kept. Update, full pass, update again: the bits of a fresh object's full pass. (Checked to fail when
// the update only recomputes terms it does not have.)
TEST(DisplacedGround, AnUpdateAfterAOneThreadFullPassStartsFromItsTerms) {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    Prepared p;
    std::vector<float> pos, nor;
    displaced_hill(p, 80, pos, nor);
    auto stamp = [&](double x, double z) {
        EXPECT_TRUE(p.field.stamp(sphere(0.25, {}), ColliderPose{{x, hill_height(x, z) + 0.1, z}, 0, 0}).ok());
        return p.field.update();
    };
    EXPECT_GT(p.dg.update(p.field.heightmap(), stamp(0.3, 0.2), pos.data(), nor.data()), 0u); // terms computed
    stamp(-0.4, 0.5);
    p.dg.displace_all(p.field.heightmap(), pos.data(), nor.data()); // the kept terms are now stale
    EXPECT_GT(p.dg.update(p.field.heightmap(), stamp(-0.1, -0.6), pos.data(), nor.data()), 0u);
    expect_full_pass_bits(p, pos, nor);
}
// On one thread the normals are summed in one pass over the faces (scattered_normals), on more each point
// gathers its faces' terms: the same bits, with and without the face-term cache, in displace_all and in the
// updates after it, on a ground with a zero-area (collinear) and a sliver triangle added.
TEST(DisplacedGround, OneThreadAndTwoThreadsGiveTheSameBits) {
    Primitive g = hill_ground(4, 60);
    const uint32_t base = uint32_t(g.vertex_count());
    const float line[] = {0.1f, 0.0f, 0.1f, 0.2f, 0.0f, 0.2f, 0.3f, 0.0f, 0.3f,  // collinear
                          0.4f, 0.0f, 0.4f, 0.6f, 0.0f, 0.4f, 0.5f, 1e-7f, 0.4f}; // a sliver
    for (float v : line) g.positions.push_back(v);
    if (!g.normals.empty()) g.normals.resize(g.positions.size(), 0.0f);
    if (!g.uv0.empty()) g.uv0.resize(2 * g.vertex_count(), 0.0f);
    for (uint32_t k = 0; k < 6; ++k) g.indices.push_back(base + k);
    for (bool keep : {true, false}) {
        SCOPED_TRACE(keep ? "face terms kept" : "no face-term cache");
        std::vector<float> pos[2], nor[2];
        for (int threads : {1, 2}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
            Prepared p;
            p.ground = g;
            DisplaceOptions o;
            o.keep_face_terms = keep;
            prepare(p, o);
            ASSERT_TRUE(p.field.add_collider(sphere(0.3, {{0.2, hill_height(0.2, 0.1) + 0.1, 0.1}})).ok());
            p.field.update();
            std::vector<float>& P = pos[threads - 1];
            std::vector<float>& N = nor[threads - 1];
            P.assign(g.positions.size(), 0.0f), N.assign(g.positions.size(), 0.0f);
            p.dg.displace_all(p.field.heightmap(), P.data(), N.data());
            ASSERT_TRUE(p.field.stamp(sphere(0.15, {}), ColliderPose{{-0.5, hill_height(-0.5, 0.4) + 0.1, 0.4}, 0, 0}).ok());
            EXPECT_GT(p.dg.update(p.field.heightmap(), p.field.update(), P.data(), N.data()), 0u);
        }
        EXPECT_EQ(pos[0], pos[1]);
        EXPECT_EQ(nor[0], nor[1]);
        size_t moved = 0;
        for (size_t i = 1; i < g.positions.size(); i += 3) moved += pos[0][i] != g.positions[i];
        EXPECT_GT(moved, 10u);
    }
}

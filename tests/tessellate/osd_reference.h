// An independent reference for the tessellate tests: uniform refinement with OpenSubdiv's Far::PrimvarRefiner
// and projection of the refined vertices to the limit surface (Far, not Bfr: a different code path).
#pragma once

#include <furrow/mesh.h>

#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <vector>

namespace furrow::test {

struct RefVertex {
    float p[3] = {0, 0, 0};
    void Clear(void* = nullptr) { p[0] = p[1] = p[2] = 0; }
    void AddWithWeight(const RefVertex& s, float w) {
        p[0] += w * s.p[0];
        p[1] += w * s.p[1];
        p[2] += w * s.p[2];
    }
};

// Limit positions of the vertices of a uniform refinement to `level` of a welded polygon mesh.
// deep_levels > 0: at interior vertices of valence 2 the limit is taken as the vertex after `deep_levels`
// uniform levels instead (converging to the limit point by refinement alone): OpenSubdiv 3.5.0's limit
// mask there is off by ~1e-2 of the face size (measured against 9 levels), the refined vertex is not.
inline std::vector<std::array<float, 3>> far_limit_points(const std::vector<float>& positions,
                                                          const std::vector<uint32_t>& indices,
                                                          const std::vector<uint32_t>& face_sizes,
                                                          OpenSubdiv::Sdc::SchemeType scheme, int level, int deep_levels = 0) {
    using namespace OpenSubdiv;
    std::vector<int> vpf(face_sizes.begin(), face_sizes.end()), idx(indices.begin(), indices.end());
    Far::TopologyDescriptor desc;
    desc.numVertices = int(positions.size() / 3);
    desc.numFaces = int(vpf.size());
    desc.numVertsPerFace = vpf.data();
    desc.vertIndicesPerFace = idx.data();
    Sdc::Options sdc;
    sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
    std::unique_ptr<Far::TopologyRefiner> refiner(Far::TopologyRefinerFactory<Far::TopologyDescriptor>::Create(
        desc, Far::TopologyRefinerFactory<Far::TopologyDescriptor>::Options(scheme, sdc)));
    if (!refiner) return {};
    Far::TopologyRefiner::UniformOptions uniform(level);
    uniform.fullTopologyInLastLevel = true; // Limit() needs the last level's edges
    refiner->RefineUniform(uniform);
    std::vector<RefVertex> src(positions.size() / 3);
    for (size_t v = 0; v < src.size(); ++v) std::copy_n(&positions[v * 3], 3, src[v].p);
    Far::PrimvarRefiner primvar(*refiner);
    for (int l = 1; l <= level; ++l) {
        std::vector<RefVertex> dst(size_t(refiner->GetLevel(l).GetNumVertices()));
        RefVertex* s = src.data();
        RefVertex* d = dst.data();
        primvar.Interpolate(l, s, d);
        src.swap(dst);
    }
    std::vector<RefVertex> limit(src.size());
    RefVertex* s = src.data();
    RefVertex* d = limit.data();
    primvar.Limit(s, d);
    std::vector<std::array<float, 3>> out(limit.size());
    for (size_t v = 0; v < limit.size(); ++v) out[v] = {limit[v].p[0], limit[v].p[1], limit[v].p[2]};
    if (deep_levels <= level) return out;
    // Interior valence-2 base vertices, followed down both refinements.
    const Far::TopologyLevel& base = refiner->GetLevel(0);
    std::vector<int> valence2;
    for (int v = 0; v < base.GetNumVertices(); ++v)
        if (base.GetVertexEdges(v).size() == 2 && !base.IsVertexBoundary(v)) valence2.push_back(v);
    if (valence2.empty()) return out;
    std::unique_ptr<Far::TopologyRefiner> deep(Far::TopologyRefinerFactory<Far::TopologyDescriptor>::Create(
        desc, Far::TopologyRefinerFactory<Far::TopologyDescriptor>::Options(scheme, sdc)));
    deep->RefineUniform(Far::TopologyRefiner::UniformOptions(deep_levels));
    std::vector<RefVertex> cur(positions.size() / 3);
    for (size_t v = 0; v < cur.size(); ++v) std::copy_n(&positions[v * 3], 3, cur[v].p);
    Far::PrimvarRefiner deep_primvar(*deep);
    std::vector<int> at_level = valence2, at_deep = valence2;
    for (int l = 1; l <= deep_levels; ++l) {
        std::vector<RefVertex> next(size_t(deep->GetLevel(l).GetNumVertices()));
        RefVertex* s2 = cur.data();
        RefVertex* d2 = next.data();
        deep_primvar.Interpolate(l, s2, d2);
        cur.swap(next);
        for (int& v : at_deep) v = deep->GetLevel(l - 1).GetVertexChildVertex(v);
        if (l <= level)
            for (int& v : at_level) v = refiner->GetLevel(l - 1).GetVertexChildVertex(v);
    }
    for (size_t k = 0; k < valence2.size(); ++k) {
        const RefVertex& q = cur[size_t(at_deep[k])];
        out[size_t(at_level[k])] = {q.p[0], q.p[1], q.p[2]};
    }
    return out;
}

// Largest distance from any point of `a` to its nearest point in `b` (brute force; small sets).
inline double max_nearest_distance(const std::vector<std::array<float, 3>>& a, const std::vector<std::array<float, 3>>& b) {
    double worst = 0;
    for (const auto& p : a) {
        double best = INFINITY;
        for (const auto& q : b) {
            double d = 0;
            for (int k = 0; k < 3; ++k) d += (double(p[size_t(k)]) - q[size_t(k)]) * (double(p[size_t(k)]) - q[size_t(k)]);
            best = std::min(best, d);
        }
        worst = std::max(worst, std::sqrt(best));
    }
    return worst;
}

inline std::vector<std::array<float, 3>> unique_points(const std::vector<float>& positions) {
    std::vector<std::array<float, 3>> out;
    for (size_t v = 0; v < positions.size() / 3; ++v) out.push_back({positions[v * 3], positions[v * 3 + 1], positions[v * 3 + 2]});
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

inline double diagonal_of(const std::vector<float>& positions) {
    std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < positions.size() / 3; ++v)
        for (int k = 0; k < 3; ++k) {
            lo[size_t(k)] = std::min(lo[size_t(k)], double(positions[v * 3 + size_t(k)]));
            hi[size_t(k)] = std::max(hi[size_t(k)], double(positions[v * 3 + size_t(k)]));
        }
    return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

} // namespace furrow::test

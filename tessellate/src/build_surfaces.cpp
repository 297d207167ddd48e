// The OpenSubdiv side of preparation: a Far::TopologyRefiner over the smooth faces and a Bfr surface factory.
//
// References: OpenSubdiv 3.5 documentation, "Bfr Overview" and tutorials bfr 1.1-2.2 (topology descriptor,
// RefinerSurfaceFactory, thread-safe SurfaceFactoryCacheThreaded). Sdc options are always set explicitly:
// OpenSubdiv's defaults (VTX_BOUNDARY_NONE, FVAR_LINEAR_ALL) would drop every boundary face and flatten UVs.
//
// Every smooth face is tried once here; a face OpenSubdiv gives no surface for is tessellated linearly, so
// that evaluation never meets a failure and ownership of shared points can be decided before it.
#include "tessellate_internal.h"

#include <opensubdiv/far/error.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <string>

namespace furrow::tessellate_detail {
namespace {

// OpenSubdiv reports topology errors through a global callback that prints by default; our contract is one
// error line, so they are collected instead (the last one is kept for the warning).
std::mutex g_far_error_mutex;
std::string g_far_error;
void far_error(osd::Far::ErrorType, const char* message) {
    std::lock_guard<std::mutex> lock(g_far_error_mutex);
    g_far_error = message ? message : "";
}
void far_warning(const char*) {}

osd::Sdc::Options::FVarLinearInterpolation fvar_rule(UvInterpolation u) {
    using O = osd::Sdc::Options;
    switch (u) {
    case UvInterpolation::smooth: return O::FVAR_LINEAR_NONE;
    case UvInterpolation::corners_only: return O::FVAR_LINEAR_CORNERS_ONLY;
    case UvInterpolation::corners_plus1: return O::FVAR_LINEAR_CORNERS_PLUS1;
    case UvInterpolation::corners_plus2: return O::FVAR_LINEAR_CORNERS_PLUS2;
    case UvInterpolation::boundaries: return O::FVAR_LINEAR_BOUNDARIES;
    case UvInterpolation::linear: return O::FVAR_LINEAR_ALL;
    }
    return O::FVAR_LINEAR_CORNERS_ONLY;
}

// OpenSubdiv 3.5.0's Bfr reads out of bounds (and crashed under the tessellate fuzzer) when it builds the
// irregular patch of a face at an interior valence-2 vertex whose corners also touch an infinitely sharp
// edge: the valence-2 fold sends it down the builder's "overlapping neighbourhood" branch, which mishandles
// sharp edges there (the same branch PR 1301 fixed for semi-sharp edges in 3.5.1). Checked with valgrind on
// the kept input: any crease on an edge at one of the face's corners triggers it, a crease elsewhere does
// not, and neighbouring faces evaluate cleanly. Such faces are tessellated linearly instead (counted as
// failed faces, with their own warning); the smooth neighbours own the shared points, so no crack opens.
// Returns how many faces it took out.
size_t keep_valence2_faces_off_creases(PreparedMesh& m, const std::vector<int>& crease_pairs) {
    if (crease_pairs.empty()) return 0;
    std::vector<uint8_t> at_crease(m.refiner_vertex_welded.size(), 0);
    for (int v : crease_pairs) at_crease[size_t(v)] = 1;
    size_t taken = 0;
    for (size_t f = 0; f < m.face_count(); ++f) {
        if (m.face_refiner[f] < 0 || !m.face_uncached[f]) continue;
        bool touches = false;
        for (uint32_t c = m.face_offset[f]; c < m.face_offset[f + 1]; ++c) touches |= at_crease[m.corner_refiner_vertex[c]] != 0;
        if (!touches) continue;
        m.face_linear[f] = 1;
        m.face_refiner[f] = -1;
        ++m.stats.failed_faces;
        ++taken;
    }
    if (taken)
        m.stats.warnings.push_back(std::to_string(taken) + " faces at valence-2 vertices next to a crease tessellated "
                                   "linearly (OpenSubdiv 3.5.0 cannot build their limit surface)");
    return taken;
}

// The last stage of build_surfaces: every smooth face's limit surface made once (a face OpenSubdiv cannot
// make goes linear), the regular interior ones marked, with their 16 control points kept.
void init_face_surfaces(PreparedMesh& m, const std::vector<int>& crease_pairs) {
    const size_t F = m.face_count();
    const size_t unsafe = keep_valence2_faces_off_creases(m, crease_pairs);
    std::vector<uint8_t> failed(F, 0);
    m.face_regular_interior.assign(F, 0);
    // Only quads are regular patches (Catmull-Clark, bilinear): no room kept on a mesh without them.
    bool quads = m.scheme != osd::Sdc::SCHEME_LOOP;
    if (quads) {
        quads = false;
        for (size_t f = 0; f < F && !quads; ++f) quads = m.face_size(f) == 4;
    }
    m.regular_control.assign(quads ? F * regular_points : 0, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, F, 256), [&](const tbb::blocked_range<size_t>& range) {
        Surface vtx, fvar;
        for (size_t f = range.begin(); f != range.end(); ++f) {
            if (m.face_refiner[f] < 0) continue;
            bool ok = m.factory_of(f).InitVertexSurface(m.face_refiner[f], &vtx);
            if (ok && m.K > 0) ok = m.factory_of(f).InitFaceVaryingSurface(m.face_refiner[f], &fvar);
            if (!ok) failed[f] = 1;
            m.face_regular[f] = ok && vtx.IsRegular() && !vtx.IsLinear();
            // Kept so that the evaluation needs no second InitVertexSurface for them (most faces of a quad mesh).
            int control[regular_points];
            if (quads && m.face_regular[f] && regular_interior(vtx, m.parameterization(f)) &&
                vtx.GetControlPointIndices(control) == regular_points) {
                m.face_regular_interior[f] = 1;
                std::copy_n(control, regular_points, &m.regular_control[f * regular_points]);
            }
        }
    });
    for (size_t f = 0; f < F; ++f)
        if (failed[f]) {
            m.face_linear[f] = 1;
            ++m.stats.failed_faces;
        }
    if (m.stats.failed_faces > unsafe)
        m.stats.warnings.push_back(std::to_string(m.stats.failed_faces - unsafe) +
                                   " faces have no limit surface in OpenSubdiv; tessellated linearly");
}

} // namespace

Status build_surfaces(PreparedMesh& m) {
    static std::once_flag once;
    std::call_once(once, [] {
        osd::Far::SetErrorCallback(far_error);
        osd::Far::SetWarningCallback(far_warning);
    });
    const size_t F = m.face_count();
    m.face_refiner.assign(F, -1);
    m.face_regular.assign(F, 0);
    std::vector<int> verts_per_face, vert_indices, fvar_indices;
    std::vector<uint32_t> fvar_of_value(m.value_attrs.size() / std::max(1, m.K) + 1, none);
    std::vector<uint32_t> fvar_values;
    int smooth_faces = 0;
    for (size_t f = 0; f < F; ++f) {
        if (!m.smooth(f)) continue;
        m.face_refiner[f] = smooth_faces++;
        verts_per_face.push_back(int(m.face_size(f)));
        for (uint32_t c = m.face_offset[f]; c < m.face_offset[f + 1]; ++c) {
            vert_indices.push_back(int(m.corner_refiner_vertex[c]));
            if (m.K > 0) {
                uint32_t& id = fvar_of_value[m.corner_value[c]];
                if (id == none) {
                    id = uint32_t(fvar_values.size());
                    fvar_values.push_back(m.corner_value[c]);
                }
                fvar_indices.push_back(int(id));
            }
        }
    }
    std::vector<int> crease_pairs;
    std::vector<float> crease_weights;
    for (size_t e = 0; e < m.edges.size(); ++e) {
        if (!m.edge_crease[e] || m.edge_side_begin[e + 1] - m.edge_side_begin[e] != 2) continue;
        const uint32_t c1 = m.side_corner[m.edge_side_begin[e]], c2 = m.side_corner[m.edge_side_begin[e] + 1];
        if (!m.smooth(m.corner_face[c1]) || !m.smooth(m.corner_face[c2])) continue;
        crease_pairs.push_back(int(m.corner_refiner_vertex[c1]));
        crease_pairs.push_back(int(m.corner_refiner_vertex[m.next_corner(c1)]));
        crease_weights.push_back(osd::Sdc::Crease::SHARPNESS_INFINITE);
    }
    if (smooth_faces == 0) return Status::success();

    osd::Far::TopologyDescriptor desc;
    desc.numVertices = int(m.refiner_vertex_welded.size());
    desc.numFaces = smooth_faces;
    desc.numVertsPerFace = verts_per_face.data();
    desc.vertIndicesPerFace = vert_indices.data();
    desc.numCreases = int(crease_weights.size());
    desc.creaseVertexIndexPairs = crease_pairs.data();
    desc.creaseWeights = crease_weights.data();
    osd::Far::TopologyDescriptor::FVarChannel channel;
    if (m.K > 0) {
        channel.numValues = int(fvar_values.size());
        channel.valueIndices = fvar_indices.data();
        desc.numFVarChannels = 1;
        desc.fvarChannels = &channel;
    }
    osd::Sdc::Options sdc;
    sdc.SetVtxBoundaryInterpolation(m.options.boundary == BoundaryInterpolation::edge_only
                                        ? osd::Sdc::Options::VTX_BOUNDARY_EDGE_ONLY
                                        : osd::Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
    sdc.SetFVarLinearInterpolation(fvar_rule(m.options.uv_interpolation));
    using Factory = osd::Far::TopologyRefinerFactory<osd::Far::TopologyDescriptor>;
    m.refiner.reset(Factory::Create(desc, Factory::Options(m.scheme, sdc)));
    if (!m.refiner) {
        std::string why;
        {
            std::lock_guard<std::mutex> lock(g_far_error_mutex);
            why = g_far_error;
        }
        m.stats.warnings.push_back("OpenSubdiv rejected the topology (" + why + "); all faces tessellated linearly");
        for (size_t f = 0; f < F; ++f) {
            if (m.smooth(f)) ++m.stats.failed_faces;
            m.face_linear[f] = 1;
            m.face_refiner[f] = -1;
        }
        return Status::success();
    }
    m.refiner_data.resize(m.refiner_vertex_welded.size() * size_t(m.W));
    for (size_t r = 0; r < m.refiner_vertex_welded.size(); ++r)
        std::copy_n(&m.welded_data[size_t(m.refiner_vertex_welded[r]) * size_t(m.W)], m.W, &m.refiner_data[r * size_t(m.W)]);
    m.refiner_fvar.resize(fvar_values.size() * size_t(m.K));
    for (size_t i = 0; i < fvar_values.size(); ++i)
        std::copy_n(&m.value_attrs[size_t(fvar_values[i]) * size_t(m.K)], m.K, &m.refiner_fvar[i * size_t(m.K)]);

    SurfaceFactory::Options fo;
    fo.SetApproxLevelSmooth(m.options.accuracy);
    fo.SetApproxLevelSharp(std::max(6, m.options.accuracy));
    if (m.K > 0) fo.SetDefaultFVarID(0);
    m.factory = std::make_unique<SurfaceFactory>(*m.refiner, fo);
    fo.EnableCaching(false);
    m.factory_uncached = std::make_unique<SurfaceFactory>(*m.refiner, fo);

    init_face_surfaces(m, crease_pairs);
    return Status::success();
}

// True if the surface is a regular B-spline patch with no boundary: at an interior (u, v) every one of the 16
// basis weights is non-zero, while a boundary folds the phantom points' weights into others and sets them to
// zero (Far's boundary-adjusted B-spline basis).
bool regular_interior(const Surface& s, const osd::Bfr::Parameterization& param) {
    if (!s.IsRegular() || s.GetNumControlPoints() != regular_points ||
        param.GetType() != osd::Bfr::Parameterization::QUAD)
        return false;
    float w[regular_points];
    const float probe[2] = {0.375f, 0.625f};
    if (s.EvaluateStencil(probe, w) != regular_points) return false;
    for (float x : w)
        if (x == 0.0f) return false;
    return true;
}

namespace {

// Where the limit surface is smooth across a shared point (a normal sector, or an edge that is no crease),
// every face has the same normal there, and where the faces are regular B-spline patches their evaluations
// agree to rounding (measured: 1.2e-7 rad): one face evaluates it for all. The point's owner serves its own
// sector (it evaluates the point anyway), the edge's owner its edge; another sector of the point is served
// by its lowest corner. Everything else keeps one normal per face, averaged: a face tessellated linearly
// (its normal is its polygon's), a linear scheme (faceted), and irregular patches, around extraordinary
// vertices, which Bfr approximates (SetApproxLevelSmooth): there the faces' normals differ by up to 7e-5 rad
// (the cube sphere, rate 5), too much to pick one.
void choose_normal_owners(PreparedMesh& m) {
    const size_t S = m.sector_begin.size() - 1, E = m.edges.size();
    m.sector_normal_owner.assign(S, none);
    for (size_t s = 0; s < S; ++s) {
        bool smooth = true;
        uint32_t lowest = none, point_owner = none;
        for (uint32_t i = m.sector_begin[s]; i < m.sector_begin[s + 1]; ++i) {
            const uint32_t c = m.sector_corners[i];
            smooth = smooth && m.smooth(m.corner_face[c]) && m.face_regular[m.corner_face[c]];
            lowest = std::min(lowest, c);
            if (m.point_owner[m.corner_point[c]] == c) point_owner = c;
        }
        if (smooth) m.sector_normal_owner[s] = point_owner != none ? point_owner : lowest;
    }
    m.edge_normal_shared.assign(E, 0);
    for (size_t e = 0; e < E; ++e) {
        if (m.edge_split[e] & 2) continue;
        bool smooth = true;
        for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s)
            smooth = smooth && m.smooth(m.corner_face[m.side_corner[s]]) && m.face_regular[m.corner_face[m.side_corner[s]]];
        m.edge_normal_shared[e] = smooth ? 1 : 0;
    }
}
} // namespace

void choose_owners(PreparedMesh& m) {
    const size_t C = m.corner_input.size();
    auto better = [&](uint32_t candidate, uint32_t current) { // smooth first, then lowest corner
        if (current == none) return true;
        bool sc = m.smooth(m.corner_face[candidate]), cc = m.smooth(m.corner_face[current]);
        return sc != cc ? sc : candidate < current;
    };
    m.point_owner.assign(m.point_welded.size(), none);
    m.group_attr_owner.assign(m.group_value.size(), none);
    for (uint32_t c = 0; c < C; ++c) {
        uint32_t& p = m.point_owner[m.corner_point[c]];
        if (better(c, p)) p = c;
    }
    // The attribute owner of a run of groups sharing (point, value) is stored on its first group.
    std::vector<uint32_t> run_first(m.group_value.size());
    for (size_t g = 0; g < m.group_value.size(); ++g)
        run_first[g] = (g > 0 && m.group_attr_end[g - 1] == m.group_attr_end[g]) ? run_first[g - 1] : uint32_t(g);
    for (uint32_t c = 0; c < C; ++c) {
        uint32_t& o = m.group_attr_owner[run_first[m.corner_group[c]]];
        if (better(c, o)) o = c;
    }
    for (size_t g = 0; g < m.group_value.size(); ++g) m.group_attr_owner[g] = m.group_attr_owner[run_first[g]];
    m.edge_owner.assign(m.edges.size(), none);
    for (size_t e = 0; e < m.edges.size(); ++e) {
        uint32_t best = none;
        for (uint32_t s = m.edge_side_begin[e]; s < m.edge_side_begin[e + 1]; ++s)
            if (best == none || better(m.side_corner[s], m.side_corner[best])) best = s;
        m.edge_owner[e] = best;
    }
    choose_normal_owners(m);
    m.stats.linear_faces = 0;
    for (size_t f = 0; f < m.face_count(); ++f) m.stats.linear_faces += m.face_linear[f];
}

} // namespace furrow::tessellate_detail

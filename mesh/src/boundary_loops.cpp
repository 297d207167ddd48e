// Boundary loops on a halfedge structure.
//
// Reference: M. Botsch, L. Kobbelt, M. Pauly, P. Alliez, B. Lévy, "Polygon Mesh Processing", AK Peters 2010,
// ch. 2 (halfedge data structure; boundary halfedges carry no face and their `next` pointers chain each hole).
// OpenMesh (Botsch, Steinberg, Bischoff, Kobbelt, "OpenMesh – a generic and efficient polygon mesh data
// structure", OpenSG Symposium 2002) provides the structure.
//
// OpenMesh's add_face refuses faces that would make the mesh non-manifold and then prints to its global
// error stream. That stream is shared with the rest of the process and not safe to toggle from concurrent
// calls, so the refusal is predicted here with the same three tests (complex vertex, complex edge, failed
// patch re-linking) through OpenMesh's public queries, and a refused face is simply never added.
#include <furrow/mesh.h>

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace furrow {
namespace {

struct Traits : OpenMesh::DefaultTraits {};
using TriMesh = OpenMesh::TriMesh_ArrayKernelT<Traits>;

// Mirrors the checks at the top of OpenMesh::PolyConnectivity::add_face (OpenMesh 8–11); read-only.
bool can_add_face(const TriMesh& mesh, const OpenMesh::VertexHandle (&v)[3]) {
    OpenMesh::HalfedgeHandle existing[3];
    for (int i = 0; i < 3; ++i) {
        if (!mesh.is_boundary(v[i])) return false; // complex vertex: a closed fan already surrounds it
        existing[i] = mesh.find_halfedge(v[i], v[(i + 1) % 3]);
        if (existing[i].is_valid() && !mesh.is_boundary(existing[i])) return false; // complex edge
    }
    for (int i = 0; i < 3; ++i) {
        const OpenMesh::HalfedgeHandle inner_prev = existing[i], inner_next = existing[(i + 1) % 3];
        if (!inner_prev.is_valid() || !inner_next.is_valid()) continue;
        if (mesh.next_halfedge_handle(inner_prev) == inner_next) continue;
        // Both edges exist but are not consecutive on the boundary: OpenMesh needs another boundary gap at
        // this vertex to move the patch in between into; without one the face cannot be linked.
        OpenMesh::HalfedgeHandle boundary_prev = mesh.opposite_halfedge_handle(inner_next);
        do
            boundary_prev = mesh.opposite_halfedge_handle(mesh.next_halfedge_handle(boundary_prev));
        while (!mesh.is_boundary(boundary_prev));
        if (boundary_prev == inner_prev) return false;
    }
    return true;
}

} // namespace

size_t boundary_loops(std::vector<std::vector<uint32_t>>& loops, const float* positions, size_t vertex_count,
                      const uint32_t* indices, size_t index_count, size_t* skipped_faces) {
    loops.clear();
    if (skipped_faces) *skipped_faces = 0;
    if (vertex_count == 0 || !positions) {
        if (skipped_faces && indices) *skipped_faces = index_count / 3;
        return 0;
    }

    std::vector<uint32_t> remap(vertex_count);
    weld_positions(remap.data(), positions, vertex_count);

    TriMesh mesh;
    std::vector<int> handle_of(vertex_count, -1); // welded representative -> OpenMesh vertex index
    std::vector<uint32_t> representative;        // OpenMesh vertex index -> welded representative
    auto vertex = [&](uint32_t rep) {
        if (handle_of[rep] < 0) {
            const float* p = positions + 3 * size_t(rep);
            handle_of[rep] = mesh.add_vertex(TriMesh::Point(p[0], p[1], p[2])).idx();
            representative.push_back(rep);
        }
        return OpenMesh::VertexHandle(handle_of[rep]);
    };

    size_t skipped = 0;
    for (size_t t = 0; indices && t + 3 <= index_count; t += 3) {
        uint32_t w[3] = {0, 0, 0};
        bool in_range = true;
        for (int k = 0; k < 3; ++k) {
            if (indices[t + k] >= vertex_count) in_range = false;
            else w[k] = remap[indices[t + k]];
        }
        // A repeated vertex is no face for a halfedge structure (OpenMesh asserts on it in debug builds).
        if (!in_range || w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) {
            ++skipped;
            continue;
        }
        OpenMesh::VertexHandle v[3] = {vertex(w[0]), vertex(w[1]), vertex(w[2])};
        if (!can_add_face(mesh, v) || !mesh.add_face(v[0], v[1], v[2]).is_valid()) ++skipped;
    }
    if (skipped_faces) *skipped_faces = skipped;

    // Walk every boundary cycle once, from its lowest-numbered halfedge, so the output order is a function
    // of the input order only. At a vertex where two holes touch (a bowtie), OpenMesh links both rims into
    // one figure-of-eight cycle; it is split there into simple loops, which is what a hole filler or a
    // shell rim wants.
    std::vector<char> visited(mesh.n_halfedges(), 0);
    std::vector<size_t> position(vertex_count, SIZE_MAX); // index in `open` of a vertex on the current walk
    for (size_t i = 0; i < mesh.n_halfedges(); ++i) {
        const OpenMesh::HalfedgeHandle start{static_cast<int>(i)};
        if (visited[i] || !mesh.is_boundary(start)) continue;
        std::vector<uint32_t> open; // the walk so far, minus the simple loops already cut off
        OpenMesh::HalfedgeHandle h = start;
        size_t steps = 0;
        do {
            visited[size_t(h.idx())] = 1;
            const uint32_t v = representative[size_t(mesh.from_vertex_handle(h).idx())];
            if (position[v] != SIZE_MAX) { // back at v: the stretch since then is a loop of its own
                std::vector<uint32_t> loop(open.begin() + std::ptrdiff_t(position[v]), open.end());
                for (size_t k = position[v] + 1; k < open.size(); ++k) position[open[k]] = SIZE_MAX;
                open.resize(position[v] + 1);
                // Boundary halfedges run against the faces; report loops in the faces' own winding.
                std::reverse(loop.begin(), loop.end());
                loops.push_back(std::move(loop));
            } else {
                position[v] = open.size();
                open.push_back(v);
            }
            h = mesh.next_halfedge_handle(h);
        } while (h != start && h.is_valid() && !visited[size_t(h.idx())] && ++steps <= mesh.n_halfedges());
        for (uint32_t v : open) position[v] = SIZE_MAX;
        std::reverse(open.begin(), open.end());
        loops.push_back(std::move(open));
    }
    return loops.size();
}

} // namespace furrow

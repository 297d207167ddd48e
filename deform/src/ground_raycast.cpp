// Contact queries: rays cast down onto the undeformed ground mesh, on an axis-aligned bounding-box tree.
//
// Reference: P. Alliez, S. Tayeb, C. Wormser, "3D Fast Intersection and Distance Computation", CGAL User and
// Reference Manual (AABB Tree package). The Last of Us Part II casts knee → foot the same way to find where a
// foot meets the ground. The tree is built once per SnowField and queried concurrently (first_intersection is
// const on a built tree). The only CGAL file of furrow::deform (its headers dominate compile time).
#include "deform_internal.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

namespace furrow::deform_detail {
namespace {

// Only hit points are constructed, and a height rounded in the last bit of a double is harmless.
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using Ray = Kernel::Ray_3;
using Triangle = Kernel::Triangle_3;
using Iterator = std::vector<Triangle>::const_iterator;
using Primitive3 = CGAL::AABB_triangle_primitive<Kernel, Iterator>;
using Traits = CGAL::AABB_traits<Kernel, Primitive3>;
using Tree = CGAL::AABB_tree<Traits>;

} // namespace

struct GroundRaycaster::Tree {
    std::vector<Triangle> triangles;
    deform_detail::Tree tree;
};

GroundRaycaster::GroundRaycaster() = default;
GroundRaycaster::~GroundRaycaster() = default;

bool GroundRaycaster::built() const { return tree_ != nullptr; }

void GroundRaycaster::build(const float* positions, size_t vertex_count, const uint32_t* indices, size_t index_count) {
    auto t = std::make_unique<Tree>();
    t->triangles.reserve(index_count / 3);
    auto pt = [&](uint32_t v) {
        return Point(positions[3 * size_t(v)], positions[3 * size_t(v) + 1], positions[3 * size_t(v) + 2]);
    };
    for (size_t i = 0; i + 3 <= index_count; i += 3) {
        uint32_t a = indices[i], b = indices[i + 1], c = indices[i + 2];
        if (a >= vertex_count || b >= vertex_count || c >= vertex_count) continue;
        Triangle tri(pt(a), pt(b), pt(c));
        if (tri.is_degenerate()) continue; // CGAL's intersection code asserts on these
        t->triangles.push_back(tri);
    }
    if (!t->triangles.empty()) {
        t->tree.insert(t->triangles.begin(), t->triangles.end());
        t->tree.build();
    }
    tree_ = std::move(t);
}

double GroundRaycaster::first_hit(const Vec3& o, const Vec3& d) const {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (!tree_ || tree_->triangles.empty()) return nan;
    const Point origin(o.x, o.y, o.z);
    const Ray ray(origin, Vector(d.x, d.y, d.z));
    // With coordinates near the double range (a collider 1e30 m up), the inexact kernel's predicates can
    // contradict each other, and CGAL reports the "impossible" case by throwing (CGAL_error, in release builds
    // too); thrown inside a TBB task it terminated the process (found by fuzz_stamp). No usable hit, then.
    // The hit is read where it is made: a default-constructed optional assigned later drew GCC 12's
    // -Wmaybe-uninitialized on boost::optional's storage.
    try {
        const auto hit = tree_->tree.first_intersection(ray);
        if (!hit) return nan;
        const double dd = dot(d, d);
        auto param = [&](const Point& p) { return ((p.x() - o.x) * d.x + (p.y() - o.y) * d.y + (p.z() - o.z) * d.z) / dd; };
        if (const Point* p = boost::get<Point>(&hit->first)) return param(*p);
        // The ray runs inside a vertical face: its nearer end is where it lands.
        if (const auto* seg = boost::get<Kernel::Segment_3>(&hit->first)) return std::min(param(seg->source()), param(seg->target()));
    } catch (const CGAL::Failure_exception&) {
        return nan;
    }
    return nan;
}

} // namespace furrow::deform_detail

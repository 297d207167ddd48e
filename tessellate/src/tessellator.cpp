// furrow::Tessellator: prepare once, tessellate many times; and the triangle budget.
//
// The budget (RateOptions::max_triangles) scales every wanted rate by one factor s before rounding, found by
// bisection on the exact triangle count of Bfr's tessellation patterns: a single factor keeps the relative
// distribution the criteria asked for (what Cycles' and Nanite's budgets do with their dicing rate), and the
// count is exact, so the output never exceeds the budget.
#include "tessellate_internal.h"
#include <furrow_kernel/no_throw.h>


#include <algorithm>
#include <chrono>
#include <new>

namespace furrow {

using namespace tessellate_detail;

struct Tessellator::Impl {
    PreparedMesh mesh;
    bool ready = false;
};

Tessellator::Tessellator() : impl_(std::make_unique<Impl>()) {}
Tessellator::~Tessellator() = default;
Tessellator::Tessellator(Tessellator&&) noexcept = default;
Tessellator& Tessellator::operator=(Tessellator&&) noexcept = default;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Integer rates for the options, the budget applied; fills the rate fields of stats.
Status final_rates(std::vector<int>& rates, TessellateStats& stats, const PreparedMesh& m, const RateOptions& r) {
    if (Status s = validate_rates(r); !s.ok()) return s;
    std::vector<double> wanted;
    if (Status s = wanted_rates(wanted, m, r); !s.ok()) return s;
    auto make = [&](double scale) {
        rates.resize(wanted.size());
        for (size_t e = 0; e < wanted.size(); ++e) rates[e] = final_rate(wanted[e], scale, r.max_rate);
    };
    double scale = 1.0;
    make(1.0);
    if (r.max_triangles > 0 && count_triangles(m, rates) > r.max_triangles) {
        make(0.0);
        const size_t minimum = count_triangles(m, rates);
        if (minimum > r.max_triangles)
            return Status::error(StatusCode::invalid_argument,
                                 "max triangles " + std::to_string(r.max_triangles) + " is below the " +
                                     std::to_string(minimum) + " triangles of the coarsest tessellation (rate 1)");
        double lo = 0.0, hi = 1.0; // lo fits, hi does not
        for (int i = 0; i < 40 && hi - lo > 1e-6 * hi; ++i) {
            const double mid = 0.5 * (lo + hi);
            make(mid);
            (count_triangles(m, rates) <= r.max_triangles ? lo : hi) = mid;
        }
        scale = lo;
        make(scale);
    }
    stats.rate_scale = scale;
    stats.min_rate = rates.empty() ? 0 : *std::min_element(rates.begin(), rates.end());
    stats.max_rate = rates.empty() ? 0 : *std::max_element(rates.begin(), rates.end());
    double sum = 0;
    for (int x : rates) sum += x;
    stats.mean_rate = rates.empty() ? 0.0 : sum / double(rates.size());
    return Status::success();
}

} // namespace

Status Tessellator::prepare(const TessellateInput& in, const SurfaceOptions& options) {
    const auto t0 = std::chrono::steady_clock::now();
    impl_->ready = false;
    const Status done = kernel::no_throw("preparing the mesh", [&]() -> Status {
        PreparedMesh& m = impl_->mesh;
        if (Status s = prepare_mesh(m, in, options); !s.ok()) return s;
        if (Status s = build_surfaces(m); !s.ok()) return s;
        choose_owners(m);
        m.stats.prepare_seconds = seconds_since(t0);
        return Status::success();
    });
    impl_->ready = done.ok();
    return done;
}

const TessellateStats& Tessellator::topology() const { return impl_->mesh.stats; }

Status Tessellator::tessellate(TessellateOutput& out, const RateOptions& r, bool keep_parameters) const {
    if (!impl_->ready) return Status::error(StatusCode::invalid_argument, "tessellator not prepared");
    const PreparedMesh& m = impl_->mesh;
    out = TessellateOutput{};
    out.stats = m.stats;
    const Status done = kernel::no_throw("tessellating", [&]() -> Status {
        auto t0 = std::chrono::steady_clock::now();
        std::vector<int> rates;
        if (Status s = final_rates(rates, out.stats, m, r); !s.ok()) return s;
        out.stats.rate_seconds = seconds_since(t0);
        t0 = std::chrono::steady_clock::now();
        const TessellateStats keep = out.stats;
        if (Status s = evaluate_tessellation(out, m, rates, keep_parameters); !s.ok()) return s;
        const size_t vertices = out.stats.vertices, triangles = out.stats.triangles;
        out.stats = keep;
        out.stats.vertices = vertices;
        out.stats.triangles = triangles;
        out.stats.evaluate_seconds = seconds_since(t0);
        return Status::success();
    });
    if (!done.ok()) out = TessellateOutput{};
    return done;
}

Status Tessellator::edge_rates(std::vector<EdgeRate>& out, const RateOptions& r) const {
    return kernel::no_throw("computing edge rates", [&]() -> Status {
        if (!impl_->ready) return Status::error(StatusCode::invalid_argument, "tessellator not prepared");
        const PreparedMesh& m = impl_->mesh;
        std::vector<int> rates;
        TessellateStats stats;
        if (Status s = final_rates(rates, stats, m, r); !s.ok()) return s;
        out.resize(rates.size());
        for (size_t e = 0; e < rates.size(); ++e)
            out[e] = {m.welded_input[m.point_welded[m.edges[e][0]]], m.welded_input[m.point_welded[m.edges[e][1]]], rates[e]};
        return Status::success();
    });
}

Status Tessellator::count_triangles(size_t& out, const RateOptions& r) const {
    return kernel::no_throw("counting triangles", [&]() -> Status {
        if (!impl_->ready) return Status::error(StatusCode::invalid_argument, "tessellator not prepared");
        std::vector<int> rates;
        TessellateStats stats;
        if (Status s = final_rates(rates, stats, impl_->mesh, r); !s.ok()) return s;
        out = tessellate_detail::count_triangles(impl_->mesh, rates);
        return Status::success();
    });
}

Status tessellate(TessellateOutput& out, const TessellateInput& in, const TessellateOptions& options) {
    Tessellator t;
    if (Status s = t.prepare(in, options.surface); !s.ok()) {
        out = TessellateOutput{};
        return s;
    }
    return t.tessellate(out, options.rates, options.keep_parameters);
}

Status Tessellator::measure(ErrorReport& out, const TessellateOutput& t, const RateOptions& view) const {
    return kernel::no_throw("measuring the error", [&]() -> Status {
        if (!impl_->ready) return Status::error(StatusCode::invalid_argument, "tessellator not prepared");
        return tessellate_detail::measure_tessellation(out, impl_->mesh, t, view);
    });
}

} // namespace furrow

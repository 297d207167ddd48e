// SVG plots of a benchmark's speed-versus-error points: error against time and error against triangles,
// log-log, one polyline per series (a criterion, a method, a shell count), one file per group (a model, a
// shape). Plain SVG 1.1 text so that a browser, an image viewer or a pull request shows it as is.
#include "bench_common.h"

#include <furrow_kernel/atomic_file.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace furrow::cli {
namespace fs = std::filesystem;

namespace {

std::string esc(const std::string& s) {
    std::string o;
    for (char c : s) {
        if (c == '<') o += "&lt;";
        else if (c == '>') o += "&gt;";
        else if (c == '&') o += "&amp;";
        else if (c == '"') o += "&quot;";
        else o += c;
    }
    return o;
}

std::string num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.1f", v);
    return b;
}

std::string tick_label(double decade) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", std::pow(10.0, decade));
    return b;
}

// A file-name-safe form of a group name.
std::string slug(const std::string& s) {
    std::string o;
    for (char c : s) o += std::isalnum(static_cast<unsigned char>(c)) ? char(std::tolower(static_cast<unsigned char>(c))) : '_';
    while (o.find("__") != std::string::npos) o.erase(o.find("__"), 1);
    while (!o.empty() && o.back() == '_') o.pop_back();
    return o.empty() ? "all" : o;
}

struct Series {
    std::string name;
    std::vector<std::pair<double, double>> xy; // log10 values
    std::vector<std::string> labels;
    std::vector<bool> at_floor; // an error of exactly 0, drawn at the floor
};

// One log-log chart. Points with y <= 0 (an exact result) are drawn hollow on the bottom edge.
std::string chart(const std::string& title, const std::string& x_name, const std::string& y_name,
                  const std::vector<std::tuple<std::string, double, double, std::string>>& points) {
    std::map<std::string, Series> by_series;
    std::vector<std::string> order;
    double min_pos_y = INFINITY;
    for (const auto& [s, x, y, l] : points)
        if (y > 0) min_pos_y = std::min(min_pos_y, y);
    const double floor_y = std::isfinite(min_pos_y) ? min_pos_y / 10 : 1e-12;
    for (const auto& [s, x, y, l] : points) {
        if (!(x > 0) || !std::isfinite(x) || !std::isfinite(y) || y < 0) continue;
        if (!by_series.count(s)) order.push_back(s);
        Series& se = by_series[s];
        se.name = s;
        se.xy.push_back({std::log10(x), std::log10(y > 0 ? y : floor_y)});
        se.labels.push_back(l);
        se.at_floor.push_back(y == 0);
    }
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (const auto& [n, se] : by_series)
        for (const auto& [x, y] : se.xy) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    if (!std::isfinite(x0)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
    // Whole decades around the data, so the ticks are 1, 10, 100 ...
    x0 = std::floor(x0), x1 = std::max(std::ceil(x1), x0 + 1), y0 = std::floor(y0), y1 = std::max(std::ceil(y1), y0 + 1);

    const double W = 760, H = 480, L = 80, R = 200, T = 40, B = 60;
    auto px = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
    auto py = [&](double y) { return H - B - (y - y0) / (y1 - y0) * (H - T - B); };
    static const char* palette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#17becf", "#bcbd22"};

    std::string s = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + num(W) +
                    "\" height=\"" + num(H) + "\" viewBox=\"0 0 " + num(W) + " " + num(H) +
                    "\" font-family=\"sans-serif\" font-size=\"12\">\n";
    s += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    s += "<text x=\"" + num(W / 2) + "\" y=\"22\" text-anchor=\"middle\" font-size=\"14\">" + esc(title) + "</text>\n";
    for (double d = x0; d <= x1 + 1e-9; d += 1) {
        s += "<line x1=\"" + num(px(d)) + "\" y1=\"" + num(T) + "\" x2=\"" + num(px(d)) + "\" y2=\"" + num(H - B) + "\" stroke=\"#ddd\"/>\n";
        s += "<text x=\"" + num(px(d)) + "\" y=\"" + num(H - B + 16) + "\" text-anchor=\"middle\">" + tick_label(d) + "</text>\n";
    }
    for (double d = y0; d <= y1 + 1e-9; d += 1) {
        s += "<line x1=\"" + num(L) + "\" y1=\"" + num(py(d)) + "\" x2=\"" + num(W - R) + "\" y2=\"" + num(py(d)) + "\" stroke=\"#ddd\"/>\n";
        s += "<text x=\"" + num(L - 6) + "\" y=\"" + num(py(d) + 4) + "\" text-anchor=\"end\">" + tick_label(d) + "</text>\n";
    }
    s += "<rect x=\"" + num(L) + "\" y=\"" + num(T) + "\" width=\"" + num(W - L - R) + "\" height=\"" + num(H - T - B) +
         "\" fill=\"none\" stroke=\"black\"/>\n";
    s += "<text x=\"" + num((L + W - R) / 2) + "\" y=\"" + num(H - 18) + "\" text-anchor=\"middle\">" + esc(x_name) + " (log)</text>\n";
    s += "<text transform=\"translate(18 " + num((T + H - B) / 2) + ") rotate(-90)\" text-anchor=\"middle\">" + esc(y_name) +
         " (log)</text>\n";
    for (size_t i = 0; i < order.size(); ++i) {
        const Series& se = by_series[order[i]];
        const std::string colour = palette[i % (sizeof palette / sizeof *palette)];
        std::vector<size_t> idx(se.xy.size());
        for (size_t k = 0; k < idx.size(); ++k) idx[k] = k;
        std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return se.xy[a].first < se.xy[b].first; });
        std::string pts;
        for (size_t k : idx) pts += num(px(se.xy[k].first)) + "," + num(py(se.xy[k].second)) + " ";
        s += "<polyline fill=\"none\" stroke=\"" + colour + "\" stroke-width=\"1.5\" points=\"" + pts + "\"/>\n";
        for (size_t k : idx)
            s += "<circle cx=\"" + num(px(se.xy[k].first)) + "\" cy=\"" + num(py(se.xy[k].second)) + "\" r=\"3.5\" fill=\"" +
                 (se.at_floor[k] ? std::string("white") : colour) + "\" stroke=\"" + colour + "\"><title>" + esc(se.name + ": " + se.labels[k]) +
                 "</title></circle>\n";
        const double ly = T + 10 + 18 * double(i);
        s += "<line x1=\"" + num(W - R + 12) + "\" y1=\"" + num(ly) + "\" x2=\"" + num(W - R + 32) + "\" y2=\"" + num(ly) + "\" stroke=\"" +
             colour + "\" stroke-width=\"2\"/>\n";
        s += "<text x=\"" + num(W - R + 38) + "\" y=\"" + num(ly + 4) + "\">" + esc(se.name) + "</text>\n";
    }
    bool any_floor = false;
    for (const auto& [n, se] : by_series)
        for (bool f : se.at_floor) any_floor |= f;
    if (any_floor)
        s += "<text x=\"" + num(W - R + 12) + "\" y=\"" + num(H - B) + "\" font-size=\"10\">hollow: error exactly 0</text>\n";
    s += "</svg>\n";
    return s;
}

void write_text_atomic(const fs::path& file, const std::string& text) {
    if (!kernel::atomic_write(file.string(), text.data(), text.size()).ok())
        throw InputError(file.string(), "cannot write the plot");
}

} // namespace

nlohmann::json plot_json(const std::string& error_name, const std::vector<PlotPoint>& points) {
    nlohmann::json p = nlohmann::json::array();
    for (const auto& q : points)
        p.push_back({{"group", q.group}, {"series", q.series}, {"label", q.label}, {"seconds", q.seconds},
                     {"triangles", q.triangles}, {"error", q.error}});
    return {{"error", error_name}, {"points", p}};
}

std::vector<std::string> write_plots(const nlohmann::json& result, const fs::path& dir) {
    std::vector<std::string> written;
    if (!result.contains("plot")) return written;
    const std::string bench = result.value("bench", std::string("bench"));
    const auto& plot = result["plot"];
    const std::string error_name = plot.value("error", std::string("error"));
    std::map<std::string, std::vector<nlohmann::json>> groups;
    std::vector<std::string> order;
    for (const auto& q : plot["points"]) {
        const std::string g = q.value("group", std::string());
        if (!groups.count(g)) order.push_back(g);
        groups[g].push_back(q);
    }
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw InputError(dir.string(), "cannot create the plot folder: " + ec.message());
    for (const auto& g : order) {
        std::vector<std::tuple<std::string, double, double, std::string>> vs_time, vs_tris, time_vs_tris;
        bool any_error = false;
        for (const auto& q : groups[g]) {
            const double e = q.value("error", 0.0), t = q.value("seconds", 0.0), n = q.value("triangles", 0.0);
            any_error |= e > 0;
            vs_time.emplace_back(q["series"], t * 1e3, e, q["label"]);
            vs_tris.emplace_back(q["series"], n, e, q["label"]);
            time_vs_tris.emplace_back(q["series"], n, t * 1e3, q["label"]);
        }
        const std::string base = bench + (g.empty() ? "" : "_" + slug(g));
        const std::string title = "furrow bench " + bench + (g.empty() ? "" : ": " + g);
        auto emit = [&](const std::string& name, const std::string& svg) {
            const fs::path f = dir / (base + "_" + name + ".svg");
            write_text_atomic(f, svg);
            written.push_back(f.string());
        };
        if (any_error) {
            emit("error_vs_time", chart(title, "time (ms)", error_name, vs_time));
            emit("error_vs_triangles", chart(title, "triangles", error_name, vs_tris));
        } else {
            // Every result exact (e.g. a lossless round trip): time against size is the useful picture.
            emit("time_vs_triangles", chart(title + " (" + error_name + " = 0 everywhere)", "triangles", "time (ms)", time_vs_tris));
        }
    }
    return written;
}

void add_bench_output_flags(CLI::App& cmd, BenchOutput& o) {
    cmd.add_flag("--json", o.json, "Print one JSON object (with the plot points) instead of the tables");
    cmd.add_option("--plots", o.plots, "Write SVG plots of error against time and against triangles into this folder");
}

void finish_bench(const nlohmann::json& result, const BenchOutput& o, const GlobalFlags& g) {
    if (o.json) std::printf("%s\n", result.dump(2).c_str());
    std::fflush(stdout); // the tables first, then the plot lines on stderr
    if (o.plots.empty()) return;
    std::vector<nlohmann::json> all;
    if (result.contains("benches") && result["benches"].is_array())
        for (const auto& r : result["benches"]) all.push_back(r);
    else
        all.push_back(result);
    for (const auto& r : all)
        for (const auto& f : write_plots(r, o.plots)) info(g, "plot: " + f);
}

} // namespace furrow::cli

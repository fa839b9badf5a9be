// SPDX-License-Identifier: Apache-2.0
#include "svg/svg_contour.hpp"

#include <cmath>
#include <deque>
#include <optional>
#include <unordered_map>

namespace hapticopt::cli::svg {

namespace {

struct Segment {
    long long a, b;  // cut-edge ids of its ends
    bool used = false;
};

}  // namespace

std::vector<Polyline> contour_lines(const SampledGrid& grid, double level) {
    const std::size_t nx = grid.xs.size(), ny = grid.ys.size();
    std::vector<Polyline> lines;
    if (nx < 2 || ny < 2 || grid.values.size() != nx * ny) return lines;
    // Edge ids: horizontal edge from (i, j) to (i+1, j) is 2 (j nx + i); vertical from (i, j) to (i, j+1)
    // is 2 (j nx + i) + 1.
    auto h_edge = [&](std::size_t i, std::size_t j) { return 2 * static_cast<long long>(j * nx + i); };
    auto v_edge = [&](std::size_t i, std::size_t j) { return 2 * static_cast<long long>(j * nx + i) + 1; };
    std::unordered_map<long long, std::pair<double, double>> points;
    auto crossing = [&](long long id) {
        auto it = points.find(id);
        if (it != points.end()) return;
        const auto cell = static_cast<std::size_t>(id / 2);
        const std::size_t i = cell % nx, j = cell / nx;
        const bool vertical = (id % 2) != 0;
        const std::size_t i2 = vertical ? i : i + 1, j2 = vertical ? j + 1 : j;
        const double f1 = grid.at(i, j), f2 = grid.at(i2, j2);
        const double t = f2 != f1 ? (level - f1) / (f2 - f1) : 0.5;
        points[id] = {grid.xs[i] + t * (grid.xs[i2] - grid.xs[i]), grid.ys[j] + t * (grid.ys[j2] - grid.ys[j])};
    };
    std::vector<Segment> segments;
    std::unordered_map<long long, std::vector<std::size_t>> at_edge;
    auto add = [&](long long a, long long b) {
        crossing(a);
        crossing(b);
        at_edge[a].push_back(segments.size());
        at_edge[b].push_back(segments.size());
        segments.push_back({a, b});
    };
    for (std::size_t j = 0; j + 1 < ny; ++j) {
        for (std::size_t i = 0; i + 1 < nx; ++i) {
            const double f00 = grid.at(i, j), f10 = grid.at(i + 1, j), f11 = grid.at(i + 1, j + 1),
                         f01 = grid.at(i, j + 1);
            if (!std::isfinite(f00) || !std::isfinite(f10) || !std::isfinite(f11) || !std::isfinite(f01)) continue;
            const int index =
                (f00 > level ? 1 : 0) | (f10 > level ? 2 : 0) | (f11 > level ? 4 : 0) | (f01 > level ? 8 : 0);
            const long long bottom = h_edge(i, j), right = v_edge(i + 1, j), top = h_edge(i, j + 1),
                            left = v_edge(i, j);
            const bool center_above = (f00 + f10 + f11 + f01) / 4 > level;
            switch (index) {
                case 0:
                case 15:
                    break;
                case 1:
                case 14:
                    add(left, bottom);
                    break;
                case 2:
                case 13:
                    add(bottom, right);
                    break;
                case 3:
                case 12:
                    add(left, right);
                    break;
                case 4:
                case 11:
                    add(right, top);
                    break;
                case 6:
                case 9:
                    add(bottom, top);
                    break;
                case 7:
                case 8:
                    add(left, top);
                    break;
                case 5:  // corners 00 and 11 above
                    if (center_above) {
                        add(left, top);
                        add(bottom, right);
                    } else {
                        add(left, bottom);
                        add(right, top);
                    }
                    break;
                case 10:  // corners 10 and 01 above
                    if (center_above) {
                        add(left, bottom);
                        add(right, top);
                    } else {
                        add(left, top);
                        add(bottom, right);
                    }
                    break;
                default:
                    break;
            }
        }
    }
    auto next_from = [&](long long edge) -> std::optional<std::size_t> {
        for (const std::size_t s : at_edge[edge]) {
            if (!segments[s].used) return s;
        }
        return std::nullopt;
    };
    for (std::size_t s = 0; s < segments.size(); ++s) {
        if (segments[s].used) continue;
        segments[s].used = true;
        std::deque<long long> chain{segments[s].a, segments[s].b};
        for (int direction = 0; direction < 2; ++direction) {
            while (true) {
                const long long end = direction == 0 ? chain.back() : chain.front();
                const auto n = next_from(end);
                if (!n) break;
                segments[*n].used = true;
                const long long other = segments[*n].a == end ? segments[*n].b : segments[*n].a;
                if (direction == 0)
                    chain.push_back(other);
                else
                    chain.push_front(other);
            }
        }
        Polyline line;
        line.reserve(chain.size());
        for (const long long id : chain) line.push_back(points[id]);
        lines.push_back(std::move(line));
    }
    return lines;
}

}  // namespace hapticopt::cli::svg

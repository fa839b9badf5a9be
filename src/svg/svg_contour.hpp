// SPDX-License-Identifier: Apache-2.0
// Contour lines of a function sampled on a rectangular grid (marching squares), for the cost
// contours of `hapticopt plot costs`.
//
// Each grid cell whose four corner values are finite is classified by which corners lie above the
// level; the crossing on each cut edge is placed by linear interpolation of the corner values, and a
// saddle cell (two opposite corners above) is resolved by the mean of its four corners. Segments
// that share a cut edge are joined into polylines, so a closed contour comes back as one polyline
// whose last point equals its first. Cells with a non-finite corner (e.g. outside the stable region,
// where a cost is +inf) produce no segments: contours end at the last complete cell.
// Accuracy: the interpolation error of the function inside one cell (the tests state the measured
// one for the cost contours); cost: O(cells) per level.
#pragma once

#include <utility>
#include <vector>

namespace hapticopt::cli::svg {

/// Values f(xs[i], ys[j]) stored at values[j * xs.size() + i].
struct SampledGrid {
    std::vector<double> xs, ys, values;
    double at(std::size_t i, std::size_t j) const { return values[j * xs.size() + i]; }
};

using Polyline = std::vector<std::pair<double, double>>;

/// The contour lines f = level, as polylines in data coordinates.
std::vector<Polyline> contour_lines(const SampledGrid& grid, double level);

}  // namespace hapticopt::cli::svg

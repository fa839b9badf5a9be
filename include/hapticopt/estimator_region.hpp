// SPDX-License-Identifier: Apache-2.0
// The main stable region of the gain plane with the wall's velocity estimator (velocity_estimator.hpp): its
// scan by the Schur-Cohn verdict of estimator_stability.hpp, its tip alpha_max, its stable beta intervals,
// its boundary as a polyline and the stable islands apart from it (normalised units m = T = 1).
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <utility>
#include <vector>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "errors.hpp"
#include "estimator_stability.hpp"
#include "parameters.hpp"
#include "region_tip.hpp"
#include "scalar_search.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

/// A stable set of the gain plane not connected to the main region, as seen on the region's scan grid
/// (bounding box of its stable grid cells; islands thinner than a cell can be missed).
struct StableIsland {
    double alpha_min = 0, alpha_max = 0, beta_min = 0, beta_max = 0;
};

struct EstimatorRegionOptions {
    int alpha_grid = 160;      ///< scan cells along alpha, >= 16
    int beta_grid = 160;       ///< scan cells along beta, >= 16
    bool find_islands = true;  ///< false: islands() stays empty, the box is fitted on a coarse grid first
};

/// The main stable region with the estimator: the connected stable set that contains small alpha > 0
/// (alpha -> 0+ at some beta). Found by a scan of the Schur-Cohn verdict on a grid over alpha in (0, 1],
/// beta in [-1, 4], flood fill from the grid's first alpha column (only the cells the fill reaches are tested,
/// except in the first scan when islands are wanted; where that column has nothing stable,
/// the box shrinks 4x in alpha and beta towards beta = 0 until it does, down to alpha 1e-9), the box re-fitted
/// to the region until it fills it (a pass whose first column has nothing stable scans no further). Without
/// find_islands (the fast optimum's grid) the box is fitted on a 16 x 16 grid first, then scanned at the options'
/// grid (not again where that is 16 x 16); where that finds nothing, the search runs again at 40 x 40, then at the
/// default 160 x 160; and on a grid coarser than 40 x 40 a corner tip (below) has the region scanned again at
/// 40 x 40 before its Brent search.
/// The region's edge along a line of constant beta is the first instability reached by marching up in alpha
/// from a main-region cell (steps of a quarter cell) refined by bisection to 1e-14. alpha_max: the largest
/// local maximum of the D-decomposition curve (alpha(theta), beta(theta)) solving p(e^{i theta}) = 0
/// (stability_region.hpp; sampled at max(64, 16 degree) frequencies in (0, pi), refined by Brent) inside the
/// scan's tip cells, taken (as the edge there) when the edge at its beta agrees with it to 1e-12 alpha; else (a corner
/// tip, where two branches cross, or a cusp) the largest candidate of region_tip_candidates (region_tip.hpp: the
/// curve's arcs bounding a stable set, their ends bisected and their maxima refined) at or above the edge's maximum
/// over beta (Brent, scalar_search.hpp; a main-region point) and joined to it by stable points (corner_tip), or
/// that edge maximum where no candidate is. Stable components of the first (wide) scan that are not connected to
/// the main one are reported as islands. Accuracy: alpha_max to ~1e-12 where the maximum is a smooth tip (checked
/// against the exact d = 0 value 12 - 8 sqrt(2) for window 1) and to 1e-10 at a corner (checked against the two
/// branches' crossing solved by Newton, tests/core/test_velocity_estimator.cpp).
class EstimatorStabilityRegion {
  public:
    HAPTICOPT_DEFERRED
    EstimatorStabilityRegion(const NormalizedPlant& plant, const VelocityEstimator& estimator,
                             const EstimatorRegionOptions& options = {})
        : test_(plant, estimator), options_(options) {
        const char* fn = "hapticopt::EstimatorStabilityRegion";
        validate(plant, fn);
        validate(estimator, fn);
        detail::require_in_range(fn, "alpha_grid", options.alpha_grid, 16, false, 1e5, "16 <= alpha_grid <= 10^5");
        detail::require_in_range(fn, "beta_grid", options.beta_grid, 16, false, 1e5, "16 <= beta_grid <= 10^5");
        std::vector<StableIsland> wide;
        bool found = !options.find_islands && fit_box(true, nullptr);
        if (!found) found = fit_box(false, options.find_islands ? &wide : nullptr);
        // Nothing found on a coarse grid: again at kFallbackGrid, then at the default grid (a region whose
        // first column the coarser scans miss: a thin one, or one at beta < 0 that the box shrinking towards
        // beta = 0 leaves).
        for (const int grid : {kFallbackGrid, EstimatorRegionOptions{}.alpha_grid}) {
            if (found || options.find_islands || std::min(options.alpha_grid, options.beta_grid) >= grid) continue;
            options_.alpha_grid = std::max(options.alpha_grid, grid);
            options_.beta_grid = std::max(options.beta_grid, grid);
            found = fit_box(false, nullptr);
        }
        if (!found) {
            alpha_max_ = 0;
            islands_ = wide;
            return;
        }
        if (!refine_tip() && !options.find_islands &&
            std::min(options_.alpha_grid, options_.beta_grid) < kFallbackGrid) {
            // A corner tip on a grid coarser than kFallbackGrid: the region again on that grid (the tip's Brent
            // search and the beta intervals start from the scan's cells); the coarse region where that finds none.
            const EstimatorRegionOptions coarse = options_;
            options_.alpha_grid = std::max(options_.alpha_grid, kFallbackGrid);
            options_.beta_grid = std::max(options_.beta_grid, kFallbackGrid);
            if (!fit_box(false, nullptr)) {
                options_ = coarse;
                fit_box(true, nullptr);
            }
            refine_tip();
        }
        // A tip the region continues beyond (a waist narrower than the scan's cells, where the flood fill stopped,
        // so the edge's maximum is no tip): the region again on finer grids, up to kFinestGrid.
        for (const int grid : {kFallbackGrid, EstimatorRegionOptions{}.alpha_grid, kFinestGrid}) {
            if (std::min(options_.alpha_grid, options_.beta_grid) >= grid) continue;
            if (!continues_beyond_tip()) break;
            const EstimatorRegionOptions coarser = options_;
            options_.alpha_grid = std::max(options_.alpha_grid, grid);
            options_.beta_grid = std::max(options_.beta_grid, grid);
            if (!fit_box(false, nullptr)) {  // keep the coarser grid's region (its tip is a stable point's alpha)
                options_ = coarser;
                fit_box(false, nullptr);
                refine_tip();
                break;
            }
            refine_tip();
        }
        // Islands: the components of the first (widest) scan not connected to its first column, except any that
        // overlaps the main region's box (a main region thinner than that scan's cells can appear detached in it).
        const double db = (b1_ - b0_) / nb();
        const double main_lo = b0_ + main_j0_ * db, main_hi = b0_ + (main_j1_ + 1) * db;
        for (const StableIsland& i : wide) {
            const bool overlaps = i.alpha_min < alpha_max_ && i.beta_min < main_hi && i.beta_max > main_lo;
            if (!overlaps) islands_.push_back(i);
        }
    }

    double alpha_max() const { return alpha_max_; }
    double beta_at_alpha_max() const { return beta_at_alpha_max_; }
    const std::vector<StableIsland>& islands() const { return islands_; }
    bool stable(double alpha, double beta) const { return test_.stable(alpha, beta); }
    const EstimatorStabilityTest& test() const { return test_; }

    /// The stable beta interval of the main region at alpha (0 < alpha < alpha_max), its ends bisected to
    /// `tolerance` x max(1, |beta|) (default 1e-14: ends to ~1e-13; a start grid needs far less);
    /// (0, 0) when alpha is outside (0, alpha_max). From the lowest main cell centre stable at alpha (nearest
    /// columns first), the lower end is marched down in steps of a quarter cell; the upper end is marched up a
    /// cell at a time through that column's run of main cells while they are stable at alpha, then in quarter
    /// cells.
    std::pair<double, double> beta_interval(double alpha, double tolerance = 1e-14) const {
        if (!(alpha > 0 && alpha < alpha_max_)) return {0, 0};
        const double da = a1_ / na(), db = (b1_ - b0_) / nb();
        int i = std::clamp(static_cast<int>(alpha / da), 0, na() - 1);
        // A stable beta of the main region at this alpha: main cells of the nearest columns, centre out.
        double start = std::nan("");
        int start_column = i;
        for (int di = 0; di <= 2 && std::isnan(start); ++di) {
            for (int sgn : {-1, 1}) {
                const int c = std::clamp(i + sgn * di, 0, na() - 1);
                for (int j = 0; j < nb() && std::isnan(start); ++j) {
                    const double b = b0_ + (j + 0.5) * db;
                    if (label(c, j) == 1 && test_.stable(alpha, b)) {
                        start = b;
                        start_column = c;
                    }
                }
            }
        }
        if (std::isnan(start)) return {0, 0};
        // Up through the run of main cells above start in its column, a cell at a time while stable at alpha.
        double top = start;
        for (int j = static_cast<int>((start - b0_) / db) + 1; j < nb() && label(start_column, j) == 1; ++j) {
            const double b = b0_ + (j + 0.5) * db;
            if (!test_.stable(alpha, b)) break;
            top = b;
        }
        auto edge = [&](double direction) {
            const double from = direction > 0 ? top : start;
            double inside = from, outside = from;
            for (int k = 1; k < 8 * nb(); ++k) {
                outside = from + direction * k * db / 4;
                if (!test_.stable(alpha, outside)) break;
                inside = outside;
            }
            for (int k = 0; k < 80 && std::abs(outside - inside) > tolerance * std::max(1.0, std::abs(inside)); ++k) {
                const double mid = (inside + outside) / 2;
                (test_.stable(alpha, mid) ? inside : outside) = mid;
            }
            return inside;
        };
        return {edge(-1), edge(1)};
    }

  private:
    static constexpr int kCoarseGrid = 16;
    static constexpr int kFallbackGrid = 40;
    static constexpr int kFinestGrid = 640;    ///< the finest re-scan of a region that continues beyond its tip
    static constexpr double kTipProbe = 1e-3;  ///< continues_beyond_tip's relative step in alpha

    /// Whether stable points lie above the tip found (alpha_max_ (1 + kTipProbe)), in the beta window three times
    /// the main region's stable interval at alpha_max_ (1 - kTipProbe) wide and centred on it, at 17 points. At a
    /// tip (smooth, corner or cusp) the region ends: none is stable. Where the scan's flood fill stopped at a
    /// waist, the region goes on as a band about as wide as that interval (window 30, d = 0, delta = 0.05: 0.124
    /// at alpha 0.115 and 0.187 at 0.120), which the 17 points (spacing 3/16 of it) find whenever the band is at
    /// least that wide inside the window. A stable island that close only costs a finer re-scan.
    bool continues_beyond_tip() const {
        const double a = alpha_max_;
        if (!(a > 0)) return false;
        auto [lo, hi] = beta_interval(a * (1 - kTipProbe), 1e-6);
        if (!(hi > lo)) {  // no interval found there: the window of one scan cell about the tip's beta
            lo = beta_at_alpha_max_ - (b1_ - b0_) / nb() / 2;
            hi = beta_at_alpha_max_ + (b1_ - b0_) / nb() / 2;
        }
        const double w = hi - lo, above = a * (1 + kTipProbe);
        for (int k = 0; k <= 16; ++k) {
            if (test_.stable(above, lo - w + k * (3 * w) / 16)) return true;
        }
        return false;
    }
    int na() const { return scan_na_; }
    int nb() const { return scan_nb_; }
    int label(int i, int j) const { return labels_[static_cast<std::size_t>(i * nb() + j)]; }

    /// Scans from the box (0, 1] x [-1, 4] and re-fits it until the main region fills it (class comment); false
    /// when the region is empty (nothing stable in the first column down to alpha 1e-9). `coarse`: the passes
    /// are on kCoarseGrid until the box fits, then one more at the options' grid (re-fitted there if it no longer
    /// fits; none more where the options' grid is kCoarseGrid). `wide`: receives the first scan's other components (the
    /// islands).
    bool fit_box(bool coarse, std::vector<StableIsland>* wide) {
        double a1 = 1, b0 = -1, b1 = 4;
        bool fine = !coarse || (options_.alpha_grid == kCoarseGrid && options_.beta_grid == kCoarseGrid);
        for (int pass = 0; pass < 40; ++pass) {
            scan(a1, b0, b1, fine ? options_.alpha_grid : kCoarseGrid, fine ? options_.beta_grid : kCoarseGrid,
                 !(wide && pass == 0));
            if (wide && pass == 0) *wide = other_components();
            if (main_cells_ == 0) {  // nothing stable in the first column: the main region is below one cell, or empty
                if (a1 < 1e-9) return false;
                const double w = (b1 - b0) / 4;
                a1 /= 4;
                b0 = -0.2 * w;
                b1 = 0.8 * w;
                continue;
            }
            // Re-fit the box: grow where the region touches an edge, shrink where it fills little of it.
            const double da = a1 / na(), db = (b1 - b0) / nb();
            const double top = (main_i1_ + 1) * da;
            const double lo = b0 + main_j0_ * db, hi = b0 + (main_j1_ + 1) * db;
            const bool touches = main_i1_ == na() - 1 || main_j0_ == 0 || main_j1_ == nb() - 1;
            const bool loose = top < 0.6 * a1 || (hi - lo) < 0.6 * (b1 - b0);
            if (!touches && !loose) {
                if (fine) return true;
                fine = true;  // the coarse box fits: scan it at the options' grid
                continue;
            }
            const double na1 = main_i1_ == na() - 1 ? 2 * a1 : 1.25 * top;
            const double margin = 0.15 * (hi - lo);
            const double nb0 = main_j0_ == 0 ? b0 - (b1 - b0) : lo - margin;
            const double nb1 = main_j1_ == nb() - 1 ? b1 + (b1 - b0) : hi + margin;
            a1 = na1;
            b0 = nb0;
            b1 = nb1;
        }
        return true;
    }

    /// Labels: 0 unstable (or, with `main_only`, not tested), 1 main component (flood fill from column 0), 2 stable
    /// elsewhere. `main_only`: only column 0 and the cells the flood fill reaches are tested (the main component is
    /// the same; nothing is labelled 2), so a pass whose column 0 has no stable cell tests that column only.
    void scan(double a1, double b0, double b1, int alpha_cells, int beta_cells, bool main_only) {
        scan_na_ = alpha_cells;
        scan_nb_ = beta_cells;
        a1_ = a1;
        b0_ = b0;
        b1_ = b1;
        const double da = a1 / na(), db = (b1 - b0) / nb();
        labels_.assign(static_cast<std::size_t>(na() * nb()), 0);
        main_cells_ = 0;
        main_i1_ = -1;
        main_j0_ = nb();
        main_j1_ = -1;
        auto stable_cell = [&](int cell) {
            const int i = cell / nb(), j = cell % nb();
            return test_.stable((i + 0.5) * da, b0 + (j + 0.5) * db);
        };
        std::vector<char> tested(labels_.size(), 0);
        if (!main_only) {
            for (std::size_t cell = 0; cell < labels_.size(); ++cell) {
                tested[cell] = 1;
                if (stable_cell(static_cast<int>(cell))) labels_[cell] = 2;
            }
        }
        std::vector<int> stack;
        auto visit = [&](int cell) {  // a stable cell the fill reaches joins the main component
            const auto c = static_cast<std::size_t>(cell);
            const bool stable = tested[c] ? labels_[c] == 2 : stable_cell(cell);
            tested[c] = 1;
            if (stable) {
                labels_[c] = 1;
                stack.push_back(cell);
            }
        };
        for (int j = 0; j < nb(); ++j) visit(j);
        while (!stack.empty()) {
            const int cell = stack.back();
            stack.pop_back();
            const int i = cell / nb(), j = cell % nb();
            ++main_cells_;
            main_i1_ = std::max(main_i1_, i);
            main_j0_ = std::min(main_j0_, j);
            main_j1_ = std::max(main_j1_, j);
            if (i > 0) visit(cell - nb());
            if (i + 1 < na()) visit(cell + nb());
            if (j > 0) visit(cell - 1);
            if (j + 1 < nb()) visit(cell + 1);
        }
    }

    std::vector<StableIsland> other_components() {
        const double da = a1_ / na(), db = (b1_ - b0_) / nb();
        std::vector<StableIsland> out;
        std::vector<int> seen(labels_.size(), 0);
        for (std::size_t start = 0; start < labels_.size(); ++start) {
            if (labels_[start] != 2 || seen[start]) continue;
            StableIsland box{HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL};
            std::vector<int> stack{static_cast<int>(start)};
            while (!stack.empty()) {
                const int cell = stack.back();
                stack.pop_back();
                if (labels_[static_cast<std::size_t>(cell)] != 2 || seen[static_cast<std::size_t>(cell)]) continue;
                seen[static_cast<std::size_t>(cell)] = 1;
                const int i = cell / nb(), j = cell % nb();
                box.alpha_min = std::min(box.alpha_min, i * da);
                box.alpha_max = std::max(box.alpha_max, (i + 1) * da);
                box.beta_min = std::min(box.beta_min, b0_ + j * db);
                box.beta_max = std::max(box.beta_max, b0_ + (j + 1) * db);
                if (i > 0) stack.push_back(cell - nb());
                if (i + 1 < na()) stack.push_back(cell + nb());
                if (j > 0) stack.push_back(cell - 1);
                if (j + 1 < nb()) stack.push_back(cell + 1);
            }
            out.push_back(box);
        }
        return out;
    }

    /// The main region's edge at beta: march up from its highest cell in the nearest column, then bisect.
    double edge_at(double beta) const {
        const double da = a1_ / na(), db = (b1_ - b0_) / nb();
        const int j = std::clamp(static_cast<int>((beta - b0_) / db), 0, nb() - 1);
        double inside = -1;
        for (int i = na() - 1; i >= 0 && inside < 0; --i) {
            if (label(i, j) == 1 && test_.stable((i + 0.5) * da, beta)) inside = (i + 0.5) * da;
        }
        if (inside < 0) return 0;
        double outside = inside;
        for (int k = 1; k < 16 * na(); ++k) {
            outside = inside + da / 4;
            if (!test_.stable(outside, beta)) break;
            inside = outside;
        }
        for (int k = 0; k < 80 && outside - inside > 1e-14 * std::max(1.0, inside); ++k) {
            const double mid = (inside + outside) / 2;
            (test_.stable(mid, beta) ? inside : outside) = mid;
        }
        return inside;
    }

    /// Sets alpha_max_ and beta_at_alpha_max_; true when the curve's maximum gave them (a smooth tip).
    bool refine_tip() {
        const double db = (b1_ - b0_) / nb();
        int best_j = -1;
        for (int j = 0; j < nb() && best_j < 0; ++j) {
            if (label(main_i1_, j) == 1) best_j = j;
        }
        int last_j = best_j;
        while (last_j + 1 < nb() && label(main_i1_, last_j + 1) == 1) ++last_j;
        const double centre = b0_ + ((best_j + last_j) / 2.0 + 0.5) * db;
        const double half = (last_j - best_j + 1) * db / 2 + 2 * db;
        if (curve_tip(centre - half, centre + half)) return true;
        const detail::ScalarMinimum m =
            detail::minimize_scalar([&](double b) { return -edge_at(b); }, centre - half, centre + half, 1e-13);
        beta_at_alpha_max_ = m.x;
        alpha_max_ = -m.value;
        corner_tip(centre - half, centre + half);
        return false;
    }

    /// A corner or cusp tip exactly: from alpha_max_, beta_at_alpha_max_ (the edge's maximum, a main-region point and
    /// a lower bound of the tip), the largest candidate of region_tip_candidates (region_tip.hpp) with beta in
    /// [beta_lo, beta_hi] and alpha at or above that bound that is joined to it by stable points: the segment from the
    /// candidate to the middle of the stable alpha interval at beta_at_alpha_max_ (marched down from the edge in steps
    /// of alpha_max_ / 1024) stable at 64 equally spaced points and at 1e-9, 1e-6 and 1e-3 of its length from the
    /// candidate. Nothing changes where no candidate passes.
    void corner_tip(double beta_lo, double beta_hi) {
        const double bound = alpha_max_, beta = beta_at_alpha_max_;
        if (!(bound > 0)) return;
        std::vector<RegionTipCandidate> candidates =
            region_tip_candidates(test_.polynomial(), std::max(64, 16 * test_.polynomial().degree()));
        std::sort(candidates.begin(), candidates.end(),
                  [](const RegionTipCandidate& a, const RegionTipCandidate& b) { return a.alpha > b.alpha; });
        double lower = bound;
        const double step = bound / 1024;
        for (int k = 1; k < 1024 && test_.stable(bound - k * step, beta); ++k) lower = bound - k * step;
        const double anchor_alpha = (lower + bound) / 2;
        for (const RegionTipCandidate& c : candidates) {
            if (c.alpha < bound * (1 - 1e-12)) break;
            if (!(c.beta >= beta_lo && c.beta <= beta_hi)) continue;
            bool joined = true;
            auto joined_at = [&](double s) {
                joined = joined && test_.stable(c.alpha + s * (anchor_alpha - c.alpha), c.beta + s * (beta - c.beta));
            };
            for (const double s : {1e-9, 1e-6, 1e-3}) joined_at(s);
            for (int k = 1; k <= 64 && joined; ++k) joined_at(k / 64.0);
            if (!joined) continue;
            alpha_max_ = c.alpha;
            beta_at_alpha_max_ = c.beta;
            return;
        }
    }

    /// The tip as a smooth maximum of the D-decomposition curve (header comment), when the region's own edge
    /// confirms it: true and alpha_max_, beta_at_alpha_max_ set, or false (a corner tip, or no local maximum of
    /// the curve in the tip's window) and nothing set.
    bool curve_tip(double beta_lo, double beta_hi) {
        const AffineCharacteristicPolynomial<double>& p = test_.polynomial();
        const int n = p.degree();
        auto point = [&](double theta) {
            const std::complex<double> z = std::polar(1.0, theta);
            std::complex<double> c0 = 0, ca = 0, cb = 0;
            for (int k = n; k >= 0; --k) {
                c0 = c0 * z + p.base(k);
                ca = ca * z + p.alpha(k);
                cb = cb * z + p.beta(k);
            }
            const double det = ca.real() * cb.imag() - ca.imag() * cb.real();
            return std::pair<double, double>{(c0.imag() * cb.real() - c0.real() * cb.imag()) / det,
                                             (c0.real() * ca.imag() - c0.imag() * ca.real()) / det};
        };
        const double pi = 3.14159265358979323846;
        const int samples = std::max(64, 16 * n);
        const double da = a1_ / na();
        const double a_lo = (main_i1_ - 1) * da, a_hi = (main_i1_ + 2) * da;
        double best_alpha = -HUGE_VAL, best_beta = 0;
        std::pair<double, double> previous = point(pi / samples), current = point(2 * pi / samples);
        for (int k = 2; k < samples; ++k) {
            const std::pair<double, double> next = point(pi * (k + 1) / samples);
            const bool peak = current.first >= previous.first && current.first >= next.first;
            if (peak && current.first > a_lo && current.first < a_hi && current.second > beta_lo &&
                current.second < beta_hi) {
                const detail::ScalarMinimum m = detail::minimize_scalar(
                    [&](double t) { return -point(t).first; }, pi * (k - 1) / samples, pi * (k + 1) / samples, 1e-15);
                const std::pair<double, double> tip = point(m.x);
                if (tip.first > best_alpha && std::isfinite(tip.second)) {
                    best_alpha = tip.first;
                    best_beta = tip.second;
                }
            }
            previous = current;
            current = next;
        }
        if (!(best_alpha > 0 && best_alpha < HUGE_VAL)) return false;
        const double edge = edge_at(best_beta);
        if (!(std::abs(edge - best_alpha) <= 1e-12 * best_alpha + 2e-14)) return false;
        alpha_max_ = edge;  // the stable side, as the edge's maximum below
        beta_at_alpha_max_ = best_beta;
        return true;
    }

    EstimatorStabilityTest test_;
    EstimatorRegionOptions options_;
    std::vector<int> labels_;
    std::vector<StableIsland> islands_;
    double a1_ = 1, b0_ = -1, b1_ = 4;
    int main_cells_ = 0, main_i1_ = -1, main_j0_ = 0, main_j1_ = -1;
    int scan_na_ = 16, scan_nb_ = 16;
    double alpha_max_ = 0, beta_at_alpha_max_ = 0;
};

/// The boundary of the main stable region with the estimator, as a closed polyline of (alpha, beta) in normalised
/// units: at alphas alpha_max sin(pi s / 2), s = 1e-6 and k / points (k = 1 .. points - 1), the ends of the
/// main region's stable beta interval (EstimatorStabilityRegion::beta_interval: the Schur-Cohn verdict of
/// EstimatorStabilityTest marched from a main-region cell and bisected to ~1e-14, i.e. the D-decomposition's
/// curves found pointwise instead of parametrically); the lower ends in increasing alpha, the tip
/// (alpha_max, beta_at_alpha_max), the upper ends in decreasing alpha, the first point repeated. The sine
/// spacing puts the points densely near the tip, where the two ends meet. Assumes one stable beta interval of the
/// main region per alpha (the region between a lower and an upper edge, as the backward difference's; where a
/// cross-section has several, the one through the scan's main cell is drawn). Stable islands are not part of it
/// (EstimatorStabilityRegion::islands). For window 1 (the backward difference) the points lie on
/// StabilityRegion's exact boundary (tests/core/test_velocity_cli.cpp). Empty when the region is empty
/// (alpha_max 0). Cost: about 2 (points + 1) x (8 beta_grid + 50) verdicts, O(degree^2) each. Throws
/// InvalidParameter naming `points` unless 8 <= points <= 10^5.
HAPTICOPT_DEFERRED
std::vector<std::pair<double, double>> estimator_region_boundary(const EstimatorStabilityRegion& region,
                                                                 int points = 256) {
    detail::require_in_range("hapticopt::estimator_region_boundary", "points", points, 8, false, 1e5,
                             "8 <= points <= 10^5");
    std::vector<std::pair<double, double>> lower, upper;
    if (!(region.alpha_max() > 0)) return lower;
    const double pi = 3.14159265358979323846;
    for (int k = 0; k < points; ++k) {
        const double s = k == 0 ? 1e-6 : static_cast<double>(k) / points;
        const double a = region.alpha_max() * std::sin(pi * s / 2);
        const std::pair<double, double> interval = region.beta_interval(a);
        if (!(interval.second > interval.first)) continue;
        lower.emplace_back(a, interval.first);
        upper.emplace_back(a, interval.second);
    }
    lower.emplace_back(region.alpha_max(), region.beta_at_alpha_max());
    lower.insert(lower.end(), upper.rbegin(), upper.rend());
    lower.push_back(lower.front());
    return lower;
}

}  // namespace hapticopt

# SPDX-License-Identifier: Apache-2.0
"""The vectorised costs: equal to the point-wise calls, broadcasting, NaN cells, the GIL released."""
from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest

import hapticopt as ho

PLANT = ho.Plant(0.0005, 0.01, 1.0)


def small_grid():
    b = ho.boundary(PLANT)
    alphas = np.linspace(-0.01, b.alpha_max * 1.05, 7)  # includes unstable columns
    betas = np.linspace(-0.1, 1.2, 6)
    return alphas, betas


@pytest.mark.parametrize("criterion", ho.CRITERIA_WITH_SURFACE)
def test_grid_equals_the_point_wise_calls(criterion):
    alphas, betas = small_grid()
    grid = ho.cost_grid(criterion, alphas, betas, PLANT)
    assert grid.shape == (len(betas), len(alphas))
    for i, b in enumerate(betas):
        for j, a in enumerate(alphas):
            # The same C++ function on the same precomputed plant: bit for bit.
            expected = ho.costs(a, b, PLANT)[criterion]
            assert grid[i, j] == expected or (math.isinf(expected) and math.isinf(grid[i, j])), (a, b)
    assert np.isinf(grid).any() and np.isfinite(grid).any()  # both regimes were exercised


def test_broadcasting_and_scalars():
    a = np.array([[0.02], [0.05]])
    b = np.array([0.2, 0.3, 0.4])
    out = ho.cost("CE2", a, b, PLANT)
    assert out.shape == (2, 3)
    assert out[1, 2] == ho.cost("CE2", 0.05, 0.4, PLANT)
    assert isinstance(ho.cost("CE2", 0.05, 0.4, PLANT), float)
    assert ho.cost("CE0", [], [], PLANT).shape == (0,)
    # Non-contiguous and integer inputs are converted.
    strided = np.linspace(0.01, 0.05, 10)[::3]
    np.testing.assert_array_equal(ho.cost("CE1", strided, 0.3, PLANT),
                                  [ho.cost("CE1", float(x), 0.3, PLANT) for x in strided])


def test_nan_gives_nan_at_that_cell_only():
    a = np.array([0.05, np.nan, 0.05, np.inf, 0.05])
    b = np.array([0.3, 0.3, np.nan, 0.3, 0.3])
    for criterion in ho.CRITERIA_WITH_SURFACE:
        out = ho.cost(criterion, a, b, PLANT)
        assert np.isnan(out[[1, 2, 3]]).all(), criterion
        assert np.isfinite(out[[0, 4]]).all(), criterion
        assert out[0] == out[4] == ho.costs(0.05, 0.3, PLANT)[criterion]


def test_unstable_cells_are_infinite():
    assert ho.cost("CE2", 0.5, 0.1, ho.Plant(delay=1.0)) == math.inf
    assert ho.cost("OV", 0.5, 0.1, ho.Plant(delay=1.0)) == math.inf


def test_the_gil_is_released_while_the_grid_computes():
    alphas = np.linspace(0.005, 0.14, 300)
    betas = np.linspace(0.05, 0.9, 300)
    done = threading.Event()
    result = {}

    def work():
        result["grid"] = ho.cost_grid("CE2", alphas, betas, PLANT)
        done.set()

    worker = threading.Thread(target=work)
    ticks = 0
    worker.start()
    while not done.is_set():  # runs only if the worker does not hold the GIL
        ticks += 1
        time.sleep(0.001)
    worker.join()
    assert result["grid"].shape == (300, 300)
    # 9e4 cells take >= 0.05 s (>= 0.5 us each: the C++ benchmark's fastest cost), so a released
    # GIL lets this loop run many times; a held GIL would allow at most one or two iterations.
    assert ticks >= 10


def test_optimal_curve_matches_the_optimal_beta_and_cost():
    o = ho.optimal_point("CE2", PLANT)
    curve = ho.optimal_curve("CE2", [o.alpha, 0.5 * o.alpha, np.nan, 10.0], PLANT)
    assert abs(curve.beta[0] - o.beta) <= 1e-8  # beta_opt polished to ~1e-10 (optimum.hpp)
    assert curve.cost[1] == ho.cost("CE2", 0.5 * o.alpha, curve.beta[1], PLANT)
    assert np.isnan(curve.beta[2]) and np.isnan(curve.beta[3])  # NaN and beyond alpha_max
    # Optimality: nearby betas cost more (by at least rounding; the minimum is quadratic).
    for delta_beta in (-1e-3, 1e-3):
        assert ho.cost("CE2", curve.alpha[1], curve.beta[1] + delta_beta, PLANT) > curve.cost[1]


@pytest.mark.parametrize("criterion", ["OV", "CI0", "CI2", "CE0"])
def test_optimal_curves_are_minima_over_beta(criterion):
    b = ho.boundary(PLANT)
    alphas = np.array([0.15, 0.4, 0.7]) * b.alpha_max
    curve = ho.optimal_curve(criterion, alphas, PLANT)
    for a, beta, c in zip(curve.alpha, curve.beta, curve.cost):
        assert c == ho.cost(criterion, a, beta, PLANT)
        lo, hi = ho.beta_range(a, PLANT)
        assert lo < beta < hi
        # A minimiser: no better beta at +-1e-3 (far beyond Brent's ~1e-8 flatness limit) nor on a
        # coarse scan of the stable interval (<= allows OV's flat zero-overshoot intervals).
        for other in (beta - 1e-3, beta + 1e-3, *np.linspace(lo, hi, 41)[1:-1]):
            assert c <= ho.cost(criterion, a, other, PLANT) * (1 + 1e-12), (a, beta, other)


@pytest.mark.parametrize("criterion", ["CE2", "OV", "CI1"])
def test_threads_give_the_same_cells(criterion):
    alphas, betas = small_grid()
    a, b = np.meshgrid(alphas, betas)
    a[2, 3] = np.nan  # a NaN cell stays NaN on every thread count
    one = ho.cost(criterion, a, b, PLANT)
    for threads in (2, 3, 64):
        np.testing.assert_array_equal(ho.cost(criterion, a, b, PLANT, threads=threads), one)
    assert np.isnan(one[2, 3])


def test_bad_thread_count():
    with pytest.raises(ValueError) as error:
        ho.cost("CE2", [0.05], [0.3], PLANT, threads=0)
    assert "threads" in str(error.value) and "accepted" in str(error.value)

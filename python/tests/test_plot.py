# SPDX-License-Identifier: Apache-2.0
"""The figures render with Agg and their artists carry the computed data."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import hapticopt as ho  # noqa: E402
from hapticopt import plot  # noqa: E402

PLANT = ho.Plant(delay=1.0)


def mesh_labelled(ax, label):
    matches = [c for c in ax.collections if c.get_label() == label]
    assert len(matches) == 1, [c.get_label() for c in ax.collections]
    return matches[0]


def line(ax, label):
    matches = [l for l in ax.get_lines() if l.get_label() == label]
    assert len(matches) == 1, [l.get_label() for l in ax.get_lines()]
    return matches[0]


@pytest.fixture
def ax():
    figure, axes = plt.subplots()
    yield axes
    figure.canvas.draw()  # renders with Agg: a drawing error fails the test
    plt.close(figure)


def test_region(ax):
    assert plot.region(ax, PLANT, optima=("CE2",)) is ax
    b = ho.boundary(PLANT)
    np.testing.assert_array_equal(line(ax, "boundary d=1").get_xydata(), np.column_stack([b.alpha, b.beta]))
    np.testing.assert_array_equal(line(ax, "alpha_max").get_xydata(), [[b.alpha_max, b.beta_at_alpha_max]])
    o = ho.optimal_point("CE2", PLANT)
    np.testing.assert_array_equal(line(ax, "CE2").get_xydata(), [[o.alpha, o.beta]])


def test_costs(ax):
    plot.costs(ax, "CE2", PLANT, resolution=40, curve_points=12)
    o = ho.optimal_point("CE2", PLANT)
    np.testing.assert_array_equal(line(ax, "optimum CE2").get_xydata(), [[o.alpha, o.beta]])
    curve = line(ax, "optimal curve CE2").get_xydata()
    expected = ho.optimal_curve("CE2", curve[:, 0], PLANT)
    np.testing.assert_array_equal(curve[:, 1], expected.beta)
    # The colour mesh is the computed grid.
    b = ho.boundary(PLANT)
    z = ho.cost_grid("CE2", np.linspace(0, b.alpha_max, 40), np.linspace(b.beta.min(), b.beta.max(), 40), PLANT)
    mesh = mesh_labelled(ax, "log10 CE2")
    drawn = np.ma.masked_invalid(mesh.get_array()).reshape(z.shape)
    np.testing.assert_array_equal(drawn.mask, ~np.isfinite(z))
    np.testing.assert_array_equal(drawn.compressed(), np.log10(z[np.isfinite(z)]))


def test_step(ax):
    o = ho.optimal_point("CE2", PLANT)
    plot.step(ax, [o, (0.03, 0.5)], PLANT, periods=30, samples_per_period=10)
    data = line(ax, "CE2").get_xydata()
    r = ho.step_response(o.alpha, o.beta, data[:, 0], PLANT)
    np.testing.assert_array_equal(data[:, 1], r.position / r.final_position)
    samples = line(ax, "samples CE2").get_xydata()
    np.testing.assert_array_equal(samples[:, 1], ho.sampled_step_response(o.alpha, o.beta, 31, PLANT) / r.final_position)
    ov = ho.overshoot(o.alpha, o.beta, PLANT)
    assert ov.value > 1e-3  # the CE2 optimum overshoots (Fig. 5)
    np.testing.assert_array_equal(line(ax, "overshoot CE2").get_xydata(), [[ov.time, 1 + ov.value]])
    # The marked maximum is at least every drawn value of that curve.
    assert 1 + ov.value >= data[:, 1].max()


def test_overshoot(ax):
    plot.overshoot(ax, PLANT, resolution=30, criteria=("OV", "CE2+OV"))
    for criterion in ("OV", "CE2+OV"):
        o = ho.optimal_point(criterion, PLANT)
        np.testing.assert_array_equal(line(ax, criterion).get_xydata(), [[o.alpha, o.beta]])
    b = ho.boundary(PLANT)
    z = ho.cost_grid("OV", np.linspace(0, b.alpha_max, 30), np.linspace(b.beta.min(), b.beta.max(), 30), PLANT)
    drawn = np.ma.masked_invalid(mesh_labelled(ax, "no overshoot").get_array()).reshape(z.shape)
    np.testing.assert_array_equal(~np.ma.getmaskarray(drawn), z <= 1e-12)
    assert (z <= 1e-12).any() and (z > 1e-12).any()


def test_new_axes_when_none():
    ax = plot.region(None, PLANT, points=32)
    assert ax.figure is not None
    plt.close(ax.figure)


def test_noise_pareto(ax):
    """Each line's vertices are noise_pareto_front() at the documented budgets; checked independently: every
    point's g_F recomputed by force_noise_gain() meets its budget (1e-12 relative: two evaluations of g_F at the
    same gains), the cost does not fall as the budget tightens (1e-9 relative: the search's stated accuracy),
    and the unconstrained marker is optimal_point() with the estimator (cost to 1e-9 relative: C is flat at its
    minimum, so the two searches' gain tolerances move it far less)."""
    estimators = ("backward", "lowpass:0.05")
    assert ho.plot_noise_pareto is plot.noise_pareto
    assert plot.noise_pareto(ax, "CE2", PLANT, estimators=estimators, points=4, decades=1.5) is ax
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    for name in estimators:
        free = ho.optimal_point("CE2", PLANT, estimator=name)
        g0 = ho.force_noise_gain(free.alpha, free.beta, PLANT, estimator=name)
        marker = line(ax, f"unconstrained {name}").get_xydata()
        np.testing.assert_allclose(marker[0, 1], free.cost, rtol=1e-9)
        budgets = marker[0, 0] * np.logspace(0.0, -1.5, 4)
        front = ho.noise_pareto_front("CE2", budgets, PLANT, estimator=name)
        drawn = line(ax, name).get_xydata()
        np.testing.assert_array_equal(drawn, [[o.force_noise_gain, o.cost] for o in front])
        assert len(front) == 4
        np.testing.assert_allclose(marker[0, 0], g0, rtol=1e-6)
        for budget, o in zip(budgets, front):
            assert ho.force_noise_gain(o.alpha, o.beta, PLANT, estimator=name) <= budget * (1 + 1e-12)
        costs = drawn[:, 1]
        assert np.all(costs[1:] >= costs[:-1] * (1 - 1e-9))
        assert costs[-1] > 10 * costs[0]  # 1.5 decades less noise cost more than a decade of CE2 (CLI figure)
    with pytest.raises(ValueError, match="points"):
        plot.noise_pareto(ax, points=1)

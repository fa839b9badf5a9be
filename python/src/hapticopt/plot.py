# SPDX-License-Identifier: Apache-2.0
"""The paper's figures on a matplotlib Axes (needs matplotlib: `pip install hapticopt[plot]`).

Every function draws on `ax` (a new figure's Axes when None) and returns it, as a notebook user
expects; the data drawn are exactly the package's computed arrays (boundary(), cost_grid(),
optimal_curve(), optimal_point(), step_response()), so the artists carry the computed values:

- region(ax, plant): Fig. 3, the exact stable region (polygon) with its tip alpha_max;
- costs(ax, criterion, plant): Fig. 4, log10 contours of C(alpha, beta), the optimal curve and point;
- step(ax, gains, plant): Fig. 5, continuous-time step responses, the samples, the overshoot maximum;
- overshoot(ax, plant): Fig. 6, the no-overshoot region (C_OV <= tolerance) and the OV / CEx+OV points;
- noise_pareto(ax, criterion, plant): beyond the paper, the optimum under a force-noise budget against g_F per
  velocity estimator (noise_pareto_front()); also hapticopt.plot_noise_pareto.

Labels (Artist.get_label()) name what each artist shows, e.g. "boundary d=1", "optimal curve CE2".
"""
from __future__ import annotations

from typing import Iterable, Optional, Sequence, Tuple, Union

import numpy as np

from .costs import cost_grid, overshoot as _overshoot
from .estimator import EstimatorLike, velocity_estimator
from .optima import Optimum, noise_pareto_front, optimal_curve, optimal_point, optimal_point_under_noise_budget
from .parameters import Gains, Plant
from .region import boundary
from .response import sampled_step_response, step_response

__all__ = ["region", "costs", "step", "overshoot", "noise_pareto"]


def _axes(ax):
    if ax is not None:
        return ax
    try:
        import matplotlib.pyplot as plt
    except ImportError as error:  # pragma: no cover - depends on the environment
        raise ImportError("hapticopt.plot needs matplotlib: pip install 'hapticopt[plot]'") from error
    return plt.figure().add_subplot()


def _plant(plant: Optional[Plant]) -> Plant:
    return Plant() if plant is None else plant


def _delay_label(plant: Plant) -> str:
    return f"d={plant.delay:g}"


def region(ax=None, plant: Optional[Plant] = None, *, points: int = 256, fill: bool = True,
           optima: Sequence[str] = (), **line_kwargs):
    """Fig. 3: the stability boundary polygon (line labelled "boundary d=<d>"), filled when `fill`,
    the tip alpha_max ("alpha_max") and markers at the optimal points of `optima` ("<criterion>")."""
    ax = _axes(ax)
    p = _plant(plant)
    b = boundary(p, points)
    line_kwargs.setdefault("label", f"boundary {_delay_label(p)}")
    (line,) = ax.plot(b.alpha, b.beta, **line_kwargs)
    if fill:
        ax.fill(b.alpha, b.beta, alpha=0.15, color=line.get_color(), label="_stable region")
    ax.plot([b.alpha_max], [b.beta_at_alpha_max], "o", color=line.get_color(), label="alpha_max")
    for criterion in optima:
        o = optimal_point(criterion, p)
        ax.plot([o.alpha], [o.beta], "x", label=criterion)
    ax.set_xlabel("alpha = K T^2/m")
    ax.set_ylabel("beta = B T/m")
    return ax


def costs(ax=None, criterion: str = "CE2", plant: Optional[Plant] = None, *,
          alpha_range: Optional[Tuple[float, float]] = None, beta_range: Optional[Tuple[float, float]] = None,
          resolution: int = 150, levels: int = 10, decades: float = 1.0, curve: bool = True, point: bool = True,
          curve_points: int = 40):
    """Fig. 4: log10 C(alpha, beta) on a resolution x resolution grid over the region's bounding box
    (or the given ranges) as a colour mesh (QuadMesh labelled "log10 <criterion>", its array the
    computed values; unstable cells, +inf, masked; colours span `decades` above the grid's minimum,
    larger values saturate) with `levels` contour lines in that span, the boundary, the
    optimal curve ("optimal curve <criterion>") and point ("optimum <criterion>")."""
    ax = _axes(ax)
    p = _plant(plant)
    b = boundary(p)
    a0, a1 = alpha_range if alpha_range else (max(b.alpha_min, 0.0), b.alpha_max)
    b0, b1 = beta_range if beta_range else (float(np.min(b.beta)), float(np.max(b.beta)))
    alphas = np.linspace(a0, a1, resolution)
    betas = np.linspace(b0, b1, resolution)
    z = cost_grid(criterion, alphas, betas, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_z = np.where(np.isfinite(z) & (z > 0), np.log10(z), np.nan)
    finite = np.isfinite(log_z)
    low = float(np.min(log_z[finite])) if finite.any() else 0.0
    mesh = ax.pcolormesh(alphas, betas, np.ma.masked_invalid(log_z), shading="nearest", vmin=low, vmax=low + decades)
    mesh.set_label(f"log10 {criterion}")
    if finite.sum() > 4:
        ax.contour(alphas, betas, np.ma.masked_invalid(log_z), levels=np.linspace(low, low + decades, levels + 1)[1:],
                   colors="k", linewidths=0.4, alpha=0.5)
    ax.plot(b.alpha, b.beta, "k-", linewidth=1, label=f"boundary {_delay_label(p)}")
    if curve and criterion != "OV":
        lo = max(b.alpha_min, a0)
        grid = np.linspace(lo + (a1 - lo) / curve_points, min(a1, b.alpha_max), curve_points)
        c = optimal_curve(criterion, grid, p)
        ax.plot(c.alpha, c.beta, "--", color="tab:orange", label=f"optimal curve {criterion}")
    if point:
        o = optimal_point(criterion, p)
        ax.plot([o.alpha], [o.beta], "r*", markersize=12, label=f"optimum {criterion}")
    ax.set_xlim(a0, a1)
    ax.set_ylim(b0, b1)
    ax.set_xlabel("alpha = K T^2/m")
    ax.set_ylabel("beta = B T/m")
    ax.set_title(f"log10 {criterion}, {_delay_label(p)}")
    return ax


GainsLike = Union[Gains, Optimum, Tuple[float, float]]


def _gains_of(g: GainsLike) -> Tuple[float, float, str]:
    if isinstance(g, Optimum):
        return g.alpha, g.beta, g.criterion
    if isinstance(g, Gains):
        return g.alpha, g.beta, f"alpha={g.alpha:.4g} beta={g.beta:.4g}"
    a, b = g
    return float(a), float(b), f"alpha={float(a):.4g} beta={float(b):.4g}"


def step(ax=None, gains: Iterable[GainsLike] = (), plant: Optional[Plant] = None, *, periods: float = 40,
         samples_per_period: int = 20, show_samples: bool = True, mark_overshoot: bool = True,
         overshoot_tolerance: float = 1e-12):
    """Fig. 5: x(t) / x_inf of the unit step for each gain pair (a Gains, an Optimum or (alpha,
    beta)); line labelled by the criterion or the gains. With `show_samples`, the samples x_j
    ("samples <label>"); with `mark_overshoot`, the continuous-time maximum (time, x_max/x_inf) when
    C_OV exceeds the tolerance ("overshoot <label>")."""
    ax = _axes(ax)
    p = _plant(plant)
    t = np.linspace(0.0, periods, int(periods * samples_per_period) + 1)
    for g in gains:
        a, b, label = _gains_of(g)
        r = step_response(a, b, t, p)
        (line,) = ax.plot(r.time, r.position / r.final_position, label=label)
        if show_samples:
            j = np.arange(int(np.floor(periods)) + 1)
            x = sampled_step_response(a, b, len(j), p)
            ax.plot(j, x / r.final_position, ".", color=line.get_color(), label=f"samples {label}")
        if mark_overshoot:
            o = _overshoot(a, b, p, tolerance=overshoot_tolerance)
            if not o.within_tolerance and np.isfinite(o.value) and o.value > 0:
                ax.plot([o.time], [1.0 + o.value], "v", color=line.get_color(), label=f"overshoot {label}")
    ax.axhline(1.0, color="grey", linewidth=0.5, label="_x_inf")
    ax.set_xlabel("t / T")
    ax.set_ylabel("x / x_inf")
    return ax


def overshoot(ax=None, plant: Optional[Plant] = None, *, tolerance: float = 1e-12, resolution: int = 100,
              criteria: Sequence[str] = ("OV", "CE0+OV", "CE1+OV", "CE2+OV")):
    """Fig. 6: the stable region ("boundary d=<d>"), the cells of a resolution x resolution grid
    without overshoot (C_OV <= tolerance; a QuadMesh labelled "no overshoot" whose array is 1 there
    and masked elsewhere), and markers at the optimal points of `criteria` ("<criterion>")."""
    ax = _axes(ax)
    p = _plant(plant)
    b = boundary(p)
    alphas = np.linspace(max(b.alpha_min, 0.0), b.alpha_max, resolution)
    betas = np.linspace(float(np.min(b.beta)), float(np.max(b.beta)), resolution)
    z = cost_grid("OV", alphas, betas, p, overshoot_tolerance=tolerance)
    indicator = np.ma.masked_where(~(z <= tolerance), np.ones_like(z))
    mesh = ax.pcolormesh(alphas, betas, indicator, shading="nearest", cmap="Greens", vmin=0.0, vmax=2.0)
    mesh.set_label("no overshoot")
    ax.plot(b.alpha, b.beta, "k-", linewidth=1, label=f"boundary {_delay_label(p)}")
    for criterion in criteria:
        o = optimal_point(criterion, p, overshoot_tolerance=tolerance)
        ax.plot([o.alpha], [o.beta], "o", label=criterion)
    ax.set_xlabel("alpha = K T^2/m")
    ax.set_ylabel("beta = B T/m")
    ax.set_title(f"no overshoot (C_OV <= {tolerance:g}), {_delay_label(p)}")
    return ax


def noise_pareto(ax=None, criterion: str = "CE2", plant: Optional[Plant] = None, *,
                 estimators: Sequence[EstimatorLike] = ("backward", "lowpass:0.02", "window:5"), points: int = 12,
                 decades: float = 2.0):
    """The trade-off of `criterion` (CE0, CE1 or CE2) against quantisation force noise: for each estimator the
    optimum under a force-noise budget (noise_pareto_front()) at `points` budgets log-spaced from the
    unconstrained optimum's g_F down to 10**-decades of it, cost against the g_F reached, both axes
    logarithmic (a line labelled with the estimator's spelling, e.g. "lowpass:0.02", its vertices
    (force_noise_gain, cost) of the front), and the unconstrained optimum ("unconstrained <spelling>").
    sigma_F = (m q / T^2) g_F in newtons. The CLI's figure: `hapticopt plot noise-pareto`. About 5 s for the
    default three estimators at d = 1."""
    if points < 2:
        raise ValueError(f"hapticopt.plot.noise_pareto: points = {points} is invalid; accepted: >= 2")
    if not (np.isfinite(decades) and decades > 0):
        raise ValueError(f"hapticopt.plot.noise_pareto: decades = {decades} is invalid; accepted: finite and > 0")
    ax = _axes(ax)
    p = _plant(plant)
    for estimator in estimators:
        e = velocity_estimator(estimator)
        free = optimal_point_under_noise_budget(criterion, 1e300, p, estimator=e)  # the unconstrained optimum
        budgets = free.unconstrained_force_noise_gain * np.logspace(0.0, -decades, points)
        front = noise_pareto_front(criterion, budgets, p, estimator=e)
        name = str(e)
        (line,) = ax.plot([o.force_noise_gain for o in front], [o.cost for o in front], ".-", label=name)
        ax.plot([free.unconstrained_force_noise_gain], [free.unconstrained_cost], "P", color=line.get_color(),
                label=f"unconstrained {name}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("g_F (force noise per encoder step, normalised; sigma_F = m q / T^2 g_F)")
    ax.set_ylabel(f"{criterion} under the budget")
    ax.set_title(f"{criterion} against force noise, {_delay_label(p)}")
    return ax

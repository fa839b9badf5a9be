# SPDX-License-Identifier: Apache-2.0
"""Coulomb friction and encoder quantisation: the rest of the quantised wall, Abbott & Okamura's passivity bound and
the describing-function limit cycle (include/hapticopt/limit_cycles.hpp; docs/limit-cycles.md for the model, the
sources, the assumptions and the measured accuracy). Physical units."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional

from . import _core
from .parameters import PhysicalPlant, WallGains


@dataclass(frozen=True)
class AbbottOkamuraPassivity:
    """K <= max(2 b / T, 2 f_c / q): a spring wall (B = 0) behind a zero-order hold without further delay (d = 0)."""

    viscous_bound: float  # 2 b / T [N/m]
    coulomb_bound: float  # 2 f_c / q [N/m]
    stiffness_bound: float  # the larger [N/m]
    passive: bool


@dataclass(frozen=True)
class LimitCycle:
    """One solution of the harmonic balance 1 + N(x0, A) G(e^{j theta}) = 0."""

    amplitude: float  # A [m], of the position's fundamental
    frequency: float  # [Hz]
    theta: float  # w T [rad]
    mean_position: float  # x0 [m]
    describing_gain: float  # N(x0, A) of the rounding quantiser
    equivalent_damping: float  # b_eq = 4 f_c / (pi A w) [N s/m]
    stable: bool  # attracts (Loeb's criterion, amplitude form)


@dataclass(frozen=True)
class LimitCyclePrediction:
    """The describing function's verdict. `cycle` is the largest stable cycle, else the largest one (None: no cycle).
    `rest_exists`: a sticking rest holds the push (exact); then the cycle may coexist with it or not exist at all.
    `grows_at_large_amplitude`: the equivalent loop is unstable at 1e3 q (outside the linear stable region)."""

    predicted: bool
    cycle: Optional[LimitCycle]
    cycles: List[LimitCycle]
    rest_exists: bool
    grows_at_large_amplitude: bool


def _cycle(d: Dict[str, object]) -> LimitCycle:
    return LimitCycle(**d)  # type: ignore[arg-type]


def abbott_okamura_passivity(gains: WallGains, plant: PhysicalPlant, coulomb_friction: float,
                             position_step: float) -> AbbottOkamuraPassivity:
    """Abbott & Okamura (IEEE Trans. Robotics 21(5), 2005) for the wall's stiffness K, the plant's viscous damping b
    and period T, Coulomb friction f_c [N] and encoder step q [m]. The condition assumes B = 0 and d = 0."""
    v, c, s, p = _core.abbott_okamura_passivity(float(gains.stiffness), float(plant.damping), float(coulomb_friction),
                                                float(position_step), float(plant.period))
    return AbbottOkamuraPassivity(v, c, s, bool(p))


def quantised_rest_exists(push: float, gains: WallGains, coulomb_friction: float, position_step: float,
                          plant_stiffness: float = 0.0) -> bool:
    """Whether the quantised wall can hold the constant push F [N] at rest: some level n q and position x in its bin
    with |F - K n q - k x| <= f_c (k: the plant's spring). Exact for the model."""
    return bool(_core.quantised_rest_exists(float(push), float(gains.stiffness), float(coulomb_friction),
                                            float(position_step), float(plant_stiffness)))


def predict_limit_cycle(gains: WallGains, plant: PhysicalPlant, position_step: float, *, coulomb_friction: float = 0.0,
                        push: float = 0.0) -> LimitCyclePrediction:
    """The describing-function limit cycle of the wall (K, B) on the plant (m, b, k, T, t_d) with the encoder step q
    [m], Coulomb friction f_c [N] and a constant push F [N] that sets the mean position. An approximation: where it
    holds and where it does not is measured in docs/limit-cycles.md. Same numbers as `hapticopt limit-cycle --json`."""
    d = _core.limit_cycle(float(plant.mass), float(plant.period), float(plant.damping), float(plant.stiffness),
                          float(plant.time_delay), float(gains.stiffness), float(gains.damping), float(coulomb_friction),
                          float(position_step), float(push))
    cycle = d["cycle"]
    return LimitCyclePrediction(predicted=bool(d["predicted"]),
                                cycle=_cycle(cycle) if cycle is not None else None,  # type: ignore[arg-type]
                                cycles=[_cycle(c) for c in d["cycles"]],  # type: ignore[attr-defined]
                                rest_exists=bool(d["rest_exists"]),
                                grows_at_large_amplitude=bool(d["grows_at_large_amplitude"]))

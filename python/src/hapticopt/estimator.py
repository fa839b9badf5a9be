# SPDX-License-Identifier: Apache-2.0
"""The wall's velocity estimator (include/hapticopt/velocity_estimator.hpp), spelled as the CLI's --velocity.

Normalised units (m = T = 1); y_j the measured position, v_j the velocity the damper sees:

    backward  v_j = y_j - y_{j-1}                                  (the paper's; the default)
    lowpass   v_j = lambda v_{j-1} + (1 - lambda)(y_j - y_{j-1}),  lambda = exp(-2 pi nu), nu = f_c T > 0
    window    v_j = (y_j - y_{j-N}) / N,  1 <= N <= 1000

Spelling (as `hapticopt --velocity`): "backward", "lowpass:NU", "lowpass:FHz" (needs the period T [s]:
nu = f_c T), "window:N". The functions that take `estimator=` accept such a string, a VelocityEstimator
or None (backward). The ranges are checked by the C++ library (InvalidParameterError naming `cutoff` or
`window`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Union

__all__ = ["VelocityEstimator", "EstimatorLike", "velocity_estimator"]


@dataclass(frozen=True)
class VelocityEstimator:
    """kind: "backward", "lowpass" or "window"; cutoff: nu = f_c T (lowpass); window: N (window)."""

    kind: str = "backward"
    cutoff: float = 0.0
    window: int = 1

    @staticmethod
    def backward() -> "VelocityEstimator":
        return VelocityEstimator()

    @staticmethod
    def lowpass(nu: float) -> "VelocityEstimator":
        return VelocityEstimator("lowpass", float(nu), 1)

    @staticmethod
    def moving_window(n: int) -> "VelocityEstimator":
        return VelocityEstimator("window", 0.0, int(n))

    @staticmethod
    def parse(text: str, period: Optional[float] = None) -> "VelocityEstimator":
        """The CLI's spelling: backward, lowpass:NU, lowpass:FHz (with period [s]), window:N."""
        t = str(text)
        if t == "backward":
            return VelocityEstimator()
        if t.startswith("lowpass:"):
            value = t[len("lowpass:"):]
            hertz = len(value) > 2 and value.endswith("Hz")
            if hertz:
                value = value[:-2]
            try:
                nu = float(value)
            except ValueError:
                raise ValueError(f"hapticopt.VelocityEstimator: lowpass cutoff = {value!r} is invalid; accepted: "
                                 "lowpass:NU with NU > 0, or lowpass:FHz with a period") from None
            if hertz:
                if period is None or not period > 0:
                    raise ValueError(f"hapticopt.VelocityEstimator: period = {period!r} is invalid (needed by "
                                     f"{t}); accepted: a period T > 0 [s]")
                nu *= float(period)
            return VelocityEstimator.lowpass(nu)
        if t.startswith("window:"):
            value = t[len("window:"):]
            try:
                n = float(value)
            except ValueError:
                n = math.nan
            if not (math.isfinite(n) and n == math.floor(n)):
                raise ValueError(f"hapticopt.VelocityEstimator: window = {value!r} is invalid; accepted: window:N "
                                 "with an integer 1 <= N <= 1000")
            return VelocityEstimator.moving_window(int(n))
        raise ValueError(f"hapticopt.VelocityEstimator: velocity = {t!r} is invalid; accepted: backward, lowpass:NU, "
                         "lowpass:FHz or window:N")

    def __str__(self) -> str:
        if self.kind == "lowpass":
            return f"lowpass:{self.cutoff!r}"
        if self.kind == "window":
            return f"window:{self.window}"
        return "backward"

    def args(self) -> tuple:
        """(kind, cutoff, window) as the extension takes them."""
        return str(self.kind), float(self.cutoff), int(self.window)


EstimatorLike = Union[None, str, VelocityEstimator]


def velocity_estimator(estimator: EstimatorLike, period: Optional[float] = None) -> VelocityEstimator:
    """None -> backward; a string -> VelocityEstimator.parse(string, period); a VelocityEstimator as is."""
    if estimator is None:
        return VelocityEstimator()
    if isinstance(estimator, VelocityEstimator):
        return estimator
    if isinstance(estimator, str):
        return VelocityEstimator.parse(estimator, period)
    raise TypeError(f"estimator must be None, a string such as 'lowpass:0.02' or a hapticopt.VelocityEstimator, "
                    f"got {type(estimator).__name__}")

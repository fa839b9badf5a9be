# SPDX-License-Identifier: Apache-2.0
"""Optimal wall gains of a device at T = 0.5 ms with 2 ms loop delay, and the cost map around them.

Run:  build/py-venv/bin/python docs/examples/python_optimal_gains.py docs/figures/python-example.png
(needs the hapticopt package with matplotlib: pip install './python[plot]').
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import hapticopt as ho  # noqa: E402
from hapticopt import plot  # noqa: E402

device = ho.PhysicalPlant(mass=0.30, period=0.0005, damping=0.5, time_delay=0.002)  # Falcon + hand, d = 4
plant = ho.normalize(device)
print(f"normalised plant: gamma {plant.gamma:.3g}, delta {plant.delta:.3g}, d {plant.delay:g}")

tunings = {c: ho.optimal_wall(c, device) for c in ("CE2", "CE2+OV", "amax")}
for name, t in tunings.items():
    cost = "" if t.cost is None else f", C = {t.cost:.4g}"
    print(f"{name:7s} K = {t.stiffness:9.1f} N/m, B = {t.damping:7.3f} N s/m "
          f"(alpha {t.alpha:.5f}, beta {t.beta:.5f}, alpha/alpha_max {t.stability_margin:.3f}{cost})")

best = tunings["CE2"]
figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
plot.costs(left, "CE2", plant, alpha_range=(0.2 * best.alpha, 2.0 * best.alpha),
           beta_range=(0.5 * best.beta, 1.6 * best.beta), resolution=160, decades=0.5)
mesh = next(c for c in left.collections if c.get_label() == "log10 CE2")
figure.colorbar(mesh, ax=left, label="log10 C_E2 (saturates 0.5 decades above the minimum)")
left.legend(handles=left.get_lines(), loc="upper left", fontsize=8)
optima = [ho.optimal_point(c, plant) for c in ("CE2", "CE2+OV")]
plot.step(right, optima, plant, periods=60, samples_per_period=10, show_samples=False)
right.set_title(f"step responses, K = {best.stiffness:.0f} N/m, B = {best.damping:.2f} N s/m (CE2)")
right.legend(fontsize=8)
figure.tight_layout()
out = sys.argv[1] if len(sys.argv) > 1 else "python-example.png"
figure.savefig(out, dpi=110)
print(f"wrote {out}")

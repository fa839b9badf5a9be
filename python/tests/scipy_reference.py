# SPDX-License-Identifier: Apache-2.0
"""An independent reference of the loop's costs, written from the paper's model (Hulin et al. 2011) with scipy only.

Model (normalised, m = T = 1; docs/methods.md): x'' + delta x' + gamma x = F - f_w;
f_j = alpha x_j + beta (x_j - x_{j-1}) acts during [j + d, j + 1 + d); integer d here. Inside a
period the plant with its constant input u is z' = A3 z, z = (x, x', u), A3 = [[0,1,0],[-gamma,-delta,1],
[0,0,0]], so z(tau) = expm(A3 tau) z(0) (scipy.linalg.expm: Pade with scaling and squaring).

Loop state at sample j: e_j = (x_j, x'_j, x_{j-1}, ..., x_{j-d-1}) as deviations from the rest
point (step) or absolute (collision, rest at 0); the input of period j is u_j = F - f_{j-d}.
Energy E(j + tau) = 1/2 z^T expm(A3 tau)^T Q expm(A3 tau) z, Q = diag(alpha + gamma, 1, 0), so
    int_0^1 tau^r E(j + tau) dtau = 1/2 z_j^T Z_r z_j,  Z_r = int_0^1 tau^r expm(A3 tau)^T Q expm(A3 tau) dtau,
Z_r by adaptive quadrature (scipy.integrate.quad_vec, epsrel 1e-13) -- not the library's Taylor series.
Sums over periods: S_k = sum_j j^k e_j e_j^T solve X = M X M^T + C (scipy.linalg.solve_discrete_lyapunov):
    S_0: C = e_0 e_0^T;  S_1: C = M S_0 M^T;  S_2: C = 2 S_1 - M S_0 M^T
(subtract the shifted sums), and C_p = (1/E(0)) sum_q binom(p, q) tr(W_q S_{p-q}) / 2, W_q = L^T Z_q L.
The collision flies freely (zero force) for the first d periods; those are integrated directly.
"""
from __future__ import annotations

from dataclasses import dataclass
from math import comb
from typing import List, Tuple

import numpy as np
from scipy.integrate import quad_vec
from scipy.linalg import expm, solve_discrete_lyapunov


@dataclass
class ReferenceCosts:
    step: Tuple[float, float, float]       # C_E0, C_E1, C_E2
    collision: Tuple[float, float, float]  # C_I0, C_I1, C_I2
    spectral_radius: float
    kronecker_condition: float             # cond(I - M (x) M): the Lyapunov solve's conditioning


class ReferenceLoop:
    def __init__(self, alpha: float, beta: float, gamma: float, delta: float, delay: int):
        self.alpha, self.beta, self.gamma, self.delta, self.d = alpha, beta, gamma, delta, int(delay)
        self.a3 = np.array([[0.0, 1.0, 0.0], [-gamma, -delta, 1.0], [0.0, 0.0, 0.0]])
        self.q = np.diag([alpha + gamma, 1.0, 0.0])
        self.n = self.d + 3
        # L: e_j -> z_j = (x_j, x'_j, u_j) with u_j = -f_{j-d} (the step's F cancels in deviations).
        self.l = np.zeros((3, self.n))
        self.l[0, 0] = 1.0
        self.l[1, 1] = 1.0
        self.l[2, self._x(self.d)] -= alpha + beta
        self.l[2, self._x(self.d + 1)] += beta
        phi = expm(self.a3)
        self.m = np.zeros((self.n, self.n))
        self.m[0:2, :] = (phi @ self.l)[0:2, :]
        self.m[2, 0] = 1.0  # x_j becomes x_{(j+1)-1}
        for k in range(1, self.d + 1):
            self.m[self._x(k + 1), self._x(k)] = 1.0
        self.z = [self._gramian(r) for r in range(3)]

    @staticmethod
    def _x(k: int) -> int:
        """Index of x_{j-k} in e_j."""
        return 0 if k == 0 else k + 1

    def _gramian(self, r: int) -> np.ndarray:
        def integrand(tau):
            e = expm(self.a3 * tau)
            return tau ** r * (e.T @ self.q @ e)

        value, _ = quad_vec(integrand, 0.0, 1.0, epsabs=0.0, epsrel=1e-13)
        return value

    def _sums(self, e0: np.ndarray) -> List[np.ndarray]:
        m = self.m
        s0 = solve_discrete_lyapunov(m, np.outer(e0, e0))
        shifted = m @ s0 @ m.T
        s1 = solve_discrete_lyapunov(m, shifted)
        s2 = solve_discrete_lyapunov(m, 2 * s1 - shifted)
        return [s0, s1, s2]

    def _moments(self, e0: np.ndarray, offset: float) -> np.ndarray:
        """sum_j int_0^1 (offset + j + tau)^p E dtau for p = 0, 1, 2, from state e0 at time offset."""
        s = self._sums(e0)
        # (offset + tau)^q = sum_r binom(q, r) offset^(q-r) tau^r
        w = [self.l.T @ sum(comb(q, r) * offset ** (q - r) * self.z[r] for r in range(q + 1)) @ self.l
             for q in range(3)]
        return np.array([sum(comb(p, q) * np.trace(w[q] @ s[p - q]) for q in range(p + 1)) / 2 for p in range(3)])

    def step_costs(self) -> Tuple[float, float, float]:
        k = self.alpha + self.gamma
        e0 = np.full(self.n, -1.0 / k)  # x = 0 everywhere before the step, x_inf = 1/k
        e0[1] = 0.0
        return tuple(self._moments(e0, 0.0) * 2 * k)  # / E(0), E(0) = 1/(2k)

    def collision_costs(self) -> Tuple[float, float, float]:
        # Free flight (zero force, F = 0) for the first d periods from x = 0, x' = 1.
        phi = expm(self.a3)
        positions = [-1.0]  # x_{-1} = -v0 T
        z = np.array([0.0, 1.0, 0.0])
        free = np.zeros(3)
        for j in range(self.d):
            positions.append(z[0])
            free += np.array([sum(comb(p, q) * j ** (p - q) * (z @ self.z[q] @ z) for q in range(p + 1)) / 2
                              for p in range(3)])
            z = phi @ z
        positions.append(z[0])  # x_d
        e = np.zeros(self.n)
        e[0], e[1] = z[0], z[1]
        for k in range(1, self.d + 2):  # x_{d-k}
            e[self._x(k)] = positions[len(positions) - 1 - k]
        return tuple((free + self._moments(e, float(self.d))) * 2)  # / E(0), E(0) = 1/2

    def reference(self) -> ReferenceCosts:
        kron = np.eye(self.n ** 2) - np.kron(self.m, self.m)
        return ReferenceCosts(self.step_costs(), self.collision_costs(),
                              float(max(abs(np.linalg.eigvals(self.m)))), float(np.linalg.cond(kron)))

    def step_position(self, t: float) -> float:
        """x(t) of the unit step: e_j at the sample before t, then expm inside the period."""
        k = self.alpha + self.gamma
        e = np.full(self.n, -1.0 / k)
        e[1] = 0.0
        j = int(np.floor(t))
        for _ in range(j):
            e = self.m @ e
        return float((expm(self.a3 * (t - j)) @ (self.l @ e))[0] + 1.0 / k)

    def step_positions_on_grid(self, periods: int, per_period: int) -> np.ndarray:
        """x(t) of the unit step at t = j + i / per_period, j < periods, i < per_period (row j)."""
        k = self.alpha + self.gamma
        e = np.full(self.n, -1.0 / k)
        e[1] = 0.0
        inside = np.array([expm(self.a3 * (i / per_period)) for i in range(per_period)])  # (per_period, 3, 3)
        rows = []
        for _ in range(periods):
            rows.append((inside @ (self.l @ e))[:, 0] + 1.0 / k)
            e = self.m @ e
        return np.array(rows)

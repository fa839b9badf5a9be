# SPDX-License-Identifier: Apache-2.0
"""``DeviceInfo``: the welcome's ``device`` (docs/protocol.md, section 2), checked for form when it is read."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple

from .errors import HapticdError


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True)
class DeviceInfo:
    """The device the daemon renders on, as its welcome describes it.

    Attributes:
        name: the profile's name.
        axes: 1 .. 3.
        period_s: the loop period, s.
        mass: kg, per axis a the mass a plane along that axis acts with, 1 / (M^-1)_aa (= M_aa for a
            diagonal M); three values (axes beyond the device's: axis 0's).
        mass_matrix: kg, the profile's mass matrix M on the device's axes, ``mass_matrix[i][j]`` (``axes``
            rows of ``axes`` values; m I for one mass). A plane with unit normal n acts with 1 / (n^T M^-1 n).
        delay_s: the total loop delay the gains are checked for (device + delay buffer), s.
        max_force: N.
        max_stiffness: N/m, the profile's stiffness limit; None: only the stability region bounds K.
        velocity_estimator: the velocity estimate every damper acts on and every check analyses: "backward",
            "lowpass:<F>Hz" or "window:<N>" ("backward" when the welcome does not name one).
        mass_scale: the plant set every check holds for: the mass matrix scaled by mass_scale[0] .. mass_scale[1]
            (the profile's mass_range widened by its mass_margin; docs/robust-stability.md).
        arm_stiffness_per_mass, arm_damping_per_mass: with every mass, an arm of k_H / m and b_H / m up to these
            (s^-2, s^-1); 0 and 0: the device alone.
        plant_set_exact: False when the checks sample the set (a profile with damping or stiffness).
    """

    name: str
    axes: int
    period_s: float
    mass: Tuple[float, ...]
    mass_matrix: Tuple[Tuple[float, ...], ...]
    delay_s: float
    max_force: float
    max_stiffness: Optional[float]
    velocity_estimator: str = "backward"
    mass_scale: Tuple[float, float] = (1.0, 1.0)
    plant_set_exact: bool = True
    arm_stiffness_per_mass: float = 0.0
    arm_damping_per_mass: float = 0.0

    @classmethod
    def from_welcome(cls, welcome: dict) -> "DeviceInfo":
        """Reads ``welcome["device"]``; HapticdError("bad_message") naming the field when it is not of the
        protocol's form."""
        device = welcome.get("device")
        if not isinstance(device, dict):
            raise HapticdError("bad_message", f"DeviceInfo.from_welcome: the welcome has no device object (got {device!r})")

        def bad(field: str, accepted: str):
            return HapticdError("bad_message", f"DeviceInfo.from_welcome: device.{field} = {device.get(field)!r}; "
                                               f"accepted: {accepted} (docs/protocol.md, section 2)")

        def number(field: str) -> float:
            if not _is_number(device.get(field)):
                raise bad(field, "a number")
            return float(device[field])

        axes = device.get("axes")
        if not isinstance(axes, int) or isinstance(axes, bool) or not 1 <= axes <= 3:
            raise bad("axes", "an integer 1 .. 3")
        name = device.get("name")
        if not isinstance(name, str):
            raise bad("name", "a string")
        mass = device.get("mass")
        if not isinstance(mass, list) or len(mass) != 3 or not all(_is_number(v) for v in mass):
            raise bad("mass", "3 numbers (kg)")
        matrix = device.get("mass_matrix")
        if (not isinstance(matrix, list) or len(matrix) != axes
                or not all(isinstance(row, list) and len(row) == axes and all(_is_number(v) for v in row) for row in matrix)):
            raise bad("mass_matrix", f"{axes} rows of {axes} numbers (kg; device.axes = {axes})")
        limit = device.get("max_stiffness")
        if limit is not None and not _is_number(limit):
            raise bad("max_stiffness", "a number (N/m) or null")
        estimator = device.get("velocity_estimator", "backward")
        if not isinstance(estimator, str):
            raise bad("velocity_estimator", 'a string ("backward", "lowpass:<F>Hz" or "window:<N>")')
        plant_set = device.get("plant_set", {})
        scale = plant_set.get("mass_scale", [1.0, 1.0]) if isinstance(plant_set, dict) else None
        if not isinstance(scale, list) or len(scale) != 2 or not all(_is_number(v) for v in scale):
            raise bad("plant_set", 'an object {"mass_scale": [c_min, c_max], "exact": true | false}')
        exact = plant_set.get("exact", True)
        if not isinstance(exact, bool):
            raise bad("plant_set", 'an object {"mass_scale": [c_min, c_max], "exact": true | false}')
        arm = [plant_set.get(k, 0.0) for k in ("arm_stiffness_per_mass", "arm_damping_per_mass")]
        if not all(_is_number(v) and v >= 0 for v in arm):
            raise bad("plant_set", 'an object whose "arm_stiffness_per_mass" and "arm_damping_per_mass" are numbers >= 0')
        return cls(name=name, axes=axes, period_s=number("period_s"), mass=tuple(float(v) for v in mass),
                   mass_matrix=tuple(tuple(float(v) for v in row) for row in matrix), delay_s=number("delay_s"),
                   max_force=number("max_force"), max_stiffness=None if limit is None else float(limit),
                   velocity_estimator=estimator, mass_scale=(float(scale[0]), float(scale[1])),
                   plant_set_exact=exact, arm_stiffness_per_mass=float(arm[0]), arm_damping_per_mass=float(arm[1]))

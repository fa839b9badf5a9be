# SPDX-License-Identifier: Apache-2.0
"""Scene objects as the protocol's JSON (docs/protocol.md, section 4), SI units: m, N, N/m, N s/m.

Gains are explicit (``K``, ``B``; checked by the daemon against the exact stability region) or by
``criterion`` (``amax OV CE0 CE1 CE2 CE0+OV CE1+OV CE2+OV``, hapticopt's; amax, the stability region's tip,
is refused as unstable_gains; the daemon computes the optimum for the mass
along the object's direction, the period and the delay). Only the form is built here; the daemon checks
the physics and answers with an error code.
"""

from __future__ import annotations

from typing import Dict, List, Optional, Sequence

Vector = Sequence[float]


def _vec3(name: str, v: Vector) -> List[float]:
    values = [float(x) for x in v]
    if len(values) != 3:
        raise ValueError(f"{name}: expected 3 numbers, got {len(values)}")
    return values


def gains(K: Optional[float] = None, B: Optional[float] = None, criterion: Optional[str] = None) -> Dict:
    """``{"K": K, "B": B}`` (B defaults to 0) or ``{"criterion": criterion}``; exactly one form."""
    if criterion is not None:
        if K is not None or B is not None:
            raise ValueError("gains: give either criterion or K/B, not both")
        return {"criterion": str(criterion)}
    if K is None:
        raise ValueError("gains: K (N/m) or criterion is required")
    return {"K": float(K), "B": float(B if B is not None else 0.0)}


def plane(normal: Vector, offset: float = 0.0, bilateral: bool = False, K: Optional[float] = None,
          B: Optional[float] = None, criterion: Optional[str] = None) -> Dict:
    """A plane wall: penetration p = offset - n.x, force n (K p + B dp/dt) while p > 0 (always if bilateral).
    Without gains it asks for criterion CE2."""
    if K is None and B is None and criterion is None:
        criterion = "CE2"
    return {"kind": "plane", "normal": _vec3("normal", normal), "offset": float(offset),
            "mode": "bilateral" if bilateral else "unilateral", "gains": gains(K, B, criterion)}


def spring(point: Vector, constraint: str = "point", direction: Optional[Vector] = None, K: Optional[float] = None,
           B: Optional[float] = None, criterion: Optional[str] = None) -> Dict:
    """A spring to a point, a line (through ``point`` along ``direction``) or a plane (normal ``direction``)."""
    if constraint not in ("point", "line", "plane"):
        raise ValueError(f"spring: constraint = {constraint!r}; accepted: 'point', 'line', 'plane'")
    obj = {"kind": "spring", "constraint": constraint, "point": _vec3("point", point), "gains": gains(K, B, criterion)}
    if constraint != "point":
        if direction is None:
            raise ValueError(f"spring: constraint = {constraint!r} needs direction")
        obj["direction"] = _vec3("direction", direction)
    return obj


def field(center: Vector, radius: float, force: Vector = (0.0, 0.0, 0.0),
          jacobian: Sequence[Vector] = ((0.0, 0.0, 0.0),) * 3) -> Dict:
    """A force field F0 + J (x - x0) inside ``radius`` of ``center``, zero outside."""
    rows = [_vec3("jacobian row", r) for r in jacobian]
    if len(rows) != 3:
        raise ValueError("field: jacobian must have 3 rows")
    return {"kind": "field", "center": _vec3("center", center), "radius": float(radius), "force": _vec3("force", force),
            "jacobian": rows}


class Batch:
    """Operations committed all-or-nothing at one tick boundary (``Client.commit(batch)``)."""

    def __init__(self) -> None:
        self.ops: List[Dict] = []

    def add(self, obj: Dict) -> "Batch":
        self.ops.append({"op": "add", "object": obj})
        return self

    def modify(self, object_id: int, obj: Dict) -> "Batch":
        self.ops.append({"op": "modify", "object_id": int(object_id), "object": obj})
        return self

    def remove(self, object_id: int) -> "Batch":
        self.ops.append({"op": "remove", "object_id": int(object_id)})
        return self

    def clear(self) -> "Batch":
        self.ops.append({"op": "clear"})
        return self

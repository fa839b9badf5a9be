# SPDX-License-Identifier: Apache-2.0
"""Scene objects written as words, the form of ``hapticctl add`` (docs/clients.md), as the protocol's JSON dict:

    plane  normal=NX,NY,NZ [offset=M] [mode=unilateral|bilateral] [criterion=C | K=N/m [B=N s/m]]
    spring [constraint=point|line|plane] point=X,Y,Z [direction=DX,DY,DZ] (K=N/m [B=N s/m] | criterion=C)
    field  center=X,Y,Z radius=M [force=FX,FY,FZ] [jacobian=J11,...,J33] [damping=N s/m]

SI units. A plane without gains asks for criterion=CE2. Only the form is checked here (known keys, finite
numbers, vector lengths); the daemon checks the physics and answers with the protocol's error codes.
``moved()`` gives the description with the object placed at a point: the move of protocol.md, section 4.
"""

from __future__ import annotations

import copy
import math
from typing import Dict, List, Sequence

ACCEPTED_FORMS = ("plane normal=NX,NY,NZ [offset=M] [mode=unilateral|bilateral] [criterion=C | K=N/m [B=N s/m]]; "
                  "spring [constraint=point|line|plane] point=X,Y,Z [direction=DX,DY,DZ] (K=N/m [B=N s/m] | criterion=C); "
                  "field center=X,Y,Z radius=M [force=FX,FY,FZ] [jacobian=J11,...,J33] [damping=N s/m]")

_KEYS = {"plane": ("normal", "offset", "mode", "criterion", "K", "B"),
         "spring": ("constraint", "point", "direction", "criterion", "K", "B"),
         "field": ("center", "radius", "force", "jacobian", "damping")}


class ObjectWordsError(ValueError):
    """A malformed description: the message names the word and the accepted form."""


def _number(key: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise ObjectWordsError(f"{key} = '{text}' is not a finite number")
    return value


def _numbers(key: str, text: str, count: int) -> List[float]:
    parts = text.split(",")
    if len(parts) != count:
        raise ObjectWordsError(f"{key} = '{text}' must be {count} comma-separated numbers")
    return [_number(key, p) for p in parts]


def _gains(kind: str, words: Dict[str, str], required: bool) -> Dict:
    if "criterion" in words and ("K" in words or "B" in words):
        raise ObjectWordsError(f"{kind}: give either criterion= or K=/B=, not both")
    if "criterion" in words:
        return {"criterion": words["criterion"]}
    if "K" in words:
        return {"K": _number("K", words["K"]), "B": _number("B", words["B"]) if "B" in words else 0.0}
    if "B" in words:
        raise ObjectWordsError(f"{kind}: B= needs K= (N/m)")
    if required:
        raise ObjectWordsError(f"{kind}: gains are required: K=N/m [B=N s/m] or criterion=CE2")
    return {"criterion": "CE2"}


def parse_object_words(text: str) -> Dict:
    """The protocol's object description (docs/protocol.md, section 4) of ``text``; ObjectWordsError naming the
    word and the accepted form when it is malformed."""
    words = text.split()
    if not words:
        raise ObjectWordsError(f"an object kind is required; accepted: {ACCEPTED_FORMS}")
    kind = words[0]
    if kind not in _KEYS:
        raise ObjectWordsError(f"object kind '{kind}' is unknown; accepted: plane, spring, field")
    values: Dict[str, str] = {}
    for word in words[1:]:
        key, sep, value = word.partition("=")
        if not sep or not key:
            raise ObjectWordsError(f"'{word}' is not key=value")
        if key not in _KEYS[kind]:
            raise ObjectWordsError(f"{kind}: unknown key '{key}'; accepted: {', '.join(_KEYS[kind])}")
        if key in values:
            raise ObjectWordsError(f"{kind}: {key}= given twice")
        values[key] = value

    def required(key: str) -> str:
        if key not in values:
            raise ObjectWordsError(f"{kind}: {key}= is required")
        return values[key]

    if kind == "plane":
        mode = values.get("mode", "unilateral")
        if mode not in ("unilateral", "bilateral"):
            raise ObjectWordsError(f"plane: mode = '{mode}'; accepted: unilateral, bilateral")
        return {"kind": "plane", "normal": _numbers("normal", required("normal"), 3),
                "offset": _number("offset", values["offset"]) if "offset" in values else 0.0, "mode": mode,
                "gains": _gains(kind, values, required=False)}
    if kind == "spring":
        constraint = values.get("constraint", "point")
        if constraint not in ("point", "line", "plane"):
            raise ObjectWordsError(f"spring: constraint = '{constraint}'; accepted: point, line, plane")
        obj = {"kind": "spring", "constraint": constraint, "point": _numbers("point", required("point"), 3),
               "gains": _gains(kind, values, required=True)}
        if constraint == "point":
            if "direction" in values:
                raise ObjectWordsError("spring: direction= is not used by constraint=point")
        else:
            obj["direction"] = _numbers("direction", required("direction"), 3)
        return obj
    j = _numbers("jacobian", values["jacobian"], 9) if "jacobian" in values else [0.0] * 9
    obj = {"kind": "field", "center": _numbers("center", required("center"), 3),
           "radius": _number("radius", required("radius")),
           "force": _numbers("force", values["force"], 3) if "force" in values else [0.0, 0.0, 0.0],
           "jacobian": [j[0:3], j[3:6], j[6:9]]}
    if "damping" in values:
        obj["damping"] = _number("damping", values["damping"])
    return obj


def moved(description: Dict, position: Sequence[float]) -> Dict:
    """The description with the object placed at ``position`` (m): a plane's surface through it (offset = n . p,
    its normal kept), a spring's point, a field's centre. Only where the object is changes: the daemon renders it
    as a move (no ramp, no check; protocol.md, section 4). ObjectWordsError for a non-finite position."""
    p = [float(v) for v in position]
    if len(p) != 3 or not all(math.isfinite(v) for v in p):
        raise ObjectWordsError(f"position = {list(position)!r}: expected 3 finite numbers (m)")
    out = copy.deepcopy(description)
    if out["kind"] == "plane":
        out["offset"] = sum(n * x for n, x in zip(out["normal"], p))
    elif out["kind"] == "spring":
        out["point"] = p
    else:
        out["center"] = p
    return out

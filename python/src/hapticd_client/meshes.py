# SPDX-License-Identifier: Apache-2.0
"""Triangle meshes for ``mesh`` objects (docs/protocol.md, sections 4 and 4a): the object description and procedural
meshes (an icosphere, a box, a torus), each as (vertices, triangles) lists in metres with outward normals
(b - a) x (c - a), closed and edge-manifold (``mode="solid"``).

Vertices and triangles may be numpy arrays (n x 3) or sequences of 3-sequences; they are sent as flat lists.
"""

from __future__ import annotations

import math
from typing import Dict, List, Optional, Sequence, Tuple

from .objects import gains

Vertices = List[Tuple[float, float, float]]
Triangles = List[Tuple[int, int, int]]


def _rows(name: str, values, kind) -> list:
    if hasattr(values, "tolist"):  # numpy without importing it
        values = values.tolist()
    rows = []
    for i, row in enumerate(values):
        row = list(row)
        if len(row) != 3:
            raise ValueError(f"mesh: {name}[{i}] has {len(row)} values; expected 3")
        converted = tuple(kind(v) for v in row)
        if kind is float and not all(math.isfinite(v) for v in converted):
            raise ValueError(f"mesh: {name}[{i}] = {converted} is not finite; accepted: finite coordinates in metres")
        if kind is int and any(v < 0 for v in converted):
            raise ValueError(f"mesh: {name}[{i}] = {converted} has a negative index")
        rows.append(converted)
    return rows


def mesh(vertices=None, triangles=None, *, mesh_id: Optional[int] = None, mode: str = "solid",
         position: Sequence[float] = (0.0, 0.0, 0.0), orientation: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
         K: Optional[float] = None, B: Optional[float] = None, criterion: Optional[str] = None,
         static_friction: float = 0.0, dynamic_friction: float = 0.0, shading: Optional[float] = None) -> Dict:
    """A ``mesh`` object: the triangle mesh (vertices n x 3 in metres, triangles m x 3 vertex indices), uploaded by
    ``Client.add``/``commit``/``modify`` before the batch (``Client.upload_mesh``), or an uploaded one by
    ``mesh_id``; its pose (position in m, orientation a unit quaternion w, x, y, z), gains (criterion CE2 without
    any) and friction coefficients (0 <= dynamic <= static). ``mode``: "solid" (closed) or "surface" (one-sided).
    ``shading``: force shading's crease angle in degrees (0 .. 80; faces meeting at more than it keep a sharp edge),
    None for off (docs/mesh-rendering.md, "Force shading")."""
    if K is None and B is None and criterion is None:
        criterion = "CE2"
    if mode not in ("solid", "surface"):
        raise ValueError(f"mesh: mode = {mode!r}; accepted: 'solid', 'surface'")
    q = [float(v) for v in orientation]
    if len(q) != 4:
        raise ValueError("mesh: orientation: expected a unit quaternion of 4 numbers (w, x, y, z)")
    p = [float(v) for v in position]
    if len(p) != 3:
        raise ValueError("mesh: position: expected 3 numbers")
    obj = {"kind": "mesh", "position": p, "orientation": q, "gains": gains(K, B, criterion),
           "friction": {"static": float(static_friction), "dynamic": float(dynamic_friction)}}
    if shading is not None:
        obj["shading"] = {"crease_angle_deg": float(shading)}
    if mesh_id is not None:
        if vertices is not None or triangles is not None:
            raise ValueError("mesh: give either mesh_id or vertices and triangles, not both")
        obj["mesh"] = int(mesh_id)
        return obj
    if vertices is None or triangles is None:
        raise ValueError("mesh: vertices and triangles (or mesh_id) are required")
    obj["_upload"] = (_rows("vertices", vertices, float), _rows("triangles", triangles, int), mode)
    return obj


def icosphere(radius: float, subdivisions: int = 2) -> Tuple[Vertices, Triangles]:
    """A sphere of ``radius`` (m): the icosahedron subdivided ``subdivisions`` times (20 * 4^s triangles), vertices
    on the sphere."""
    if not radius > 0.0 or not 0 <= subdivisions <= 6:
        raise ValueError("icosphere: radius must be > 0 and subdivisions 0 .. 6")
    t = (1.0 + math.sqrt(5.0)) / 2.0
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
             (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
             (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        cache: Dict[Tuple[int, int], int] = {}

        def middle(a: int, b: int) -> int:
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = [(verts[a][i] + verts[b][i]) / 2.0 for i in range(3)]
                n = math.sqrt(sum(c * c for c in m))
                verts.append(tuple(c / n for c in m))
                cache[key] = len(verts) - 1
            return cache[key]

        refined = []
        for a, b, c in faces:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            refined += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = refined
    return [tuple(radius * c for c in v) for v in verts], faces


def box(half_extents: Sequence[float]) -> Tuple[Vertices, Triangles]:
    """The box [-hx, hx] x [-hy, hy] x [-hz, hz] (m): 8 vertices, 12 triangles."""
    hx, hy, hz = (float(v) for v in half_extents)
    if not (hx > 0 and hy > 0 and hz > 0):
        raise ValueError("box: half_extents must be > 0")
    verts = [((hx if i & 1 else -hx), (hy if i & 2 else -hy), (hz if i & 4 else -hz)) for i in range(8)]
    faces = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4), (2, 6, 3), (3, 6, 7), (0, 4, 2),
             (2, 4, 6), (1, 3, 5), (3, 7, 5)]
    return verts, faces


def torus(major_radius: float, minor_radius: float, major_segments: int = 32,
          minor_segments: int = 16) -> Tuple[Vertices, Triangles]:
    """A torus about the z axis (m): the tube of ``minor_radius`` around the circle of ``major_radius``,
    2 * major_segments * minor_segments triangles."""
    if not (major_radius > minor_radius > 0.0) or major_segments < 3 or minor_segments < 3:
        raise ValueError("torus: need major_radius > minor_radius > 0 and at least 3 segments each")
    verts = []
    for i in range(major_segments):
        u = 2.0 * math.pi * i / major_segments
        for j in range(minor_segments):
            v = 2.0 * math.pi * j / minor_segments
            r = major_radius + minor_radius * math.cos(v)
            verts.append((r * math.cos(u), r * math.sin(u), minor_radius * math.sin(v)))
    faces = []
    for i in range(major_segments):
        for j in range(minor_segments):
            a = i * minor_segments + j
            b = ((i + 1) % major_segments) * minor_segments + j
            c = ((i + 1) % major_segments) * minor_segments + (j + 1) % minor_segments
            d = i * minor_segments + (j + 1) % minor_segments
            faces += [(a, b, c), (a, c, d)]
    return verts, faces

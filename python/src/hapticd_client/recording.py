# SPDX-License-Identifier: Apache-2.0
"""Reader of hapticd recordings (``hapticd --record FILE``; the format: docs/recording.md).

    from hapticd_client import recording
    rec = recording.load("run.rec")
    rec.ticks["force"]          # (n, 3) float64, N: the force written to the device in each tick
    rec.ticks["position"]       # (n, 3) float64, m
    for b in rec.batches:       # each batch the loop took from a ring, at its tick
        print(b.tick, b.source, b.seq, b.updates["action"], b.updates["offset"])
    for m in rec.meshes.values():  # the clients' meshes the session rendered (format version 2)
        print(m.id, m.mode, m.vertices.shape, m.triangles.shape)

The numpy dtypes are built from the layout the file's own header declares (``header["layout"]``: name, type,
offset, count of every field of each 128-byte chunk kind), and checked against the layout this module
expects for its format version, so a file is read with the offsets it was written with or refused.
Needs numpy (a dependency of the distribution); the rest of hapticd_client does not.
"""

from __future__ import annotations

import json
import pathlib
import struct
from dataclasses import dataclass, field
from typing import Dict, List, Union

import numpy as np

MAGIC = b"HAPTREC\0"
FORMAT_VERSION = 2
SUPPORTED_VERSIONS = (1, 2)  # version 1: no mesh records, updates in two parts
CHUNK_SIZE = 128
KIND_TICK, KIND_BATCH, KIND_UPDATE_A, KIND_UPDATE_B, KIND_END = 1, 2, 3, 4, 5
KIND_UPDATE_C, KIND_MESH, KIND_MESH_VERTICES, KIND_MESH_TRIANGLES = 6, 7, 8, 9  # version 2
VERTICES_PER_CHUNK, TRIANGLES_PER_CHUNK = 5, 10
# The protocol's mesh limits (docs/protocol.md, section 4a; mesh_error's in src/mesh/triangle_mesh.hpp).
MAX_VERTICES, MAX_TRIANGLES, MAX_COORDINATE = 200_000, 200_000, 100.0
SOURCES = {0: "commit", 1: "departure", 2: "jumped"}  # the ring a batch came from (docs/recording.md)
ACTIONS = {0: "set", 1: "move", 2: "remove", 3: "cut"}
OBJECT_KINDS = {0: "plane", 1: "spring", 2: "field", 3: "mesh"}
MESH_MODES = {0: "surface", 1: "solid"}

# The layout of format version 1 (src/daemon/recording_format.hpp before the meshes): [name, numpy type, offset,
# count].
LAYOUT_V1: Dict[str, List[list]] = {
    "tick": [["kind", "<u4", 0, 1], ["read_status", "u1", 4, 1], ["write_status", "u1", 5, 1], ["fault", "u1", 6, 1],
             ["gain_row", "u1", 7, 1], ["tick", "<u8", 8, 1], ["time_s", "<f8", 16, 1], ["position", "<f8", 24, 3],
             ["velocity", "<f8", 48, 3],
             ["force", "<f8", 72, 3], ["contact_mask", "<u8", 96, 1], ["config_contact_mask", "<u8", 104, 1],
             ["wake_latency_ns", "<i8", 112, 1], ["batches", "<u4", 120, 1]],
    "batch": [["kind", "<u4", 0, 1], ["source", "u1", 4, 1], ["tick", "<u8", 8, 1], ["seq", "<u8", 16, 1],
              ["count", "<u4", 24, 1], ["index", "<u4", 28, 1]],
    "update_a": [["kind", "<u4", 0, 1], ["slot", "u1", 4, 1], ["action", "u1", 5, 1], ["object_kind", "u1", 6, 1],
                 ["bilateral", "u1", 7, 1], ["constraint", "u1", 8, 1], ["id", "<u4", 12, 1], ["direction", "<f8", 16, 3],
                 ["offset", "<f8", 40, 1], ["point", "<f8", 48, 3], ["radius", "<f8", 72, 1], ["force", "<f8", 80, 3],
                 ["K", "<f8", 104, 1], ["B", "<f8", 112, 1], ["offset_rate", "<f8", 120, 1]],
    "update_b": [["kind", "<u4", 0, 1], ["jacobian", "<f8", 8, 9], ["point_rate", "<f8", 80, 3]],
    "end": [["kind", "<u4", 0, 1], ["complete", "<u4", 4, 1], ["ticks", "<u8", 8, 1], ["batches", "<u8", 16, 1],
            ["updates", "<u8", 24, 1], ["dropped_ticks", "<u8", 32, 1], ["dropped_batches", "<u8", 40, 1],
            ["checksum", "<u8", 48, 1]],
}

# The layout of format version 2 (src/daemon/recording_format.hpp): version 1's, the end record's mesh count, the
# third part of an update and the mesh records.
EXPECTED_LAYOUT: Dict[str, List[list]] = dict(
    LAYOUT_V1,
    end=LAYOUT_V1["end"] + [["meshes", "<u8", 56, 1]],
    update_c=[["kind", "<u4", 0, 1], ["mesh", "<u4", 4, 1], ["orientation", "<f8", 8, 4],
              ["static_friction", "<f8", 40, 1], ["dynamic_friction", "<f8", 48, 1], ["shading", "<u4", 56, 1],
              ["crease_angle_deg", "<f8", 64, 1]],
    mesh=[["kind", "<u4", 0, 1], ["mode", "u1", 4, 1], ["mesh", "<u4", 8, 1], ["vertices", "<u8", 16, 1],
          ["triangles", "<u8", 24, 1]],
    mesh_vertices=[["kind", "<u4", 0, 1], ["count", "<u4", 4, 1], ["xyz", "<f8", 8, 3 * VERTICES_PER_CHUNK]],
    mesh_triangles=[["kind", "<u4", 0, 1], ["count", "<u4", 4, 1], ["indices", "<u4", 8, 3 * TRIANGLES_PER_CHUNK]],
)


def _without_gain_row(layout: Dict[str, List[list]]) -> Dict[str, List[list]]:
    return dict(layout, tick=[f for f in layout["tick"] if f[0] != "gain_row"])


# The same layouts as recorded before the tick's gain_row was declared (the byte was 0 then): read with the same dtype.
LAYOUT_WITHOUT_GAIN_ROW = _without_gain_row(EXPECTED_LAYOUT)
ACCEPTED_LAYOUTS = {1: (LAYOUT_V1, _without_gain_row(LAYOUT_V1)), 2: (EXPECTED_LAYOUT, LAYOUT_WITHOUT_GAIN_ROW)}


class RecordingError(ValueError):
    """A file that is not a complete, intact hapticd recording; the message names the file and the defect."""


def dtype_of(fields: List[list], itemsize: int = CHUNK_SIZE) -> np.dtype:
    """The numpy structured dtype of one chunk kind from its layout entries [name, type, offset, count]."""
    return np.dtype({
        "names": [f[0] for f in fields],
        "formats": [f[1] if f[3] == 1 else (f[1], (f[3],)) for f in fields],
        "offsets": [f[2] for f in fields],
        "itemsize": itemsize,
    })


TICK_DTYPE = dtype_of(EXPECTED_LAYOUT["tick"])
BATCH_DTYPE = dtype_of(EXPECTED_LAYOUT["batch"])
END_DTYPE = dtype_of(EXPECTED_LAYOUT["end"])
MESH_DTYPE = dtype_of(EXPECTED_LAYOUT["mesh"])
MESH_VERTICES_DTYPE = dtype_of(EXPECTED_LAYOUT["mesh_vertices"])
MESH_TRIANGLES_DTYPE = dtype_of(EXPECTED_LAYOUT["mesh_triangles"])
# One SlotUpdate: its parts' fields (without their kind words); in a version-1 file mesh is 0 and the orientation
# (1, 0, 0, 0).
UPDATE_DTYPE = np.dtype([(f[0], f[1] if f[3] == 1 else (f[1], (f[3],)))
                         for f in EXPECTED_LAYOUT["update_a"][1:] + EXPECTED_LAYOUT["update_b"][1:]
                         + EXPECTED_LAYOUT["update_c"][1:]])


@dataclass
class Batch:
    tick: int            # the tick whose apply_commits took it
    index: int           # its place among that tick's batches
    source: str          # "commit", "departure" or "jumped" (applied at once ahead of a departure)
    seq: int             # the server's batch sequence number
    updates: np.ndarray  # UPDATE_DTYPE, one row per slot update


@dataclass
class Mesh:
    id: int               # the daemon's mesh id; the updates' "mesh" field names it
    mode: str             # "surface" or "solid"
    vertices: np.ndarray  # (n, 3) float64, m, in the mesh's frame, exactly as uploaded
    triangles: np.ndarray  # (m, 3) uint32 vertex indices
    record: int           # the chunk index of its record (before the first batch that renders it)


@dataclass
class Recording:
    path: str
    header: dict                 # the header's JSON object (argv, files and hashes, layout, ...)
    ticks: np.ndarray            # TICK_DTYPE, one row per tick; ticks["tick"] == 0, 1, 2, ...
    batches: List[Batch] = field(default_factory=list)
    end: dict = field(default_factory=dict)  # the end record: counts, drops, complete, checksum (, meshes)
    meshes: Dict[int, Mesh] = field(default_factory=dict)  # the clients' meshes it renders, by id (version 2)

    @property
    def period_s(self) -> float:
        return 1.0 / float(self.header["rate_hz"])


def fnv1a64(data: bytes, h: int = 14695981039346656037) -> int:
    """FNV-1a 64 (offset basis 14695981039346656037, prime 1099511628211), as the end record's checksum.
    Pure Python: about 0.2 s per MB."""
    prime, mask = 1099511628211, (1 << 64) - 1
    for byte in data:
        h = ((h ^ byte) * prime) & mask
    return h


def _read_meshes(raw: np.ndarray, kinds: np.ndarray, bad) -> Dict[int, Mesh]:
    """The mesh records (version 2): each checked against the protocol's limits, its data chunks' kinds and counts,
    finite coordinates within +-MAX_COORDINATE m and indices within its vertices (what mesh_error checks first; the
    daemon's --replay also checks the solid's topology); every data chunk must belong to one."""
    meshes: Dict[int, Mesh] = {}
    claimed = np.zeros(len(kinds), dtype=bool)
    for at in np.nonzero(kinds == KIND_MESH)[0].tolist():
        head = raw[at:at + 1].copy().view(MESH_DTYPE)[0]
        ident, mode, nv_items, nt_items = int(head["mesh"]), int(head["mode"]), int(head["vertices"]), int(head["triangles"])
        name = f"mesh record {at} (mesh {ident})"
        if ident == 0 or mode > 1 or not 3 <= nv_items <= MAX_VERTICES or not 1 <= nt_items <= MAX_TRIANGLES:
            raise bad(f"corrupt: {name} has mode {mode}, {nv_items} vertices and {nt_items} triangles (accepted: mesh id "
                      f"1 .. 2^32-1, mode 0 surface or 1 solid, 3 .. {MAX_VERTICES} vertices, 1 .. {MAX_TRIANGLES} "
                      "triangles: the protocol's limits)")
        if ident in meshes:
            raise bad(f"corrupt: {name} repeats the id of an earlier mesh record")
        nv = -(-nv_items // VERTICES_PER_CHUNK)
        nt = -(-nt_items // TRIANGLES_PER_CHUNK)
        if at + 1 + nv + nt > len(kinds):
            raise bad(f"corrupt: {name} announces {nv} vertex and {nt} triangle chunks; only {len(kinds) - at - 1} "
                      "chunks follow it")
        span_v, span_t = slice(at + 1, at + 1 + nv), slice(at + 1 + nv, at + 1 + nv + nt)
        for span, kind, items, per, what in ((span_v, KIND_MESH_VERTICES, nv_items, VERTICES_PER_CHUNK, "vertices"),
                                             (span_t, KIND_MESH_TRIANGLES, nt_items, TRIANGLES_PER_CHUNK, "triangles")):
            counts = raw[span, 4:8].copy().view("<u4")[:, 0]
            expected = np.minimum(per, items - per * np.arange(span.stop - span.start))
            wrong = np.nonzero((kinds[span] != kind) | (counts != expected))[0]
            if len(wrong):
                k = int(wrong[0])
                raise bad(f"corrupt: chunk {span.start - at - 1 + k} after {name} has kind {int(kinds[span][k])} and "
                          f"count {int(counts[k])}; expected the mesh's {what} (kind {kind}, count {int(expected[k])})")
        vertices = raw[span_v].copy().view(MESH_VERTICES_DTYPE)["xyz"].reshape(-1, 3)[:nv_items]
        triangles = raw[span_t].copy().view(MESH_TRIANGLES_DTYPE)["indices"].reshape(-1, 3)[:nt_items]
        outside = np.nonzero(~(np.abs(vertices) <= MAX_COORDINATE))
        if len(outside[0]):
            v, k = int(outside[0][0]), int(outside[1][0])
            raise bad(f"corrupt: {name} is invalid: vertex {v} coordinate {'xyz'[k]} = {float(vertices[v, k])!r}, accepted a "
                      f"finite number in [-{MAX_COORDINATE:g}, {MAX_COORDINATE:g}] m")
        beyond = np.nonzero(triangles >= nv_items)
        if len(beyond[0]):
            t, k = int(beyond[0][0]), int(beyond[1][0])
            raise bad(f"corrupt: {name} is invalid: triangle {t} vertex index {k} = {int(triangles[t, k])}, accepted "
                      f"0..{nv_items - 1}")
        claimed[at:at + 1 + nv + nt] = True
        meshes[ident] = Mesh(id=ident, mode=MESH_MODES[mode], vertices=vertices, triangles=triangles, record=at)
    stray = np.nonzero(((kinds == KIND_MESH_VERTICES) | (kinds == KIND_MESH_TRIANGLES)) & ~claimed)[0]
    if len(stray):
        raise bad(f"corrupt: record {int(stray[0])} holds mesh data but follows no mesh record")
    return meshes


def load(path: Union[str, pathlib.Path], verify_checksum: bool = False) -> Recording:
    """Reads a recording (format version 1 or 2). Raises RecordingError (message: "recording '<path>': <defect>")
    for a file that is too short, has another magic or version, a header that is not JSON or declares another
    layout, a size that is not the header plus whole chunks (truncated), no end record, an unknown chunk kind,
    updates that do not follow their batch, ticks out of order, counts that differ from the end record's, records
    dropped (incomplete), or a broken mesh record (cut short, counts beyond the protocol's limits, a non-finite
    coordinate, an index out of range, an update naming a mesh no record before it holds). verify_checksum: also
    recompute the end record's FNV-1a 64 (slow in pure Python)."""
    path = str(path)

    def bad(what: str) -> RecordingError:
        return RecordingError(f"recording '{path}': {what}")

    try:
        data = pathlib.Path(path).read_bytes()
    except OSError as e:
        raise bad(f"cannot open: {e.strerror}") from None
    if len(data) < 16:
        raise bad(f"too short ({len(data)} bytes) to be a hapticd recording")
    if data[:8] != MAGIC:
        raise bad('not a hapticd recording (wrong magic: the file must start with "HAPTREC\\0")')
    version, header_size = struct.unpack_from("<II", data, 8)
    if version not in SUPPORTED_VERSIONS:
        raise bad(f"format version {version} is not supported; accepted: {SUPPORTED_VERSIONS[0]} .. "
                  f"{SUPPORTED_VERSIONS[-1]}")
    if header_size < CHUNK_SIZE or header_size % CHUNK_SIZE or header_size > len(data):
        raise bad(f"header size {header_size} is invalid: truncated or corrupt")
    try:
        header = json.loads(data[16:header_size].decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError):
        header = None
    if not isinstance(header, dict):
        raise bad("the header is not a JSON object: corrupt")
    layout = header.get("layout")
    if layout not in ACCEPTED_LAYOUTS[version] or header.get("chunk_size") != CHUNK_SIZE:
        raise bad(f"the header's record layout is not that of format version {version}")
    body = data[header_size:]
    if len(body) % CHUNK_SIZE:
        raise bad(f"truncated: {len(body) % CHUNK_SIZE} bytes after the last whole {CHUNK_SIZE}-byte record")
    raw = np.frombuffer(body, dtype=np.uint8).reshape(-1, CHUNK_SIZE)
    kinds = raw[:, :4].copy().view("<u4")[:, 0] if len(raw) else np.zeros(0, "<u4")
    if len(raw) == 0 or kinds[-1] != KIND_END:
        raise bad("truncated: no end record (the recording was cut off before hapticd closed it)")
    end_row = raw[-1:].copy().view(END_DTYPE)[0]
    end = {name: int(end_row[name]) for name in END_DTYPE.names if name != "kind"}
    if version < 2:
        end.pop("meshes")  # reserved bytes in version 1
    if verify_checksum and fnv1a64(body[:-CHUNK_SIZE]) != end["checksum"]:
        raise bad("corrupt: the records' checksum does not match the end record's")
    if end["complete"] != 1:
        raise bad(f"incomplete: {end['dropped_ticks']} tick and {end['dropped_batches']} batch records were dropped "
                  "(recorder ring full) or a write failed")
    kinds = kinds[:-1]
    raw = raw[:-1]
    last_kind = KIND_MESH_TRIANGLES if version >= 2 else KIND_UPDATE_B
    unknown = np.nonzero((kinds < KIND_TICK) | (kinds > last_kind) | (kinds == KIND_END))[0]
    if len(unknown):
        raise bad(f"corrupt: record {int(unknown[0])} has kind {int(kinds[unknown[0]])}")
    meshes = _read_meshes(raw, kinds, bad) if version >= 2 else {}

    ticks = raw[kinds == KIND_TICK].copy().view(TICK_DTYPE).reshape(-1)
    if not np.array_equal(ticks["tick"], np.arange(len(ticks), dtype=np.uint64)):
        raise bad("corrupt: the tick records are not ticks 0, 1, 2, ... in order")

    batch_at = np.nonzero(kinds == KIND_BATCH)[0]
    heads = raw[batch_at].copy().view(BATCH_DTYPE).reshape(-1)
    a_at = np.nonzero(kinds == KIND_UPDATE_A)[0]
    b_at = np.nonzero(kinds == KIND_UPDATE_B)[0]
    c_at = np.nonzero(kinds == KIND_UPDATE_C)[0]
    # Every batch's updates follow it, each in its parts (A, B[, C]): the expected positions from the batches' counts.
    parts = 3 if version >= 2 else 2
    counts = heads["count"].astype(np.int64)
    expected_a = (np.concatenate([at + 1 + parts * np.arange(c) for at, c in zip(batch_at, counts)]) if len(counts)
                  else np.zeros(0, np.int64))
    if (len(a_at) != len(expected_a) or not np.array_equal(a_at, expected_a) or not np.array_equal(b_at, expected_a + 1)
            or (parts == 3 and not np.array_equal(c_at, expected_a + 2))):
        raise bad("corrupt: the update records do not follow their batch records")
    a_rows = raw[a_at].copy().view(dtype_of(EXPECTED_LAYOUT["update_a"])).reshape(-1)
    b_rows = raw[b_at].copy().view(dtype_of(EXPECTED_LAYOUT["update_b"])).reshape(-1)
    updates = np.zeros(len(a_rows), UPDATE_DTYPE)
    updates["orientation"] = (1.0, 0.0, 0.0, 0.0)
    if parts == 3:
        c_rows = raw[c_at].copy().view(dtype_of(EXPECTED_LAYOUT["update_c"])).reshape(-1)
        for name in ("mesh", "orientation", "static_friction", "dynamic_friction", "shading", "crease_angle_deg"):
            updates[name] = c_rows[name]
    for name in UPDATE_DTYPE.names:
        if name in a_rows.dtype.names:
            updates[name] = a_rows[name]
        elif name in b_rows.dtype.names:
            updates[name] = b_rows[name]
    is_mesh = updates["object_kind"] == 3
    if parts == 2 and is_mesh.any():
        raise bad(f"update record {int(a_at[np.nonzero(is_mesh)[0][0]])} is a client's mesh, which a version-1 "
                  "recording does not hold")
    for u in np.nonzero((updates["mesh"] != 0) | (is_mesh & (updates["action"] <= 1)))[0].tolist():
        ident = int(updates["mesh"][u])
        m = meshes.get(ident)
        if not is_mesh[u] or m is None or m.record > a_at[u]:
            raise bad(f"corrupt: update record {int(a_at[u])} names mesh {ident}, which is not a mesh object's mesh "
                      "held by a mesh record before it")
    # A batch's tick: the tick record after it (the batches of a tick precede the tick's record).
    tick_rows_before = np.cumsum(kinds == KIND_TICK)[batch_at] if len(batch_at) else np.zeros(0, np.int64)
    if not np.array_equal(heads["tick"], tick_rows_before.astype(np.uint64)):
        raise bad("corrupt: a batch record is not followed by the record of its tick")
    if (len(ticks), len(heads), len(updates)) != (end["ticks"], end["batches"], end["updates"]) or \
            len(meshes) != end.get("meshes", 0):
        raise bad(f"corrupt: {len(ticks)} ticks, {len(heads)} batches, {len(updates)} updates and {len(meshes)} meshes "
                  f"found; the end record counts {end['ticks']}, {end['batches']}, {end['updates']} and "
                  f"{end.get('meshes', 0)}")
    batches: List[Batch] = []
    first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    for k, h in enumerate(heads):
        batches.append(Batch(tick=int(h["tick"]), index=int(h["index"]), source=SOURCES.get(int(h["source"]), str(int(h["source"]))),
                             seq=int(h["seq"]), updates=updates[first[k]:first[k + 1]]))
    return Recording(path=path, header=header, ticks=ticks, batches=batches, end=end, meshes=meshes)

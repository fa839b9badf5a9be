# SPDX-License-Identifier: Apache-2.0
"""Reader of hapticd recordings (``hapticd --record FILE``; the format: docs/recording.md).

    from hapticd_client import recording
    rec = recording.load("run.rec")
    rec.ticks["force"]          # (n, 3) float64, N: the force written to the device in each tick
    rec.ticks["position"]       # (n, 3) float64, m
    for b in rec.batches:       # each batch the loop took from a ring, at its tick
        print(b.tick, b.source, b.seq, b.updates["action"], b.updates["offset"])

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
FORMAT_VERSION = 1
CHUNK_SIZE = 128
KIND_TICK, KIND_BATCH, KIND_UPDATE_A, KIND_UPDATE_B, KIND_END = 1, 2, 3, 4, 5
SOURCES = {0: "commit", 1: "departure", 2: "jumped"}  # the ring a batch came from (docs/recording.md)
ACTIONS = {0: "set", 1: "move", 2: "remove", 3: "cut"}
OBJECT_KINDS = {0: "plane", 1: "spring", 2: "field"}

# The layout of format version 1 (src/daemon/recording_format.hpp): [name, numpy type, offset, count].
EXPECTED_LAYOUT: Dict[str, List[list]] = {
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

# The same layout as recorded before the tick's gain_row was declared (the byte was 0 then): read with the dtype above.
LAYOUT_WITHOUT_GAIN_ROW: Dict[str, List[list]] = dict(
    EXPECTED_LAYOUT, tick=[f for f in EXPECTED_LAYOUT["tick"] if f[0] != "gain_row"])


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
# One SlotUpdate: both halves' fields (without their kind words).
UPDATE_DTYPE = np.dtype([(f[0], f[1] if f[3] == 1 else (f[1], (f[3],)))
                         for f in EXPECTED_LAYOUT["update_a"][1:] + EXPECTED_LAYOUT["update_b"][1:]])


@dataclass
class Batch:
    tick: int            # the tick whose apply_commits took it
    index: int           # its place among that tick's batches
    source: str          # "commit", "departure" or "jumped" (applied at once ahead of a departure)
    seq: int             # the server's batch sequence number
    updates: np.ndarray  # UPDATE_DTYPE, one row per slot update


@dataclass
class Recording:
    path: str
    header: dict                 # the header's JSON object (argv, files and hashes, layout, ...)
    ticks: np.ndarray            # TICK_DTYPE, one row per tick; ticks["tick"] == 0, 1, 2, ...
    batches: List[Batch] = field(default_factory=list)
    end: dict = field(default_factory=dict)  # the end record: counts, drops, complete, checksum

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


def load(path: Union[str, pathlib.Path], verify_checksum: bool = False) -> Recording:
    """Reads a recording. Raises RecordingError (message: "recording '<path>': <defect>") for a file that is too
    short, has another magic or version, a header that is not JSON or declares another layout, a size that is
    not the header plus whole chunks (truncated), no end record, an unknown chunk kind, updates that do not
    follow their batch, ticks out of order, counts that differ from the end record's, or records dropped
    (incomplete). verify_checksum: also recompute the end record's FNV-1a 64 (slow in pure Python)."""
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
    if version != FORMAT_VERSION:
        raise bad(f"format version {version} is not supported; accepted: {FORMAT_VERSION}")
    if header_size < CHUNK_SIZE or header_size % CHUNK_SIZE or header_size > len(data):
        raise bad(f"header size {header_size} is invalid: truncated or corrupt")
    try:
        header = json.loads(data[16:header_size].decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError):
        header = None
    if not isinstance(header, dict):
        raise bad("the header is not a JSON object: corrupt")
    layout = header.get("layout")
    if layout not in (EXPECTED_LAYOUT, LAYOUT_WITHOUT_GAIN_ROW) or header.get("chunk_size") != CHUNK_SIZE:
        raise bad("the header's record layout is not that of format version 1")
    body = data[header_size:]
    if len(body) % CHUNK_SIZE:
        raise bad(f"truncated: {len(body) % CHUNK_SIZE} bytes after the last whole {CHUNK_SIZE}-byte record")
    raw = np.frombuffer(body, dtype=np.uint8).reshape(-1, CHUNK_SIZE)
    kinds = raw[:, :4].copy().view("<u4")[:, 0] if len(raw) else np.zeros(0, "<u4")
    if len(raw) == 0 or kinds[-1] != KIND_END:
        raise bad("truncated: no end record (the recording was cut off before hapticd closed it)")
    end_row = raw[-1:].copy().view(END_DTYPE)[0]
    end = {name: int(end_row[name]) for name in END_DTYPE.names if name != "kind"}
    if verify_checksum and fnv1a64(body[:-CHUNK_SIZE]) != end["checksum"]:
        raise bad("corrupt: the records' checksum does not match the end record's")
    if end["complete"] != 1:
        raise bad(f"incomplete: {end['dropped_ticks']} tick and {end['dropped_batches']} batch records were dropped "
                  "(recorder ring full) or a write failed")
    kinds = kinds[:-1]
    raw = raw[:-1]
    unknown = np.nonzero((kinds < KIND_TICK) | (kinds > KIND_UPDATE_B))[0]
    if len(unknown):
        raise bad(f"corrupt: record {int(unknown[0])} has kind {int(kinds[unknown[0]])}")

    ticks = raw[kinds == KIND_TICK].copy().view(TICK_DTYPE).reshape(-1)
    if not np.array_equal(ticks["tick"], np.arange(len(ticks), dtype=np.uint64)):
        raise bad("corrupt: the tick records are not ticks 0, 1, 2, ... in order")

    batch_at = np.nonzero(kinds == KIND_BATCH)[0]
    heads = raw[batch_at].copy().view(BATCH_DTYPE).reshape(-1)
    a_at = np.nonzero(kinds == KIND_UPDATE_A)[0]
    b_at = np.nonzero(kinds == KIND_UPDATE_B)[0]
    # Every batch's updates follow it in pairs (A, B): the expected positions from the batches' counts.
    counts = heads["count"].astype(np.int64)
    expected_a = np.concatenate([at + 1 + 2 * np.arange(c) for at, c in zip(batch_at, counts)]) if len(counts) else np.zeros(0, np.int64)
    if len(a_at) != len(expected_a) or not np.array_equal(a_at, expected_a) or not np.array_equal(b_at, expected_a + 1):
        raise bad("corrupt: the update records do not follow their batch records")
    a_rows = raw[a_at].copy().view(dtype_of(EXPECTED_LAYOUT["update_a"])).reshape(-1)
    b_rows = raw[b_at].copy().view(dtype_of(EXPECTED_LAYOUT["update_b"])).reshape(-1)
    updates = np.zeros(len(a_rows), UPDATE_DTYPE)
    for name in UPDATE_DTYPE.names:
        updates[name] = a_rows[name] if name in a_rows.dtype.names else b_rows[name]
    # A batch's tick: the tick record after it (the batches of a tick precede the tick's record).
    tick_rows_before = np.cumsum(kinds == KIND_TICK)[batch_at] if len(batch_at) else np.zeros(0, np.int64)
    if not np.array_equal(heads["tick"], tick_rows_before.astype(np.uint64)):
        raise bad("corrupt: a batch record is not followed by the record of its tick")
    if (len(ticks), len(heads), len(updates)) != (end["ticks"], end["batches"], end["updates"]):
        raise bad(f"corrupt: {len(ticks)} ticks, {len(heads)} batches and {len(updates)} updates found; the end "
                  f"record counts {end['ticks']}, {end['batches']} and {end['updates']}")
    batches: List[Batch] = []
    first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    for k, h in enumerate(heads):
        batches.append(Batch(tick=int(h["tick"]), index=int(h["index"]), source=SOURCES.get(int(h["source"]), str(int(h["source"]))),
                             seq=int(h["seq"]), updates=updates[first[k]:first[k + 1]]))
    return Recording(path=path, header=header, ticks=ticks, batches=batches, end=end)

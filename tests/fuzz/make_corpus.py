#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Writes the small seed corpora of tests/fuzz/corpus/<target>/ (run from anywhere; deterministic).
The config corpus also takes the repository's own config files. Re-run after changing a format."""
import pathlib
import random
import shutil
import struct

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent
CORPUS = HERE / "corpus"
rng = random.Random(20110925)


def put(target, name, data):
    d = CORPUS / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())


# config_file: the shipped files and one example of each issue the checker reports.
for f in [ROOT / "config" / "hapticd.toml", *sorted((ROOT / "config" / "devices").glob("*.toml"))]:
    put("config_file", f.name, f.read_bytes())
for i, text in enumerate([
    "", "# only a comment\n", "[table]\nkey = 1\n", "key value\n", "bad key! = 1\n", "key =\n",
    "a = 1\na = 2\n", "s = 'literal'\nt = \"basic \\\" esc\"\n", "f = 1.5e-3\ng = inf\nh = -nan\nb = true\n",
    "arr = [1, 2,\n  3, # comment\n  4]\n", "arr = [1, 2\n", "x = \"unterminated\n", "k = 1 # trailing\r\n",
    "k = [\"a\", 'b', 1.0, true]\n", "k = 0x10\n", "=\n", "k = [[1], [2]]\n",
    # TOML that the toml++ reader accepts, or rejects with a position: multi-line arrays and strings,
    # underscores, other bases, tables, inline tables, dates, quoted and dotted keys, a BOM with CRLF.
    "wall = [\n  \"axis=0 position=0.0 direction=+1\",\n  \"axis=0 position=0.05 direction=-1\",\n]\n",
    "rate = 1_000.0\nn = 0o17\nb = 0b101\nh = 0xdead_beef\n",
    "d = \"\"\"\nline one\nline \\\n  two\"\"\"\nl = '''raw\\n'''\n",
    "[server]\nsocket = \"/run/x\"\n", "k = {a = 1, b = [2]}\n", "t = 1979-05-27T07:32:00Z\n",
    "\"quoted key\" = 1\na.b = 2\n", "\ufeffrate = 1.0\r\nmass = 2\r\n", "s = \"\\u00e9\\U0001F600\"\n",
    "x = 1e400\ny = -0.0\n",
]):
    put("config_file", f"case{i:02d}.toml", text)
# Inputs that reach toml++ 3.3.0's known bugs (see tests/fuzz/toml_assert_policy.hpp): the replay shows the
# parse errors the shipped library gives instead.
put("config_file", "toml_issue_294_ampersand.toml", "[&\n")
put("config_file", "toml_issue_294_nul.toml", "[\0\0table]\nkey = 1\n")
put("config_file", "toml_issue_date_nul.toml", "t = 1979-05-27T\0\x192:00Z\n")
put("config_file", "toml_issue_190.toml", "s = \"\"\"\\\n\u00a7\"\"\"\nk \u00da= 1\n")


# falcon_frames: valid status frames, a stream with garbage, a short frame and a malformed one.
def status(enc, homed, buttons):
    p = [0x3C]
    for v in enc:
        bits = v & 0xFFFF
        p += [((bits >> (4 * n)) & 0xF) + 0x41 for n in range(4)]
    p += [(((homed & 7) << 4) | (buttons & 0xF)) + 0x41, 0x41, 0x3E]
    return bytes(p)


frames = [status((0, 0, 0), 0, 0), status((1000, -1000, 32767), 7, 15), status((-32768, 5, -1), 3, 1)]
put("falcon_frames", "one", bytes([16]) + frames[0])
put("falcon_frames", "stream", bytes([5]) + b"xx" + frames[1] + frames[2][:9] + frames[0] + b"\x00>" + frames[2])
bad = bytearray(frames[1]); bad[5] = 0x20
put("falcon_frames", "malformed", bytes([3]) + bytes(bad) + frames[0])
put("falcon_frames", "torques", bytes([1, 0x00, 0x80, 0xFF, 0x7F, 0x10, 0x00, 0x0F]) + frames[2])

# ftdi_strip: sizes around the 64-byte chunking.
for n in (0, 1, 2, 3, 63, 64, 65, 66, 128, 130, 200):
    put("ftdi_strip", f"size{n:03d}", bytes(rng.randrange(256) for _ in range(n)))

# hid_reports: 8 layout bytes, then the report.
def hid(layout, report):
    return bytes(layout) + bytes(report)

put("hid_reports", "position_i16", hid([1, 5, 1 | 4, 1, 0, 0x12, 10, 50], [1, 0, 0, 0, 0, 0x34, 0x12]))
put("hid_reports", "position_u32", hid([1, 3, 2, 0, 3, 0x12, 0, 5], [1, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF]))
put("hid_reports", "position_u8_end", hid([2, 4, 0, 1, 0, 0x12, 0, 1], [2, 0, 0, 0, 0x80]))
put("hid_reports", "width3", hid([1, 1, 3, 1, 0, 0x12, 0, 1], [1, 1, 2, 3, 4, 5]))
put("hid_reports", "short", hid([1, 5, 1, 1, 0, 0x12, 0, 1], [1, 0, 0]))
put("hid_reports", "block_load_ok", hid([9, 1, 1, 1, 0, 0x12, 0, 1], [0x12, 3, 1, 0, 1]))
put("hid_reports", "block_load_full", hid([9, 1, 1, 1, 0, 0x12, 0, 1], [0x12, 3, 2, 0, 1]))
put("hid_reports", "empty_report", hid([0, 0, 0, 0, 0, 0, 0, 0], []))

# stream_framing: two bytes (the frame limit and the cut of the stream into appends), then the stream: protocol
# lines, empty lines, CRLF, a line at the limit and one above it, a tail without '\n', NUL and invalid UTF-8.
STREAM_SEEDS = [
    b'{"type":"hello","protocol":1}\n{"type":"heartbeat","id":1}\n',
    b'\n\n\r\n{"type":"status","id":2}\r\n',
    b'a' * 40 + b'\n' + b'b' * 41 + b'\n',
    b'x' * 600,
    b'{"id":1}\n{"id":2',
    b'\x00\xff\xfe\n\r\r\n\n',
]
for i, stream in enumerate(STREAM_SEEDS):
    for limit_byte, cut_byte in ((20, 0), (20, 7), (255, 255), (0, 1)):
        put("stream_framing", f"seed_{i}_{limit_byte}_{cut_byte}", bytes([limit_byte, cut_byte]) + stream)

# recording: small recordings (docs/recording.md, format 2 and 1) with the end chunk's checksum valid (the target
# reseals it anyway): a mesh record (the 8-vertex, 12-triangle box: two vertex and two triangle chunks) and a batch
# whose update renders it; then the broken mesh records --replay refuses: cut short, counts beyond the protocol's
# limits, NaN, an index out of range, an update naming an unknown mesh, a repeated id; a version-1 file with a
# plane and one with a mesh object.
def fnv1a64(data, h=14695981039346656037):
    for byte in data:
        h = ((h ^ byte) * 1099511628211) & ((1 << 64) - 1)
    return h


def chunk(kind, payload=b""):
    return (struct.pack("<I", kind) + payload).ljust(128, b"\0")


def tick(n, batches=0):
    return chunk(1, struct.pack("<BBBBQd", 0, 0, 0, 0, n, n * 1e-3) + b"\0" * 96 + struct.pack("<I", batches))


def updates(version, slot, action, kind, mesh=0, K=2000.0):
    a = chunk(3, struct.pack("<BBBBB3xI", slot, action, kind, 0, 0, 7) + b"\0" * 88 + struct.pack("<dd", K, 2.0))
    b = chunk(4)
    c = chunk(6, struct.pack("<I4ddd", mesh, 1.0, 0.0, 0.0, 0.0, 0.4, 0.3))
    return a + b + (c if version >= 2 else b"")


def batch(n, count, index=0):
    return chunk(2, struct.pack("<B3xQQII", 0, n, 1 + n, count, index))


BOX_V = [((i & 1) and 0.01 or -0.01, (i & 2) and 0.01 or -0.01, (i & 4) and 0.01 or -0.01) for i in range(8)]
BOX_T = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4), (2, 6, 3), (3, 6, 7), (0, 4, 2),
         (2, 4, 6), (1, 3, 5), (3, 7, 5)]


def mesh_record(ident, vertices, triangles, mode=1, count_v=None, count_t=None):
    out = chunk(7, struct.pack("<B3xIIQQ", mode, ident, 0, len(vertices) if count_v is None else count_v,
                               len(triangles) if count_t is None else count_t))
    for at in range(0, len(vertices), 5):
        part = vertices[at:at + 5]
        out += chunk(8, struct.pack("<I", len(part)) + b"".join(struct.pack("<ddd", *v) for v in part))
    for at in range(0, len(triangles), 10):
        part = triangles[at:at + 10]
        out += chunk(9, struct.pack("<I", len(part)) + b"".join(struct.pack("<III", *t) for t in part))
    return out


def recording_file(version, body, ticks, batches, n_updates, meshes):
    header = b'{"format":"hapticd-recording"}'.ljust(112, b" ")
    end = chunk(5, struct.pack("<IQQQQQQQ", 1, ticks, batches, n_updates, 0, 0, fnv1a64(body),
                               meshes if version >= 2 else 0))
    return b"HAPTREC\0" + struct.pack("<II", version, 128) + header + body + end


def mesh_session(mesh=None, update_mesh=1, extra=b""):
    mesh = mesh_record(1, BOX_V, BOX_T) if mesh is None else mesh
    body = tick(0) + mesh + extra + batch(1, 1) + updates(2, 0, 0, 3, update_mesh) + tick(1, 1) + \
        batch(2, 1) + updates(2, 0, 1, 3, update_mesh) + tick(2, 1) + batch(3, 1) + updates(2, 0, 2, 3, update_mesh) + tick(3, 1)
    return recording_file(2, body, 4, 3, 3, 1 + (1 if extra else 0))


put("recording", "mesh_session", mesh_session())
put("recording", "mesh_cut", mesh_session(mesh=mesh_record(1, BOX_V, BOX_T)[:-128]))
put("recording", "mesh_vertices_beyond_limit", mesh_session(mesh=mesh_record(1, BOX_V, BOX_T, count_v=200_001)))
put("recording", "mesh_vertices_beyond_file", mesh_session(mesh=mesh_record(1, BOX_V, BOX_T, count_v=199_999)))
put("recording", "mesh_triangles_beyond_limit", mesh_session(mesh=mesh_record(1, BOX_V, BOX_T, count_t=200_001)))
put("recording", "mesh_nan", mesh_session(mesh=mesh_record(1, [BOX_V[0], (0.01, float("nan"), -0.01)] + BOX_V[2:], BOX_T)))
put("recording", "mesh_index", mesh_session(mesh=mesh_record(1, BOX_V, [(0, 2, 8)] + BOX_T[1:])))
put("recording", "mesh_surface_open", mesh_session(mesh=mesh_record(1, BOX_V, BOX_T[:10], mode=0)))
put("recording", "mesh_solid_open", mesh_session(mesh=mesh_record(1, BOX_V, BOX_T[:10], mode=1)))
put("recording", "mesh_unknown_id", mesh_session(update_mesh=2))
put("recording", "mesh_repeated_id", mesh_session(extra=mesh_record(1, BOX_V, BOX_T)))
put("recording", "mesh_second", mesh_session(extra=mesh_record(5, BOX_V, BOX_T, mode=0)))
put("recording", "v1_plane", recording_file(1, tick(0) + batch(1, 1) + updates(1, 0, 0, 0) + tick(1, 1), 2, 1, 1, 0))
put("recording", "v1_mesh", recording_file(1, tick(0) + batch(1, 1) + updates(1, 0, 0, 3) + tick(1, 1), 2, 1, 1, 0))
put("recording", "ticks_only", recording_file(2, tick(0) + tick(1) + tick(2), 3, 0, 0, 0))

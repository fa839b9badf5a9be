# SPDX-License-Identifier: Apache-2.0
"""hapticd_client.recording and hapticd-scope --recording against a recording made by a real daemon.

hapticd --serve --record at its real 1 kHz rate (a recording in real-time mode: the recorder's non-blocking
path) for --duration 3 s on the default simulated device (1 axis, no config wall), started by the first commit
(--serve-wait-commit); a client adds a plane around the resting handle (normal -x, surface at x = -5 mm), moves
it once and leaves. The reader's arrays are checked against the file's own header and end record, the daemon's
--replay of the same file reproduces it (its count of ticks and batches is the reader's), and the scope renders
the recording headless. Bad files raise RecordingError naming the defect.
"""
from __future__ import annotations

import json
import math
import os
import pathlib
import re
import signal
import struct
import subprocess
import sys
import time

import numpy as np
import pytest

from daemon_support import HAPTICD, REPOSITORY, SCOPE_ENV, connectable, hc, needs_daemon, wait_until
from hapticd_client import recording  # noqa: E402


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """The path of the recording and the daemon's output."""
    directory = tmp_path_factory.mktemp("recording")
    socket_path = str(directory / "hapticd.sock")
    path = str(directory / "run.rec")
    shm = f"/hapticd-recording-pytest-{os.getpid()}"
    process = subprocess.Popen([HAPTICD, "--config", "", "--no-walls", "--rt-priority", "0", "--mlock", "false",
                                "--watchdog-overruns", "1000000", "--watchdog-stall-periods", "1000000",
                                "--serve", "--serve-socket", socket_path, "--serve-shm", shm, "--serve-wait-commit",
                                "--duration", "3", "--record", path],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert wait_until(lambda: connectable(socket_path) or process.poll() is not None, 20.0)
        assert process.poll() is None, "hapticd ended at start-up"
        with hc.Client.connect(socket_path=socket_path, client="pytest-recording") as client:
            wall = client.add(hc.plane(normal=(-1, 0, 0), offset=0.005, criterion="CE2"))
            time.sleep(0.3)
            client.modify(wall, hc.plane(normal=(-1, 0, 0), offset=0.006, criterion="CE2"))
            time.sleep(0.3)
            client.bye()
        out, _ = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 0, out
    return {"path": path, "out": out}


@needs_daemon
def test_the_arrays_agree_with_the_header_and_the_end_record(recorded):
    rec = recording.load(recorded["path"], verify_checksum=True)
    assert rec.header["format"] == "hapticd-recording" and rec.header["version"] == recording.FORMAT_VERSION
    assert rec.header["layout"] == recording.EXPECTED_LAYOUT
    assert rec.header["axes"] == 1 and rec.header["rate_hz"] == 1000.0 and rec.header["serve"] is True
    assert rec.header["argv"][-2:] == ["--record", recorded["path"]]
    # --duration 3 at 1 kHz: 3000 ticks, numbered 0 .. 2999, the loop's ideal times k T.
    assert len(rec.ticks) == rec.end["ticks"] == 3000
    assert np.array_equal(rec.ticks["tick"], np.arange(3000))
    assert np.all(np.diff(rec.ticks["time_s"]) > 0)
    assert rec.end["complete"] == 1 and rec.end["dropped_ticks"] == 0 and rec.end["dropped_batches"] == 0
    assert len(rec.batches) == rec.end["batches"] and sum(len(b.updates) for b in rec.batches) == rec.end["updates"]
    # The add starts the loop: taken at tick 0; then the move and the departure, in order of ticks and seq.
    assert rec.batches[0].tick == 0 and rec.batches[0].source == "commit"
    add = rec.batches[0].updates
    assert len(add) == 1 and add["action"][0] == 0 and add["object_kind"][0] == 0
    assert add["offset"][0] == 0.005 and np.array_equal(add["direction"][0], [-1.0, 0.0, 0.0]) and add["K"][0] > 0
    ticks_of = [b.tick for b in rec.batches]
    assert ticks_of == sorted(ticks_of) and [b.seq for b in rec.batches] == sorted(b.seq for b in rec.batches)
    moves = [b for b in rec.batches if b.source == "commit" and b.updates["action"][0] == 1]
    assert len(moves) == 1 and moves[0].updates["offset"][0] == 0.006
    assert any(b.source == "departure" for b in rec.batches)
    # Each tick counts the batches before it.
    per_tick = np.bincount(np.array(ticks_of, dtype=np.int64), minlength=len(rec.ticks))
    assert np.array_equal(rec.ticks["batches"], per_tick)
    # The plane pushed: along its normal -x (f = n K p with p > 0), so f_x < 0.
    assert rec.ticks["force"][:, 0].min() < -0.1
    assert np.all(rec.ticks["force"][:, 1:] == 0.0)  # 1 axis: the others are never written


def assert_replays_bit_for_bit(path):
    """`hapticd --replay` of the file exits 0 and counts the ticks and batches the reader reads."""
    rec = recording.load(path)
    result = subprocess.run([HAPTICD, "--replay", path], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert f"{len(rec.ticks)} ticks, {len(rec.batches)} batches: every force identical" in result.stdout


@needs_daemon
def test_the_daemon_replays_what_the_reader_reads(recorded):
    assert_replays_bit_for_bit(recorded["path"])


@needs_daemon
def test_the_scope_plots_a_recording_headless(recorded, tmp_path):
    png, npz = tmp_path / "recording.png", tmp_path / "recording.npz"
    result = subprocess.run([sys.executable, "-m", "hapticd_client.scope", "--recording", recorded["path"], "--out", str(png),
                             "--data", str(npz), "--size", "640x480", "--dpi", "80"],
                            capture_output=True, text=True, env=SCOPE_ENV, timeout=120)
    assert result.returncode == 0, result.stderr
    head = png.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", head[16:24]) == (640, 480)
    import matplotlib.image
    pixels = matplotlib.image.imread(png)
    assert pixels.std() > 0.01, "an image, not a blank page"
    data = np.load(npz)
    rec = recording.load(recorded["path"])
    assert np.array_equal(data["force"], rec.ticks["force"]) and np.array_equal(data["tick"], rec.ticks["tick"])


@needs_daemon
def test_a_layout_without_the_gain_row_reads_with_the_row_zero(recorded, tmp_path):
    # A recording made before the tick's gain_row byte was declared (--retune's row, docs/recording.md): its header
    # lists the tick fields without it and the byte is 0; the reader accepts it with the same dtype.
    good = pathlib.Path(recorded["path"]).read_bytes()
    size = struct.unpack("<I", good[12:16])[0]
    header = json.loads(good[16:size].decode("utf-8"))
    assert header["layout"] == recording.EXPECTED_LAYOUT
    header["layout"]["tick"] = [f for f in header["layout"]["tick"] if f[0] != "gain_row"]
    text = json.dumps(header, separators=(",", ":")).encode("utf-8")
    assert len(text) <= size - 16
    f = tmp_path / "old_layout.rec"
    f.write_bytes(good[:16] + text + b" " * (size - 16 - len(text)) + good[size:])
    old, new = recording.load(f), recording.load(recorded["path"])
    assert np.array_equal(old.ticks, new.ticks) and not old.ticks["gain_row"].any()
    header["layout"]["tick"][4] = ["renamed", "<u8", 8, 1]
    text = json.dumps(header, separators=(",", ":")).encode("utf-8")
    f.write_bytes(good[:16] + text + b" " * (size - 16 - len(text)) + good[size:])
    with pytest.raises(recording.RecordingError, match="record layout"):
        recording.load(f)


@needs_daemon
def test_bad_files_raise_recording_error(recorded, tmp_path):
    good = pathlib.Path(recorded["path"]).read_bytes()
    cases = {
        "short": (b"HAPT", r"too short \(4 bytes\)"),
        "magic": (b"X" + good[1:], r"not a hapticd recording"),
        "version": (good[:8] + struct.pack("<I", 9) + good[12:], r"format version 9 is not supported"),
        "cut": (good[:-200], r"truncated: 56 bytes after the last whole 128-byte record"),  # 200 = 128 + 72; 128 - 72 left
        "no_end": (good[:-128], r"truncated: no end record"),
        "flipped": (good[:-1000] + bytes([good[-1000] ^ 1]) + good[-999:], r"corrupt: the records' checksum"),
    }
    for name, (data, message) in cases.items():
        f = tmp_path / f"{name}.rec"
        f.write_bytes(data)
        with pytest.raises(recording.RecordingError, match=re.escape(f"recording '{f}': ") + message):
            recording.load(f, verify_checksum=True)
    result = subprocess.run([sys.executable, "-m", "hapticd_client.scope", "--recording", str(tmp_path / "cut.rec"), "--out",
                             str(tmp_path / "x.png")], capture_output=True, text=True, env=SCOPE_ENV, timeout=60)
    assert result.returncode == 10 and "truncated" in result.stderr


SIM3 = os.path.join(REPOSITORY, "tests", "server", "sim3.toml")


@pytest.fixture(scope="module")
def mesh_recorded(tmp_path_factory):
    """A recording at the real 1 kHz rate (about 1.5 s: in lockstep the loop would record millions of ticks while the
    client sleeps) on the 3-axis simulated device of a session with a mesh: an icosphere (radius 1 cm,
    162 vertices, 320 triangles) uploaded, added beside the resting handle, moved until the handle is 0.2 mm inside
    its outline (turned a little about z, with friction), removed. Returns its path, the mesh and its id."""
    directory = tmp_path_factory.mktemp("mesh-recording")
    socket_path = str(directory / "hapticd.sock")
    path = str(directory / "mesh.rec")
    shm = f"/hapticd-mesh-recording-pytest-{os.getpid()}"
    vertices, triangles = hc.icosphere(0.01, 2)
    process = subprocess.Popen([HAPTICD, "--config", "", "--device", SIM3, "--no-walls", "--rt-priority",
                                "0", "--mlock", "false", "--serve", "--serve-socket", socket_path, "--serve-shm", shm,
                                "--serve-wait-commit", "--hand-stiffness", "-1", "--hand-damping", "-1", "--record", path],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert wait_until(lambda: connectable(socket_path) or process.poll() is not None, 20.0)
        assert process.poll() is None, "hapticd ended at start-up"
        with hc.Client.connect(socket_path=socket_path, client="pytest-mesh-recording") as client:
            mesh_id = client.upload_mesh(vertices, triangles, solid=True)

            def sphere(y, angle):
                return hc.mesh(mesh_id=mesh_id, position=(0.0, y, 0.0),
                               orientation=(math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)),
                               static_friction=0.4, dynamic_friction=0.3)

            obj = client.add(sphere(0.02, 0.0))
            time.sleep(0.3)
            for i, y in enumerate((0.012, 0.0102, 0.0098), start=1):
                client.modify(obj, sphere(y, 0.02 * i))
                time.sleep(0.3)
            client.remove(obj)
            time.sleep(0.3)
            client.bye()
        process.send_signal(signal.SIGTERM)
        out, _ = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 0, out
    return {"path": path, "id": mesh_id, "vertices": np.array(vertices, dtype=np.float64),
            "triangles": np.array(triangles, dtype=np.uint32)}


@needs_daemon
def test_a_mesh_recording_holds_the_mesh_as_uploaded(mesh_recorded):
    rec = recording.load(mesh_recorded["path"], verify_checksum=True)
    assert rec.header["version"] == 2 and rec.end["meshes"] == 1
    assert list(rec.meshes) == [mesh_recorded["id"]]
    m = rec.meshes[mesh_recorded["id"]]
    assert m.mode == "solid"
    assert np.array_equal(m.vertices, mesh_recorded["vertices"])  # the same doubles, bit for bit
    assert np.array_equal(m.triangles, mesh_recorded["triangles"])
    # Before the first batch that renders it; every mesh update names it, with its pose's quaternion and friction.
    updates = np.concatenate([b.updates for b in rec.batches])
    mine = updates[updates["object_kind"] == 3]
    assert len(mine) >= 5 and np.all(mine["mesh"] == mesh_recorded["id"])
    assert np.all(updates["mesh"][updates["object_kind"] != 3] == 0)
    assert np.all(mine["static_friction"] == 0.4) and np.all(mine["dynamic_friction"] == 0.3)
    assert np.allclose(np.linalg.norm(mine["orientation"], axis=1), 1.0, rtol=0, atol=1e-12)
    # The handle was inside the sphere's outline: it was pushed along -y (contact with slot 0).
    assert np.count_nonzero(rec.ticks["contact_mask"]) > 100 and rec.ticks["force"][:, 1].min() < -1e-3


@needs_daemon
def test_the_daemon_replays_a_mesh_recording_bit_for_bit(mesh_recorded):
    assert_replays_bit_for_bit(mesh_recorded["path"])


@needs_daemon
def test_broken_mesh_records_raise_recording_error(mesh_recorded, tmp_path):
    good = pathlib.Path(mesh_recorded["path"]).read_bytes()
    size = struct.unpack("<I", good[12:16])[0]
    kinds = [struct.unpack_from("<I", good, at)[0] for at in range(size, len(good), 128)]
    head = size + 128 * kinds.index(recording.KIND_MESH)
    name = re.escape(f"mesh record {kinds.index(recording.KIND_MESH)} (mesh {mesh_recorded['id']})")

    def changed(at, fmt, value):
        data = bytearray(good)
        struct.pack_into(fmt, data, at, value)
        return bytes(data)

    cases = {
        "beyond_limit": (changed(head + 16, "<Q", 200_001), name + r" has mode 1, 200001 vertices and 320 triangles"),
        # Within the limits, but the file ends (its end record) after the mesh's own 64 chunks.
        "beyond_file": (changed(head + 16, "<Q", 199_999)[:head + 128 * 65] + good[-128:],
                        name + r" announces 40000 vertex and 32 triangle chunks; only 64 chunks follow it"),
        "nan": (changed(head + 128 + 8 + 8 * 4, "<d", float("nan")), name + r" is invalid: vertex 1 coordinate y = nan"),
        "index": (changed(head + 128 * 34 + 8 + 4 * 2, "<I", 162),
                  name + r" is invalid: triangle 0 vertex index 2 = 162, accepted 0\.\.161"),
        "cut": (good[:head + 128 * 65] + good[head + 128 * 66:],  # its last triangle chunk
                r"chunk 64 after " + name + r" has kind \d+ and count \d+; expected the mesh's triangles"),
    }
    for case, (data, message) in cases.items():
        f = tmp_path / f"{case}.rec"
        f.write_bytes(data)
        with pytest.raises(recording.RecordingError, match=re.escape(f"recording '{f}': ") + "corrupt: " + message):
            recording.load(f)

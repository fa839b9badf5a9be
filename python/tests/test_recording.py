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
import os
import pathlib
import re
import struct
import subprocess
import sys
import time

import numpy as np
import pytest

from daemon_support import HAPTICD, SCOPE_ENV, connectable, hc, needs_daemon, wait_until
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


@needs_daemon
def test_the_daemon_replays_what_the_reader_reads(recorded):
    rec = recording.load(recorded["path"])
    result = subprocess.run([HAPTICD, "--replay", recorded["path"]], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert f"{len(rec.ticks)} ticks, {len(rec.batches)} batches: every force identical" in result.stdout


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

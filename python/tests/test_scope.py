# SPDX-License-Identifier: Apache-2.0
"""hapticd-scope (python -m hapticd_client.scope) headless against a real ``hapticd --serve``.

The daemon runs at its real 1 kHz rate (a Python reader cannot copy a lockstep daemon's state between its
writes) on the default simulated device (1 axis, 0.30 kg) with no config wall; the simulated hand rests at
the workspace centre. A client plane (normal -x, surface at x = -5 mm, CE2) appears around the handle,
pushes it out and holds it: the handle rests on the plane, in contact, pressed with about 1 N.
The binary: $HAPTICD_BINARY, else build/release/apps/hapticd/hapticd; the tests skip only when neither exists
(scripts/test-python.sh sets it and fails when it is missing).
"""
from __future__ import annotations

import os
import pathlib
import shutil
import struct
import subprocess
import sys
import time

import numpy as np
import pytest

from daemon_support import SCOPE_ENV, hc, needs_daemon, serving_daemon, wait_until
from hapticd_client import scope  # noqa: E402


def run_scope(*args, timeout=30):
    return subprocess.run([sys.executable, "-m", "hapticd_client.scope", *args], capture_output=True, text=True,
                          env=SCOPE_ENV, timeout=timeout)


def png_size(path):
    """(width, height) from the PNG signature and its first chunk, IHDR (PNG spec, section 11.2.2)."""
    head = pathlib.Path(path).read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    length, kind = struct.unpack(">I4s", head[8:16])
    assert kind == b"IHDR" and length == 13
    return struct.unpack(">II", head[16:24])


@pytest.fixture(scope="module")
def resting_on_a_plane(tmp_path_factory):
    """The daemon at 1 kHz, a client holding a plane the handle rests on, and the plane's id."""
    directory = tmp_path_factory.mktemp("scope")
    shm = f"/hapticd-scope-pytest-{os.getpid()}"
    with serving_daemon(directory, shm) as socket_path, \
            hc.Client.connect(socket_path=socket_path, client="pytest-scope") as client, hc.StateReader(shm) as state:
        wall = client.add(hc.plane(normal=(-1, 0, 0), offset=0.005, criterion="CE2"))
        # The plane pushes the handle out to its surface at 1 cm/s (5 mm: 0.5 s); 1.5 s bounds a loaded machine.
        assert wait_until(lambda: wall in state.read().contacts() and state.read().position[0] < -0.0049, 5.0)
        yield {"socket": socket_path, "shm": shm, "wall": wall, "state": state, "directory": directory}
        client.bye()


@needs_daemon
def test_a_headless_frame_carries_the_samples_read_from_the_state(resting_on_a_plane, tmp_path):
    d = resting_on_a_plane
    png, npz = tmp_path / "scope.png", tmp_path / "scope.npz"
    process = subprocess.Popen([sys.executable, "-m", "hapticd_client.scope", "--shm", d["shm"], "--out", str(png),
                                "--data", str(npz), "--duration", "1", "--window", "1", "--every", "0.5",
                                "--size", "640x480", "--dpi", "80"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=SCOPE_ENV)
    # Meanwhile the same state read directly: tick -> the fields the scope stores.
    direct = {}
    while process.poll() is None:
        try:
            s = d["state"].read()
        except hc.HapticdError:
            continue
        direct[s.tick] = (s.position, s.velocity, s.force, s.contact_mask, s.slot_object_id)
        time.sleep(0.0003)
    out, err = process.communicate(timeout=30)
    assert process.returncode == 0, err

    assert png_size(png) == (640, 480)
    import matplotlib.image
    pixels = matplotlib.image.imread(png)  # decodes every chunk: a valid PNG
    assert pixels.shape[:2] == (480, 640) and pixels.std() > 0.01, "an image, not a blank page"

    data = np.load(npz)
    tick, time_s = data["tick"], data["time_s"]
    # The sampler reads at 1 kHz for 1 s: on a shared 2-core machine it may lose the CPU for a while, so
    # the bounds are a tenth of the ticks and half of the run; the window bounds the span from above.
    assert len(tick) >= 100, len(tick)
    assert np.all(np.diff(tick.astype(np.int64)) > 0), "ticks strictly increase"
    assert np.all(np.diff(time_s) > 0)
    assert 0.5 < time_s[-1] - time_s[0] <= 1.0
    assert int(data["axes"]) == 1 and str(data["shm"]) == d["shm"]

    common = [i for i, t in enumerate(tick) if int(t) in direct]
    assert len(common) >= 10, f"{len(common)} ticks read by both"
    for i in common:
        position, velocity, force, mask, slots = direct[int(tick[i])]
        # The same tick of the same segment: the same bytes (exact equality, no tolerance).
        assert tuple(data["position"][i]) == position and tuple(data["velocity"][i]) == velocity
        assert tuple(data["force"][i]) == force
        assert int(data["contact_mask"][i]) == mask and list(data["slot_object_id"][i]) == slots

    # The object rows: the plane is present and in contact in every sample, and pushes towards -x.
    ids = list(data["object_ids"])
    assert ids == [d["wall"]]
    assert data["present"][:, 0].all() and data["in_contact"][:, 0].all()
    assert np.all(data["force"][:, 0] < 0.0)
    assert "frame(s)" in err and str(png) in err


@needs_daemon
def test_frames_go_to_a_directory_every_F_seconds(resting_on_a_plane, tmp_path):
    frames = tmp_path / "frames"
    result = run_scope("--shm", resting_on_a_plane["shm"], "--out", str(frames), "--every", "0.2", "--duration", "0.6",
                       "--size", "400x300")
    assert result.returncode == 0, result.stderr
    names = sorted(p.name for p in frames.iterdir())
    # Frames at 0.2 and 0.4 s and one at the end (0.6 s); a frame that took longer than F skips the ones it
    # overran, so at least the first and the last; never more than one per F plus the last.
    assert 2 <= len(names) <= 4, names
    assert names == [f"frame-{k:06d}.png" for k in range(len(names))]
    assert all(png_size(frames / n) == (400, 300) for n in names)


XVFB_RUN = shutil.which("xvfb-run")


@needs_daemon
@pytest.mark.skipif(XVFB_RUN is None, reason="no xvfb-run (Debian package xvfb): the window mode needs an X display")
def test_the_window_mode_runs_on_an_X_display(resting_on_a_plane, tmp_path):
    """The window (matplotlib's default interactive backend, TkAgg on Debian) on a virtual X display, closed
    by --duration; its last frame's samples as in the headless mode."""
    env = {k: v for k, v in SCOPE_ENV.items() if k != "MPLBACKEND"}
    npz = tmp_path / "window.npz"
    result = subprocess.run([XVFB_RUN, "-a", sys.executable, "-m", "hapticd_client.scope", "--shm",
                             resting_on_a_plane["shm"], "--duration", "1", "--rate", "5", "--data", str(npz)],
                            capture_output=True, text=True, env=env, timeout=60)
    assert result.returncode == 0, result.stderr
    data = np.load(npz)
    assert len(data["tick"]) >= 50 and np.all(np.diff(data["tick"].astype(np.int64)) > 0)
    assert list(data["object_ids"]) == [resting_on_a_plane["wall"]] and data["in_contact"].all()


def test_the_frame_plots_the_samples_it_is_given():
    """Scope.draw on known samples: each line holds its axis' values in the panel's unit, the object rows
    hold the ids, and a contact bar covers the samples whose contact bit is set for the object's slot."""
    import matplotlib.figure

    n = 50
    samples = np.zeros(n, scope.STATE_DTYPE)
    samples["tick"] = np.arange(1000, 1000 + n)
    samples["time_s"] = 10.0 + 1e-3 * np.arange(n)
    samples["position"][:, 0] = np.linspace(-0.002, 0.003, n)
    samples["velocity"][:, 1] = 0.25
    samples["force"][:, 2] = np.linspace(0.0, -1.5, n)
    samples["slot_object_id"][:, 0] = 7
    samples["slot_object_id"][n // 2:, 5] = 9
    samples["contact_mask"][10:20] = 1  # slot 0: object 7
    samples["contact_mask"][30:] = 1 << 5  # slot 5: object 9
    figure = matplotlib.figure.Figure(figsize=(6, 4), dpi=50)
    view = scope.Scope(figure, axes=3, window_s=0.1, shm="/test")
    view.draw(samples, "")
    t = samples["time_s"] - samples["time_s"][-1]
    np.testing.assert_array_equal(view.lines["position"][0].get_xdata(), t)
    np.testing.assert_array_equal(view.lines["position"][0].get_ydata(), 1e3 * samples["position"][:, 0])
    np.testing.assert_array_equal(view.lines["velocity"][1].get_ydata(), 1e3 * samples["velocity"][:, 1])
    np.testing.assert_array_equal(view.lines["force"][2].get_ydata(), samples["force"][:, 2])
    assert [label.get_text() for label in view.ax_contacts.get_yticklabels()] == ["id 7", "id 9"]
    assert "tick 1049" in view.title.get_text() and "in contact {9}" in view.title.get_text()

    ids, present, in_contact = scope.object_rows(samples)
    assert list(ids) == [7, 9]
    assert present[:, 0].all() and present[:, 1].tolist() == [False] * (n // 2) + [True] * (n - n // 2)
    assert in_contact[:, 0].tolist() == [10 <= i < 20 for i in range(n)]
    assert in_contact[:, 1].tolist() == [i >= 30 for i in range(n)]


def test_a_missing_segment_is_exit_9_naming_shm(tmp_path):
    # In its own process: the exit status is the process's.
    name = f"/hapticd-scope-missing-{os.getpid()}"
    result = run_scope("--shm", name, "--out", str(tmp_path / "x.png"))
    assert result.returncode == 9, result.stderr
    assert f"--shm {name}" in result.stderr and "No such file" in result.stderr
    assert not (tmp_path / "x.png").exists()


# The other refusals run scope.main in this process (the same code path, minus an interpreter start each).

def test_a_segment_that_never_ticked_is_stale_exit_9(tmp_path, capsys):
    # A segment with a valid header (state_layout.hpp) whose heartbeat was never written: no loop behind it.
    name = f"/hapticd-scope-stale-{os.getpid()}"
    path = hc.shm_path(name)
    header = struct.pack("<IIIIdI", 0x54535048, 2, 1152, 1, 1e-3, 64)
    pathlib.Path(path).write_bytes(header + bytes(1152 - len(header)))
    try:
        code = scope.main(["--shm", name, "--out", str(tmp_path / "x.png")])
    finally:
        os.unlink(path)
    err = capsys.readouterr().err
    assert code == 9, err
    assert f"--shm {name}" in err and "stale" in err and "never ticked" in err


def test_no_daemon_at_the_socket_is_exit_3_naming_socket(tmp_path, capsys):
    code = scope.main(["--socket", str(tmp_path / "none.sock"), "--out", str(tmp_path / "x.png")])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "--socket" in err and "none.sock" in err


@pytest.mark.parametrize("args, named, accepted", [
    (["--window", "-1"], "--window", "(0, 600]"),
    (["--window", "nan"], "--window", "(0, 600]"),
    (["--every", "0.01"], "--every", "[0.05, 3600]"),
    (["--sample-rate", "0"], "--sample-rate", "(0, 5000]"),
    (["--dpi", "1.5"], "--dpi", "[20, 600]"),
    (["--size", "10x10"], "--size", "[200, 8000]"),
    (["--size", "big"], "--size", "WIDTHxHEIGHT"),
    (["--data", "samples.txt"], "--data", ".npz"),
    (["--data", "/nonexistent-dir/samples.npz"], "--data", "does not exist"),
])
def test_bad_options_are_exit_2_naming_the_option(tmp_path, capsys, args, named, accepted):
    code = scope.main(["--shm", "/none", "--out", str(tmp_path / "x.png"), *args])
    err = capsys.readouterr().err
    assert code == 2, err
    assert named in err and accepted in err, err


def test_without_a_display_out_is_required(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    code = scope.main(["--shm", "/none"])
    err = capsys.readouterr().err
    assert code == 2 and "no display" in err and "--out DIR" in err and "--out FILE.png" in err, err


def test_out_naming_a_file_that_is_not_a_directory_is_exit_2(tmp_path, capsys):
    (tmp_path / "frames").write_text("")
    assert scope.main(["--shm", "/none", "--out", str(tmp_path / "frames")]) == 2
    assert "--out" in capsys.readouterr().err


def test_out_in_a_missing_directory_is_exit_2(tmp_path, capsys):
    assert scope.main(["--shm", "/none", "--out", str(tmp_path / "no" / "x.png")]) == 2
    assert "--out" in capsys.readouterr().err

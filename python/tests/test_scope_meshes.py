# SPDX-License-Identifier: Apache-2.0
"""Mesh objects' god-object proxies in the state (docs/protocol.md, section 6) through hapticd_client: the shared
memory reader, the subscribed state messages and hapticd-scope (docs/scope.md, "Mesh objects").

Live: a real ``hapticd --serve`` at its 1 kHz on the 3-axis simulated device (tests/server/sim3.toml, free: no
simulated hand), a box mesh whose +z face carries the oblique plane n = (0, 0.6, 0.8) through the origin and a
field of -1 N n pressing the handle into it (as tests/server/test_server_mesh_proxy.cpp): the proxy lies on the
face's plane moved out by the proxy's 1 um offset (n.proxy = 0), the handle behind it. Synthetic: segments written
here byte by byte (a daemon with proxies, one without) and Scope.draw on known samples.
"""
from __future__ import annotations

import math
import os
import pathlib
import struct
import subprocess
import sys

import numpy as np
import pytest

from daemon_support import REPOSITORY, SCOPE_ENV, hc, needs_daemon, serving_daemon, wait_until
from hapticd_client import scope, state

SIM3 = os.path.join(REPOSITORY, "tests", "server", "sim3.toml")
NORMAL = (0.0, 0.6, 0.8)
HALF = 0.02
DELTA = 1e-6  # the proxy's clearance in front of a face (kSurfaceOffset, src/mesh/mesh_hierarchy.hpp)


def dot(u, v):
    return sum(a * b for a, b in zip(u, v))


@pytest.fixture(scope="module")
def pressed_mesh(tmp_path_factory):
    """The daemon, a client holding the pressed box mesh and the field, and the mesh object's id."""
    directory = tmp_path_factory.mktemp("scope-meshes")
    shm = f"/hapticd-scope-meshes-pytest-{os.getpid()}"
    with serving_daemon(directory, shm, ["--device", SIM3, "--hand-stiffness", "0", "--hand-damping", "0"]) as \
            socket_path, hc.Client.connect(socket_path=socket_path, client="pytest-scope-meshes") as client, \
            hc.StateReader(shm) as reader:
        theta = math.atan2(-0.6, 0.8)  # R_x(theta) e_z = n
        box = client.add(hc.mesh(*hc.box((HALF, HALF, HALF)),
                                 position=(0.0, -0.6 * (HALF + DELTA), -0.8 * (HALF + DELTA)),
                                 orientation=(math.cos(theta / 2), math.sin(theta / 2), 0.0, 0.0)))
        client.add(hc.field(center=(0, 0, 0), radius=1.0, force=(0.0, -0.6, -0.8)))

        def pressed():
            s = reader.read()
            return len(s.mesh_proxies) == 1 and s.mesh_proxies[0].constraints == 1 and dot(NORMAL, s.position) < -5e-6
        assert wait_until(pressed, 5.0)
        yield {"socket": socket_path, "shm": shm, "mesh": box, "reader": reader, "client": client}
        client.bye()


@needs_daemon
def test_the_reader_gives_the_proxy_on_the_pressed_face_with_the_handle_behind(pressed_mesh):
    reader = pressed_mesh["reader"]
    assert reader.mesh_proxy_capacity == 7
    checked = 0
    for _ in range(100):
        s = reader.read()
        assert len(s.mesh_proxies) == 1
        p = s.mesh_proxies[0]
        assert p.object_id == pressed_mesh["mesh"] and s.slot_object_id[p.slot] == p.object_id
        assert s.mesh_slot_mask == 1 << p.slot
        assert (p.constraints == 1) == bool(s.contact_mask >> p.slot & 1)
        if p.constraints != 1:
            continue
        checked += 1
        # On the face's plane moved out by 1 um: n.proxy = 0 to the proxy's geometry (1e-12 m; ten times allowed).
        assert abs(dot(NORMAL, p.proxy)) < 1e-11
        assert dot(NORMAL, s.position) < -DELTA  # the handle behind the face, so behind the proxy
        assert p.triangle is not None and p.converged and not p.sliding
        assert len(p.normals) == 1 and all(abs(a - b) < 1e-6 for a, b in zip(p.normals[0], NORMAL))  # float normals
    assert checked >= 90


@needs_daemon
def test_subscribed_state_messages_carry_the_proxy(pressed_mesh):
    source = hc.StateSource(pressed_mesh["client"], rate_hz=100.0, mode="subscribe")
    s = source.read(2.0)
    pressed_mesh["client"].unsubscribe()
    assert len(s.mesh_proxies) == 1
    p = s.mesh_proxies[0]
    assert p.object_id == pressed_mesh["mesh"] and p.constraints == 1 and s.mesh_slot_mask == 1 << p.slot
    assert abs(dot(NORMAL, p.proxy)) < 1e-11
    assert all(abs(a - b) < 1e-6 for a, b in zip(p.normals[0], NORMAL))


@needs_daemon
def test_the_scope_plots_and_saves_the_proxy_read_from_the_state(pressed_mesh, tmp_path):
    png, npz = tmp_path / "scope.png", tmp_path / "scope.npz"
    result = subprocess.run([sys.executable, "-m", "hapticd_client.scope", "--shm", pressed_mesh["shm"], "--out",
                             str(png), "--data", str(npz), "--duration", "1", "--window", "1", "--size", "640x480",
                             "--dpi", "80"], capture_output=True, text=True, env=SCOPE_ENV, timeout=60)
    assert result.returncode == 0, result.stderr
    assert png.stat().st_size > 0
    data = np.load(npz)
    ids = list(data["object_ids"])
    k = ids.index(pressed_mesh["mesh"])
    # Every sample holds the mesh's proxy: the row's proxy is the state's entry, bit for bit.
    assert np.all(data["mesh_proxies"] == 1)
    np.testing.assert_array_equal(data["proxy"][:, k], data["mesh_proxy_position"][:, 0])
    assert np.all(data["mesh_proxy_object_id"][:, 0] == pressed_mesh["mesh"])
    # The penetration is |proxy - handle|, and in contact it is the depth behind the offset plane: -n.x.
    np.testing.assert_array_equal(data["penetration"][:, k],
                                  np.linalg.norm(data["proxy"][:, k] - data["position"], axis=1))
    pressed = data["proxy_constraints"][:, k] == 1
    assert pressed.sum() >= 0.9 * len(pressed)
    depth = -(data["position"][pressed] @ np.array(NORMAL))
    np.testing.assert_allclose(data["penetration"][pressed, k], depth, rtol=0, atol=1e-11)
    assert np.all(depth > DELTA)
    # The other row (the field) has no proxy.
    other = 1 - k
    assert np.isnan(data["proxy"][:, other]).all() and np.all(data["proxy_constraints"][:, other] == -1)


def make_samples(n=40):
    samples = np.zeros(n, scope.SAMPLE_DTYPE)
    samples["tick"] = np.arange(n)
    samples["time_s"] = 1e-3 * np.arange(n)
    samples["position"][:, 0] = np.linspace(0.001, -0.002, n)
    samples["slot_object_id"][:, 0] = 3  # a plane
    samples["slot_object_id"][:, 4] = 8  # a mesh
    samples["mesh_slot_mask"] = 1 << 4
    samples["mesh_proxies"] = 1
    entry = samples["mesh_proxy"][:, 0]
    entry["object_id"] = 8
    entry["slot"] = 4
    entry["proxy"][:, 0] = np.maximum(samples["position"][:, 0], 0.0)  # stopped at x = 0
    entry["constraints"] = (samples["position"][:, 0] < 0).astype(np.uint8)
    samples["mesh_proxy"][:, 0] = entry
    return samples


def test_the_frame_draws_the_proxy_it_is_given():
    """Scope.draw on known samples: a dashed line per axis holds the proxy (mm), the mesh's row says so and
    names the newest penetration; a sample with a mesh beyond the 7 says so in the title."""
    import matplotlib.figure

    samples = make_samples()
    figure = matplotlib.figure.Figure(figsize=(6, 4), dpi=50)
    view = scope.Scope(figure, axes=3, window_s=0.1, shm="/test")
    view.draw(samples, "")
    assert len(view.proxy_lines) == 3
    np.testing.assert_array_equal(view.proxy_lines[0].get_ydata(), 1e3 * samples["mesh_proxy"][:, 0]["proxy"][:, 0])
    assert view.proxy_lines[0].get_linestyle() == "--"
    assert [label.get_text() for label in view.ax_contacts.get_yticklabels()] == ["id 3", "id 8 mesh"]
    assert [t.get_text() for t in view.row_notes] == ["|proxy - handle| 2.000 mm, 1 constraint(s)"]
    assert "beyond" not in view.title.get_text()
    samples["mesh_slot_mask"] |= 1 << 9
    view.draw(samples, "")  # redrawn: the old lines and notes go
    assert len(view.proxy_lines) == 3 and len(view.row_notes) == 1
    assert "1 mesh(es) beyond the 7 proxies the state holds" in view.title.get_text()
    # A plain STATE_DTYPE array (no proxies) draws as before.
    plain = np.zeros(5, scope.STATE_DTYPE)
    plain["time_s"] = np.arange(5.0)
    view.draw(plain, "")
    assert view.proxy_lines == [] and view.row_notes == []


def test_write_data_saves_the_proxy_rows(tmp_path):
    samples = make_samples()
    scope.write_data(str(tmp_path / "d.npz"), samples, 3, 0.1, "/test")
    data = np.load(tmp_path / "d.npz")
    assert list(data["object_ids"]) == [3, 8]
    assert np.isnan(data["proxy"][:, 0]).all()
    np.testing.assert_array_equal(data["proxy"][:, 1], samples["mesh_proxy"][:, 0]["proxy"])
    np.testing.assert_allclose(data["penetration"][:, 1], np.abs(np.minimum(samples["position"][:, 0], 0.0)), atol=0)
    assert data["mesh_proxy_normal"].shape == (len(samples), 7, 3, 3)


def write_segment(path, capacity, entries=()):
    """A segment as a daemon writes it (state_layout.hpp): header, an even sequence, a heartbeat, the mesh block."""
    buf = bytearray(1152)
    struct.pack_into("<IIIIdI", buf, 0, 0x54535048, 2, 1152, 3, 1e-3, 64)
    struct.pack_into("<iI", buf, 32, os.getpid(), capacity)
    struct.pack_into("<Q", buf, 64, 2)  # sequence: even, one tick written
    struct.pack_into("<Q", buf, 128, 77)  # tick
    struct.pack_into("<q", buf, 576, 1)  # heartbeat (old: the sample is stale, which read() reports, not refuses)
    mask = 0
    for i, (object_id, slot, proxy, normals, triangle, flags) in enumerate(entries):
        mask |= 1 << slot
        flat = [c for n in normals for c in n] + [0.0] * (9 - 3 * len(normals))
        struct.pack_into("<3d9fIBBBBI", buf, 616 + 72 * i, *proxy, *flat, triangle, slot, len(normals), flags, 0,
                         object_id)
    struct.pack_into("<QI", buf, 600, mask, len(entries))
    pathlib.Path(path).write_bytes(bytes(buf))


def test_the_reader_decodes_the_segments_entries_and_an_older_daemons_zeros():
    name = f"/hapticd-meshes-synthetic-{os.getpid()}"
    path = hc.shm_path(name)
    try:
        write_segment(path, 7, [(5, 2, (0.01, 0.02, 0.03), [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0)], 41, 1),
                                (6, 9, (-0.5, 0.25, 0.125), [], 0xFFFFFFFF, 2)])
        with hc.StateReader(name) as reader:
            assert reader.mesh_proxy_capacity == 7
            s = reader.read()
        assert s.tick == 77 and s.mesh_slot_mask == (1 << 2) | (1 << 9)
        a, b = s.mesh_proxies
        assert (a.object_id, a.slot, a.proxy, a.constraints, a.triangle) == (5, 2, (0.01, 0.02, 0.03), 2, 41)
        assert a.normals == ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)) and a.sliding and a.converged
        assert (b.object_id, b.slot, b.proxy, b.constraints, b.triangle) == (6, 9, (-0.5, 0.25, 0.125), 0, None)
        assert b.normals == () and not b.sliding and not b.converged
        # A daemon that publishes no proxies: capacity 0, zeros, no entries.
        write_segment(path, 0)
        with hc.StateReader(name) as reader:
            assert reader.mesh_proxy_capacity == 0
            s = reader.read()
        assert s.mesh_proxies == [] and s.mesh_slot_mask == 0
    finally:
        os.unlink(path)


def test_a_state_message_with_proxies_becomes_a_sample():
    message = {"type": "state", "tick": 5, "mesh_slot_mask": 4,
               "mesh_proxies": [{"object_id": 7, "slot": 2, "proxy": [0.001, 0.0, -0.002], "constraints": 2,
                                 "normals": [[0, 0, 1], [0, 1, 0]], "triangle": 3, "sliding": True,
                                 "converged": True}]}
    s = hc.sample_from_state_message(message)
    assert s.mesh_slot_mask == 4 and len(s.mesh_proxies) == 1
    p = s.mesh_proxies[0]
    assert (p.object_id, p.slot, p.proxy, p.constraints, p.triangle, p.sliding) == (7, 2, (0.001, 0.0, -0.002), 2, 3, True)
    assert p.normals == ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0))
    assert hc.sample_from_state_message({"type": "state"}).mesh_proxies == []  # an older daemon's message


def test_the_python_layout_is_the_cpp_headers():
    """The reader's and the scope's offsets of the mesh block are the static_asserts of state_layout.hpp (a field
    moved on one side only fails here)."""
    import re
    from hapticd_client import scope_proxies
    text = (pathlib.Path(REPOSITORY) / "include" / "hapticd" / "state_layout.hpp").read_text()
    layout = dict((name, int(offset)) for name, offset in
                  re.findall(r"offsetof\(StateLayout, (\w+)\) == (\d+)", text))
    entry = dict((name, int(offset)) for name, offset in re.findall(r"offsetof\(StateMeshProxy, (\w+)\) == (\d+)", text))
    assert int(re.search(r"kStateMeshProxyCapacity = (\d+);", text).group(1)) == state.MESH_PROXY_CAPACITY
    assert int(re.search(r"sizeof\(StateMeshProxy\) == (\d+)", text).group(1)) == scope_proxies.MESH_PROXY_DTYPE.itemsize
    assert layout["mesh_proxy_capacity"] == 36
    assert layout["mesh_slot_mask"] == state.MESH_OFFSET
    for name in ("mesh_slot_mask", "mesh_proxies", "mesh_proxy"):
        assert layout[name] - state.MESH_OFFSET == scope_proxies.MESH_DTYPE.fields[name][1], name
    assert layout["reserved"] == state.MESH_OFFSET + state.MESH_BLOCK_SIZE
    assert len(entry) == 6
    for name, offset in entry.items():
        assert scope_proxies.MESH_PROXY_DTYPE.fields[name][1] == offset, name

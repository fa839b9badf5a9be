# SPDX-License-Identifier: Apache-2.0
"""Meshes through hapticd_client against a real ``hapticd --serve`` on the 3-axis simulated device
(tests/server/sim3.toml, lockstep): the procedural meshes (closed, outward: positive volume), numpy and sequence
input, the upload and the ``mesh`` object (its criterion gains equal the plane's for the one mass), the daemon's
refusals, and the session's meshes freed when it ends (docs/protocol.md, sections 4 and 4a)."""
from __future__ import annotations

import math
import os
import signal
import subprocess

import pytest

from daemon_support import HAPTICD, REPOSITORY, connectable, hc, needs_daemon, wait_until

pytestmark = needs_daemon

SIM3 = os.path.join(REPOSITORY, "tests", "server", "sim3.toml")


@pytest.fixture(scope="module")
def daemon(tmp_path_factory):
    directory = tmp_path_factory.mktemp("hapticd-meshes")
    socket_path = str(directory / "hapticd.sock")
    shm = f"/hapticd-meshes-pytest-{os.getpid()}"
    log = open(directory / "hapticd.log", "w+")
    process = subprocess.Popen([HAPTICD, "--config", "", "--device", SIM3, "--no-walls", "--lockstep", "--serve",
                                "--serve-socket", socket_path, "--serve-shm", shm], stdout=log,
                               stderr=subprocess.STDOUT)
    try:
        assert wait_until(lambda: connectable(socket_path) or process.poll() is not None, 20.0)
        assert process.poll() is None, "hapticd ended at start-up"
        yield {"socket": socket_path}
    finally:
        process.send_signal(signal.SIGTERM)
        code = process.wait(20)
        log.seek(0)
        text = log.read()
        log.close()
        assert code == 0, text


def connect(daemon) -> hc.Client:
    return hc.Client.connect(socket_path=daemon["socket"], client="pytest-meshes")


def signed_volume(vertices, triangles):
    total = 0.0
    for a, b, c in triangles:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = vertices[a], vertices[b], vertices[c]
        total += (ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)) / 6.0
    return total


def test_the_procedural_meshes_are_closed_and_outward_with_their_volumes():
    # Independent: the analytic volumes; an inscribed polyhedron is smaller, within its tessellation's error.
    v, t = hc.icosphere(0.01, 3)
    assert len(t) == 20 * 4 ** 3
    assert all(math.isclose(math.dist(p, (0, 0, 0)), 0.01, rel_tol=1e-12) for p in v)
    assert 0.985 * 4 / 3 * math.pi * 1e-6 < signed_volume(v, t) < 4 / 3 * math.pi * 1e-6
    v, t = hc.box((0.01, 0.02, 0.03))
    assert signed_volume(v, t) == pytest.approx(8 * 0.01 * 0.02 * 0.03, rel=1e-12)
    v, t = hc.torus(0.02, 0.005, 64, 32)
    exact = 2 * math.pi ** 2 * 0.02 * 0.005 ** 2
    assert 0.98 * exact < signed_volume(v, t) < exact
    for v, t in (hc.icosphere(0.01, 1), hc.box((1, 1, 1)), hc.torus(0.02, 0.005, 8, 6)):  # every edge twice, opposite
        edges = {}
        for tri in t:
            for i in range(3):
                edges[(tri[i], tri[(i + 1) % 3])] = edges.get((tri[i], tri[(i + 1) % 3]), 0) + 1
        assert all(n == 1 and edges.get((b, a)) == 1 for (a, b), n in edges.items())


def test_a_mesh_object_gets_the_planes_criterion_gains_and_is_listed(daemon):
    # One after the other: a CE2 mesh counts in the sums as a spring of K in every direction, so a CE2 plane beside
    # it would be refused (unstable_sum; docs/protocol.md, section 5).
    with connect(daemon) as c:
        sphere = c.add(hc.mesh(*hc.icosphere(0.01, 2), position=(0.0, 0.0, -0.03), criterion="CE2",
                               static_friction=0.3, dynamic_friction=0.2))
        listed = {o["id"]: o for o in c.list()}
        assert listed[sphere]["kind"] == "mesh"
        assert listed[sphere]["object"]["friction"] == {"static": 0.3, "dynamic": 0.2}
        assert c.status()["meshes"] == 1
        c.remove(sphere)
        assert wait_until(lambda: sphere not in {o["id"] for o in c.list()}, 5.0)
        wall = c.add(hc.plane(normal=(0, 0, 1), offset=-0.05, criterion="CE2"))
        plane_gains = {o["id"]: o for o in c.list()}[wall]
    # One mass (0.3 kg on every axis): every contact configuration acts with it, as the plane does.
    assert listed[sphere]["K"] == plane_gains["K"] > 0
    assert listed[sphere]["B"] == plane_gains["B"] > 0


def test_numpy_arrays_are_accepted(daemon):
    np = pytest.importorskip("numpy")
    v, t = hc.box((0.01, 0.01, 0.01))
    with connect(daemon) as c:
        mesh_id = c.upload_mesh(np.array(v), np.array(t, dtype=np.uint32))
        assert c.request("mesh_status", mesh=mesh_id)["state"] == "ready"
        assert c.add(hc.mesh(mesh_id=mesh_id, position=(0.0, 0.03, 0.0), K=300, B=3)) > 0


def test_a_shaded_mesh_is_listed_with_its_crease_angle_and_bad_angles_are_refused(daemon):
    assert "shading" not in hc.mesh(mesh_id=1)  # off by default: the object is what it was
    assert hc.mesh(mesh_id=1, shading=30)["shading"] == {"crease_angle_deg": 30.0}
    with connect(daemon) as c:
        mesh_id = c.upload_mesh(*hc.icosphere(0.01, 2))
        ball = c.add(hc.mesh(mesh_id=mesh_id, position=(0.0, 0.0, -0.03), criterion="CE2", shading=30))
        assert {o["id"]: o for o in c.list()}[ball]["object"]["shading"] == {"crease_angle_deg": 30.0}
        c.remove(ball)
        with pytest.raises(hc.HapticdError) as steep:
            c.add(hc.mesh(mesh_id=mesh_id, position=(0.0, 0.0, -0.03), shading=85))
        assert steep.value.code == "bad_message"
        assert "mesh.shading.crease_angle_deg = 85; accepted: 0 .. 80" in str(steep.value)


def test_bad_meshes_are_refused_naming_the_problem(daemon):
    with connect(daemon) as c:
        with pytest.raises(ValueError, match="not finite"):
            hc.mesh([(0, 0, 0), (1, 0, math.nan), (0, 1, 0)], [(0, 1, 2)])
        v, t = hc.box((0.01, 0.01, 0.01))
        with pytest.raises(hc.HapticdError) as open_solid:
            c.upload_mesh(v, t[:-1], solid=True)
        assert open_solid.value.code == "bad_message" and "solid" in str(open_solid.value)
        assert c.upload_mesh(v, t[:-1], solid=False) > 0  # the same open mesh as a one-sided surface
        with pytest.raises(hc.HapticdError) as far:
            c.upload_mesh([(0, 0, 0), (11, 0, 0), (0, 1, 0)], [(0, 1, 2)], solid=False)
        assert far.value.code == "bad_message" and "vertices[3]" in str(far.value)
        with pytest.raises(hc.HapticdError) as unknown:
            c.add(hc.mesh(mesh_id=987654))
        assert unknown.value.code == "unknown_object"


def test_a_sessions_meshes_are_freed_when_it_ends(daemon):
    with connect(daemon) as watcher:
        before = watcher.status()["mesh_bytes"]
        with connect(daemon) as c:
            c.upload_mesh(*hc.torus(0.02, 0.005, 32, 16))
            c.add(hc.mesh(*hc.icosphere(0.01, 1), position=(0.0, 0.0, -0.03)))
            assert watcher.status()["mesh_bytes"] > before
        assert wait_until(lambda: watcher.status()["mesh_bytes"] == before, 5.0)

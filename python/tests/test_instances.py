# SPDX-License-Identifier: Apache-2.0
"""Two hapticd instances (``--instance NAME``) on two simulated devices at once, found by name by the Python client.

Both run at 1 kHz with the soft config wall of test_hapticd_client.py; the left one on the default simulated
device (1 axis), the right one on tests/server/sim3.toml (3 axes). Their sockets are in ``$RUNTIME_DIRECTORY``, a
directory of this test: ``Client.connect(instance=...)``, ``default_socket_path(instance)`` and
``$HAPTICD_INSTANCE`` reach each daemon by its name; an object added on one is not on the other; each state segment
is its own daemon's, for its own device; a second daemon with a running instance's name exits 9.
"""
from __future__ import annotations

import os
import signal
import subprocess

import pytest

from daemon_support import HAPTICD, REPOSITORY, connectable, hc, needs_daemon, wait_until

pytestmark = needs_daemon

# Paced at 1 kHz (not lockstep: two daemons ticking flat out on a 2-core machine leave a reader of the state
# segment no gap between writes), without real-time priority, the watchdog off (a loaded machine stalls the loops).
BASE_ARGS = ["--config", "", "--rt-priority", "0", "--watchdog-overruns", "1000000", "--watchdog-stall-periods",
             "1000000", "--serve", "--wall", "axis=0 position=0.05 direction=+1", "--stiffness",
             "100", "--damping", "1", "--scenario", "hold", "--hold-distance", "0.055", "--hold-force", "2"]
SIM3 = str(REPOSITORY / "tests" / "server" / "sim3.toml")


@pytest.fixture(scope="module")
def instances(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("run")
    saved = {k: os.environ.get(k) for k in ("RUNTIME_DIRECTORY", "HAPTICD_SOCKET", "HAPTICD_INSTANCE")}
    os.environ["RUNTIME_DIRECTORY"] = str(run_dir)
    os.environ.pop("HAPTICD_SOCKET", None)
    os.environ.pop("HAPTICD_INSTANCE", None)
    names = {"left": f"pyleft-{os.getpid()}", "right": f"pyright-{os.getpid()}"}
    extra = {"left": [], "right": ["--device", SIM3]}
    logs, processes = {}, {}
    try:
        for side, name in names.items():
            logs[side] = open(run_dir / f"{side}.log", "w+")
            processes[side] = subprocess.Popen([HAPTICD, *BASE_ARGS, "--instance", name, *extra[side]],
                                               stdout=logs[side], stderr=subprocess.STDOUT)
        for side, name in names.items():
            path = str(run_dir / f"hapticd-{name}.sock")
            assert wait_until(lambda: connectable(path) or processes[side].poll() is not None, 20.0)
            assert processes[side].poll() is None, f"hapticd --instance {name} ended at start-up"
        yield {"dir": run_dir, "names": names, "processes": processes}
    finally:
        for side, process in processes.items():
            process.send_signal(signal.SIGTERM)
            code = process.wait(20)
            logs[side].seek(0)
            text = logs[side].read()
            logs[side].close()
            assert code == 0, text
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def test_each_client_reaches_its_own_daemon_and_state(instances):
    names, run_dir = instances["names"], instances["dir"]
    assert hc.default_socket_path(names["left"]) == str(run_dir / f"hapticd-{names['left']}.sock")
    with hc.Client.connect(instance=names["left"], client="pytest-left") as left, \
            hc.Client.connect(instance=names["right"], client="pytest-right") as right:
        assert left.welcome["state_shm"] == hc.instance_state_shm(names["left"]) == f"/hapticd-{names['left']}-state"
        assert right.welcome["state_shm"] == f"/hapticd-{names['right']}-state"
        assert (left.device.name, left.device.axes) == ("sim", 1)
        assert (right.device.name, right.device.axes) == ("sim3", 3)
        with hc.StateReader(left.welcome["state_shm"]) as ls, hc.StateReader(right.welcome["state_shm"]) as rs:
            assert wait_until(lambda: ls.read().tick > 100 and rs.read().tick > 100, 10.0)
            assert ls.axes == 1 and rs.axes == 3
            assert ls.writer_pid == instances["processes"]["left"].pid
            assert rs.writer_pid == instances["processes"]["right"].pid


def test_an_object_added_on_one_instance_is_not_on_the_other(instances):
    names = instances["names"]

    def client_objects(name):
        with hc.Client.connect(instance=name, client="pytest-list") as c:
            return {o["id"] for o in c.list() if o["owner"] != 0}

    before_right = client_objects(names["right"])
    with hc.Client.connect(instance=names["left"], client="pytest-plane") as left:
        oid = left.add(hc.plane(normal=(-1, 0, 0), offset=0.005, K=100.0, B=1.0))
        assert oid in client_objects(names["left"])
        assert client_objects(names["right"]) == before_right


def test_the_environment_and_bad_names(instances, monkeypatch):
    names, run_dir = instances["names"], instances["dir"]
    monkeypatch.setenv("HAPTICD_INSTANCE", names["right"])
    assert hc.default_socket_path() == str(run_dir / f"hapticd-{names['right']}.sock")
    with hc.Client.connect(client="pytest-env") as c:
        assert c.welcome["state_shm"] == f"/hapticd-{names['right']}-state"
    assert hc.default_socket_path(names["left"]).endswith(f"hapticd-{names['left']}.sock")  # explicit wins
    monkeypatch.setenv("HAPTICD_SOCKET", "/elsewhere.sock")  # the socket's own variable wins over the instance's
    assert hc.default_socket_path() == "/elsewhere.sock"
    monkeypatch.delenv("HAPTICD_SOCKET")
    monkeypatch.setenv("HAPTICD_INSTANCE", "Right")
    with pytest.raises(ValueError, match=r"\$HAPTICD_INSTANCE = 'Right' is invalid; accepted: 1 to 32 characters"):
        hc.default_socket_path()
    monkeypatch.delenv("HAPTICD_INSTANCE")
    assert hc.default_socket_path() == str(run_dir / "hapticd.sock")  # the default instance keeps its name
    for bad in ("Left", "-x", "_x", "a/b", "../x", "a.b", "a" * 33):
        with pytest.raises(ValueError, match="instance = .* is invalid; accepted: 1 to 32 characters"):
            hc.default_socket_path(bad)
    assert hc.valid_instance_name("a" * 32) and hc.valid_instance_name("0_a-b")
    with pytest.raises(ValueError, match="both given"):
        hc.Client.connect(socket_path=str(run_dir / "x.sock"), instance=names["left"])


def test_a_second_daemon_with_a_running_instances_name_exits_9(instances):
    name = instances["names"]["left"]
    second = subprocess.run([HAPTICD, *BASE_ARGS, "--instance", name, "--duration", "1"], capture_output=True,
                            text=True, timeout=60)
    assert second.returncode == 9, second.stderr
    assert f"hapticd-{name}.sock' is in use" in second.stderr
    with hc.Client.connect(instance=name, client="pytest-after") as c:  # the running one still serves
        with hc.StateReader(c.welcome["state_shm"]) as state:
            assert state.writer_pid == instances["processes"]["left"].pid
            first = state.read().tick
            assert wait_until(lambda: state.read().tick > first, 10.0)

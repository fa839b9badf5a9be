# SPDX-License-Identifier: Apache-2.0
"""Fixtures of the hapticd-ros tests: a real ``hapticd --serve`` (paced at 1 kHz on the simulated device, no
walls, the simulated hand at rest), ``hapticd-ros`` processes against it, and an rclpy node of the test's own.

Isolation: every run takes its own ROS_DOMAIN_ID (set by scripts/test-ros.sh, else 1 + pid % 100 here) and
ROS_LOCALHOST_ONLY=1 (discovery on the loopback only), its own socket and state segment."""
from __future__ import annotations

import os
import pathlib
import signal
import socket
import subprocess
import sys
import time

import pytest

os.environ.setdefault("ROS_DOMAIN_ID", str(1 + os.getpid() % 100))
os.environ["ROS_LOCALHOST_ONLY"] = "1"

import rclpy  # noqa: E402  (after the environment above: rclpy reads it at init)

import hapticd_client as hc  # noqa: E402

REPOSITORY = pathlib.Path(__file__).resolve().parents[2]
HAPTICD = os.environ.get("HAPTICD_BINARY", str(REPOSITORY / "build/release/apps/hapticd/hapticd"))
# The paced daemon of the Python client's tests (python/tests/test_hapticd_client.py): real time at 1 kHz
# without SCHED_FIFO; the watchdog off, since a loaded 2-core machine wakes the loop late at times.
DAEMON_ARGS = ["--config", "", "--no-walls", "--rt-priority", "0", "--watchdog-overruns", "1000000",
               "--watchdog-stall-periods", "1000000"]


def wait_until(predicate, timeout_s=10.0, step_s=0.02, spin=None):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if spin is not None:
            rclpy.spin_once(spin, timeout_sec=step_s)
        else:
            time.sleep(step_s)
        if predicate():
            return True
    return False


def _connectable(path):
    with socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as s:
        try:
            s.connect(path)
            return True
        except OSError:
            return False


@pytest.fixture(scope="module")
def daemon(tmp_path_factory):
    if not os.access(HAPTICD, os.X_OK):
        pytest.fail(f"no hapticd binary at {HAPTICD}: build the release preset or set HAPTICD_BINARY")
    directory = tmp_path_factory.mktemp("hapticd")
    socket_path = str(directory / "hapticd.sock")
    shm = f"/hapticd-ros-pytest-{os.getpid()}-{directory.name}"
    log = open(directory / "hapticd.log", "w+")
    process = subprocess.Popen([HAPTICD, *DAEMON_ARGS, "--serve", "--serve-socket", socket_path, "--serve-shm", shm],
                               stdout=log, stderr=subprocess.STDOUT)
    try:
        assert wait_until(lambda: _connectable(socket_path) or process.poll() is not None, 20.0)
        assert process.poll() is None, "hapticd ended at start-up"
        yield {"socket": socket_path, "shm": shm, "process": process, "log": log}
    finally:
        process.send_signal(signal.SIGTERM)
        code = process.wait(20)
        log.seek(0)
        text = log.read()
        log.close()
        assert code == 0, text


def daemon_objects(daemon):
    """The daemon's client objects (owner != 0), by id."""
    with hc.Client.connect(socket_path=daemon["socket"], client="pytest list") as c:
        return {o["id"]: o for o in c.list() if o["owner"] != 0 and not o.get("ramping_out")}


class NodeProcess:
    """``hapticd-ros`` in its own process (the console script of the venv running the tests)."""

    def __init__(self, daemon, namespace, log_path, *extra):
        self.namespace = namespace
        self.log = open(log_path, "w+")
        script = pathlib.Path(sys.executable).with_name("hapticd-ros")
        self.process = subprocess.Popen([str(script), "--socket", daemon["socket"], "--namespace", namespace, *extra],
                                        stdout=self.log, stderr=subprocess.STDOUT)

    def output(self):
        self.log.flush()
        self.log.seek(0)
        return self.log.read()

    def stop(self):
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        try:
            code = self.process.wait(20)
        finally:
            self.log.close()
        return code


@pytest.fixture(scope="module")
def ros():
    """rclpy and a node of the test's own."""
    rclpy.init()
    node = rclpy.create_node(f"hapticd_ros_pytest_{os.getpid()}")
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.shutdown()


def wait_for_node(ros, node_process, timeout_s=60.0):
    """Until the node publishes its first pose: it is constructed (its parameter services answer from the first
    spin of its executor, which starts after that) and connected to the daemon."""
    from geometry_msgs.msg import PoseStamped
    got = []
    subscription = ros.create_subscription(PoseStamped, f"{node_process.namespace}/pose", got.append, 10)
    ok = wait_until(lambda: got or node_process.process.poll() is not None, timeout_s, spin=ros)
    ros.destroy_subscription(subscription)
    assert ok and node_process.process.poll() is None, node_process.output()


def set_parameters(ros, fqn, values, atomically=False, timeout_s=20.0):
    """Sets string parameters through the node's standard service; the SetParametersResult(s)."""
    from rcl_interfaces.msg import Parameter as ParameterMsg, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters, SetParametersAtomically
    kind = SetParametersAtomically if atomically else SetParameters
    client = ros.create_client(kind, f"{fqn}/set_parameters" + ("_atomically" if atomically else ""))
    assert client.wait_for_service(timeout_sec=timeout_s)
    request = kind.Request()
    for name, value in values.items():
        if value is None:
            v = ParameterValue(type=ParameterType.PARAMETER_NOT_SET)
        elif isinstance(value, str):
            v = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
        else:
            v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
        request.parameters.append(ParameterMsg(name=name, value=v))
    future = client.call_async(request)
    rclpy.spin_until_future_complete(ros, future, timeout_sec=timeout_s)
    ros.destroy_client(client)
    assert future.done(), f"{fqn}: no answer to {kind.__name__} within {timeout_s} s"
    response = future.result()
    return response.result if atomically else list(response.results)

# SPDX-License-Identifier: Apache-2.0
"""What the tests against a real hapticd share: the client package (installed, else from the source tree),
the daemon binary ($HAPTICD_BINARY, else build/release/apps/hapticd/hapticd), the environment that runs the
scope headless from the same package, waiting for a socket or a condition, and a serving daemon."""
from __future__ import annotations

import contextlib
import os
import pathlib
import signal
import socket
import subprocess
import sys
import time

import pytest

REPOSITORY = pathlib.Path(__file__).resolve().parents[2]
try:
    import hapticd_client as hc
except ImportError:  # not installed: the package is pure Python, use it from the source tree
    sys.path.insert(0, str(REPOSITORY / "python" / "src"))
    import hapticd_client as hc


def _hapticd_binary():
    for candidate in (os.environ.get("HAPTICD_BINARY"), str(REPOSITORY / "build/release/apps/hapticd/hapticd")):
        if candidate and os.access(candidate, os.X_OK):
            return candidate
    return None


HAPTICD = _hapticd_binary()
needs_daemon = pytest.mark.skipif(HAPTICD is None, reason="no hapticd binary: set HAPTICD_BINARY (or build build/release)")

# The scope runs in its own process from the same package as the one imported here, with no display.
SCOPE_ENV = {**os.environ, "PYTHONPATH": str(pathlib.Path(hc.__file__).resolve().parents[1]),
             "PYTHONDONTWRITEBYTECODE": "1"}
SCOPE_ENV.pop("DISPLAY", None)
SCOPE_ENV.pop("WAYLAND_DISPLAY", None)


def connectable(path):
    """The daemon accepts connections (its socket file exists from bind(), before listen())."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as s:
        try:
            s.connect(path)
            return True
        except OSError:
            return False


def wait_until(predicate, timeout_s=5.0, step_s=0.01):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step_s)
    return False


@contextlib.contextmanager
def serving_daemon(directory, shm, options=()):
    """``hapticd --serve`` at ``directory``/hapticd.sock with state segment ``shm`` (no config, no walls, normal
    priority, the watchdog out of the way of a loaded machine) plus ``options``; yields the socket's path once it
    accepts connections. On leaving: SIGTERM, and the daemon must exit 0 (its log in the assertion)."""
    socket_path = str(pathlib.Path(directory) / "hapticd.sock")
    with open(pathlib.Path(directory) / "hapticd.log", "w+") as log:
        process = subprocess.Popen([HAPTICD, "--config", "", "--no-walls", "--rt-priority", "0",
                                    "--watchdog-overruns", "1000000", "--watchdog-stall-periods", "1000000",
                                    *options, "--serve", "--serve-socket", socket_path, "--serve-shm", shm],
                                   stdout=log, stderr=subprocess.STDOUT)
        try:
            assert wait_until(lambda: connectable(socket_path) or process.poll() is not None, 20.0)
            assert process.poll() is None, "hapticd ended at start-up"
            yield socket_path
        finally:
            process.send_signal(signal.SIGTERM)
            code = process.wait(20)
            log.seek(0)
            assert code == 0, log.read()

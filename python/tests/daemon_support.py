# SPDX-License-Identifier: Apache-2.0
"""What the tests against a real hapticd share: the client package (installed, else from the source tree),
the daemon binary ($HAPTICD_BINARY, else build/release/apps/hapticd/hapticd), the environment that runs the
scope headless from the same package, and waiting for a socket or a condition."""
from __future__ import annotations

import os
import pathlib
import socket
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

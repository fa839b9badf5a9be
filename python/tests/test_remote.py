# SPDX-License-Identifier: Apache-2.0
"""Remote clients (docs/clients.md, "Remote use"; docs/protocol.md, section 1, the stream transport).

The daemon runs at its real 1 kHz rate on the default simulated device (1 axis, 0.30 kg, no config wall), the
simulated hand at rest at the workspace centre. A real OpenSSH server started here (ssh_support.py) forwards a
local Unix socket to the daemon's stream socket (``ssh -N -L local.sock:hapticd.sock.stream``); a client over it
adds a plane (normal -x, surface at x = -5 mm, CE2) that pushes the handle out to its surface and holds it
there, reads that through ``subscribe`` (the state segment is local: StateSource subscribes over a stream
socket), and gets a refusal as an error. A forward of the SOCK_SEQPACKET socket cannot reach the daemon:
sshd connects with SOCK_STREAM (EPROTOTYPE), the reason the stream socket exists.

The sshd tests skip when sshd, ssh or ssh-keygen is missing, and fail instead when $HAPTICD_REQUIRE_SSHD is set
(.ci/run sets it: scripts/install-deps.sh installs openssh-server there).
"""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import time

import pytest

from daemon_support import HAPTICD, REPOSITORY, connectable, hc, needs_daemon, wait_until
from ssh_support import SshServer, missing_tools

pytestmark = needs_daemon
HAPTICCTL = os.environ.get("HAPTICCTL_BINARY", str(REPOSITORY / "build/release/apps/hapticctl/hapticctl"))


@pytest.fixture(scope="module")
def daemon(tmp_path_factory):
    """hapticd at 1 kHz with its two sockets: hapticd.sock (SOCK_SEQPACKET) and hapticd.sock.stream."""
    directory = tmp_path_factory.mktemp("remote")
    socket_path = str(directory / "hapticd.sock")
    shm = f"/hapticd-remote-pytest-{os.getpid()}"
    log = open(directory / "hapticd.log", "w+")
    process = subprocess.Popen([HAPTICD, "--config", "", "--no-walls", "--rt-priority", "0",
                                "--watchdog-overruns", "1000000", "--watchdog-stall-periods", "1000000",
                                "--serve", "--serve-socket", socket_path, "--serve-shm", shm],
                               stdout=log, stderr=subprocess.STDOUT)
    try:
        assert wait_until(lambda: (connectable(socket_path) and os.path.exists(socket_path + ".stream"))
                          or process.poll() is not None, 20.0)
        assert process.poll() is None, "hapticd ended at start-up"
        yield {"socket": socket_path, "stream": socket_path + ".stream", "shm": shm, "directory": directory}
    finally:
        process.send_signal(signal.SIGTERM)
        code = process.wait(20)
        log.seek(0)
        text = log.read()
        log.close()
        assert code == 0, text


@pytest.fixture(scope="module")
def ssh(daemon):
    missing = missing_tools()
    if missing:
        message = f"{', '.join(missing)} not installed (Debian: openssh-server, openssh-client)"
        if os.environ.get("HAPTICD_REQUIRE_SSHD"):
            pytest.fail(message + "; $HAPTICD_REQUIRE_SSHD is set")
        pytest.skip(message)
    server = SshServer(daemon["directory"] / "ssh")
    try:
        yield server
    finally:
        server.close()


def raw_stream(path):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.connect(path)
    s.settimeout(10.0)
    return s


def read_lines(s, count):
    """`count` newline-terminated messages from a stream socket, parsed."""
    data = b""
    while data.count(b"\n") < count:
        chunk = s.recv(65536)
        if not chunk:
            break
        data += chunk
    return [json.loads(line) for line in data.split(b"\n")[:count]]


HELLO = b'{"type":"hello","protocol":1,"client":"raw"}\n'


# ---- the stream socket itself --------------------------------------------------------------------------
def test_the_stream_socket_answers_one_line_per_message_however_the_bytes_are_cut(daemon):
    s = raw_stream(daemon["stream"])
    try:
        # hello and two requests in one send, then a request cut in three sends, with empty lines and a CRLF.
        s.sendall(HELLO + b'\n{"type":"heartbeat","id":1}\r\n{"type":"status","id":2}\n')
        welcome, first, second = read_lines(s, 3)
        assert welcome["type"] == "welcome" and welcome["max_message_bytes"] == 65536
        assert (first["type"], first["id"], second["type"], second["id"]) == ("ok", 1, "ok", 2)
        for part in (b'{"type":"hea', b'rtbeat","i', b'd":3}\n'):
            s.sendall(part)
            time.sleep(0.05)
        (third,) = read_lines(s, 1)
        assert third["type"] == "ok" and third["id"] == 3 and third["tick"] >= first["tick"]
        # Not JSON: bad_json, the connection stays.
        s.sendall(b'{"type": heartbeat}\n{"type":"heartbeat","id":4}\n')
        bad, fourth = read_lines(s, 2)
        assert bad["type"] == "error" and bad["code"] == "bad_json" and bad["id"] is None
        assert fourth["id"] == 4
    finally:
        s.close()


def test_requests_sent_before_a_half_close_are_answered_then_the_session_ends(daemon):
    """socat at the end of piped input shuts its sending side down (shutdown(SHUT_WR)): the server answers what
    came before and ends the session at the end of the stream."""
    s = raw_stream(daemon["stream"])
    try:
        s.sendall(HELLO + b'{"type":"status","id":1}\n{"type":"heartbeat","id":2}\n')
        s.shutdown(socket.SHUT_WR)
        welcome, status, beat = read_lines(s, 3)
        assert (welcome["type"], status["id"], beat["id"]) == ("welcome", 1, 2) and status["type"] == "ok"
        assert s.recv(100) == b""  # then the server closes
    finally:
        s.close()


def test_a_line_longer_than_64_KiB_is_answered_oversized_and_closed(daemon):
    s = raw_stream(daemon["stream"])
    try:
        s.sendall(HELLO)
        assert read_lines(s, 1)[0]["type"] == "welcome"
        s.sendall(b'{"type":"heartbeat","id":1,"pad":"' + b"x" * 70000)  # no newline: the frame never ends
        (reply,) = read_lines(s, 1)
        assert reply["type"] == "error" and reply["code"] == "oversized", reply
        assert "65536" in reply["message"]
        assert s.recv(100) == b""  # closed
    finally:
        s.close()


def test_a_stream_client_that_does_not_read_is_closed_and_the_daemon_goes_on(daemon):
    """Replies to 20000 requests (~ 1.5 MB) the client never reads: past the socket buffer and the 256 KiB the
    server keeps, the session is closed (slow_consumer); the server never blocked (another client is served)."""
    s = raw_stream(daemon["stream"])
    s.setblocking(False)
    try:
        s.sendall(HELLO)
        sent = 0
        request = b'{"type":"status","id":1}\n' * 100
        deadline = time.monotonic() + 20.0
        closed = False
        while time.monotonic() < deadline and not closed and sent < 8_000_000:
            try:
                sent += s.send(request)
            except BlockingIOError:
                time.sleep(0.01)
            except (BrokenPipeError, ConnectionResetError):
                closed = True
        log = daemon["directory"] / "hapticd.log"
        assert wait_until(lambda: "slow_consumer" in log.read_text(), 10.0), (sent, log.read_text())
        with hc.Client.connect(socket_path=daemon["socket"], client="bystander", timeout_s=5.0) as other:
            assert other.heartbeat() >= 0
    finally:
        s.close()


def test_python_and_cpp_clients_pick_the_transport_from_the_socket(daemon):
    with hc.Client.connect(socket_path=daemon["stream"], client="auto") as c:
        assert c.stream and c.heartbeat() >= 0
    with hc.Client.connect(socket_path=daemon["socket"], client="auto") as c:
        assert not c.stream and c.heartbeat() >= 0
    with pytest.raises(hc.HapticdError) as e:
        hc.Client.connect(socket_path=daemon["stream"], transport="seqpacket")
    assert e.value.code == "transport" and "stream socket" in str(e.value)
    with pytest.raises(ValueError):
        hc.Client.connect(socket_path=daemon["stream"], transport="tcp")
    out = subprocess.run([HAPTICCTL, "--socket", daemon["stream"], "status"], capture_output=True, text=True,
                         timeout=30)
    assert out.returncode == 0 and "device sim" in out.stdout, out


def test_the_state_source_maps_the_local_segment_and_subscribes_over_a_stream_socket(daemon):
    with hc.Client.connect(socket_path=daemon["socket"]) as c, hc.StateSource(c) as state:
        assert state.kind == "shm"
        assert state.read().tick > 0
    with hc.Client.connect(socket_path=daemon["stream"]) as c, hc.StateSource(c, rate_hz=200) as state:
        assert state.kind == "subscribe" and "stream" in state.why
        a = state.read(5.0)
        time.sleep(0.05)
        b = state.read(5.0)
        assert b.tick > a.tick > 0
    with pytest.raises(ValueError):
        hc.StateSource(None, rate_hz=2000)


# ---- through a real sshd ------------------------------------------------------------------------------
def test_a_forward_of_the_seqpacket_socket_cannot_reach_the_daemon(daemon, ssh, tmp_path):
    local = str(tmp_path / "seqpacket-forward.sock")
    ssh.forward(local, daemon["socket"])
    with pytest.raises(hc.HapticdError) as e:
        hc.Client.connect(socket_path=local, timeout_s=5.0)
    assert e.value.code == "transport", e.value
    assert wait_until(lambda: "Protocol wrong type for socket" in ssh.log.read_text(), 10.0), ssh.log.read_text()


def test_a_client_over_ssh_adds_a_plane_the_handle_rests_on_and_gets_refusals(daemon, ssh, tmp_path):
    local = str(tmp_path / "hapticd-forward.sock")
    ssh.forward(local, daemon["stream"])
    with hc.Client.connect(socket_path=local, client="over-ssh", lease_s=2.0) as c, \
            hc.StateSource(c, rate_hz=100) as state:
        assert c.stream and state.kind == "subscribe"
        wall = c.add(hc.plane(normal=(-1, 0, 0), offset=0.005, criterion="CE2"))
        # The plane pushes the handle out to its surface at 1 cm/s (5 mm: 0.5 s); 10 s bounds a loaded machine.
        def resting():
            s = state.read(5.0)
            return wall in s.contacts() and s.position[0] < -0.0049 and s.force[0] < 0.0
        assert wait_until(resting, 10.0)
        s = state.read(5.0)
        assert s.position[0] == pytest.approx(-0.005, abs=5e-4), s  # on the surface (a CE2 wall yields < 0.5 mm)
        with pytest.raises(hc.HapticdError) as e:
            c.add(hc.plane(normal=(-1, 0, 0), offset=0.005, K=1e6, B=50))
        assert e.value.code == "unstable_gains" and "K = 1e+06" in str(e.value)
        assert [o["id"] for o in c.list()] == [wall]
        c.bye()
    # The C++ client over the same forward: hapticctl watch picks the subscription (the segment is local).
    out = subprocess.run([HAPTICCTL, "--socket", local, "watch", "--count", "3", "--rate", "50", "--stall-timeout", "10"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and len(out.stdout.strip().splitlines()) == 3, out


def test_the_stream_socket_option_names_its_path_or_none(tmp_path):
    sock = str(tmp_path / "h.sock")
    same = subprocess.run([HAPTICD, "--config", "", "--no-walls", "--serve", "--serve-socket", sock,
                           "--serve-stream-socket", sock, "--duration", "0.1"], capture_output=True, text=True, timeout=60)
    assert same.returncode != 0 and "serve-stream-socket" in same.stderr, same
    log = open(tmp_path / "none.log", "w+")
    process = subprocess.Popen([HAPTICD, "--config", "", "--no-walls", "--rt-priority", "0", "--serve",
                                "--serve-socket", sock, "--serve-stream-socket", "none",
                                "--serve-shm", f"/hapticd-remote-none-{os.getpid()}"], stdout=log, stderr=subprocess.STDOUT)
    try:
        assert wait_until(lambda: connectable(sock) or process.poll() is not None, 20.0)
        assert process.poll() is None
        assert not os.path.exists(sock + ".stream")
    finally:
        process.send_signal(signal.SIGTERM)
        assert process.wait(20) == 0
        log.close()

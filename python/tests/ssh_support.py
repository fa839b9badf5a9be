# SPDX-License-Identifier: Apache-2.0
"""A real OpenSSH server and a Unix-socket forward for the remote-client tests and measurements
(docs/clients.md, "Remote use"): ``/usr/sbin/sshd -D -e -f CONFIG -p PORT`` on 127.0.0.1, as the current user,
with a host key and a user key made by ssh-keygen in a temporary directory, and ``ssh -N -L LOCAL:REMOTE``
to it. Nothing of the system's sshd is used or started (Debian's openssh-server: scripts/install-deps.sh)."""
from __future__ import annotations

import getpass
import os
import pathlib
import shutil
import socket
import subprocess
import time

SSHD = "/usr/sbin/sshd"


def missing_tools():
    """What is not installed of sshd, ssh and ssh-keygen (an empty list: all are)."""
    return [t for t in (SSHD, shutil.which("ssh") or "ssh", shutil.which("ssh-keygen") or "ssh-keygen")
            if not os.access(t, os.X_OK)]


def _free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait(predicate, timeout_s):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.02)
    return False


class SshServer:
    """sshd on 127.0.0.1:port, accepting only the user key made here; ``forward`` opens ssh -L forwards."""

    def __init__(self, directory: pathlib.Path):
        self.directory = pathlib.Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        d = self.directory
        for name in ("host_key", "user_key"):
            subprocess.run(["ssh-keygen", "-q", "-t", "ed25519", "-N", "", "-f", str(d / name)], check=True)
        shutil.copy(d / "user_key.pub", d / "authorized_keys")
        os.chmod(d / "authorized_keys", 0o600)
        if os.geteuid() == 0:
            # sshd as root separates privileges into /run/sshd (Debian's sshd refuses to start without it).
            os.makedirs("/run/sshd", mode=0o755, exist_ok=True)
        self.user = getpass.getuser()
        self.processes = []
        self.log = d / "sshd.log"
        for _ in range(5):  # a free port may be taken between the probe and sshd's bind: try another
            self.port = _free_port()
            (d / "sshd_config").write_text(
                f"ListenAddress 127.0.0.1\nHostKey {d / 'host_key'}\nAuthorizedKeysFile {d / 'authorized_keys'}\n"
                "PidFile none\nPasswordAuthentication no\nKbdInteractiveAuthentication no\nUsePAM no\n"
                "StrictModes no\nAllowStreamLocalForwarding yes\n"
                # CI runs as root: this sshd (and only this one) accepts root with a key.
                "PermitRootLogin prohibit-password\n")
            log = open(self.log, "w")
            sshd = subprocess.Popen([SSHD, "-D", "-e", "-f", str(d / "sshd_config"), "-p", str(self.port)],
                                    stdout=log, stderr=subprocess.STDOUT)
            log.close()
            if _wait(lambda: "Server listening" in self.log.read_text() or sshd.poll() is not None, 20.0) \
                    and sshd.poll() is None:
                self.processes.append(sshd)
                return
            if sshd.poll() is None:
                sshd.terminate()
                sshd.wait(10)
        raise RuntimeError(f"sshd did not start; its log: {self.log.read_text()}")

    def forward(self, local: str, remote: str) -> subprocess.Popen:
        """ssh -N -L local:remote to this server; returns once ``local`` exists (the forward listens)."""
        d = self.directory
        log = open(d / f"ssh-{len(self.processes)}.log", "w")
        ssh = subprocess.Popen(
            ["ssh", "-N", "-F", "/dev/null", "-i", str(d / "user_key"), "-p", str(self.port),
             "-o", "BatchMode=yes", "-o", "StrictHostKeyChecking=no", "-o", "UserKnownHostsFile=/dev/null",
             "-o", "ExitOnForwardFailure=yes", "-o", "StreamLocalBindUnlink=yes", "-o", "LogLevel=ERROR",
             "-L", f"{local}:{remote}", f"{self.user}@127.0.0.1"], stdout=log, stderr=subprocess.STDOUT)
        log.close()
        self.processes.append(ssh)
        if not _wait(lambda: os.path.exists(local) or ssh.poll() is not None, 20.0) or ssh.poll() is not None:
            raise RuntimeError(f"ssh -L {local}:{remote} did not start: {pathlib.Path(log.name).read_text()}"
                               f"; sshd: {self.log.read_text()}")
        return ssh

    def close(self):
        for p in reversed(self.processes):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
        self.processes.clear()

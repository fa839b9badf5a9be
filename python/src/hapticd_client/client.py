# SPDX-License-Identifier: Apache-2.0
"""A session with ``hapticd --serve`` (docs/protocol.md): a Unix-domain SOCK_SEQPACKET socket carrying one
UTF-8 JSON object per message (at most 65536 bytes), the versioned ``hello``/``welcome`` handshake, requests
with ids and their replies, batches, leases and subscriptions. Standard library only.

    with Client.connect(client="demo", lease_s=0.5) as c:
        wall = c.add(plane(normal=(0, 0, 1), offset=0.0, criterion="CE2"))
        c.modify(wall, plane(normal=(0, 0, 1), offset=0.002, criterion="CE2"))
        with StateReader(c.welcome["state_shm"]) as state:
            print(state.read().position)

Objects live as long as their session: closing the connection (or a lost lease) ramps them out.
Not thread-safe: one Client per thread.
"""

from __future__ import annotations

import json
import os
import select
import socket
import time
from typing import Dict, Iterable, List, Optional, Union

from .device import DeviceInfo
from .errors import HapticdError
from .objects import Batch

PROTOCOL_VERSION = 1
MAX_MESSAGE_BYTES = 65536


def default_socket_path() -> str:
    """``$HAPTICD_SOCKET``, else ``$RUNTIME_DIRECTORY/hapticd.sock``, ``$XDG_RUNTIME_DIR/hapticd.sock``,
    ``/run/hapticd/hapticd.sock`` (the order of the daemon and the C++ client)."""
    if os.environ.get("HAPTICD_SOCKET"):
        return os.environ["HAPTICD_SOCKET"]
    for var in ("RUNTIME_DIRECTORY", "XDG_RUNTIME_DIR"):
        if os.environ.get(var):
            return os.path.join(os.environ[var], "hapticd.sock")
    return "/run/hapticd/hapticd.sock"


class Client:
    """One session. Use ``Client.connect(...)``; the ``welcome`` dict holds the server's answer (device
    name, axes, period, masses, delay, max force, capacity, ``state_shm``, ``ramp_s``, ``lease_s``), and
    ``device`` its device as a ``DeviceInfo`` (with ``mass_matrix`` and ``max_stiffness``)."""

    def __init__(self, sock: socket.socket, timeout_s: float) -> None:
        self._sock = sock
        self._timeout_s = timeout_s
        self._next_id = 1
        self._pending_states: List[Dict] = []
        self.welcome: Dict = {}
        self.device: Optional[DeviceInfo] = None
        self._last_sent = time.monotonic()

    # -- connection ------------------------------------------------------------------------------------
    @classmethod
    def connect(cls, socket_path: Optional[str] = None, client: str = "hapticd_client.py", lease_s: float = 0.0,
                timeout_s: float = 5.0, protocol: int = PROTOCOL_VERSION) -> "Client":
        """Connects and performs the handshake; raises HapticdError ("transport", "protocol_version", ...)."""
        path = socket_path or default_socket_path()
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET | socket.SOCK_CLOEXEC)
        try:
            sock.connect(path)
        except OSError as e:
            sock.close()
            raise HapticdError("transport", f"Client.connect: connect to {path!r}: {e.strerror} "
                                            "(is hapticd running with --serve? may this user open the socket?)") from e
        c = cls(sock, timeout_s)
        try:
            c.send_raw(json.dumps({"type": "hello", "protocol": protocol, "client": client, "lease_s": lease_s}))
            raw = c.receive_raw(timeout_s)
            if raw is None:
                raise HapticdError("transport", f"Client.connect: no answer to hello within {timeout_s} s")
            answer = c._decode("Client.connect", raw)
            if answer.get("type") != "welcome":
                raise HapticdError.from_reply("Client.connect", answer)
            device = DeviceInfo.from_welcome(answer)
        except BaseException:
            sock.close()
            raise
        c.welcome = answer
        c.device = device
        return c

    def close(self) -> None:
        """Closes the socket: the server ramps this session's objects out."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def fileno(self) -> int:
        return self._sock.fileno()

    # -- raw messages ----------------------------------------------------------------------------------
    def send_raw(self, message: Union[str, bytes]) -> None:
        if self._sock is None:
            raise HapticdError("transport", "Client.send_raw: not connected")
        data = message.encode("utf-8") if isinstance(message, str) else message
        try:
            self._sock.send(data)
        except OSError as e:
            raise HapticdError("transport", f"Client.send_raw: send: {e.strerror}") from e
        self._last_sent = time.monotonic()

    def receive_raw(self, timeout_s: float) -> Optional[bytes]:
        """One message, or None after ``timeout_s``; HapticdError("transport") when the server closed."""
        if self._sock is None:
            raise HapticdError("transport", "Client.receive_raw: not connected")
        ready, _, _ = select.select([self._sock], [], [], max(0.0, timeout_s))
        if not ready:
            return None
        try:
            data = self._sock.recv(MAX_MESSAGE_BYTES + 1)
        except OSError as e:
            raise HapticdError("transport", f"Client.receive_raw: recv: {e.strerror}") from e
        if not data:
            raise HapticdError("transport", "Client.receive_raw: the server closed the connection")
        return data

    @staticmethod
    def _decode(function: str, raw: bytes) -> Dict:
        try:
            value = json.loads(raw.decode("utf-8"))
        except (UnicodeDecodeError, ValueError) as e:
            raise HapticdError("bad_json", f"{function}: the server's message is not JSON: {e}") from e
        if not isinstance(value, dict):
            raise HapticdError("bad_json", f"{function}: the server's message is not a JSON object")
        return value

    # -- requests --------------------------------------------------------------------------------------
    def request(self, type_: str, **fields) -> Dict:
        """Sends one request and returns its ``ok`` reply; raises HapticdError for an ``error`` reply."""
        request_id = self._next_id
        self._next_id += 1
        self.send_raw(json.dumps({"type": type_, "id": request_id, **fields}))
        function = f"Client.{type_}"
        deadline = time.monotonic() + self._timeout_s
        while True:
            raw = self.receive_raw(deadline - time.monotonic())
            if raw is None:
                raise HapticdError("transport", f"{function}: no reply within {self._timeout_s} s")
            reply = self._decode(function, raw)
            kind = reply.get("type")
            if kind == "state":
                self._pending_states.append(reply)
                continue
            if kind == "expired":
                raise HapticdError.from_reply(function, reply)
            if reply.get("id") != request_id:
                if kind == "error":  # about an earlier message without an id the server could echo
                    raise HapticdError.from_reply(function, reply)
                continue
            if kind == "error":
                raise HapticdError.from_reply(function, reply)
            return reply

    def heartbeat(self) -> int:
        """Renews the lease; returns the loop's last published tick."""
        return int(self.request("heartbeat")["tick"])

    def keep_alive(self) -> None:
        """Sends a heartbeat if the lease needs one (nothing sent for a third of ``lease_s``)."""
        lease = float(self.welcome.get("lease_s", 0.0) or 0.0)
        if lease > 0.0 and time.monotonic() - self._last_sent > lease / 3.0:
            self.heartbeat()

    def commit(self, batch: Union[Batch, Iterable[Dict]]) -> Dict:
        """Commits the operations all-or-nothing at one tick boundary. Returns the reply: ``commit_seq``
        (seen as ``last_commit_seq`` in the state once applied) and ``object_ids`` (one per add)."""
        ops = batch.ops if isinstance(batch, Batch) else list(batch)
        return self.request("commit", ops=ops)

    def add(self, obj: Dict) -> int:
        """Adds one object (a batch of one); returns its id."""
        return int(self.commit(Batch().add(obj))["object_ids"][0])

    def modify(self, object_id: int, obj: Dict) -> int:
        """Replaces one of this session's objects; returns the commit_seq."""
        return int(self.commit(Batch().modify(object_id, obj))["commit_seq"])

    def remove(self, object_id: int) -> int:
        return int(self.commit(Batch().remove(object_id))["commit_seq"])

    def clear(self) -> int:
        return int(self.commit(Batch().clear())["commit_seq"])

    def list(self) -> List[Dict]:
        """Every object of the scene: ``id``, ``owner`` (session; 0 = the daemon's config walls), ``kind``,
        the description, and the gains used ``K``, ``B``."""
        return list(self.request("list")["objects"])

    def status(self) -> Dict:
        """``tick``, ``sessions``, ``objects``, ``overruns``, ``fault``, ``commits_applied``."""
        return self.request("status")

    def subscribe(self, rate_hz: float) -> None:
        """State messages at ``rate_hz`` (0.1 .. 1000); read them with ``next_state``."""
        self.request("subscribe", rate_hz=rate_hz)

    def unsubscribe(self) -> None:
        self.request("unsubscribe")
        self._pending_states.clear()

    def next_state(self, timeout_s: float) -> Optional[Dict]:
        """The next subscribed ``state`` message (a dict), or None after ``timeout_s``."""
        if self._pending_states:
            return self._pending_states.pop(0)
        deadline = time.monotonic() + timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            raw = self.receive_raw(left)
            if raw is None:
                return None
            message = self._decode("Client.next_state", raw)
            if message.get("type") == "state":
                return message
            if message.get("type") == "expired":
                raise HapticdError.from_reply("Client.next_state", message)

    def bye(self) -> None:
        """Orderly end of the session (its objects ramp out)."""
        try:
            self.request("bye")
        except HapticdError as e:
            if e.code != "transport":
                raise
        self.close()

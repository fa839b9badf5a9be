# SPDX-License-Identifier: Apache-2.0
"""The device state from wherever this client can read it (docs/clients.md, "Remote use"): the shared memory
when the daemon runs on this machine, else ``subscribe`` over the session's socket.

The shared memory is local. Over the stream transport (the ``.stream`` socket or an ``ssh -L`` forward of it)
the daemon may run on another machine, and a segment of the same name here would belong to another daemon, so
``auto`` subscribes there; over the SOCK_SEQPACKET socket it maps the segment and subscribes only when the
segment cannot be opened (another mount namespace, no permission).

    with Client.connect(path) as c, StateSource(c, rate_hz=200) as state:
        print(state.kind, state.read().position)
"""

from __future__ import annotations

from typing import Dict, Optional, Tuple

from .client import Client
from .errors import HapticdError
from .state import FAULT_NAMES, MeshProxy, StateReader, StateSample

MODES = ("auto", "shm", "subscribe")
_FAULT_NUMBERS = {name: int(fault) for fault, name in FAULT_NAMES.items()}


def _vec3(v) -> Tuple[float, float, float]:
    return tuple(float(x) for x in v[:3]) + (0.0,) * (3 - len(v[:3])) if isinstance(v, list) else (0.0, 0.0, 0.0)


def sample_from_state_message(message: Dict) -> StateSample:
    """A ``state`` message (docs/protocol.md, section 6) as a StateSample: ``slot_object_id``/``slot_ramp`` are
    not in the message (zeros), the ids in contact are (``contact_ids``), and the mesh proxies (``mesh_proxies``,
    ``mesh_slot_mask``) when the daemon sends them; ``stale`` is False (the daemon sent it) and ``heartbeat_age_s`` 0."""
    def vec(key):
        v = message.get(key)
        return tuple(float(x) for x in v[:3]) + (0.0,) * (3 - len(v[:3])) if isinstance(v, list) else (0.0, 0.0, 0.0)
    fault = message.get("fault", "none")
    sample = StateSample(tick=int(message.get("tick", 0)), time_s=float(message.get("time_s", 0.0)),
                         position=vec("position"), velocity=vec("velocity"), force=vec("force"),
                         contact_mask=int(message.get("contact_mask", 0)),
                         config_contact_mask=int(message.get("config_contact_mask", 0)),
                         overruns=int(message.get("overruns", 0)), wake_latency_ns=int(message.get("wake_latency_ns", 0)),
                         last_commit_seq=int(message.get("last_commit_seq", 0)),
                         fault=_FAULT_NUMBERS.get(fault, -1) if isinstance(fault, str) else int(fault),
                         objects=int(message.get("objects", 0)))
    sample.mesh_slot_mask = int(message.get("mesh_slot_mask", 0))
    for e in message.get("mesh_proxies") or []:
        normals = tuple(tuple(float(x) for x in n[:3]) for n in e.get("normals", []) if isinstance(n, list))
        triangle = e.get("triangle")
        sample.mesh_proxies.append(MeshProxy(
            object_id=int(e.get("object_id", 0)), slot=int(e.get("slot", 0)), proxy=_vec3(e.get("proxy")),
            constraints=int(e.get("constraints", len(normals))), normals=normals,
            triangle=int(triangle) if isinstance(triangle, int) else None, sliding=bool(e.get("sliding", False)),
            converged=bool(e.get("converged", True))))
    contact = message.get("contact")
    if isinstance(contact, list):
        sample.contact_ids = [int(i) for i in contact if isinstance(i, int)]
    return sample


class StateSource:
    """Reads the device state of ``client``'s daemon. ``mode``: ``shm`` (the shared memory, HapticdError
    "transport" when it cannot be opened), ``subscribe`` (state messages at ``rate_hz``, 0.1 .. 1000), ``auto``
    (module docstring). ``kind`` says which was chosen; ``read()`` returns the latest tick either way."""

    def __init__(self, client: Client, rate_hz: float = 1000.0, mode: str = "auto") -> None:
        if mode not in MODES:
            raise ValueError(f"StateSource: mode = {mode!r} is invalid; accepted: {', '.join(MODES)}")
        if not 0.1 <= rate_hz <= 1000.0:
            raise ValueError(f"StateSource: rate_hz = {rate_hz!r} is invalid; accepted range: 0.1 .. 1000")
        self._client = client
        self._reader: Optional[StateReader] = None
        self.why = ""
        if mode == "shm" or (mode == "auto" and not client.stream):
            try:
                self._reader = StateReader(client.welcome.get("state_shm", "/hapticd-state"))
            except HapticdError as e:
                if mode == "shm":
                    raise
                self.why = f"the shared memory cannot be opened here ({e})"
        elif mode == "auto":
            self.why = "the stream transport (the daemon may be on another machine)"
        if self._reader is None:
            client.subscribe(rate_hz)
        self.kind = "shm" if self._reader is not None else "subscribe"
        self.rate_hz = rate_hz

    def read(self, timeout_s: float = 1.0) -> StateSample:
        """The latest tick: from the shared memory, or the newest state message arrived (waiting up to
        ``timeout_s`` for one; HapticdError "transport" when none comes)."""
        if self._reader is not None:
            return self._reader.read()
        message = self._client.latest_state(timeout_s)
        if message is None:
            raise HapticdError("transport", f"StateSource.read: no state message within {timeout_s} s")
        return sample_from_state_message(message)

    def close(self) -> None:
        if self._reader is not None:
            self._reader.close()
            self._reader = None
        elif self.kind == "subscribe" and self._client._sock is not None:
            self._client.unsubscribe()
        self.kind = "closed"

    def __enter__(self) -> "StateSource":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

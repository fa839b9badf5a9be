# SPDX-License-Identifier: Apache-2.0
"""A session with ``hapticd --serve`` (docs/protocol.md): a Unix-domain SOCK_SEQPACKET socket carrying one
UTF-8 JSON object per message (at most 65536 bytes), or the daemon's SOCK_STREAM socket (``<socket>.stream``,
the one an ``ssh -L`` Unix-socket forward reaches) carrying one JSON object per line; the versioned
``hello``/``welcome`` handshake, requests with ids and their replies, batches, leases and subscriptions.
Standard library only.

    with Client.connect(client="demo", lease_s=0.5) as c:
        wall = c.add(plane(normal=(0, 0, 1), offset=0.0, criterion="CE2"))
        c.modify(wall, plane(normal=(0, 0, 1), offset=0.002, criterion="CE2"))
        with StateReader(c.welcome["state_shm"]) as state:
            print(state.read().position)

Objects live as long as their session: closing the connection (or a lost lease) ramps them out.
Not thread-safe: one Client per thread.
"""

from __future__ import annotations

import collections
import errno
import json
import os
import select
import socket
import time
from dataclasses import dataclass, field
from typing import Deque, Dict, Iterable, List, Optional, Tuple, Union

from .device import DeviceInfo
from .errors import HapticdError
from .instance import check_instance_name, instance_socket_path
from .objects import Batch

PROTOCOL_VERSION = 1
MAX_MESSAGE_BYTES = 65536
EVENT_QUEUE_CAPACITY = 256
CONTACT_QUEUE_CAPACITY = 4096


@dataclass(frozen=True)
class Event:
    """An unsolicited message of the server (docs/protocol.md, section 3, "Events"): ``{"type": "event",
    "code": ...}`` without an id. ``code`` says what happened (``objects_removed``: another session left and
    these objects of this session had to ramp out with its own); ``object_ids`` the objects it concerns
    (empty when it names none); ``message`` the server's explanation; ``fields`` the whole message, for the
    fields a later event carries that this class does not name."""
    code: str
    message: str = ""
    object_ids: Tuple[int, ...] = ()
    fields: Dict = field(default_factory=dict)

    @classmethod
    def from_message(cls, message: Dict) -> "Event":
        ids = message.get("object_ids")
        ids = tuple(int(i) for i in ids if isinstance(i, int) and not isinstance(i, bool)) if isinstance(ids, list) else ()
        return cls(code=str(message.get("code", "")), message=str(message.get("message", "")), object_ids=ids,
                   fields=dict(message))


@dataclass(frozen=True)
class ContactEvent:
    """One begin or end of contact as the loop rendered it (a ``contact`` message, docs/protocol.md,
    section 6, "Contact events"): ``event`` "begin" or "end"; ``object_id`` a client object's id or a config
    wall's (1 .. n); ``tick`` the loop's tick whose published state first (begin) or no longer (end) has it in
    contact, ``time_s`` that tick's state time; ``position`` the handle (m) and ``force`` the force commanded
    to the device (N) at that tick; ``dropped`` the events of this subscription lost before this one."""
    event: str
    object_id: int
    tick: int
    time_s: float
    position: Tuple[float, float, float]
    force: Tuple[float, float, float]
    dropped: int = 0

    @property
    def begin(self) -> bool:
        return self.event == "begin"

    @classmethod
    def from_message(cls, message: Dict) -> "ContactEvent":
        def vec(key):
            v = message.get(key)
            return tuple(float(x) for x in v[:3]) if isinstance(v, list) and len(v) == 3 else (0.0, 0.0, 0.0)
        return cls(event=str(message.get("event", "")), object_id=int(message.get("object_id", 0)),
                   tick=int(message.get("tick", 0)), time_s=float(message.get("time_s", 0.0)), position=vec("position"),
                   force=vec("force"), dropped=int(message.get("dropped", 0)))


def default_socket_path(instance: Optional[str] = None) -> str:
    """The socket of ``instance`` (hapticd --instance NAME: ``hapticd-NAME.sock``) when given; else
    ``$HAPTICD_SOCKET``, else the socket of the instance ``$HAPTICD_INSTANCE`` names; in
    ``$RUNTIME_DIRECTORY``, ``$XDG_RUNTIME_DIR`` or ``/run/hapticd`` (the order of the daemon and the C++ client).
    An invalid name raises ValueError naming it and the accepted form."""
    if instance:
        return instance_socket_path(check_instance_name(instance))
    if os.environ.get("HAPTICD_SOCKET"):
        return os.environ["HAPTICD_SOCKET"]
    if os.environ.get("HAPTICD_INSTANCE"):
        return instance_socket_path(check_instance_name(os.environ["HAPTICD_INSTANCE"], "$HAPTICD_INSTANCE"))
    return instance_socket_path(None)


TRANSPORTS = ("auto", "seqpacket", "stream")


def _open_socket(path: str, transport: str) -> Tuple[socket.socket, bool]:
    """A connected socket and whether it is the stream transport. ``auto``: SOCK_SEQPACKET, and SOCK_STREAM
    when the socket at ``path`` is a stream socket (connect fails with EPROTOTYPE: the daemon's ``.stream``
    socket, or the local end of an ``ssh -L`` forward)."""
    if transport not in TRANSPORTS:
        raise ValueError(f"Client.connect: transport = {transport!r} is invalid; accepted: {', '.join(TRANSPORTS)}")
    kinds = [socket.SOCK_STREAM] if transport == "stream" else [socket.SOCK_SEQPACKET]
    if transport == "auto":
        kinds.append(socket.SOCK_STREAM)
    for kind in kinds:
        sock = socket.socket(socket.AF_UNIX, kind | socket.SOCK_CLOEXEC)
        try:
            sock.connect(path)
            return sock, kind == socket.SOCK_STREAM
        except OSError as e:
            sock.close()
            if e.errno == errno.EPROTOTYPE and kind != kinds[-1]:
                continue
            hint = (" (a stream socket: connect with transport 'stream' or 'auto')" if e.errno == errno.EPROTOTYPE
                    else " (is hapticd running with --serve? may this user open the socket?)")
            raise HapticdError("transport", f"Client.connect: connect to {path!r}: {e.strerror}{hint}") from e
    raise AssertionError("unreachable")  # pragma: no cover


BUSY_RETRY_DEFAULT = (8, 1e-3, 0.05)  # tries, initial delay (s), largest delay (s): as the C++ client's BusyRetry


def _check_busy_retry(retry) -> None:
    tries, initial, largest = retry
    if not isinstance(tries, int) or not 1 <= tries <= 1000:
        raise ValueError(f"busy_retry: tries = {tries!r} is invalid; accepted range: 1 .. 1000")
    if not 0.0 <= initial <= 10.0:
        raise ValueError(f"busy_retry: initial_delay_s = {initial!r} is invalid; accepted range: 0 .. 10 s")
    if not initial <= largest <= 10.0:
        raise ValueError(f"busy_retry: max_delay_s = {largest!r} is invalid; accepted range: initial_delay_s .. 10 s")


class Client:
    """One session. Use ``Client.connect(...)``; the ``welcome`` dict holds the server's answer (device
    name, axes, period, masses, delay, max force, capacity, ``state_shm``, ``ramp_s``, ``lease_s``), and
    ``device`` its device as a ``DeviceInfo`` (with ``mass_matrix`` and ``max_stiffness``)."""

    def __init__(self, sock: socket.socket, timeout_s: float, event_queue_capacity: int = EVENT_QUEUE_CAPACITY) -> None:
        self._busy_retry = BUSY_RETRY_DEFAULT
        self._sock = sock
        self._timeout_s = timeout_s
        self._next_id = 1
        self._pending_states: List[Dict] = []
        self._events: Deque[Event] = collections.deque()
        self._event_capacity = max(0, int(event_queue_capacity))
        self.events_dropped = 0  # events beyond the queue's capacity (then list() tells the scene as it is)
        self._contacts: Deque[ContactEvent] = collections.deque()
        self._contact_capacity = CONTACT_QUEUE_CAPACITY
        self.contacts_dropped = 0  # contact events beyond the queue's capacity (the server's own: ContactEvent.dropped)
        self.welcome: Dict = {}
        self.device: Optional[DeviceInfo] = None
        self._last_sent = time.monotonic()
        self.stream = False  # the stream transport: one JSON object per line (docs/protocol.md, section 1)
        self._rx = bytearray()  # stream: received bytes not yet returned as messages

    # -- connection ------------------------------------------------------------------------------------
    @classmethod
    def connect(cls, socket_path: Optional[str] = None, client: str = "hapticd_client.py", lease_s: float = 0.0,
                timeout_s: float = 5.0, protocol: int = PROTOCOL_VERSION,
                event_queue_capacity: int = EVENT_QUEUE_CAPACITY,
                busy_retry: Tuple[int, float, float] = BUSY_RETRY_DEFAULT,
                contact_queue_capacity: int = CONTACT_QUEUE_CAPACITY, instance: Optional[str] = None,
                transport: str = "auto") -> "Client":
        """Connects and performs the handshake; raises HapticdError ("transport", "protocol_version", ...).
        ``instance``: the daemon instance (hapticd --instance NAME) whose socket to use when ``socket_path`` is
        not given (both: ValueError).
        ``event_queue_capacity``: events kept until ``poll_event``/``next_event`` takes them (more are
        dropped and counted in ``events_dropped``). ``busy_retry``: how ``commit`` retries ``busy``
        (``set_busy_retry``). ``contact_queue_capacity``: contact events kept until ``poll_contact``/
        ``next_contact`` takes them (more are dropped and counted in ``contacts_dropped``). ``transport``:
        ``seqpacket`` (the control socket), ``stream`` (the ``.stream`` socket or a forward of it, e.g.
        ``ssh -L``), ``auto`` (the one the socket at the path is)."""
        _check_busy_retry(busy_retry)
        if socket_path and instance:
            raise ValueError(f"socket_path = {socket_path!r} and instance = {instance!r} both given; "
                             "accepted: one of them")
        path = socket_path or default_socket_path(instance)
        sock, stream = _open_socket(path, transport)
        c = cls(sock, timeout_s, event_queue_capacity)
        c.stream = stream
        c._busy_retry = tuple(busy_retry)
        c._contact_capacity = max(0, int(contact_queue_capacity))
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
            if self.stream:
                self._sock.sendall(data + b"\n")
            else:
                self._sock.send(data)
        except OSError as e:
            raise HapticdError("transport", f"Client.send_raw: send: {e.strerror}") from e
        self._last_sent = time.monotonic()

    def receive_raw(self, timeout_s: float) -> Optional[bytes]:
        """One message, or None after ``timeout_s``; HapticdError("transport") when the server closed."""
        if self._sock is None:
            raise HapticdError("transport", "Client.receive_raw: not connected")
        if self.stream:
            return self._receive_line(timeout_s)
        ready, _, _ = select.select([self._sock], [], [], max(0.0, timeout_s))
        if not ready:
            return None
        return self._recv()

    def _recv(self) -> bytes:
        """What one recv() gives (one message on SOCK_SEQPACKET); HapticdError("transport") on an error or hang-up."""
        try:
            data = self._sock.recv(MAX_MESSAGE_BYTES + 1)
        except OSError as e:
            raise HapticdError("transport", f"Client.receive_raw: recv: {e.strerror}") from e
        if not data:
            raise HapticdError("transport", "Client.receive_raw: the server closed the connection")
        return data

    def _receive_line(self, timeout_s: float) -> Optional[bytes]:
        """The stream transport: the next line (without its newline), or None after ``timeout_s``."""
        deadline = time.monotonic() + max(0.0, timeout_s)
        while True:
            end = self._rx.find(b"\n")
            if end >= 0:
                line = bytes(self._rx[:end])
                del self._rx[:end + 1]
                if line.strip():
                    return line
                continue
            if len(self._rx) > MAX_MESSAGE_BYTES + 1:
                raise HapticdError("transport", f"Client.receive_raw: a line of more than {MAX_MESSAGE_BYTES} bytes "
                                                "from the server")
            ready, _, _ = select.select([self._sock], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                return None
            self._rx += self._recv()

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
            if kind in ("state", "event", "expired", "contact"):
                self._keep_unsolicited(function, reply)
                continue
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
        ops = [self._uploaded(op) for op in (batch.ops if isinstance(batch, Batch) else list(batch))]
        tries, delay, max_delay = self._busy_retry
        start = time.monotonic()
        attempt = 1
        while True:
            try:
                return self.request("commit", ops=ops)
            except HapticdError as e:
                if e.code != "busy":
                    raise
                if attempt >= tries:
                    raise HapticdError("busy", f"{e} (busy after {attempt} tries over {time.monotonic() - start:.3f} s; "
                                               "busy_retry)", e.op_index, None, e.reply) from e
            time.sleep(delay)
            delay = min(2.0 * delay, max_delay)
            attempt += 1

    def _uploaded(self, op: Dict) -> Dict:
        """An operation whose ``mesh`` object carries its geometry (``hapticd_client.mesh(vertices, triangles)``):
        the mesh uploaded first (``upload_mesh``) and the object naming it."""
        obj = op.get("object") if isinstance(op, dict) else None
        if not isinstance(obj, dict) or "_upload" not in obj:
            return op
        vertices, triangles, mode = obj["_upload"]
        sent = {k: v for k, v in obj.items() if k != "_upload"}
        sent["mesh"] = self.upload_mesh(vertices, triangles, solid=(mode == "solid"))
        return {**op, "object": sent}

    def upload_mesh(self, vertices, triangles, solid: bool = True, build_timeout_s: float = 10.0) -> int:
        """Uploads a triangle mesh (docs/protocol.md, section 4a: ``mesh_begin``, chunks of at most 500 vertices or
        1000 triangles, ``mesh_end``) and waits up to ``build_timeout_s`` until the daemon has built it. Vertices
        (n x 3, m) and triangles (m x 3 indices) as numpy arrays or sequences. Returns the mesh id (for
        ``mesh(mesh_id=...)``); the daemon's refusals raise HapticdError naming the vertex, triangle or limit."""
        from .meshes import _rows
        v = _rows("vertices", vertices, float)
        t = _rows("triangles", triangles, int)
        mesh_id = int(self.request("mesh_begin", vertices=len(v), triangles=len(t),
                                   mode="solid" if solid else "surface")["mesh"])
        for at in range(0, len(v), 500):
            self.request("mesh_chunk", mesh=mesh_id, first=at, vertices=[c for row in v[at:at + 500] for c in row])
        for at in range(0, len(t), 1000):
            self.request("mesh_chunk", mesh=mesh_id, first=at, triangles=[i for row in t[at:at + 1000] for i in row])
        self.request("mesh_end", mesh=mesh_id)
        deadline = time.monotonic() + build_timeout_s
        while True:
            status = self.request("mesh_status", mesh=mesh_id)
            if status.get("state") == "ready":
                return mesh_id
            if status.get("state") == "failed":
                raise HapticdError("bad_message", f"Client.upload_mesh: mesh {mesh_id} failed: {status.get('message')}")
            if time.monotonic() > deadline:
                raise HapticdError("busy", f"Client.upload_mesh: mesh {mesh_id} still {status.get('state')} after "
                                           f"{build_timeout_s} s")
            time.sleep(0.005)

    def delete_mesh(self, mesh_id: int) -> None:
        """Drops an uploaded mesh (freed once no object renders it)."""
        self.request("mesh_delete", mesh=int(mesh_id))

    def set_busy_retry(self, tries: int = 8, initial_delay_s: float = 1e-3, max_delay_s: float = 0.05) -> None:
        """How ``commit`` retries a ``busy`` reply (the hand-over queue to the loop is full): up to ``tries``
        attempts in all (1: no retry), sleeping ``initial_delay_s`` before the second and doubling up to
        ``max_delay_s`` (defaults: 1, 2, 4, 8, 16, 32, 50 ms, 113 ms of waiting at most); after the last,
        HapticdError("busy") says how many tries and how long. Raises ValueError naming a bad value."""
        retry = (tries, initial_delay_s, max_delay_s)
        _check_busy_retry(retry)
        self._busy_retry = retry

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
        """``tick``, ``sessions``, ``objects``, ``overruns``, ``fault``, ``commits_applied``, ``meshes``,
        ``mesh_bytes``, ``commit_check`` (None, or the ``session`` whose commit's scenes are being checked and
        ``running_s``), ``commits_waiting`` (other sessions' commits waiting for that check) and
        ``departures_waiting`` (sessions gone whose objects render until their departure is planned)."""
        return self.request("status")

    def subscribe(self, rate_hz: float) -> None:
        """State messages at ``rate_hz`` (0.1 .. 1000); read them with ``next_state``."""
        self.request("subscribe", rate_hz=rate_hz)

    def unsubscribe(self) -> None:
        self.request("unsubscribe")
        self._pending_states.clear()

    def next_state(self, timeout_s: float) -> Optional[Dict]:
        """The next subscribed ``state`` message (a dict), or None after ``timeout_s``."""
        return self._read_until("Client.next_state", timeout_s,
                                lambda: self._pending_states.pop(0) if self._pending_states else None)

    def latest_state(self, timeout_s: float) -> Optional[Dict]:
        """The newest subscribed ``state`` message that has arrived (older ones queued are discarded); with none
        arrived, the next one within ``timeout_s``, else None."""
        self._read_until("Client.latest_state", 0.0, lambda: None)
        if self._pending_states:
            newest = self._pending_states[-1]
            self._pending_states.clear()
            return newest
        return self.next_state(timeout_s)

    def subscribe_contacts(self, object_ids: Optional[Iterable[int]] = None) -> List[int]:
        """Contact events (docs/protocol.md, section 6, "Contact events"): of every object, or only of
        ``object_ids`` (1 .. 64 ids). Returns the objects in contact when the subscription took effect (the
        events that follow continue from there); subscribing again replaces the filter and starts afresh
        (contact events queued here are discarded). Read them with ``poll_contact``/``next_contact``; every
        call that reads the socket queues them, in order."""
        fields = {} if object_ids is None else {"object_ids": [int(i) for i in object_ids]}
        reply = self.request("subscribe_contacts", **fields)
        self._contacts.clear()
        return [int(i) for i in reply.get("contacts", [])]

    def unsubscribe_contacts(self) -> None:
        self.request("unsubscribe_contacts")
        self._contacts.clear()

    @property
    def contacts_queued(self) -> int:
        return len(self._contacts)

    def poll_contact(self) -> Optional[ContactEvent]:
        """The oldest queued contact event; with none queued, first reads what has arrived without waiting."""
        return self._read_until("Client.poll_contact", 0.0, self._take_contact)

    def next_contact(self, timeout_s: float) -> Optional[ContactEvent]:
        """The next contact event, waiting up to ``timeout_s``; None when none came."""
        return self._read_until("Client.next_contact", timeout_s, self._take_contact)

    def _take_contact(self) -> Optional[ContactEvent]:
        return self._contacts.popleft() if self._contacts else None

    def _read_until(self, function: str, timeout_s: float, take):
        """Reads messages (keeping each, _keep_unsolicited) until ``take()`` gives one or ``timeout_s`` has
        passed; with ``timeout_s`` 0, only what has arrived, without waiting."""
        deadline = time.monotonic() + timeout_s
        while True:
            value = take()
            if value is not None:
                return value
            raw = self.receive_raw(max(0.0, deadline - time.monotonic()))
            if raw is None:
                return None
            self._keep_unsolicited(function, self._decode(function, raw))

    # -- events ----------------------------------------------------------------------------------------
    def _keep_unsolicited(self, function: str, message: Dict) -> None:
        """A message that is not the reply awaited: a state (kept for next_state), an event or a contact
        event (queued), ``expired`` (raised); anything else (a late reply) is ignored."""
        kind = message.get("type")
        if kind == "state":
            self._pending_states.append(message)
        elif kind == "contact":
            if len(self._contacts) >= self._contact_capacity:
                self.contacts_dropped += 1
            else:
                self._contacts.append(ContactEvent.from_message(message))
        elif kind == "expired":
            raise HapticdError.from_reply(function, message)
        elif kind == "event":
            if len(self._events) >= self._event_capacity:
                self.events_dropped += 1
            else:
                self._events.append(Event.from_message(message))

    @property
    def events_queued(self) -> int:
        return len(self._events)

    def poll_event(self) -> Optional[Event]:
        """The oldest queued event; with none queued, first reads what has arrived without waiting. None: no
        event. Every call that reads the socket (a request waiting for its reply, ``next_state``) queues the
        events it reads, so none is lost while a request waits. Polled, not called back: a callback run
        inside ``commit`` could call ``commit`` again."""
        return self._read_until("Client.poll_event", 0.0, self._take_event)

    def _take_event(self) -> Optional[Event]:
        return self._events.popleft() if self._events else None

    def poll_events(self) -> List[Event]:
        """Every event queued or arrived so far, oldest first (an empty list: none)."""
        events = []
        while True:
            event = self.poll_event()
            if event is None:
                return events
            events.append(event)

    def next_event(self, timeout_s: float) -> Optional[Event]:
        """The next event, waiting up to ``timeout_s``; None when none came."""
        return self._read_until("Client.next_event", timeout_s, self._take_event)

    def bye(self) -> None:
        """Orderly end of the session (its objects ramp out)."""
        try:
            self.request("bye")
        except HapticdError as e:
            if e.code != "transport":
                raise
        self.close()

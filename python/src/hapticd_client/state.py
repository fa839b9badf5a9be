# SPDX-License-Identifier: Apache-2.0
"""The daemon's state stream read from POSIX shared memory without a system call per read
(docs/protocol.md, section 6: layout version 2, 1152 bytes, a seqlock written once per tick by the loop).

Mesh objects' proxies (bytes 600..1119, under the seqlock): ``StateSample.mesh_proxies`` lists the god-object
proxies of the first ``MESH_PROXY_CAPACITY`` (7) slots that render a mesh, in slot order; ``mesh_slot_mask`` has a
bit for every such slot. A daemon that publishes none has ``mesh_proxy_capacity`` 0 in its header (the reader's
attribute) and zeros there.

Liveness: the loop stores CLOCK_MONOTONIC (ns) into ``heartbeat_ns`` after every tick. A sample is
``stale`` when that is older than ``stale_after_s(period_s)`` (10 periods, at least 50 ms), was never
written, or the fault says the daemon died (4 fatal signal, 5 std::terminate): the daemon is dead or
stalled and the sample is not the device's present state.

Seqlock read: s1 = sequence; if odd, retry; copy the fields; s2 = sequence; equal: the copy is one tick.
The sequence is read with one aligned 8-byte load (a memoryview of native 'Q' items), never byte by byte.
The ordering of those loads relies on the CPU: x86-64 does not reorder loads with loads, so the read is
exact there. CPython cannot issue memory fences; on weakly ordered CPUs (arm64) prefer the socket
subscription (``Client.subscribe``) or the C++ client, whose reader has the acquire fences.
"""

from __future__ import annotations

import enum
import mmap
import os
import struct
import sys
import time
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

from .errors import HapticdError

MAGIC = 0x54535048  # "HPST"
LAYOUT_VERSION = 2
LAYOUT_SIZE = 1152
CAPACITY = 64
_HEADER = struct.Struct("<IIIId I")  # magic, layout_version, size, axes, period_s, capacity (offsets 0..27)
_SEQUENCE_INDEX = 64 // 8  # `sequence` at byte 64, as the 9th uint64
_FIELDS_OFFSET = 128
# tick, time_s, position[3], velocity[3], force[3], contact_mask, overruns, wake_latency_ns, last_commit_seq,
# fault, objects, slot_object_id[64], slot_ramp[64]   (offsets 128 .. 575)
_FIELDS = struct.Struct("<Qd3d3d3dQQqQII64I64B")
assert _HEADER.size == 28 and _FIELDS.size == 576 - 128
_WRITER_PID = struct.Struct("<i")  # offset 32
_HEARTBEAT_INDEX = 576 // 8  # heartbeat_ns (int64, CLOCK_MONOTONIC ns; 0: never written), one aligned load
_FATAL_SIGNAL = struct.Struct("<I")  # offset 584
_CONFIG_CONTACT_INDEX = 592 // 8  # config_contact_mask (uint64, under the seqlock)
_MESH_PROXY_CAPACITY_AT = struct.Struct("<I")  # offset 36: mesh_proxy_capacity (header; 0: none published)
MESH_PROXY_CAPACITY = 7
MESH_OFFSET = 600  # mesh_slot_mask (uint64), mesh_proxies (uint32), padding, then the entries at 616
_MESH_HEAD = struct.Struct("<QII")
# One StateMeshProxy: proxy[3] (f8), normal[3][3] (f4), triangle (u4), slot, constraints, flags, reserved (u1),
# object_id (u4): 72 bytes.
_MESH_ENTRY = struct.Struct("<3d9fIBBBBI")
MESH_BLOCK_SIZE = _MESH_HEAD.size + MESH_PROXY_CAPACITY * _MESH_ENTRY.size  # bytes 600 .. 1119
assert _MESH_ENTRY.size == 72 and MESH_BLOCK_SIZE == 520
MESH_PROXY_SLIDING = 1  # flags: friction, the proxy slid at this tick
MESH_PROXY_UNCONVERGED = 2  # flags: the proxy's step ran out of sweeps (it goes on at the next tick)
TRIANGLE_FREE = 0xFFFFFFFF


def stale_after_s(period_s: float) -> float:
    """The heartbeat age beyond which a sample is stale: 10 periods, at least 50 ms (state_layout.hpp)."""
    return max(10.0 * period_s, 0.05)

if sys.byteorder != "little":  # pragma: no cover - the layout is native, hapticd runs on little-endian hosts
    raise ImportError("hapticd_client.state: the state layout is little-endian; this host is big-endian")


@dataclass
class MeshProxy:
    """A mesh object's god-object proxy at the sample's tick, device frame (include/hapticd/state_layout.hpp,
    StateMeshProxy): the object pushes the handle towards it, K (proxy - position)."""

    object_id: int = 0
    slot: int = 0
    proxy: Tuple[float, float, float] = (0.0, 0.0, 0.0)  # m, on or outside the surface (1 um in front of its faces)
    constraints: int = 0  # active faces 0..3; 0: free (the proxy is at the handle)
    normals: Tuple[Tuple[float, float, float], ...] = ()  # unit outward normals of the active constraints
    triangle: Optional[int] = None  # one active face (index in the uploaded mesh); None when free
    sliding: bool = False
    converged: bool = True


def mesh_proxies_from_block(block: bytes) -> Tuple[int, List[MeshProxy]]:
    """``mesh_slot_mask`` and the proxies of the state's bytes 600..1119 (``MESH_BLOCK_SIZE`` bytes)."""
    mask, count, _ = _MESH_HEAD.unpack_from(block, 0)
    proxies = []
    for i in range(min(count, MESH_PROXY_CAPACITY)):
        v = _MESH_ENTRY.unpack_from(block, _MESH_HEAD.size + i * _MESH_ENTRY.size)
        # v: proxy 0..2, normals 3..11, triangle 12, slot 13, constraints 14, flags 15, reserved 16, object_id 17
        constraints = min(v[14], 3)
        proxies.append(MeshProxy(object_id=v[17], slot=v[13], proxy=tuple(v[0:3]), constraints=constraints,
                                 normals=tuple(tuple(v[3 + 3 * k:6 + 3 * k]) for k in range(constraints)),
                                 triangle=None if v[12] == TRIANGLE_FREE or constraints == 0 else v[12],
                                 sliding=bool(v[15] & MESH_PROXY_SLIDING), converged=not v[15] & MESH_PROXY_UNCONVERGED))
    return mask, proxies


@dataclass
class StateSample:
    """One consistent tick of the loop."""

    tick: int = 0
    time_s: float = 0.0  # CLOCK_MONOTONIC at the tick's wake-up
    position: Tuple[float, float, float] = (0.0, 0.0, 0.0)  # m
    velocity: Tuple[float, float, float] = (0.0, 0.0, 0.0)  # m/s, backward difference of the sampled position
    force: Tuple[float, float, float] = (0.0, 0.0, 0.0)  # N, commanded this tick
    contact_mask: int = 0  # bit s: the object in slot s is in contact
    config_contact_mask: int = 0  # bit i: the config wall with object id i + 1 is in contact
    overruns: int = 0
    wake_latency_ns: int = 0
    last_commit_seq: int = 0  # every batch up to this one is applied
    fault: int = 0  # 0 none, 1 device, 2 non-finite, 3 watchdog, 4 fatal signal, 5 std::terminate
    objects: int = 0
    slot_object_id: List[int] = field(default_factory=lambda: [0] * CAPACITY)
    slot_ramp: List[int] = field(default_factory=lambda: [0] * CAPACITY)
    stale: bool = False  # the writer is dead or stalled (module docstring)
    heartbeat_age_s: float = 0.0  # s since the loop's last tick; -1: never written
    fatal_signal: int = 0  # the signal that ended the daemon (fault 4 or 5)
    contact_ids: Optional[List[int]] = None  # a subscribed state message's `contact` (no slot table in it)
    mesh_slot_mask: int = 0  # bit s: slot s renders a mesh
    mesh_proxies: List[MeshProxy] = field(default_factory=list)  # the first 7 of those slots' proxies, slot order

    def contacts(self) -> List[int]:
        """The ids of the objects in contact: the config walls' (ascending), then the client objects' in slot order."""
        if self.contact_ids is not None:
            return list(self.contact_ids)
        walls = [i + 1 for i in range(64) if (self.config_contact_mask >> i) & 1]
        return walls + [self.slot_object_id[s] for s in range(CAPACITY)
                        if (self.contact_mask >> s) & 1 and self.slot_object_id[s] != 0]


class StateFault(enum.IntEnum):
    """The state's ``fault`` (include/hapticd/state_layout.hpp, ``hapticd::StateFault``; the same numbers; a test
    compares the two): why the loop stopped rendering."""

    NONE = 0
    DEVICE = 1  # the device reported an error
    NON_FINITE = 2  # non-finite position or force
    WATCHDOG = 3  # too many consecutive overruns, or a stall
    FATAL_SIGNAL = 4  # SIGSEGV, SIGBUS, SIGFPE, SIGILL or SIGABRT ended the daemon
    TERMINATE = 5  # std::terminate ended the daemon


#: The protocol's name of each fault (``to_string(StateFault)``), as the state and status messages carry it.
FAULT_NAMES = {StateFault.NONE: "none", StateFault.DEVICE: "device", StateFault.NON_FINITE: "non_finite",
               StateFault.WATCHDOG: "watchdog", StateFault.FATAL_SIGNAL: "fatal_signal", StateFault.TERMINATE: "terminate"}
FAULT_FATAL_SIGNAL = StateFault.FATAL_SIGNAL
FAULT_TERMINATE = StateFault.TERMINATE


def shm_path(name: str) -> str:
    """The file of a POSIX shared-memory name on Linux: ``/hapticd-state`` -> ``/dev/shm/hapticd-state``."""
    if not name.startswith("/") or "/" in name[1:] or len(name) < 2:
        raise HapticdError("transport", f"shm_path: name = {name!r}: expected '/' followed by a name without '/'")
    return "/dev/shm" + name


class StateReader:
    """Read-only mapping of the daemon's state; ``read()`` returns the latest tick."""

    def __init__(self, name: str = "/hapticd-state") -> None:
        path = shm_path(name)
        try:
            fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
        except OSError as e:
            raise HapticdError("transport", f"StateReader: open {path}: {e.strerror} (is hapticd running with --serve?)") from e
        try:
            self._map = mmap.mmap(fd, LAYOUT_SIZE, flags=mmap.MAP_SHARED, prot=mmap.PROT_READ)
        except (OSError, ValueError) as e:
            raise HapticdError("transport", f"StateReader: mmap {path}: {e}") from e
        finally:
            os.close(fd)
        magic, version, size, axes, period_s, capacity = _HEADER.unpack_from(self._map, 0)
        if magic != MAGIC or version != LAYOUT_VERSION or size != LAYOUT_SIZE:
            self._map.close()
            raise HapticdError("transport", f"StateReader: {path} is not a hapticd state of layout version "
                                            f"{LAYOUT_VERSION} (magic {magic:#x}, version {version}, size {size})")
        self.name = name
        self.axes = axes
        self.period_s = period_s
        self.capacity = capacity
        self.writer_pid = _WRITER_PID.unpack_from(self._map, 32)[0]
        self.mesh_proxy_capacity = min(_MESH_PROXY_CAPACITY_AT.unpack_from(self._map, 36)[0], MESH_PROXY_CAPACITY)
        self.stale_after_s = stale_after_s(period_s)
        self._words = memoryview(self._map).cast("Q")  # native uint64 items: one 8-byte load each

    def close(self) -> None:
        if self._map is not None:
            self._words.release()
            self._map.close()
            self._map = None

    def __enter__(self) -> "StateReader":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def read_raw(self, max_attempts: int = 1000) -> Optional[bytes]:
        """The 448 bytes of one tick's fields, or None when ``max_attempts`` reads overlapped a write or the writer
        stayed inside one publication longer than the stale age."""
        got = self._read_consistent(max_attempts, meshes=False)
        return None if got is None else got[0]

    def read_raw_meshes(self, max_attempts: int = 1000) -> Optional[bytes]:
        """The 448 bytes of one tick's fields followed by the 520 of its mesh proxies (bytes 600..1119) of the same
        tick, or None when ``max_attempts`` reads overlapped a write."""
        got = self._read_consistent(max_attempts, meshes=True)
        return None if got is None else got[0] + got[2]

    def _read_consistent(self, max_attempts: int, meshes: bool = True) -> Optional[Tuple[bytes, int, bytes]]:
        """The fields' 448 bytes, config_contact_mask and (``meshes``) the mesh block of one tick (seqlock), or None."""
        words = self._words
        m = self._map
        attempt = 0
        odd_since = None
        while attempt < max_attempts:
            s1 = words[_SEQUENCE_INDEX]
            if s1 & 1:
                # The writer is inside a publication (a preempted loop holds it for milliseconds on a loaded
                # machine): wait for it up to the stale age, without counting an attempt.
                now = time.monotonic()
                if odd_since is None:
                    odd_since = now
                elif now - odd_since > self.stale_after_s:
                    return None
                continue
            odd_since = None
            attempt += 1
            block = m[_FIELDS_OFFSET:_FIELDS_OFFSET + _FIELDS.size]
            config_contacts = words[_CONFIG_CONTACT_INDEX]
            mesh_block = m[MESH_OFFSET:MESH_OFFSET + MESH_BLOCK_SIZE] if meshes else b""
            if words[_SEQUENCE_INDEX] == s1:
                return block, config_contacts, mesh_block
        return None

    def read(self, max_attempts: int = 1000, require_live: bool = False) -> StateSample:
        """One consistent tick (a write in progress is waited for up to the stale age). Raises
        HapticdError("transport") if every attempt overlapped a write or one write outlasted the stale age, and
        with ``require_live`` HapticdError("stale_state") when the sample is stale (module docstring)."""
        got = self._read_consistent(max_attempts)
        if got is None:
            raise HapticdError("transport", f"StateReader.read: no consistent tick: {max_attempts} reads in a row overlapped "
                               f"the loop's writes, or one write lasted over {self.stale_after_s:.3f} s")
        block, config_contacts, mesh_block = got
        v = _FIELDS.unpack(block)
        mesh_mask, proxies = mesh_proxies_from_block(mesh_block)
        beat = self._words[_HEARTBEAT_INDEX]
        if beat >= 1 << 63:
            beat -= 1 << 64
        age = -1.0 if beat == 0 else 1e-9 * (time.clock_gettime_ns(time.CLOCK_MONOTONIC) - beat)
        fault = v[15]
        stale = beat == 0 or age > self.stale_after_s or fault in (FAULT_FATAL_SIGNAL, FAULT_TERMINATE)
        sample = StateSample(tick=v[0], time_s=v[1], position=tuple(v[2:5]), velocity=tuple(v[5:8]), force=tuple(v[8:11]),
                             contact_mask=v[11], config_contact_mask=config_contacts, overruns=v[12], wake_latency_ns=v[13], last_commit_seq=v[14], fault=fault,
                             objects=v[16], slot_object_id=list(v[17:81]), slot_ramp=list(v[81:145]), stale=stale,
                             heartbeat_age_s=age, fatal_signal=_FATAL_SIGNAL.unpack_from(self._map, 584)[0],
                             mesh_slot_mask=mesh_mask, mesh_proxies=proxies)
        if require_live and stale:
            why = (f"the daemon died (fault {FAULT_NAMES.get(fault, fault)}, signal {sample.fatal_signal})"
                   if fault in (FAULT_FATAL_SIGNAL, FAULT_TERMINATE)
                   else "the loop never ticked" if beat == 0
                   else f"no tick for {age:.3f} s > {self.stale_after_s:.3f} s")
            raise HapticdError("stale_state", f"StateReader.read: the state of {self.name} is stale: {why}")
        return sample

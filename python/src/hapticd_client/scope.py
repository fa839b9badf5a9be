# SPDX-License-Identifier: Apache-2.0
"""hapticd-scope: a live plot of the daemon's state from its shared memory (docs/scope.md).

    python3 -m hapticd_client.scope                          # a window, when a display exists
    python3 -m hapticd_client.scope --out frames/ --every 1  # over SSH: a PNG frame every second
    python3 -m hapticd_client.scope --out scope.png --data scope.npz --duration 5
    python3 -m hapticd_client.scope --recording run.rec --out run.png   # a recording (hapticd --record)

Four panels over the last ``--window`` seconds, against the loop's own clock: position (mm), velocity
(mm/s) and force (N) per axis of the device, and the objects: one row per object id, a thin line while the
object is in a slot of the scene, a bar while it is in contact (bit s of ``contact_mask`` for its slot s).
A mesh object's god-object proxy (the state's mesh proxies, scope_proxies.py) is a dashed line on each position
axis beside the handle's, and its row names the newest penetration |proxy - handle| (mm) and active constraints.

A sampler thread reads the state (one seqlock read, ``StateReader.read_raw``) ``--sample-rate`` times per
second and keeps each new tick in a ring buffer of numpy records whose layout is the state's fields
(include/hapticd/state_layout.hpp, offsets 128..575), so a sample holds the bytes the loop wrote: the
values are bit for bit those of any other reader of the same tick. The scope samples the stream; it does
not see every tick when the loop runs faster than ``--sample-rate`` or while the sampler waits for the GIL.

With ``--recording FILE`` it plots a recording made with ``hapticd --record`` instead (every tick, the whole
run or its last ``--window`` seconds when that is given; read with hapticd_client.recording): the same three
panels against the loop's clock from the first tick, the contacts per slot (labelled with the id of the object
the slot held), and a vertical mark at each batch the loop took (commit: grey, departure: red).

Needs numpy and matplotlib (the extra ``plot`` of the distribution); the rest of hapticd_client does not.
Exit codes (hapticctl's where they overlap): 0 done, 2 bad option or matplotlib missing, 3 no daemon at the
socket, 9 the state cannot be read, is stale, or stopped advancing for ``--stall-timeout`` seconds, 10 the
recording cannot be read (hapticd's code for a bad recording).
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import signal
import sys
import threading
import time
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .errors import HapticdError
from .instance import INSTANCE_NAME_FORM, valid_instance_name
from .scope_proxies import has_meshes, meshes_beyond, proxy_rows, sample_dtype
from .state import CAPACITY, LAYOUT_SIZE, StateReader, _FIELDS, _FIELDS_OFFSET, FAULT_NAMES

EXIT_OK = 0
EXIT_USAGE = 2
EXIT_NO_DAEMON = 3
EXIT_NO_STATE = 9
EXIT_BAD_RECORDING = 10

# The per-tick fields of the state, offsets relative to byte 128 of the segment (state_layout.hpp).
STATE_DTYPE = np.dtype({
    "names": ["tick", "time_s", "position", "velocity", "force", "contact_mask", "overruns", "wake_latency_ns",
              "last_commit_seq", "fault", "objects", "slot_object_id", "slot_ramp"],
    "formats": ["<u8", "<f8", ("<f8", (3,)), ("<f8", (3,)), ("<f8", (3,)), "<u8", "<u8", "<i8", "<u8", "<u4", "<u4",
                ("<u4", (CAPACITY,)), ("u1", (CAPACITY,))],
    "offsets": [0, 8, 16, 40, 64, 88, 96, 104, 112, 120, 124, 128, 384],
    "itemsize": _FIELDS.size,
})
assert STATE_DTYPE.itemsize == 448 and _FIELDS_OFFSET + STATE_DTYPE.itemsize <= LAYOUT_SIZE
# What the sampler keeps per tick: those fields, then the mesh proxies of the same tick (bytes 600..1119).
SAMPLE_DTYPE = sample_dtype(STATE_DTYPE)

AXIS_NAMES = ("x", "y", "z")
FILE_SUFFIXES = (".png", ".svg", ".pdf")


def _number_in(name: str, low: float, high: float, integer: bool = False):
    """An argparse type: a finite number in [low, high] (exclusive of 0 when low is 0)."""
    def parse(text: str):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: expected a number in [{low:g}, {high:g}]")
        if not math.isfinite(value) or value < low or value > high or (low == 0 and value == 0):
            bound = f"(0, {high:g}]" if low == 0 else f"[{low:g}, {high:g}]"
            raise argparse.ArgumentTypeError(f"{name} = {text}: accepted range {bound}")
        return value
    return parse


def _size(text: str) -> Tuple[int, int]:
    """An argparse type: WIDTHxHEIGHT in pixels, each in [200, 8000]."""
    parts = text.lower().split("x")
    try:
        w, h = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size = {text!r}: expected WIDTHxHEIGHT in pixels, e.g. 1280x800")
    if not (200 <= w <= 8000 and 200 <= h <= 8000):
        raise argparse.ArgumentTypeError(f"--size = {text}: width and height in [200, 8000] pixels")
    return w, h


def _instance_name(text: str) -> str:
    if not valid_instance_name(text):
        raise argparse.ArgumentTypeError(f"--instance = {text!r}: accepted: {INSTANCE_NAME_FORM}")
    return text


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="hapticd-scope",
        description="Plot hapticd's position, velocity and force per axis and the contacts over the last seconds, "
                    "live from its shared-memory state (docs/scope.md).",
        epilog="Exit codes: 0 done, 2 bad option or matplotlib missing, 3 no daemon at the socket, "
               "9 the state cannot be read, is stale, or stopped advancing, 10 --recording cannot be read.")
    src = p.add_argument_group("source")
    src.add_argument("--shm", metavar="NAME",
                     help="shared-memory name of the state (e.g. /hapticd-state); default: ask the daemon at --socket")
    src.add_argument("--socket", metavar="PATH",
                     help="control socket, used only to learn the state's name (default $HAPTICD_SOCKET, then hapticd's)")
    src.add_argument("--instance", metavar="NAME", type=_instance_name,
                     help="the daemon instance (hapticd --instance NAME) whose socket to ask (default $HAPTICD_INSTANCE)")
    src.add_argument("--recording", metavar="FILE",
                     help="plot a recording (hapticd --record FILE) instead of the live state: every tick of the run, "
                          "or of its last --window seconds when --window is given (docs/recording.md)")
    view = p.add_argument_group("view")
    view.add_argument("--window", type=_number_in("--window", 0, 600.0), default=None, metavar="S",
                      help="seconds shown, (0, 600] (default 5; with --recording: the whole run)")
    view.add_argument("--rate", type=_number_in("--rate", 0, 60.0), default=20.0, metavar="HZ",
                      help="frames per second in a window, (0, 60] (default 20)")
    view.add_argument("--sample-rate", type=_number_in("--sample-rate", 0, 5000.0), default=1000.0, metavar="HZ",
                      help="state reads per second, (0, 5000] (default 1000)")
    view.add_argument("--size", type=_size, default=(1280, 800), metavar="WxH",
                      help="figure size in pixels, each in [200, 8000] (default 1280x800)")
    view.add_argument("--dpi", type=_number_in("--dpi", 20, 600, integer=True), default=100,
                      help="dots per inch of the figure, [20, 600] (default 100)")
    out = p.add_argument_group("headless (no display needed)")
    out.add_argument("--out", metavar="DIR|FILE.png",
                     help="write frames instead of a window: a file ending in .png/.svg/.pdf holds the latest frame; "
                          "anything else is a directory that gets frame-NNNNNN.png")
    out.add_argument("--every", type=_number_in("--every", 0.05, 3600.0), default=1.0, metavar="F",
                     help="with --out: a frame every F seconds, [0.05, 3600] (default 1), and one at the end")
    out.add_argument("--data", metavar="FILE.npz",
                     help="at the end, write the samples of the last frame (numpy .npz; docs/scope.md lists the arrays)")
    out.add_argument("--duration", type=_number_in("--duration", 0, 1e9), default=None, metavar="S",
                     help="stop after S seconds (default: until Ctrl-C, SIGTERM or the window is closed)")
    out.add_argument("--stall-timeout", type=_number_in("--stall-timeout", 0, 3600.0), default=2.0, metavar="S",
                     help="exit 9 when the tick has not advanced for S seconds (default 2); a window only says so")
    return p


class Sampler:
    """Reads the state in a thread at ``rate_hz`` and keeps every new tick in a ring buffer of SAMPLE_DTYPE."""

    def __init__(self, reader: StateReader, capacity: int, rate_hz: float) -> None:
        self.reader = reader
        self.buffer = np.zeros(capacity, SAMPLE_DTYPE)
        self.count = 0  # samples ever stored; the newest is at (count - 1) % capacity
        self.overlapped = 0  # reads that overlapped the loop's writes every attempt
        self.last_change = time.monotonic()
        self.period_s = 1.0 / rate_hz
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="hapticd-scope-sampler", daemon=True)

    def poll(self) -> bool:
        """One read; True when it gave a tick not stored yet."""
        block = self.reader.read_raw_meshes(max_attempts=100)
        if block is None:
            self.overlapped += 1
            return False
        record = np.frombuffer(block, SAMPLE_DTYPE, count=1)[0]
        with self._lock:
            if self.count and self.buffer[(self.count - 1) % len(self.buffer)]["tick"] == record["tick"]:
                return False
            self.buffer[self.count % len(self.buffer)] = record
            self.count += 1
        self.last_change = time.monotonic()
        return True

    def _run(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            self.poll()
            next_t += self.period_s
            delay = next_t - time.monotonic()
            if delay > 0:
                self._stop.wait(delay)
            else:
                next_t = time.monotonic()  # behind (GIL, scheduling): no burst of catch-up reads

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def window(self, seconds: float) -> np.ndarray:
        """The stored samples whose loop time is within ``seconds`` of the newest, oldest first (a copy)."""
        with self._lock:
            n = min(self.count, len(self.buffer))
            if n == 0:
                return np.zeros(0, SAMPLE_DTYPE)
            start = self.count - n
            index = np.arange(start, self.count) % len(self.buffer)
            samples = self.buffer[index].copy()
        return samples[samples["time_s"] >= samples["time_s"][-1] - seconds]


def object_rows(samples: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The object ids seen in the samples' slots (sorted), and per sample and id whether the object is in a
    slot (``present``) and in contact (``in_contact``: bit s of contact_mask set for its slot s)."""
    slots = samples["slot_object_id"].astype(np.int64)  # (n, 64); 0 is a free slot
    bits = ((samples["contact_mask"][:, None] >> np.arange(CAPACITY, dtype=np.uint64)) & np.uint64(1)).astype(bool)
    ids = np.unique(slots[slots != 0])
    present = np.zeros((len(samples), len(ids)), bool)
    in_contact = np.zeros((len(samples), len(ids)), bool)
    for k, object_id in enumerate(ids):
        here = slots == object_id
        present[:, k] = here.any(axis=1)
        in_contact[:, k] = (here & bits).any(axis=1)
    return ids, present, in_contact


class Scope:
    """The figure: four panels drawn from a window of samples."""

    def __init__(self, figure, axes: int, window_s: float, shm: str) -> None:
        self.figure = figure
        self.axes = axes
        self.window_s = window_s
        self.shm = shm
        panels = figure.subplots(4, 1, sharex=True, gridspec_kw={"height_ratios": [3, 3, 3, 2]})
        self.ax_position, self.ax_velocity, self.ax_force, self.ax_contacts = panels
        self.lines: Dict[str, List] = {}
        for name, ax, unit in (("position", self.ax_position, "position (mm)"),
                               ("velocity", self.ax_velocity, "velocity (mm/s)"),
                               ("force", self.ax_force, "force (N)")):
            self.lines[name] = [ax.plot([], [], lw=1.2, color=f"C{a}", label=AXIS_NAMES[a])[0] for a in range(axes)]
            ax.set_ylabel(unit)
            ax.grid(True, alpha=0.3)
        figure.legend(handles=self.lines["position"], loc="upper right", ncol=axes, fontsize="small", frameon=False)
        self.ax_contacts.set_ylabel("objects")
        self.ax_contacts.set_xlabel("time before the newest sample (s), loop clock")
        self.ax_contacts.set_xlim(-window_s, 0.0)
        self.title = figure.suptitle(f"hapticd state {shm}: waiting for samples", fontsize="medium", x=0.08, ha="left")
        self.status_line = ""
        self.proxy_lines: List = []  # the mesh proxies' dashed lines on the position panel (redrawn each frame)
        self.row_notes: List = []  # the mesh rows' penetration texts
        figure.subplots_adjust(left=0.08, right=0.98, top=0.93, bottom=0.07, hspace=0.12)

    def draw(self, samples: np.ndarray, status: str) -> None:
        """Set every artist from ``samples`` (the plotted data; write_data saves the same array)."""
        if len(samples):
            t = samples["time_s"] - samples["time_s"][-1]
            rows = object_rows(samples)
            proxy, penetration, constraints = proxy_rows(samples, rows[0])
            self._draw_proxies(t, rows[0], proxy)
            for name, scale in (("position", 1e3), ("velocity", 1e3), ("force", 1.0)):
                ax = self.ax_position if name == "position" else self.ax_velocity if name == "velocity" else self.ax_force
                values = samples[name]
                for a, line in enumerate(self.lines[name]):
                    line.set_data(t, values[:, a] * scale)
                ax.relim()
                ax.autoscale_view(scalex=False)
                low, high = ax.get_ylim()
                if high - low < 1e-9:  # a flat trace: a visible band around it
                    ax.set_ylim(low - 1.0, high + 1.0)
            self._draw_objects(t, rows, penetration, constraints)
            newest = samples[-1]
            beyond = meshes_beyond(newest) if has_meshes(samples) else 0
            touching = [int(newest["slot_object_id"][s]) for s in range(CAPACITY) if (int(newest["contact_mask"]) >> s) & 1]
            self.title.set_text(
                f"hapticd state {self.shm}: tick {int(newest['tick'])}, "
                f"{int(newest['objects'])} objects, in contact {{{', '.join(map(str, touching))}}}, "
                f"overruns {int(newest['overruns'])}, "
                f"fault {FAULT_NAMES.get(int(newest['fault']), int(newest['fault']))}; {len(samples)} samples"
                + (f"; {beyond} mesh(es) beyond the 7 proxies the state holds" if beyond else "")
                + (f"; {status}" if status else ""))
            self.title.set_color("C3" if status else "black")
        self.ax_contacts.set_xlim(-self.window_s, 0.0)

    def _draw_proxies(self, t: np.ndarray, ids: np.ndarray, proxy: np.ndarray) -> None:
        """Each mesh object's proxy (mm) as a dashed line per axis in the axis' colour, beside the handle's line;
        NaN (no line) where the sample holds no proxy of it. Dash patterns tell several meshes apart."""
        for line in self.proxy_lines:
            line.remove()
        self.proxy_lines = []
        meshes = [k for k in range(len(ids)) if np.isfinite(proxy[:, k, 0]).any()]
        for m, k in enumerate(meshes):
            dashes = (4, 2) if m == 0 else (1 + m, 2, 1, 2)
            for a in range(self.axes):
                line, = self.ax_position.plot(t, proxy[:, k, a] * 1e3, lw=1.4, color=f"C{a}", dashes=dashes, zorder=3,
                                              label=f"proxy id {int(ids[k])} {AXIS_NAMES[a]}")
                self.proxy_lines.append(line)

    def _draw_objects(self, t: np.ndarray, rows, penetration: np.ndarray, constraints: np.ndarray) -> None:
        ax = self.ax_contacts
        for artist in list(ax.lines) + list(ax.collections) + self.row_notes:
            artist.remove()
        self.row_notes = []
        ids, present, in_contact = rows
        labels = []
        for k, object_id in enumerate(ids):
            ax.fill_between(t, k - 0.05, k + 0.05, where=present[:, k], step="post", color="0.6", lw=0)
            ax.fill_between(t, k - 0.35, k + 0.35, where=in_contact[:, k], step="post", color=f"C{3 + k % 7}", lw=0)
            mesh = np.isfinite(penetration[:, k]).any()
            labels.append(f"id {object_id} mesh" if mesh else f"id {object_id}")
            if mesh:  # the newest sample that holds its proxy, written just above the row's bar
                i = int(np.flatnonzero(np.isfinite(penetration[:, k]))[-1])
                self.row_notes.append(ax.text(
                    0.995, k + 0.5, f"|proxy - handle| {1e3 * penetration[i, k]:.3f} mm, "
                                    f"{int(constraints[i, k])} constraint(s)",
                    transform=ax.get_yaxis_transform(), ha="right", va="center", fontsize="x-small"))
        ax.set_yticks(range(len(ids)))
        ax.set_yticklabels(labels)
        ax.set_ylim(-0.7, max(len(ids), 1) - 0.3)


def write_data(path: str, samples: np.ndarray, axes: int, window_s: float, shm: str) -> None:
    """The samples of a frame as numpy arrays (SI units, the state's own values) plus the object rows and, for the
    mesh objects, their proxies and penetrations (docs/scope.md lists the arrays)."""
    ids, present, in_contact = object_rows(samples)
    arrays = {name: samples[name] for name in STATE_DTYPE.names}
    proxy, penetration, constraints = proxy_rows(samples, ids)
    arrays.update(proxy=proxy, penetration=penetration, proxy_constraints=constraints)
    if has_meshes(samples):
        entries = samples["mesh_proxy"]
        arrays.update(mesh_slot_mask=samples["mesh_slot_mask"], mesh_proxies=samples["mesh_proxies"],
                      mesh_proxy_object_id=entries["object_id"], mesh_proxy_slot=entries["slot"],
                      mesh_proxy_position=entries["proxy"], mesh_proxy_normal=entries["normal"],
                      mesh_proxy_constraints=entries["constraints"], mesh_proxy_triangle=entries["triangle"],
                      mesh_proxy_flags=entries["flags"])
    target = pathlib.Path(path)
    tmp = target.with_name(target.name + ".tmp.npz")
    np.savez(tmp, **arrays, object_ids=ids, present=present, in_contact=in_contact, axes=np.int64(axes),
             window_s=np.float64(window_s), shm=np.str_(shm))
    os.replace(tmp, target)


def _save_figure(figure, path: pathlib.Path, dpi: int) -> None:
    """Write atomically: a reader of the file sees the previous frame or this one, never half of one."""
    tmp = path.with_name(f".{path.name}.tmp{path.suffix}")
    figure.savefig(tmp, dpi=dpi)
    os.replace(tmp, path)


def _has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) or sys.platform in ("darwin", "win32")


def _open_state(args) -> StateReader:
    """The reader of --shm, or of the state the daemon at --socket names in its welcome."""
    shm = args.shm
    if shm is None:
        from .client import Client  # the socket is needed only for the name
        try:
            with Client.connect(socket_path=args.socket, instance=args.instance, client="hapticd-scope") as client:
                shm = client.welcome["state_shm"]
                client.bye()
        except HapticdError as e:
            raise _Exit(EXIT_NO_DAEMON, f"--socket: {e} (give --shm NAME to read a state without asking the daemon)")
        except ValueError as e:  # --socket and --instance both, or a bad $HAPTICD_INSTANCE
            raise _Exit(EXIT_USAGE, str(e))
    try:
        return StateReader(shm)
    except HapticdError as e:
        raise _Exit(EXIT_NO_STATE, f"--shm {shm}: {e}")


class _Exit(Exception):
    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


def run(argv: Optional[Sequence[str]] = None) -> int:
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:  # argparse printed the message (or --help)
        return EXIT_OK if e.code in (0, None) else EXIT_USAGE
    if args.data is not None and not args.data.endswith(".npz"):
        raise _Exit(EXIT_USAGE, f"--data = {args.data!r}: expected a file name ending in .npz")
    out_file: Optional[pathlib.Path] = None
    out_dir: Optional[pathlib.Path] = None
    if args.out is not None:
        out = pathlib.Path(args.out)
        if out.suffix.lower() in FILE_SUFFIXES:
            if not out.parent.is_dir():
                raise _Exit(EXIT_USAGE, f"--out = {args.out!r}: the directory {str(out.parent)!r} does not exist")
            out_file = out
        else:
            if out.exists() and not out.is_dir():
                raise _Exit(EXIT_USAGE, f"--out = {args.out!r}: exists and is not a directory (a single frame: "
                                        f"a name ending in {', '.join(FILE_SUFFIXES)})")
            out_dir = out
    elif not _has_display():
        raise _Exit(EXIT_USAGE, "no display ($DISPLAY and $WAYLAND_DISPLAY unset): give --out DIR for frames or "
                                "--out FILE.png for the latest frame")
    if args.data is not None and not pathlib.Path(args.data).resolve().parent.is_dir():
        raise _Exit(EXIT_USAGE, f"--data = {args.data!r}: its directory does not exist")
    if args.recording is not None:
        return _run_recording(args, out_file, out_dir)
    if args.window is None:
        args.window = 5.0

    reader = _open_state(args)
    try:
        headless = _matplotlib_for(args)
        try:
            reader.read(require_live=True)
        except HapticdError as e:
            hint = (" (a --lockstep daemon rewrites its state faster than Python copies it: run it at its real rate)"
                    if e.code == "transport" else "")
            raise _Exit(EXIT_NO_STATE, f"--shm {reader.name}: {e}{hint}")
        if out_dir is not None:
            out_dir.mkdir(parents=True, exist_ok=True)
        capacity = int(math.ceil(args.window * args.sample_rate * 1.25)) + 16
        sampler = Sampler(reader, capacity, args.sample_rate)
        sampler.start()
        try:
            if headless:
                return _run_headless(args, reader, sampler, out_file, out_dir)
            return _run_window(args, reader, sampler)
        finally:
            sampler.stop()
    finally:
        reader.close()


def _status(reader: StateReader, sampler: Sampler, stall_s: float) -> str:
    """Why the newest sample is not the device's present state, or ''."""
    stalled_for = time.monotonic() - sampler.last_change
    if stalled_for > stall_s:
        try:
            s = reader.read()
            if s.stale:
                return f"STALE: no tick for {s.heartbeat_age_s:.1f} s, fault {FAULT_NAMES.get(s.fault, s.fault)}"
        except HapticdError:
            pass
        return f"STALLED: no new tick read for {stalled_for:.1f} s"
    return ""


def _run_headless(args, reader: StateReader, sampler: Sampler, out_file, out_dir) -> int:
    from matplotlib.figure import Figure

    stop = threading.Event()
    previous = {s: signal.signal(s, lambda *_: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        width, height = args.size
        figure = Figure(figsize=(width / args.dpi, height / args.dpi), dpi=args.dpi)
        scope = Scope(figure, reader.axes, args.window, reader.name)
        start = time.monotonic()
        end = start + args.duration if args.duration is not None else math.inf
        frame = 0
        frame_time_s = 0.0  # the longest frame: draw and write
        code = EXIT_OK
        status = ""
        next_frame = start + args.every
        while True:
            now = time.monotonic()
            status = _status(reader, sampler, args.stall_timeout)
            final = now >= end or stop.is_set() or status != ""
            if final or now >= next_frame:
                drawing = time.monotonic()
                samples = sampler.window(args.window)
                scope.draw(samples, status)
                if out_dir is not None:
                    _save_figure(figure, out_dir / f"frame-{frame:06d}.png", args.dpi)
                else:
                    _save_figure(figure, out_file, args.dpi)
                frame += 1
                frame_time_s = max(frame_time_s, time.monotonic() - drawing)
                next_frame += args.every * max(1, math.ceil((now - next_frame) / args.every + 1e-9))
                if final:
                    if args.data is not None:
                        write_data(args.data, samples, reader.axes, args.window, reader.name)
                    if status:
                        print(f"hapticd-scope: --shm {reader.name}: {status} (--stall-timeout {args.stall_timeout:g} s)",
                              file=sys.stderr)
                        code = EXIT_NO_STATE
                    break
            # Wake at the next frame or the end, and at least every 0.1 s to check for a stall.
            stop.wait(min(max(0.0, min(next_frame, end) - time.monotonic()), 0.1))
        where = out_file if out_file is not None else out_dir
        print(f"hapticd-scope: {frame} frame(s) in {where} (longest {1e3 * frame_time_s:.0f} ms), {sampler.count} "
              f"samples read ({sampler.overlapped} reads overlapped the loop's writes)", file=sys.stderr)
        return code
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _run_window(args, reader: StateReader, sampler: Sampler) -> int:
    import matplotlib
    from matplotlib import rcsetup
    import matplotlib.pyplot as plt

    backend = matplotlib.get_backend()
    if backend.lower() in {b.lower() for b in rcsetup.non_interactive_bk}:
        raise _Exit(EXIT_USAGE, f"matplotlib's backend {backend!r} cannot open a window: give --out DIR or "
                                f"--out FILE.png, or set MPLBACKEND to an interactive backend (e.g. TkAgg, QtAgg)")
    width, height = args.size
    figure = plt.figure(figsize=(width / args.dpi, height / args.dpi), dpi=args.dpi)
    figure.canvas.manager.set_window_title(f"hapticd-scope {reader.name}")
    scope = Scope(figure, reader.axes, args.window, reader.name)
    shown = {"samples": np.zeros(0, SAMPLE_DTYPE)}
    start = time.monotonic()

    def update() -> None:
        shown["samples"] = sampler.window(args.window)
        scope.draw(shown["samples"], _status(reader, sampler, args.stall_timeout))
        figure.canvas.draw_idle()
        if args.duration is not None and time.monotonic() - start >= args.duration:
            plt.close(figure)

    timer = figure.canvas.new_timer(interval=int(1000.0 / args.rate))
    timer.add_callback(update)
    timer.start()
    try:
        plt.show()
    except KeyboardInterrupt:
        pass
    timer.stop()
    if args.data is not None:
        write_data(args.data, shown["samples"], reader.axes, args.window, reader.name)
    return EXIT_OK


def recording_figure(figure, rec, window_s: Optional[float] = None) -> np.ndarray:
    """Draws a recording (hapticd_client.recording.Recording) on ``figure``: position (mm), velocity (mm/s) and
    force (N) per axis against the loop's clock, the contacts per slot, and a vertical mark per batch taken
    (commit: grey, departure or jumped ahead of one: red). Returns the plotted tick rows."""
    ticks = rec.ticks
    if window_s is not None and len(ticks):
        ticks = ticks[ticks["time_s"] >= ticks["time_s"][-1] - window_s]
    axes = max(1, min(3, int(rec.header.get("axes", 3))))
    t = ticks["time_s"]
    panels = figure.subplots(4, 1, sharex=True, gridspec_kw={"height_ratios": [3, 3, 3, 2]})
    for ax, name, scale, unit in zip(panels[:3], ("position", "velocity", "force"), (1e3, 1e3, 1.0),
                                     ("position (mm)", "velocity (mm/s)", "force (N)")):
        for a in range(axes):
            ax.plot(t, ticks[name][:, a] * scale, lw=1.0, color=f"C{a}", label=AXIS_NAMES[a])
        ax.set_ylabel(unit)
        ax.grid(True, alpha=0.3)
    panels[0].legend(loc="upper right", ncol=axes, fontsize="small", frameon=False)
    # The object id each slot held last (its latest Set) labels the slot's contact row.
    slot_ids: Dict[int, int] = {}
    for b in rec.batches:
        for u in b.updates:
            if int(u["action"]) == 0:
                slot_ids[int(u["slot"])] = int(u["id"])
    mask = ticks["contact_mask"]
    slots = sorted({s for s in range(CAPACITY) if np.any((mask >> np.uint64(s)) & np.uint64(1))} | set(slot_ids))
    ax = panels[3]
    for k, s in enumerate(slots):
        on = ((mask >> np.uint64(s)) & np.uint64(1)).astype(bool)
        ax.fill_between(t, k - 0.35, k + 0.35, where=on, step="post", color=f"C{3 + k % 7}", lw=0)
    ax.set_yticks(range(len(slots)))
    ax.set_yticklabels([f"slot {s}" + (f" id {slot_ids[s]}" if s in slot_ids else "") for s in slots])
    ax.set_ylim(-0.7, max(len(slots), 1) - 0.3)
    ax.set_ylabel("contacts")
    ax.set_xlabel("loop time (s)")
    if len(ticks):
        first, last = int(ticks["tick"][0]), int(ticks["tick"][-1])
        for b in rec.batches:
            if first <= b.tick <= last:
                x = float(rec.ticks["time_s"][b.tick])
                for p in panels:
                    p.axvline(x, color="C3" if b.source != "commit" else "0.5", lw=0.6, ls="--", alpha=0.7)
    figure.suptitle(f"hapticd recording {pathlib.Path(rec.path).name}: {len(rec.ticks)} ticks, {len(rec.batches)} batches"
                    + (f" (last {window_s:g} s shown)" if window_s is not None else ""), fontsize="medium", x=0.08, ha="left")
    figure.subplots_adjust(left=0.1, right=0.98, top=0.93, bottom=0.07, hspace=0.12)
    return ticks


def _matplotlib_for(args) -> bool:
    """Imports matplotlib (a usage error naming the package when it is missing) and selects the Agg backend
    when the output is a file or frames (--out); returns whether it is headless."""
    try:
        import matplotlib
    except ImportError:
        raise _Exit(EXIT_USAGE, "hapticd-scope needs matplotlib: pip install 'hapticopt[plot]' "
                                "(Debian: apt install python3-matplotlib)")
    headless = args.out is not None
    if headless:
        matplotlib.use("Agg")
    return headless


def _run_recording(args, out_file: Optional[pathlib.Path], out_dir: Optional[pathlib.Path]) -> int:
    """--recording FILE: one figure of the recording, to --out FILE (or DIR/recording.png) or a window."""
    from . import recording
    try:
        rec = recording.load(args.recording)
    except recording.RecordingError as e:
        raise _Exit(EXIT_BAD_RECORDING, str(e))
    headless = _matplotlib_for(args)
    import matplotlib.pyplot as plt
    figure = plt.figure(figsize=(args.size[0] / args.dpi, args.size[1] / args.dpi), dpi=args.dpi)
    shown = recording_figure(figure, rec, args.window)
    if args.data is not None:
        target = pathlib.Path(args.data)
        tmp = target.with_name(target.name + ".tmp.npz")
        np.savez(tmp, **{name: shown[name] for name in shown.dtype.names})
        os.replace(tmp, target)
    if headless:
        if out_dir is not None:
            out_dir.mkdir(parents=True, exist_ok=True)
            out_file = out_dir / "recording.png"
        _save_figure(figure, out_file, args.dpi)
        plt.close(figure)
    else:
        plt.show()
    return EXIT_OK


def main(argv: Optional[Sequence[str]] = None) -> int:
    try:
        return run(argv)
    except _Exit as e:
        print(f"hapticd-scope: {e}", file=sys.stderr)
        return e.code


if __name__ == "__main__":
    sys.exit(main())

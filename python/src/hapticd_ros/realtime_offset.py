# SPDX-License-Identifier: Apache-2.0
"""CLOCK_REALTIME - CLOCK_MONOTONIC, the offset that turns a tick's monotonic time into a ROS stamp.

A single pair of reads, ``realtime() - monotonic()``, is wrong by however long the thread was preempted between the
two reads: on a loaded 2-core machine that is a scheduler slice, milliseconds, enough to stamp a later tick before an
earlier one. So the offset is measured bracketed: ``m1 = monotonic(), r = realtime(), m2 = monotonic()`` gives
``r - (m1 + m2) / 2`` within ``(m2 - m1) / 2``; of ``tries`` brackets the narrowest is kept, and only if it is at
most ``max_bracket_ns`` wide (100 us by default; an unpreempted bracket is ~0.1 us). Otherwise the previous offset
stays. The offset is measured again every ``refresh_s`` (0.1 s by default) and is constant in between, so the stamps
of later ticks are later, up to what the system clock itself does: a refresh moves the offset by the clock's
adjustment since the last one (NTP slews at most 500 ppm, 50 us per 0.1 s, below the loop's 1 ms period) plus the
two measurements' error (at most ``max_bracket_ns``); a step of the clock is a step of the stamps, as it is for
every other ROS stamp on the machine."""

from __future__ import annotations

import time
from typing import Callable, Optional


class RealtimeOffset:
    """The offset CLOCK_REALTIME - CLOCK_MONOTONIC in ns, measured bracketed and held for ``refresh_s``.

    ``clock`` reads a clock by id (``time.clock_gettime_ns`` by default; tests pass a scripted one). Not thread-safe:
    each publishing thread owns one."""

    def __init__(self, refresh_s: float = 0.1, max_bracket_ns: int = 100_000, tries: int = 3,
                 clock: Callable[[int], int] = time.clock_gettime_ns) -> None:
        if not refresh_s > 0:
            raise ValueError(f"refresh_s must be > 0 s, got {refresh_s!r}")
        if not max_bracket_ns > 0:
            raise ValueError(f"max_bracket_ns must be > 0 ns, got {max_bracket_ns!r}")
        if not (isinstance(tries, int) and tries >= 1):
            raise ValueError(f"tries must be a whole number >= 1, got {tries!r}")
        self._refresh_ns = int(refresh_s * 1e9)
        self._max_bracket_ns = int(max_bracket_ns)
        self._tries = tries
        self._clock = clock
        self._offset_ns: Optional[int] = None
        self._measured_at_ns = 0  # CLOCK_MONOTONIC of the last measurement kept
        self.rejected = 0  # measurements whose narrowest bracket was wider than max_bracket_ns

    def _measure(self) -> tuple:
        """(offset, bracket width, monotonic time) of the narrowest of ``tries`` brackets."""
        best = None
        for _ in range(self._tries):
            m1 = self._clock(time.CLOCK_MONOTONIC)
            r = self._clock(time.CLOCK_REALTIME)
            m2 = self._clock(time.CLOCK_MONOTONIC)
            width = m2 - m1
            if best is None or width < best[1]:
                best = (r - (m1 + m2) // 2, width, m2)
        return best

    def ns(self) -> int:
        """The offset in ns: the last kept measurement, measured again when older than ``refresh_s``. The first call
        keeps its measurement whatever its bracket (there is no other yet), but a wide one only until the next call,
        which measures again."""
        now = self._clock(time.CLOCK_MONOTONIC)
        if self._offset_ns is None or now - self._measured_at_ns >= self._refresh_ns:
            offset, width, at = self._measure()
            if width <= self._max_bracket_ns:
                self._offset_ns, self._measured_at_ns = offset, at
            else:
                self.rejected += 1
                if self._offset_ns is None:  # provisional: due again at the next call
                    self._offset_ns, self._measured_at_ns = offset, at - self._refresh_ns
        return self._offset_ns

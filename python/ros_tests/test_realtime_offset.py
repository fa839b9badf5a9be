# SPDX-License-Identifier: Apache-2.0
"""hapticd_ros.realtime_offset: the offset CLOCK_REALTIME - CLOCK_MONOTONIC that stamps the node's messages. A
scripted clock gives each bracket its width, so the choices (the narrowest of the tries, a wide bracket rejected and
the previous offset kept, a refresh only after refresh_s) are checked against offsets worked out by hand; the real
clocks check that stamps of increasing monotonic times increase while two busy threads preempt the reader."""
from __future__ import annotations

import threading
import time

import pytest

from hapticd_ros.realtime_offset import RealtimeOffset


class ScriptedClock:
    """Returns the scripted readings in order: (clock id, value) pairs, the id checked at each read."""

    def __init__(self, readings):
        self.readings = list(readings)

    def __call__(self, clock_id):
        expected, value = self.readings.pop(0)
        assert clock_id == expected, (clock_id, expected)
        return value


M, R = time.CLOCK_MONOTONIC, time.CLOCK_REALTIME


def bracket(m1, r, m2):
    return [(M, m1), (R, r), (M, m2)]


def test_the_narrowest_of_the_brackets_gives_the_offset():
    # Offsets of the three brackets: 5000 - 1500 = 3500 (width 1000), 9100 - 5050 = 4050 (width 100),
    # 20000 - 12000 = 8000 (width 4000): the second, the narrowest, is kept.
    clock = ScriptedClock([(M, 0)] + bracket(1000, 5000, 2000) + bracket(5000, 9100, 5100) + bracket(10000, 20000, 14000))
    offset = RealtimeOffset(tries=3, clock=clock)
    assert offset.ns() == 4050
    assert not clock.readings


def test_a_wide_bracket_keeps_the_previous_offset_and_is_measured_again():
    refresh = 100_000_000  # 0.1 s in ns
    clock = ScriptedClock(
        [(M, 0)] + bracket(0, 1000, 0)                      # first: offset 1000, width 0
        + [(M, refresh - 1)]                                 # not yet due: no measurement
        + [(M, refresh)] + bracket(refresh, 900_000_000, refresh + 200_000)  # due; width 200 us > 100 us: rejected
        + [(M, refresh + 300_000)] + bracket(refresh + 300_000, refresh + 300_000 + 1200, refresh + 300_000)
    )
    offset = RealtimeOffset(refresh_s=0.1, max_bracket_ns=100_000, tries=1, clock=clock)
    assert offset.ns() == 1000
    assert offset.ns() == 1000
    assert offset.ns() == 1000 and offset.rejected == 1  # the preempted read is not used
    assert offset.ns() == 1200  # measured again at once, and kept (width 0)
    assert not clock.readings


def test_a_wide_first_bracket_is_kept_only_until_the_next_call():
    clock = ScriptedClock(
        [(M, 0)] + bracket(0, 5_000_000, 300_000)            # first: width 300 us, offset 4 850 000, provisional
        + [(M, 400_000)] + bracket(400_000, 401_000, 400_000)  # the next call measures again: offset 1000, kept
        + [(M, 500_000)]                                     # then held for refresh_s
    )
    offset = RealtimeOffset(refresh_s=0.1, max_bracket_ns=100_000, tries=1, clock=clock)
    assert offset.ns() == 4_850_000 and offset.rejected == 1
    assert offset.ns() == 1000
    assert offset.ns() == 1000
    assert not clock.readings


@pytest.mark.parametrize("kwargs, named", [
    (dict(refresh_s=0), "refresh_s"), (dict(refresh_s=float("nan")), "refresh_s"),
    (dict(max_bracket_ns=0), "max_bracket_ns"), (dict(tries=0), "tries"), (dict(tries=1.5), "tries"),
])
def test_bad_settings_are_named(kwargs, named):
    with pytest.raises(ValueError, match=named):
        RealtimeOffset(**kwargs)


def stamp_steps_under_preemption(offset_ns, seconds=1.0):
    """(smallest, largest) step between the stamps ``t_i + offset_ns()`` of monotonic times t_i 1 ms apart, taken
    back to back for ``seconds`` of wall time while two busy threads compete with this one for the interpreter (its
    switch interval is 5 ms, so a thread is preempted between any two reads now and then) and for the cores."""
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            pass

    threads = [threading.Thread(target=spin) for _ in range(2)]
    for t in threads:
        t.start()
    try:
        end = time.monotonic() + seconds
        tick_ns, previous = 0, None
        smallest, largest = None, None
        while time.monotonic() < end:
            stamp = tick_ns + offset_ns()
            if previous is not None:
                step = stamp - previous
                smallest = step if smallest is None else min(smallest, step)
                largest = step if largest is None else max(largest, step)
            previous = stamp
            tick_ns += 1_000_000
    finally:
        stop.set()
        for t in threads:
            t.join()
    return smallest, largest


def test_stamps_increase_while_busy_threads_preempt_the_reader():
    """Each kept measurement is within max_bracket_ns / 2 (50 us) of the true offset, and the clocks drift apart by
    at most NTP's 500 ppm slew over the 0.1 s between measurements (50 us), so a refresh moves the offset by at most
    150 us: the steps of stamps 1 ms apart stay within 1 ms +- 0.25 ms however the reader is preempted. The one
    exception, a wide provisional first offset, needs all three of the first call's brackets (each ~1 us) preempted,
    and a preemption hands the thread a fresh time slice for the next."""
    offset = RealtimeOffset()
    smallest, largest = stamp_steps_under_preemption(offset.ns)
    assert 750_000 < smallest and largest < 1_250_000, (smallest, largest, offset.rejected)

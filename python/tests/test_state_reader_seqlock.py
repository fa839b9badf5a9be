# SPDX-License-Identifier: Apache-2.0
"""hapticd_client.StateReader against a segment written by this test (include/hapticd/state_layout.hpp): a writer
held inside a publication (the sequence odd) is waited for; one that never leaves it (stalled, or killed
mid-write) makes read() raise "transport" once the stale age has passed, not at once and not never."""
from __future__ import annotations

import mmap
import os
import struct
import threading
import time

import pytest

from daemon_support import hc

SIZE = 1152  # sizeof(StateLayout), layout version 2


def write_segment(path, period_s):
    """Header (magic, version 2, size, 3 axes, period), an even sequence, tick 1."""
    buf = bytearray(SIZE)
    struct.pack_into("<IIIIdI", buf, 0, 0x54535048, 2, SIZE, 3, period_s, 64)
    struct.pack_into("<iI", buf, 32, os.getpid(), 7)
    struct.pack_into("<Q", buf, 64, 2)
    struct.pack_into("<Q", buf, 128, 1)
    with open(path, "wb") as f:
        f.write(bytes(buf))


@pytest.fixture
def segment():
    name = f"/hapticd-seqlock-{os.getpid()}"
    path = hc.shm_path(name)
    yield name, path
    if os.path.exists(path):
        os.unlink(path)


def test_the_reader_waits_for_a_writer_held_inside_a_publication(segment):
    name, path = segment
    write_segment(path, 0.1)  # stale age 1 s: fifty times the 20 ms hold below
    with open(path, "r+b") as f, mmap.mmap(f.fileno(), SIZE) as m, hc.StateReader(name) as reader:
        assert reader.stale_after_s == pytest.approx(1.0)
        struct.pack_into("<Q", m, 64, 3)  # odd: inside a publication

        def finish():
            time.sleep(0.02)
            struct.pack_into("<Q", m, 128, 2)
            struct.pack_into("<Q", m, 64, 4)

        writer = threading.Thread(target=finish)
        writer.start()
        try:
            s = reader.read(max_attempts=1)
        finally:
            writer.join()
        assert s.tick == 2


def test_the_reader_gives_up_on_a_writer_that_never_leaves_its_publication_after_the_stale_age(segment):
    name, path = segment
    write_segment(path, 1e-3)  # stale age 50 ms
    with hc.StateReader(name) as reader:
        assert reader.read().tick == 1
        with open(path, "r+b") as f, mmap.mmap(f.fileno(), SIZE) as m:
            struct.pack_into("<Q", m, 64, 5)
        start = time.monotonic()
        with pytest.raises(hc.HapticdError) as e:
            reader.read()
        assert time.monotonic() - start >= 0.05
        assert e.value.code == "transport" and "one write lasted over 0.050 s" in str(e.value)

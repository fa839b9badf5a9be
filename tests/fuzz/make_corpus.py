#!/usr/bin/env python3
"""Writes the small seed corpora of tests/fuzz/corpus/<target>/ (run from anywhere; deterministic).
The config corpus also takes the repository's own config files. Re-run after changing a format."""
import pathlib
import random
import shutil

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent
CORPUS = HERE / "corpus"
rng = random.Random(20110925)


def put(target, name, data):
    d = CORPUS / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())


# config_file: the shipped files and one example of each issue the checker reports.
for f in [ROOT / "config" / "hapticd.toml", *sorted((ROOT / "config" / "devices").glob("*.toml"))]:
    put("config_file", f.name, f.read_bytes())
for i, text in enumerate([
    "", "# only a comment\n", "[table]\nkey = 1\n", "key value\n", "bad key! = 1\n", "key =\n",
    "a = 1\na = 2\n", "s = 'literal'\nt = \"basic \\\" esc\"\n", "f = 1.5e-3\ng = inf\nh = -nan\nb = true\n",
    "arr = [1, 2,\n  3, # comment\n  4]\n", "arr = [1, 2\n", "x = \"unterminated\n", "k = 1 # trailing\r\n",
    "k = [\"a\", 'b', 1.0, true]\n", "k = 0x10\n", "=\n", "k = [[1], [2]]\n",
]):
    put("config_file", f"case{i:02d}.toml", text)


# falcon_frames: valid status frames, a stream with garbage, a short frame and a malformed one.
def status(enc, homed, buttons):
    p = [0x3C]
    for v in enc:
        bits = v & 0xFFFF
        p += [((bits >> (4 * n)) & 0xF) + 0x41 for n in range(4)]
    p += [(((homed & 7) << 4) | (buttons & 0xF)) + 0x41, 0x41, 0x3E]
    return bytes(p)


frames = [status((0, 0, 0), 0, 0), status((1000, -1000, 32767), 7, 15), status((-32768, 5, -1), 3, 1)]
put("falcon_frames", "one", bytes([16]) + frames[0])
put("falcon_frames", "stream", bytes([5]) + b"xx" + frames[1] + frames[2][:9] + frames[0] + b"\x00>" + frames[2])
bad = bytearray(frames[1]); bad[5] = 0x20
put("falcon_frames", "malformed", bytes([3]) + bytes(bad) + frames[0])
put("falcon_frames", "torques", bytes([1, 0x00, 0x80, 0xFF, 0x7F, 0x10, 0x00, 0x0F]) + frames[2])

# ftdi_strip: sizes around the 64-byte chunking.
for n in (0, 1, 2, 3, 63, 64, 65, 66, 128, 130, 200):
    put("ftdi_strip", f"size{n:03d}", bytes(rng.randrange(256) for _ in range(n)))

# hid_reports: 8 layout bytes, then the report.
def hid(layout, report):
    return bytes(layout) + bytes(report)

put("hid_reports", "position_i16", hid([1, 5, 1 | 4, 1, 0, 0x12, 10, 50], [1, 0, 0, 0, 0, 0x34, 0x12]))
put("hid_reports", "position_u32", hid([1, 3, 2, 0, 3, 0x12, 0, 5], [1, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF]))
put("hid_reports", "position_u8_end", hid([2, 4, 0, 1, 0, 0x12, 0, 1], [2, 0, 0, 0, 0x80]))
put("hid_reports", "width3", hid([1, 1, 3, 1, 0, 0x12, 0, 1], [1, 1, 2, 3, 4, 5]))
put("hid_reports", "short", hid([1, 5, 1, 1, 0, 0x12, 0, 1], [1, 0, 0]))
put("hid_reports", "block_load_ok", hid([9, 1, 1, 1, 0, 0x12, 0, 1], [0x12, 3, 1, 0, 1]))
put("hid_reports", "block_load_full", hid([9, 1, 1, 1, 0, 0x12, 0, 1], [0x12, 3, 2, 0, 1]))
put("hid_reports", "empty_report", hid([0, 0, 0, 0, 0, 0, 0, 0], []))

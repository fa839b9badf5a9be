#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""How long a ctest -j2 run of a built tree lasts in each test order, from the tree's measured test costs.

Reads <tree>/Testing/Temporary/CTestCostData.txt (each test's wall time from earlier runs) and the tree's tests in
definition order (ctest --show-only=json-v1, with the ctest selection arguments given after the tree), and schedules
them as ctest -jN does: each test to the first free slot, a RUN_SERIAL test alone once every slot is free. Prints the
end of the run in definition order (a fresh tree without cost data), with the tests matching --first started first
(their COST property), and in descending order of measured cost (a tree with cost data). A model: tests that sleep
or spawn processes share the cores differently in a real run.

Usage: scripts/ctest-schedule.py [--slots N] [--first REGEX] BUILD_DIR [ctest selection arguments...]
  e.g. scripts/ctest-schedule.py --first '^compile_time' build/release
"""
import argparse
import json
import re
import subprocess
import sys


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slots", type=int, default=2)
    parser.add_argument("--first", default=None, help="regex of the tests started first")
    parser.add_argument("tree")
    parser.add_argument("selection", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    listing = json.loads(subprocess.check_output(["ctest", "--test-dir", args.tree, "--show-only=json-v1", *args.selection]))
    serial = {t["name"] for t in listing["tests"]
              if any(p["name"] == "RUN_SERIAL" and p["value"] for p in t.get("properties", []))}
    cost = {}
    with open(f"{args.tree}/Testing/Temporary/CTestCostData.txt") as data:
        for line in data:
            if line.startswith("---"):
                break
            parts = line.split()
            if len(parts) == 3:
                cost[parts[0]] = float(parts[2])
    defined = [t["name"] for t in listing["tests"] if t["name"] in cost]

    def end_of_run(order):
        slots = [0.0] * args.slots
        for name in order:
            if name in serial:
                slots = [max(slots) + cost[name]] * args.slots
            else:
                slots[slots.index(min(slots))] += cost[name]
        return max(slots)

    print(f"{args.tree}: {len(defined)} tests with a measured cost ({len(listing['tests'])} selected), "
          f"{sum(cost[n] for n in defined):.0f} s in all, {args.slots} slots")
    print(f"  definition order: {end_of_run(defined):.0f} s")
    if args.first:
        first = re.compile(args.first)
        print(f"  {args.first} first: {end_of_run(sorted(defined, key=lambda n: 0 if first.search(n) else 1)):.0f} s")
    print(f"  by measured cost: {end_of_run(sorted(defined, key=lambda n: -cost[n])):.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

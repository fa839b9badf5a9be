#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""How conservative passivity is: for d = 0..6 and delta in {0.02, 0.1}, the largest passive
alpha against alpha_max, and the best passive cost against the optimal cost for C_E2 and C_I2, each from
one `hapticopt` call (boundary --passivity, optimum [--passive]). Prints the Markdown table of
docs/passivity.md. Usage: docs/passivity/passivity_table.py PATH/TO/hapticopt"""
import json
import subprocess
import sys


def cli(binary, *args):
    out = subprocess.run([binary, *args, "--json"], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else "hapticopt"
    print("| d | delta | largest passive alpha (at beta) | alpha_max | ratio | CE2 passive | CE2 optimal | ratio "
          "| CI2 passive | CI2 optimal | ratio |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for delta in ("0.02", "0.1"):
        for d in range(7):
            plant = ["--delta", delta, "--delay", str(d)]
            b = cli(binary, "boundary", "--passivity", "--points", "8", *plant)
            row = [str(d), delta, "%.6f (%.6f)" % (b["largest_passive_alpha"], b["beta_at_largest_passive_alpha"]),
                   "%.6f" % b["alpha_max"], "%.4f" % (b["largest_passive_alpha"] / b["alpha_max"])]
            for criterion in ("CE2", "CI2"):
                passive = cli(binary, "optimum", "--criterion", criterion, "--passive", *plant)
                optimal = cli(binary, "optimum", "--criterion", criterion, *plant)
                row += ["%.5g" % passive["cost"], "%.5g" % optimal["cost"], "%.1f" % (passive["cost"] / optimal["cost"])]
            print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()

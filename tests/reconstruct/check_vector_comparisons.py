#!/usr/bin/env python3
"""Checks that the vector kernels' AVX-512 and AVX2 clones compare in vector registers.

GCC 12 once compiled the lanes' comparisons in these clones into one scalar `vcomisd` a lane
(1,144 in the range kernel's AVX-512 clone, 1,656 in the solve's), which made the range kernel
1.4-1.9x slower with the same results (reconstruct/simd_lanes.inc, docs/speed.md). The
functions below have no scalar double comparison of their own, so any `vcomisd` in them is
that again. (Pisarenko's clones are not checked: their per-pixel scalar code compares doubles.)

usage: check_vector_comparisons.py LIBRARY [OBJDUMP]
"""
import re
import subprocess
import sys

# Each clone's name; every one must be found, so that a rename cannot pass unchecked.
CLONES = [
    f"{name}{level}"
    for name in ("RangeBlock", "SolveBlockLanes", "CumulativeLanes", "LogAndArgLanes")
    for level in ("V4", "V3")
]
FUNCTION = re.compile(r"^[0-9a-f]+ <(.*)>:$")


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    library = sys.argv[1]
    objdump = sys.argv[2] if len(sys.argv) == 3 else "objdump"
    listing = subprocess.run([objdump, "-d", "--no-show-raw-insn", "-C", library],
                             check=True, capture_output=True, text=True).stdout
    counts = {}  # clone -> vcomisd in it
    clone = None
    for line in listing.splitlines():
        match = FUNCTION.match(line)
        if match:
            name = match.group(1)
            clone = next((c for c in CLONES if re.search(rf"::{c}\(", name)), None)
            if clone is not None:
                counts.setdefault(clone, 0)
            continue
        if clone is not None and "\tvcomisd" in line:
            counts[clone] += 1
    missing = [c for c in CLONES if c not in counts]
    if missing:
        sys.exit(f"{library}: no function named {', '.join(missing)}; "
                 "update this check's list of clones")
    scalar = {c: n for c, n in counts.items() if n > 0}
    for c in CLONES:
        print(f"{c}: {counts[c]} scalar comparisons (vcomisd)")
    if scalar:
        sys.exit("comparisons compiled one lane at a time in "
                 + ", ".join(f"{c} ({n})" for c, n in scalar.items())
                 + ": see reconstruct/simd_lanes.inc on Vm")
    print(f"{len(CLONES)} clones compare in vector registers")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Summarises Nsight Compute's source page (`ncu --import R --page source
--csv --print-source cuda,sass`, a kernel built with -lineinfo) per source
file: the SASS instructions executed at all (the code the instruction cache
must hold), the warp instructions executed, and the warp-state samples.
  bench/ncu_hot.py SOURCE.csv [FILE_SUBSTRING]
With FILE_SUBSTRING, the same per line of the files whose path holds it."""
import collections
import csv
import sys


def load(path):
    """[(file, line, source text, [(address, executed, samples)])]"""
    rows, file, cur, cols = [], None, None, None
    with open(path, newline="") as f:
        for r in csv.reader(f):
            if not r:
                continue
            if r[0] == "File Path":
                file = r[1]
            elif r[0] == "Line No":
                cols = {name: i for i, name in enumerate(r) if i >= 2}
            elif r[0] and r[0] != "Function Name" and cols:
                cur = (file, int(r[0]), r[1], [])
                rows.append(cur)
            elif cur and cols and len(r) > 3 and r[2].startswith("0x"):
                num = lambda name: int((r[cols[name]] or "0").replace(",", "")) if name in cols else 0
                cur[3].append((int(r[2], 16), num("Instructions Executed"), num("# Samples")))
    return rows


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    rows = load(sys.argv[1])
    hot = {}  # address -> executed, once per instruction
    for _, _, _, sass in rows:
        for a, n, _ in sass:
            hot[a] = max(hot.get(a, 0), n)
    print("SASS instructions executed at all: %d of %d listed; warp instructions executed: %d"
          % (sum(1 for n in hot.values() if n), len(hot), sum(hot.values())))
    key = (lambda r: (r[0], r[1], r[2])) if len(sys.argv) == 3 else (lambda r: (r[0],))
    agg = collections.defaultdict(lambda: [0, 0, 0])
    for r in rows:
        if len(sys.argv) == 3 and sys.argv[2] not in r[0]:
            continue
        a = agg[key(r)]
        a[0] += sum(1 for _, n, _ in r[3] if n)
        a[1] += sum(n for _, n, _ in r[3])
        a[2] += sum(s for _, _, s in r[3])
    print("%8s %14s %9s  %s" % ("hot", "executed", "samples", "file" if len(sys.argv) == 2 else "line"))
    for k, (h, n, s) in sorted(agg.items(), key=lambda kv: -kv[1][0]):
        if h:
            where = k[0] if len(k) == 1 else "%s:%d  %s" % (k[0].rsplit("/", 1)[-1], k[1], k[2].strip()[:80])
            print("%8d %14d %9d  %s" % (h, n, s, where))


if __name__ == "__main__":
    main()

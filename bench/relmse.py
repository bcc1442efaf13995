#!/usr/bin/env python3
"""relMSE of an image against a reference, as bench/reference.h takes it:
the mean over pixels and channels of (x - r)² / (r² + 0.01). Both PFM
(what `luz render -o X.pfm` writes), of one size.
  bench/relmse.py REFERENCE.pfm IMAGE.pfm"""
import struct
import sys

K_EPS = 0.01


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        if kind not in (b"PF", b"Pf"):
            sys.exit(f"relmse: {path}: not a PFM")
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        n = width * height * (3 if kind == b"PF" else 1)
        data = f.read(4 * n)
        if len(data) != 4 * n:
            sys.exit(f"relmse: {path}: truncated")
        return (width, height, kind), struct.unpack(("<" if scale < 0 else ">") + f"{n}f", data)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: bench/relmse.py REFERENCE.pfm IMAGE.pfm")
    (shape_r, ref), (shape_x, img) = read_pfm(sys.argv[1]), read_pfm(sys.argv[2])
    if shape_r != shape_x:
        sys.exit(f"relmse: {sys.argv[2]} is {shape_x[0]}x{shape_x[1]}, the reference {shape_r[0]}x{shape_r[1]}")
    print(f"{sum((x - r) ** 2 / (r * r + K_EPS) for x, r in zip(img, ref)) / len(ref):.6g}")


main()

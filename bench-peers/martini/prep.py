"""Decode a DEM to metres and make it a (2^k+1)^2 grid for martini: a 2^k tile is padded by
replicating its last row and column (martini's own convention); other sizes are cropped to the
largest 2^k+1 square. Writes little-endian f32, row-major.

usage: prep.py IN FORMAT OUT.f32    (FORMAT: png-dm | terrain-rgb | terrarium | tiff)
prints: N (the side, 2^k+1)
"""
import sys

import numpy as np
from PIL import Image


def decode(path, fmt):
    a = np.array(Image.open(path))
    if fmt in ("png-dm", "tiff"):
        a = a.astype(np.float64)
        return a * 0.1 if fmt == "png-dm" else a
    rgb = a[..., :3].astype(np.float64)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    if fmt == "terrain-rgb":
        return -10000.0 + (r * 65536.0 + g * 256.0 + b) * 0.1
    if fmt == "terrarium":
        return r * 256.0 + g + b / 256.0 - 32768.0
    raise SystemExit(f"unknown format {fmt}")


def main():
    src, fmt, out = sys.argv[1:4]
    h = decode(src, fmt)
    rows, cols = h.shape
    m = min(rows, cols)
    if m & (m - 1) == 0:  # 2^k: pad by one replicated row and column
        h = h[:m, :m]
        h = np.vstack([h, h[-1:, :]])
        h = np.hstack([h, h[:, -1:]])
    else:
        k = 1
        while 2 * k + 1 <= m:
            k *= 2
        h = h[: k + 1, : k + 1]
    h.astype("<f4").tofile(out)
    print(h.shape[0])


main()

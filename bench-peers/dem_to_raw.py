"""Decode a DEM (16-bit PNG, Terrain-RGB, Terrarium, TIFF) to raw little-endian f32 so that every
tool in the TIN comparison reads bit-identical heights (CONVENTIONS.md decoding rules).

usage: dem_to_raw.py IN FORMAT OUT.f32   (FORMAT: png | terrain-rgb | terrarium | tiff)
prints: WIDTH HEIGHT
"""
import sys

import numpy as np
from PIL import Image


def decode(path, fmt):
    img = Image.open(path)
    a = np.array(img)
    if fmt in ("png", "tiff"):
        if a.ndim != 2:
            raise SystemExit(f"{path}: expected one band, got shape {a.shape}")
        return a.astype(np.float64)
    rgb = a[..., :3].astype(np.float64)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    if fmt == "terrain-rgb":
        return -10000.0 + (r * 65536.0 + g * 256.0 + b) * 0.1
    if fmt == "terrarium":
        return r * 256.0 + g + b / 256.0 - 32768.0
    raise SystemExit(f"unknown format {fmt}")


def main():
    src, fmt, out = sys.argv[1:4]
    h = decode(src, fmt).astype("<f4")
    if not np.isfinite(h).all():
        raise SystemExit(f"{src}: non-finite heights")
    h.tofile(out)
    print(h.shape[1], h.shape[0])


if __name__ == "__main__":
    main()

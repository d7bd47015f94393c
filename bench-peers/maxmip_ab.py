"""A/B of `relief` binaries on the max-mip method: the fourteen views of embree_rays.sh (every
DEM of its list, camera and grazing), 384 x 256 rays, `--surface triangles --threads 1`, each
binary in turn. Prints, per view, each binary's walk steps and chunked rays per second
(`--chunk-rays 4096 --chunk-reps 9`, `rays_per_s_chunked`), and whether all binaries wrote the
same depth image. No Embree run: for changes to the walk, where the image must not change.

usage (from the repository root, with the venv of embree_rays.sh, which has numpy and embreex):
    /tmp/venv-embree/bin/python bench-peers/maxmip_ab.py BIN_A BIN_B [BIN_A BIN_B ...]
env: PACKET=1 times the AVX-512 packets (default: ray by ray, `--no-packet`); WIDE=1 ray by ray
through sixteen-wide nodes (`--no-packet --wide`, the best form for the CPU); ONLY="puget fuji"
limits the DEMs; VIEWS="camera grazing low" picks the views (default camera and grazing;
`low` is embree_trace.py's level view from just above the ground); SURFACE=bilinear (plane, nearest) traces another surface; SHOW=1 prints each
view's `relief trace` command (for profiling one view by hand); the DEMs' raw files are kept
in the temporary folder it names. List a binary twice, alternated, to see the machine's drift.
IR=1 counts instructions instead of timing (valgrind's cachegrind, `--chunk-reps 1`, so each
view traces its rays twice): the instructions executed in the tracing code (functions under
`relief_core::ray`, less the pyramid's build and the tracer's height scan), which, unlike the
time, do not move with the machine's load. IR=functions prints them by function too (the shares
BENCHMARKS.md quotes for "where the default walk's time goes").
"""
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import numpy as np  # noqa: E402
from embree_trace import fmt, view  # noqa: E402

DATA = "../shared/data"
# name file format dx dy z-multiplier: the list of embree_rays.sh
DEMS = [
    ("puget", "data/puget_sound_1k.png", "png", "160", "160", "0.1"),
    ("fuji", f"{DATA}/martini_fuji.png", "terrain-rgb", "62.4", "62.4", "1"),
    ("bayhills", f"{DATA}/delatin_14-2625-6369.png", "terrain-rgb", "3.81", "3.81", "1"),
    ("sthelens", f"{DATA}/pymartini_mapbox_st_helens.png", "terrain-rgb", "6.61", "6.61", "1"),
    ("canyon", f"{DATA}/pymartini_terrarium.png", "terrarium", "61.8", "61.8", "1"),
    ("tujunga", f"{DATA}/topotoolbox_srtm_bigtujunga30m_utm11.tif", "tiff", "30", "30", "1"),
    ("pysheds", f"{DATA}/pysheds_dem.tif", "tiff", "77.9", "92.6", "1"),
]


def ray_instructions(cmd, tmp, by_function=None):
    """Instructions executed in `relief_core::ray` functions by `cmd`, under cachegrind; adds
    each function's count to the dict `by_function` when one is given."""
    cg = os.path.join(tmp, "cachegrind.out")
    cmd = ["valgrind", "--tool=cachegrind", "--cache-sim=no", f"--cachegrind-out-file={cg}"] + cmd
    subprocess.run(cmd, check=True, capture_output=True)
    rows = subprocess.run(
        ["cg_annotate", "--show=Ir", "--show-percs=no", "--auto=no", "--threshold=0", cg],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.splitlines()
    total = 0
    for row in rows:
        m = re.match(r"\s*([0-9,]+)\s+\S*?:(.*)$", row)
        # The tracing code: `relief_core::ray`, less the pyramid's build and the tracer's
        # height scan, which come before the timed tracing.
        f = m.group(2) if m else ""
        if "relief_core::ray" in f and "MaxMip::build" not in f and "RayTracer<T>::new" not in f:
            n = int(m.group(1).replace(",", ""))
            total += n
            if by_function is not None:
                name = f.strip().split("::")[-1]
                by_function[name] = by_function.get(name, 0) + n
    return total


def main():
    bins = sys.argv[1:]
    if not bins:
        sys.exit(__doc__)
    packet = os.environ.get("PACKET", "0") == "1"
    ir = os.environ.get("IR", "0") in ("1", "functions")
    by_fn = os.environ.get("IR") == "functions"
    wide = os.environ.get("WIDE", "0") == "1"
    only = os.environ.get("ONLY", "").split()
    tmp = tempfile.mkdtemp()
    out = os.path.join(tmp, "depth.f32")
    what = "M instructions" if ir else "steps, M rays/s"
    print("| DEM | view | " + " | ".join(f"{os.path.basename(b)}: {what}" for b in bins) + " | images |")
    print("|---|---|" + "---|" * len(bins) + "---|")
    for name, path, fm, dx, dy, zmul in DEMS:
        if only and name not in only:
            continue
        raw = os.path.join(tmp, f"{name}.raw")
        dims = subprocess.run(
            [sys.executable, os.path.join(os.path.dirname(__file__), "dem_to_raw.py"), path, fm, raw],
            check=True,
            capture_output=True,
            text=True,
        ).stdout.split()
        gw, gh = int(dims[0]), int(dims[1])
        z = np.fromfile(raw, "<f4") * np.float32(float(zmul))
        z.astype("<f4").tofile(raw)
        z = z.astype(np.float64).reshape(gh, gw)
        for vn in os.environ.get("VIEWS", "camera grazing").split():
            eye, target, fov = view(vn, z, float(dx), float(dy))
            eye = eye.astype(np.float32).astype(np.float64)
            target = target.astype(np.float32).astype(np.float64)
            cells, images = [], set()
            for b in bins:
                cmd = [
                    b, "trace", "--dem", raw, "--format", "raw-f32", "--width", str(gw),
                    "--height", str(gh), "--dx", dx, "--dy", dy, "--eye", fmt(eye),
                    "--target", fmt(target), "--fov", str(fov), "--size", "384x256",
                    "--method", "maxmip", "--surface", os.environ.get("SURFACE", "triangles"), "--threads", "1",
                    "--out", out, "--json", "--chunk-rays", "4096", "--chunk-reps", "1" if ir else "9",
                ] + ([] if packet else ["--no-packet"]) + (["--wide"] if wide else [])
                if os.environ.get("SHOW") == "1":
                    print("    " + " ".join(cmd), flush=True)
                if ir:
                    funcs = {} if by_fn else None
                    n = ray_instructions(cmd, tmp, funcs)
                    cells.append(f"{n / 1e6:.1f}")
                    for f, k in sorted((funcs or {}).items(), key=lambda e: -e[1])[:8]:
                        print(f"    {os.path.basename(b)} {name} {vn}: {f} {k / 1e6:.1f} M ({100 * k / n:.1f}%)")
                else:
                    rj = json.loads(subprocess.run(cmd, check=True, capture_output=True).stdout)
                    cells.append(f"{rj['steps']}, {rj['rays_per_s_chunked'] / 1e6:.2f}")
                with open(out, "rb") as f:
                    images.add(hashlib.md5(f.read()).hexdigest())
            same = "same" if len(images) == 1 else "DIFFER"
            print(f"| {name} | {vn} | " + " | ".join(cells) + f" | {same} |", flush=True)


if __name__ == "__main__":
    main()

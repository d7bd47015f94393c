"""Run pydelatin (C++, fogleman/hmm) on a raw f32 DEM at several max errors.

usage: pydelatin_run.py RAW.f32 WIDTH HEIGHT REPEATS E [E ...]
prints one JSON object per E: tool, max_error, vertices, triangles, error (pydelatin's own),
ms (best of REPEATS runs of the whole build: data copy, triangulation) and cpu_ms (the same
build's CPU time of the calling thread, time.thread_time: leaves out waiting for a core).
"""
import json
import sys
import time

import numpy as np
from pydelatin import Delatin


def main():
    path, w, h, reps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    arr = np.fromfile(path, dtype="<f4").reshape(h, w)
    for e in map(float, sys.argv[5:]):
        best = best_cpu = float("inf")
        tin = None
        for _ in range(reps):
            c0 = time.thread_time()
            t0 = time.perf_counter()
            tin = Delatin(arr, max_error=e)
            best = min(best, (time.perf_counter() - t0) * 1e3)
            best_cpu = min(best_cpu, (time.thread_time() - c0) * 1e3)
        print(json.dumps({
            "tool": "pydelatin",
            "max_error": e,
            "vertices": int(tin.vertices.shape[0]),
            "triangles": int(tin.triangles.shape[0]),
            "error": float(tin.error),
            "ms": best,
            "cpu_ms": best_cpu,
        }), flush=True)


if __name__ == "__main__":
    main()

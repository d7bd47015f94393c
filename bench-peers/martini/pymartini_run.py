"""pymartini 0.6.0 on a raw f32 (2^k+1)^2 grid: create_tile and get_mesh times (best of REPS) at
each E and at martini's equal-measured-error E' (pymartini ports martini: same meshes).

usage: pymartini_run.py RAW N REPS E:E' ...   prints one JSON line per E.
"""
import json
import sys
import time

import numpy as np
from pymartini import Martini

raw, n, reps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
terrain = np.fromfile(raw, dtype="<f4", count=n * n).reshape(n, n)


def best(f):
    t, r = float("inf"), None
    for _ in range(reps):
        s = time.perf_counter()
        r = f()
        t = min(t, (time.perf_counter() - s) * 1e3)
    return t, r


martini = Martini(n)
create_ms, tile = best(lambda: martini.create_tile(terrain))
for pair in sys.argv[4:]:
    e, e_eq = (float(x) for x in pair.split(":"))
    ms, (v, t) = best(lambda: tile.get_mesh(e))
    ms_eq, (v2, t2) = best(lambda: tile.get_mesh(e_eq))
    print(json.dumps({"tool": "pymartini", "n": n, "E": e, "create_ms": create_ms, "mesh_ms": ms,
                      "triangles": t.size // 3, "E_equal": e_eq, "mesh_ms_equal": ms_eq,
                      "triangles_equal": t2.size // 3}))

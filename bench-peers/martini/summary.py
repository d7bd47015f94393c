"""Markdown tables from martini_peers.sh's JSON lines: per DEM and E, triangles at equal
measured error (relief at E against martini at E') and times as ratios in the same run."""
import json
import sys
from collections import defaultdict

rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
by = defaultdict(dict)
for r in rows:
    by[(r["dem"], r["E"])][r["tool"]] = r

print("| DEM (grid) | E (m) | relief tris (measured err) | martini at E: tris (measured err) | martini E' | martini tris at E' | relief / martini tris at equal error | relief mesh ms: fresh buffers (reused buffers) | martini getMesh ms | pymartini get_mesh ms | speed-up vs martini / pymartini (tris/s), fresh buffers | same, relief into reused buffers | same, relief with the peers' protocol (fresh buffers per call, fastest of 3 in one process) | same, relief writing grid-coordinate vertices as the peers do (peers' protocol) |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
tot_r = tot_m = 0
worst = 0
for (dem, e), t in sorted(by.items(), key=lambda k: (k[0][0], k[0][1])):
    r, m, p = t.get("relief-full"), t.get("martini"), t.get("pymartini")
    if not (r and m):
        continue
    ratio = r["triangles"] / m["triangles_equal"]
    worst = max(worst, ratio)
    tot_r += r["triangles"]
    tot_m += m["triangles_equal"]
    rr = r["triangles"] / r["mesh_ms"]
    sm = rr / (m["triangles"] / m["mesh_ms"])
    sp = rr / (p["triangles"] / p["mesh_ms"]) if p else float("nan")
    ru = r.get("mesh_reused_ms", float("nan"))
    um = (r["triangles"] / ru) / (m["triangles"] / m["mesh_ms"])
    up = (r["triangles"] / ru) / (p["triangles"] / p["mesh_ms"]) if p else float("nan")
    rf = r.get("mesh_fresh_repeat_ms", float("nan"))
    fm = (r["triangles"] / rf) / (m["triangles"] / m["mesh_ms"])
    fp = (r["triangles"] / rf) / (p["triangles"] / p["mesh_ms"]) if p else float("nan")
    g = t.get("relief-full-grid")
    if g:
        assert g["triangles"] == r["triangles"], (dem, e)
        gf = g["mesh_fresh_repeat_ms"]
        gm = (g["triangles"] / gf) / (m["triangles"] / m["mesh_ms"])
        gp = (g["triangles"] / gf) / (p["triangles"] / p["mesh_ms"]) if p else float("nan")
        grid = f"{gm:.1f}x / {gp:.1f}x ({gf:.2f} ms)"
    else:
        grid = "n/a"
    print(f"| {dem} ({r['n']}^2) | {e:g} | {r['triangles']} ({r['measured']:.3f}) | {m['triangles']} ({m['measured']:.3f}) | {m['E_equal']:.4g} | {m['triangles_equal']} | {ratio:.3f} | {r['mesh_ms']:.2f} ({ru:.2f}) | {m['mesh_ms']:.2f} | {p['mesh_ms'] if p else float('nan'):.2f} | {sm:.1f}x / {sp:.1f}x | {um:.1f}x / {up:.1f}x | {fm:.1f}x / {fp:.1f}x ({rf:.2f} ms) | {grid} |")
print()
print(f"Total triangles at equal measured error: relief {tot_r}, martini {tot_m}, ratio {tot_r / max(tot_m, 1):.3f}; worst single case {worst:.3f}.")
print()
print("| DEM | relief preprocess ms (full / compact), first call in its process | the same, fastest of 3 more calls in the process (the peers' protocol) | martini createTile ms | pymartini create_tile ms | relief compact / martini: first call, peers' protocol |")
print("|---|---|---|---|---|---|")
seen = set()
for (dem, e), t in sorted(by.items()):
    if dem in seen or "martini" not in t:
        continue
    seen.add(dem)
    rf, rc, m, p = t.get("relief-full"), t.get("relief-compact"), t["martini"], t.get("pymartini")
    fq, cq = rf.get("create_repeat_ms", float("nan")), rc.get("create_repeat_ms", float("nan"))
    print(f"| {dem} | {rf['create_ms']:.1f} / {rc['create_ms']:.1f} | {fq:.1f} / {cq:.1f} | {m['create_ms']:.1f} | {p['create_ms'] if p else float('nan'):.1f} | {rc['create_ms'] / m['create_ms']:.2f} / {cq / m['create_ms']:.2f} |")

"""Summarise tin_peers.sh JSON lines: per DEM and E, triangles and times of relief-tin, pydelatin
and JS delatin, with the ratios the TIN issue asks about (triangles and time vs pydelatin, time
vs JS delatin), each tool's fastest run. Reads JSON lines on stdin, prints a Markdown table
and a summary line: how many cases meet triangles <= 1.05x and time <= 2x of pydelatin, and
time below JS delatin."""
import json
import sys

rows = {}
for line in sys.stdin:
    line = line.strip()
    if not line.startswith("{"):
        continue
    r = json.loads(line)
    t = rows.setdefault((r["dem"], r["max_error"]), {})
    # Several rounds: keep the fastest run of each tool (counts are identical across runs).
    if r["tool"] not in t or r["ms"] < t[r["tool"]]["ms"]:
        t[r["tool"]] = r

print("| DEM | E | relief tris | pydelatin tris | tris ratio | relief ms | pydelatin ms | time ratio | delatin-js ms | relief/js |")
print("|---|---|---|---|---|---|---|---|---|---|")
for (dem, e), t in rows.items():
    r, p, j = t.get("relief-tin"), t.get("pydelatin"), t.get("delatin-js")
    if not (r and p and j):
        continue
    print(f"| {dem} | {e:g} | {r['triangles']} | {p['triangles']} | {r['triangles'] / p['triangles']:.3f} "
          f"| {r['ms']:.1f} | {p['ms']:.1f} | {r['ms'] / p['ms']:.2f} | {j['ms']:.1f} | {r['ms'] / j['ms']:.2f} |")
n = ok_t = ok_ms = ok_js = 0
for (dem, e), t in rows.items():
    r, p, j = t.get("relief-tin"), t.get("pydelatin"), t.get("delatin-js")
    if r and p and j:
        n += 1
        ok_t += r["triangles"] <= 1.05 * p["triangles"]
        ok_ms += r["ms"] <= 2.0 * p["ms"]
        ok_js += r["ms"] < j["ms"]
print(f"\n{n} cases: triangles <= 1.05x pydelatin in {ok_t}, time <= 2x pydelatin in {ok_ms}, "
      f"faster than JS delatin in {ok_js}")

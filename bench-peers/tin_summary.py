"""Summarise tin_peers.sh JSON lines: per DEM and E, triangles and times of relief-tin, pydelatin
and JS delatin, with the ratios the TIN issue asks about (triangles and time vs pydelatin, time
vs JS delatin). Reads JSON lines on stdin, prints a Markdown table."""
import json
import sys

rows = {}
for line in sys.stdin:
    line = line.strip()
    if not line.startswith("{"):
        continue
    r = json.loads(line)
    rows.setdefault((r["dem"], r["max_error"]), {})[r["tool"]] = r

print("| DEM | E | relief tris | pydelatin tris | tris ratio | relief ms | pydelatin ms | time ratio | delatin-js ms | relief/js |")
print("|---|---|---|---|---|---|---|---|---|---|")
for (dem, e), t in rows.items():
    r, p, j = t.get("relief-tin"), t.get("pydelatin"), t.get("delatin-js")
    if not (r and p and j):
        continue
    print(f"| {dem} | {e:g} | {r['triangles']} | {p['triangles']} | {r['triangles'] / p['triangles']:.3f} "
          f"| {r['ms']:.1f} | {p['ms']:.1f} | {r['ms'] / p['ms']:.2f} | {j['ms']:.1f} | {r['ms'] / j['ms']:.2f} |")

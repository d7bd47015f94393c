"""Summarise tin_peers.sh JSON lines: per DEM and E, triangles and times of relief-tin, pydelatin
and JS delatin, with the ratios the TIN issue asks about (triangles and time vs pydelatin, time
vs JS delatin), each tool's fastest run. Reads JSON lines on stdin, prints a Markdown table
and a summary line: how many cases meet triangles <= 1.05x and time <= 2x of pydelatin, and
time below JS delatin, for wall-clock and for on-CPU time."""
import json
import sys

rows = {}
for line in sys.stdin:
    line = line.strip()
    if not line.startswith("{"):
        continue
    r = json.loads(line)
    t = rows.setdefault((r["dem"], r["max_error"]), {})
    # Several rounds: keep the fastest run of each tool (counts are identical across runs), for
    # wall-clock and on-CPU time separately.
    tool = t.setdefault(r["tool"], dict(r))
    tool["ms"] = min(tool["ms"], r["ms"])
    if r.get("cpu_ms") is not None:
        tool["cpu_ms"] = min(tool.get("cpu_ms") or float("inf"), r["cpu_ms"])


def cpu(x):
    return x.get("cpu_ms") or float("nan")


print("| DEM | E | relief tris | pydelatin tris | tris ratio | relief ms | pydelatin ms | time ratio "
      "| delatin-js ms | relief/js | relief CPU ms | pydelatin CPU ms | CPU ratio | delatin-js CPU ms "
      "| CPU relief/js |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for (dem, e), t in rows.items():
    r, p, j = t.get("relief-tin"), t.get("pydelatin"), t.get("delatin-js")
    if not (r and p and j):
        continue
    print(f"| {dem} | {e:g} | {r['triangles']} | {p['triangles']} | {r['triangles'] / p['triangles']:.3f} "
          f"| {r['ms']:.1f} | {p['ms']:.1f} | {r['ms'] / p['ms']:.2f} | {j['ms']:.1f} | {r['ms'] / j['ms']:.2f} "
          f"| {cpu(r):.1f} | {cpu(p):.1f} | {cpu(r) / cpu(p):.2f} | {cpu(j):.1f} | {cpu(r) / cpu(j):.2f} |")
n = ok_t = ok_ms = ok_js = ok_cpu = ok_cpu_js = 0
for (dem, e), t in rows.items():
    r, p, j = t.get("relief-tin"), t.get("pydelatin"), t.get("delatin-js")
    if r and p and j:
        n += 1
        ok_t += r["triangles"] <= 1.05 * p["triangles"]
        ok_ms += r["ms"] <= 2.0 * p["ms"]
        ok_js += r["ms"] < j["ms"]
        ok_cpu += cpu(r) <= 2.0 * cpu(p)
        ok_cpu_js += cpu(r) < cpu(j)
print(f"\n{n} cases: triangles <= 1.05x pydelatin in {ok_t}; wall-clock: time <= 2x pydelatin in {ok_ms}, "
      f"faster than JS delatin in {ok_js}; on-CPU: time <= 2x pydelatin in {ok_cpu}, "
      f"faster than JS delatin in {ok_cpu_js}")

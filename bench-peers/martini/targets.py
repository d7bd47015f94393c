#!/usr/bin/env python3
"""Issue 3's extraction targets (10x martini's getMesh, 6x pymartini's get_mesh) from one or
more result files of martini_peers.sh (OUT=...jsonl), one column per file, in the order given.

Cases: every DEM and E whose mesh has at least MIN triangles (default 100000). relief's time is
`relief-full-grid`'s refine_fresh_repeat_ms (grid-coordinate vertices, fresh buffers on every
call: the peers' own output format and protocol); the speed-ups are against the peers' times in
the same file (the same run), two ways: the issue's own measure, triangles per second (relief's
triangles over its time against the peer's triangles over its time, at the same E, where
relief's true bound makes a few per cent more triangles than martini's), and the stricter ratio
of the times alone. A case counts as met when both peers' targets are met; the closing line
counts each measure.

usage: bench-peers/martini/targets.py RUN1.jsonl [RUN2.jsonl ...]   (env: MIN=100000)
"""
import json
import os
import statistics
import sys

MIN = int(os.environ.get("MIN", "100000"))


def load(path):
    rows = {}
    for line in open(path):
        if line.strip():
            d = json.loads(line)
            rows[(d["dem"], d["E"], d["tool"])] = d
    return rows


runs = [load(p) for p in sys.argv[1:]]
if not runs:
    sys.exit(__doc__)
cases = sorted(
    {(dem, e) for r in runs for (dem, e, tool) in r if tool == "relief-full-grid"},
    key=lambda c: (c[0], c[1]),
)
head = "| DEM | E (m) | triangles | " + " | ".join(
    f"run {i + 1}: martini / pymartini ms; relief ms; speed-ups" for i in range(len(runs))
) + " |"
print(head)
print("|---|---|---|" + "---|" * len(runs))
met = [0] * len(runs)
met_time = [0] * len(runs)
# Per case, the speed-ups by triangles per second in every run, for the medians line.
ratios = {}
counted = 0
for dem, e in cases:
    cells = []
    tris = None
    for i, r in enumerate(runs):
        g = r.get((dem, e, "relief-full-grid"))
        m = r.get((dem, e, "martini"))
        p = r.get((dem, e, "pymartini"))
        if not (g and m and p):
            cells.append("-")
            continue
        tris = g["triangles"]
        t = g["mesh_fresh_repeat_ms"]
        # The peers' triangles: pymartini writes no vertex count but the same mesh as martini.
        pt = p.get("triangles", m["triangles"])
        sm, sp = m["mesh_ms"] / t, p["mesh_ms"] / t
        rm, rp = sm * tris / m["triangles"], sp * tris / pt
        both = rm >= 10 and rp >= 6
        strict = sm >= 10 and sp >= 6
        if tris >= MIN:
            met[i] += both
            met_time[i] += strict
            ratios.setdefault((dem, e), []).append((rm, rp))
        cells.append(
            f"{m['mesh_ms']:.2f} / {p['mesh_ms']:.2f}; {t:.2f}; triangles/s {rm:.1f}x / {rp:.1f}x"
            + (" (both met)" if both else "")
            + f"; time {sm:.1f}x / {sp:.1f}x"
            + (" (both met)" if strict else "")
        )
    if tris is None or tris < MIN:
        continue
    counted += 1
    print(f"| {dem} | {e} | {tris} | " + " | ".join(cells) + " |")
print()
print(
    f"Both targets met, cases of at least {MIN} triangles, by triangles per second: "
    + ", ".join(f"run {i + 1} {k} of {counted}" for i, k in enumerate(met))
    + "; by time alone: "
    + ", ".join(f"run {i + 1} {k} of {counted}" for i, k in enumerate(met_time))
)
if len(runs) > 1:
    # The median over the runs of each case's speed-ups (triangles per second), each peer's
    # separately: a reading less at the mercy of one disturbed run than "every run".
    med = {c: (statistics.median(r[0] for r in v), statistics.median(r[1] for r in v))
           for c, v in ratios.items()}
    short = [f"{dem} E = {e}: {m:.1f}x / {p:.1f}x" for (dem, e), (m, p) in sorted(med.items())
             if not (m >= 10 and p >= 6)]
    print(
        f"Medians over the {len(runs)} runs: both targets met in {len(med) - len(short)} of "
        f"{len(med)} cases" + (" (short: " + "; ".join(short) + ")" if short else "")
    )

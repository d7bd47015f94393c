#!/usr/bin/env bash
# A/B of two `relief mesh` binaries on the peer script's grids (view-independent, grid-coordinate
# vertices): the two alternated REPS times on each DEM and E; prints per case the kept share
# (vertices / samples), the fastest refine_ms (fresh output buffers, first call of the process)
# and refine_reused_ms (the same extraction into the touched buffers: the extraction alone) of
# each, and their ratios A / B (above 1: B faster).
#
# usage: bench-peers/martini/ab_mesh.sh A_RELIEF B_RELIEF
#   (env: REPS=7, ES="1 5 20 50", DEMS="name:format ..." as in martini_peers.sh, DATA=../shared/data)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
A=$1
B=$2
DATA=${DATA:-$root/../shared/data}
REPS=${REPS:-7}
ES=${ES:-1 5 20 50}
DEMS=${DEMS:-topotoolbox_srtm_bigtujunga30m_utm11.tif:tiff diligent_ps_height_1k.png:png-dm martini_fuji.png:terrain-rgb delatin_14-2625-6369.png:terrain-rgb pysheds_dem.tif:tiff}
cd "$here"
if [ ! -x .venv/bin/python ]; then python3 -m venv .venv; fi
.venv/bin/python -c "import numpy, PIL" 2>/dev/null || .venv/bin/pip install -q numpy pillow
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| DEM | E (m) | triangles | kept share | refine_ms A | refine_ms B | A / B | refine_reused_ms A | refine_reused_ms B | A / B |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for spec in $DEMS; do
    IFS=: read -r name fmt <<<"$spec"
    raw="$tmp/${name%.*}.f32"
    n=$(.venv/bin/python prep.py "$DATA/$name" "$fmt" "$raw")
    for e in $ES; do
        : > "$tmp/a.jsonl"
        : > "$tmp/b.jsonl"
        for _ in $(seq "$REPS"); do
            for side in a b; do
                bin=$A
                [ "$side" = b ] && bin=$B
                "$bin" mesh --dem "$raw" --format raw-f32 --width "$n" --height "$n" \
                    --max-error "$e" --vertices grid --out "$tmp/m.obj" --json >> "$tmp/$side.jsonl"
            done
        done
        .venv/bin/python - "$tmp/a.jsonl" "$tmp/b.jsonl" "$name" "$e" "$n" <<'PY'
import json, sys
a, b = ([json.loads(l) for l in open(p)] for p in sys.argv[1:3])
name, e, n = sys.argv[3], sys.argv[4], int(sys.argv[5])
assert all(d["triangles"] == a[0]["triangles"] for d in a + b), "A and B differ in triangles"
best = lambda runs, k: min(d[k] for d in runs)
ra, rb = best(a, "refine_ms"), best(b, "refine_ms")
ua, ub = best(a, "refine_reused_ms"), best(b, "refine_reused_ms")
share = a[0]["vertices"] / (n * n)
print(f"| {name} | {e} | {a[0]['triangles']} | {share:.3f} | {ra:.3f} | {rb:.3f} | {ra / rb:.2f} "
      f"| {ua:.3f} | {ub:.3f} | {ua / ub:.2f} |")
PY
    done
done

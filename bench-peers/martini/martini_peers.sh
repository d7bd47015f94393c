#!/usr/bin/env bash
# SOAR (relief mesh, view-independent) against @mapbox/martini 0.2.0 (npm) and pymartini 0.6.0
# (PyPI) on the same heights (decoded once to metres and made (2^k+1)^2 by prep.py, so all three
# read bit-identical input), at E = 1, 5, 20, 50 m. Protocol (shared/CI-NOTES.md): martini's
# max_error is not a true bound, so it is also run at the largest E' whose *measured* error is
# still <= E (bisection in martini_run.mjs), and triangle counts are compared there.
# Times: best of REPS runs, measured inside each tool (relief: preprocess_ms / refine_ms of
# `relief mesh --json`, which include allocating the output; martini: createTile / getMesh;
# pymartini: create_tile / get_mesh, which allocate fresh output arrays too). relief's
# preprocess_ms is the first call of its process; preprocess_repeat_ms (--preprocess-repeats 3:
# three more calls in the same process, each into fresh buffers allocated and freed inside the
# timing, the fastest) is the peers' own protocol for createTile (best of REPS calls in one
# process) and is printed beside it. relief's
# refine_reused_ms (the same extraction into the already-touched buffers, as a library user
# refining every frame gets) is reported next to it, never instead of it, and so is
# refine_fresh_repeat_ms: fresh output buffers on each of 3 calls in one process, the fastest,
# which is the peers' own protocol (best of REPS calls in one process, each allocating its
# output, where the allocator hands a call the memory the previous one freed). The
# `relief-full-grid` rows time the same extraction with grid-coordinate vertices (`--vertices
# grid`: `[u16; 2]`, no heights read), the vertex format martini and pymartini return.
#
# usage: bench-peers/martini/martini_peers.sh   (env: REPS=5, DATA=../shared/data, RELIEF=path)
# prints one JSON line per tool, DEM and E, then a Markdown table (summary.py).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
DATA=${DATA:-$root/../shared/data}
REPS=${REPS:-5}
cd "$here"

# Peers, installed from the registries into this folder (git-ignored).
[ -f package.json ] || echo '{"name":"relief-martini-peer","private":true}' > package.json
[ -f node_modules/@mapbox/martini/package.json ] ||
    npm install --no-save --no-audit --no-fund "@mapbox/martini@0.2.0" >/dev/null
if [ ! -x .venv/bin/python ]; then python3 -m venv .venv; fi
.venv/bin/python -c "import pymartini, numpy, PIL" 2>/dev/null ||
    .venv/bin/pip install -q "pymartini==0.6.0" numpy pillow

if [ -z "${RELIEF:-}" ]; then
    (cd "$root" && cargo build --release -q -p relief-cli)
    RELIEF="${CARGO_TARGET_DIR:-$root/target}/release/relief"
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
out=${OUT:-$here/results.jsonl}
: > "$out"
ES="1 5 20 50"
specs=(
    "diligent_ps_height_1k.png:png-dm"
    "martini_fuji.png:terrain-rgb"
    "delatin_14-2625-6369.png:terrain-rgb"
    "pymartini_mapbox_st_helens.png:terrain-rgb"
    "pymartini_terrarium.png:terrarium"
    "topotoolbox_srtm_bigtujunga30m_utm11.tif:tiff"
    "pysheds_dem.tif:tiff"
)
for spec in "${specs[@]}"; do
    IFS=: read -r name fmt <<<"$spec"
    src="$DATA/$name"
    if [ ! -f "$src" ]; then
        echo "skipped: $src not present" >&2
        continue
    fi
    raw="$tmp/${name%.*}.f32"
    n=$(.venv/bin/python prep.py "$src" "$fmt" "$raw")
    for e in $ES; do
        # full-grid: the full layout timed with grid-coordinate vertices (`[u16; 2]`, what
        # martini and pymartini output) instead of positions.
        for variant in full compact full-grid; do
            layout=${variant%-grid}; vf=positions
            [ "$variant" = full-grid ] && vf=grid
            bp=""; br=""; bu=""; bf=""; bq=""; line=""
            for _ in $(seq "$REPS"); do
                line=$("$RELIEF" mesh --dem "$raw" --format raw-f32 --width "$n" --height "$n" \
                    --max-error "$e" --layout "$layout" --vertices "$vf" --out "$tmp/m.obj" \
                    --json --preprocess-repeats 3)
                p=$(echo "$line" | .venv/bin/python -c "import json,sys; print(json.load(sys.stdin)['preprocess_ms'])")
                q=$(echo "$line" | .venv/bin/python -c "import json,sys; print(json.load(sys.stdin)['preprocess_repeat_ms'])")
                bq=$(.venv/bin/python -c "print(min(float('$q'), float('${bq:-inf}')))")
                r=$(echo "$line" | .venv/bin/python -c "import json,sys; print(json.load(sys.stdin)['refine_ms'])")
                u=$(echo "$line" | .venv/bin/python -c "import json,sys; print(json.load(sys.stdin)['refine_reused_ms'])")
                f=$(echo "$line" | .venv/bin/python -c "import json,sys; print(json.load(sys.stdin)['refine_fresh_repeat_ms'])")
                bp=$(.venv/bin/python -c "print(min(float('$p'), float('${bp:-inf}')))")
                bu=$(.venv/bin/python -c "print(min(float('$u'), float('${bu:-inf}')))")
                bf=$(.venv/bin/python -c "print(min(float('$f'), float('${bf:-inf}')))")
                br=$(.venv/bin/python -c "print(min(float('$r'), float('${br:-inf}')))")
            done
            echo "$line" | .venv/bin/python -c "
import json,sys
d=json.load(sys.stdin)
print(json.dumps({'dem':'$name','tool':'relief-$variant','n':$n,'E':$e,'create_ms':$bp,'create_repeat_ms':$bq,'mesh_ms':$br,'mesh_reused_ms':$bu,'mesh_fresh_repeat_ms':$bf,
 'triangles':d['triangles'],'vertices':d['vertices'],'measured':d['max_error_measured']}))" | tee -a "$out"
        done
    done
    # shellcheck disable=SC2086
    node martini_run.mjs "$raw" "$n" "$REPS" $ES | sed "s/^{/{\"dem\": \"$name\", /" | tee -a "$out" > "$tmp/m.jsonl"
    pairs=$(.venv/bin/python -c "
import json
print(' '.join(f\"{d['E']}:{d['E_equal']}\" for d in map(json.loads, open('$tmp/m.jsonl'))))")
    # shellcheck disable=SC2086
    .venv/bin/python pymartini_run.py "$raw" "$n" "$REPS" $pairs | sed "s/^{/{\"dem\": \"$name\", /" | tee -a "$out"
done
.venv/bin/python summary.py "$out"

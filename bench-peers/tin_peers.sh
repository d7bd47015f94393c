#!/usr/bin/env bash
# TIN peer comparison: relief's greedy TIN (`relief mesh --method tin`) against pydelatin 0.4.0
# (PyPI, C++ fogleman/hmm) and delatin 0.2.0 (npm, JS mapbox/delatin) on the same heights at the
# same max error E. Every tool reads the same raw f32 file (decoded once by dem_to_raw.py), so the
# inputs are bit-identical. Times are each tool's whole build, measured inside the tool (relief:
# refine_ms; pydelatin: the Delatin() call; delatin: constructor + run), fastest of ROUNDS
# interleaved rounds of two runs each (the second run of a Python or Node process is warm), both
# wall-clock (ms) and on-CPU (cpu_ms: relief's and pydelatin's building thread, Node's whole
# process), since on a shared machine wall-clock includes waiting for a core.
#
# usage: bench-peers/tin_peers.sh            (env: ROUNDS=3, DATA=../shared/data, RELIEF=path)
# prints one JSON line per tool, DEM and E, then a table (tin_summary.py).
# Peers, installed from the registries into this folder (git-ignored).
# shellcheck source=bench-peers/tin_common.sh
source "$(dirname "$0")/tin_common.sh"
[ -f node_modules/delatin/package.json ] ||
    npm install --no-save --no-audit --no-fund "delatin@0.2.0" >/dev/null

out="$tmp/results.jsonl"

# file : format : E list (in the file's height units: metres, except the 16-bit PNG's decimetres)
specs=(
    "delatin_14-2625-6369.png:terrain-rgb:0.1 0.5 1 5"
    "martini_fuji.png:terrain-rgb:1 5 20"
    "pymartini_mapbox_st_helens.png:terrain-rgb:0.5 1 5"
    "pymartini_terrarium.png:terrarium:1 5 20"
    "diligent_ps_height_1k.png:png:50 200 500"
    "topotoolbox_srtm_bigtujunga30m_utm11.tif:tiff:1 5 20"
    "pysheds_dem.tif:tiff:0.5 1 5"
)
# Rounds are interleaved (every tool on every DEM once per round) so that load on a shared
# machine hits all tools alike; the summary keeps each tool's fastest round.
for round in $(seq "$ROUNDS"); do
for spec in "${specs[@]}"; do
    IFS=: read -r name fmt errors <<<"$spec"
    src="$DATA/$name"
    if [ ! -f "$src" ]; then
        [ "$round" = 1 ] && echo "skipped: $src not present" >&2
        continue
    fi
    dem_raw "$name" "$fmt"
    # shellcheck disable=SC2086
    pydelatin_lines "$name" $errors | tee -a "$out"
    # shellcheck disable=SC2086
    node delatin_run.mjs "$raw" "$w" "$h" 2 $errors | sed "s/^{/{\"dem\": \"$name\", /" | tee -a "$out"
    for e in $errors; do for _ in 1 2; do
        relief_tin_line "$RELIEF" "$name" "$e" relief-tin | tee -a "$out"
    done; done
done
done
.venv/bin/python tin_summary.py <"$out"

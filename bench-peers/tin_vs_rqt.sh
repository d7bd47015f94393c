#!/usr/bin/env bash
# Triangles vs error of the greedy TIN against view-independent refinement (RQT, SOAR), both
# through `relief mesh` on the same DEM at the same error targets E, in one run. Prints JSON
# lines, then a Markdown table: per E, triangles and measured max error of each, the triangle
# ratio RQT / TIN, and times (RQT: preprocess + refine; TIN: whole build, best of REPS).
#
# usage: bench-peers/tin_vs_rqt.sh [DEM ARGS...]   (default: the bundled Puget Sound DEM in metres)
#        env: REPS=3, ERRORS="200 100 50 20 10 5", RELIEF=path
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
REPS=${REPS:-3}
ERRORS=${ERRORS:-"200 100 50 20 10 5"}
if [ $# -eq 0 ]; then
    set -- --dem "$root/data/puget_sound_1k.png" --dx 160 --dy 160 --z-scale 0.1
fi
if [ -z "${RELIEF:-}" ]; then
    (cd "$root" && cargo build --release -q -p relief-cli)
    RELIEF="${CARGO_TARGET_DIR:-$root/target}/release/relief"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for e in $ERRORS; do
    for method in rqt tin; do
        for _ in $(seq "$REPS"); do
            "$RELIEF" mesh --method "$method" "$@" --max-error "$e" --out "$tmp/m.obj" --json |
                python3 -c '
import json, sys
r = json.load(sys.stdin)
print(json.dumps({"method": sys.argv[1], "max_error": float(sys.argv[2]), "vertices": r["vertices"],
    "triangles": r["triangles"], "max_error_measured": r["max_error_measured"],
    "ms": r.get("preprocess_ms", 0.0) + r["refine_ms"]}))' "$method" "$e"
        done
    done
done | tee "$tmp/rows.jsonl"
python3 - "$tmp/rows.jsonl" <<'PY'
import json, sys
best = {}
for line in open(sys.argv[1]):
    r = json.loads(line)
    k = (r["max_error"], r["method"])
    if k not in best or r["ms"] < best[k]["ms"]:
        best[k] = r
print("| E | RQT triangles | RQT max error | RQT ms | TIN triangles | TIN max error | TIN ms | RQT/TIN triangles |")
print("|---|---|---|---|---|---|---|---|")
for e in sorted({k[0] for k in best}, reverse=True):
    q, t = best.get((e, "rqt")), best.get((e, "tin"))
    if q and t:
        print(f"| {e:g} | {q['triangles']} | {q['max_error_measured']:.3f} | {q['ms']:.1f} | {t['triangles']} "
              f"| {t['max_error_measured']:.3f} | {t['ms']:.1f} | {q['triangles'] / t['triangles']:.2f} |")
PY

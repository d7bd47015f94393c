#!/usr/bin/env bash
# A/B of two relief binaries on view-independent `relief mesh`: for each E, R alternating rounds
# (A then B), the fastest refine_ms (fresh buffers) and refine_reused_ms (reused buffers) per
# binary, and B / A. Both binaries must make the same mesh (the triangle counts are compared).
#
# usage: benches/scripts/mesh_ab.sh A B [relief mesh input args...]
#   env: ES="5 50 200" (max errors), R=7 (rounds)
# e.g.   benches/scripts/mesh_ab.sh /tmp/relief_base target/release/relief \
#            --dem data/puget_sound_1k.png --dx 160 --dy 160 --z-scale 0.1
set -euo pipefail
a=$1 b=$2
shift 2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| E | triangles | A fresh ms | B fresh ms | B / A fresh | A reused ms | B reused ms | B / A reused |"
echo "|---|---|---|---|---|---|---|---|"
for e in ${ES:-5 50 200}; do
    for k in $(seq "${R:-7}"); do
        for side in a b; do
            bin=$a
            [ "$side" = b ] && bin=$b
            "$bin" mesh "$@" --max-error "$e" --out "$tmp/m.obj" --json >>"$tmp/$side.$e.jsonl"
        done
    done
    python3 - "$tmp/a.$e.jsonl" "$tmp/b.$e.jsonl" "$e" <<'PY'
import json, sys
a = [json.loads(l) for l in open(sys.argv[1])]
b = [json.loads(l) for l in open(sys.argv[2])]
ta, tb = {d["triangles"] for d in a}, {d["triangles"] for d in b}
if ta != tb:
    sys.exit(f"E={sys.argv[3]}: the binaries made different meshes ({ta} vs {tb} triangles)")
fa, fb = min(d["refine_ms"] for d in a), min(d["refine_ms"] for d in b)
ua, ub = min(d["refine_reused_ms"] for d in a), min(d["refine_reused_ms"] for d in b)
print(f"| {sys.argv[3]} | {a[0]['triangles']} | {fa:.3f} | {fb:.3f} | {fb / fa:.3f} | {ua:.4f} | {ub:.4f} | {ub / ua:.3f} |")
PY
done

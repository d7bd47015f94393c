#!/usr/bin/env bash
# Cost of each GPU effect as a ratio to the bare frame (seed 003, table 1 measured this by hand):
# `relief render --json` on the bundled DEM, one effect at a time, median pass times over
# REPEAT frames (setup passes, run once, excluded), all in one run on one device. The scenes are
# run ROUNDS times interleaved and each scene keeps its fastest round (the machine is shared).
# Usage: bash adapters/wgpu/bench/effects.sh [path/to/relief] [WxH] [REPEAT] [ROUNDS]
set -euo pipefail
cd "$(dirname "$0")/../../.."
RELIEF=${1:-target/release/relief}
SIZE=${2:-640x360}
REPEAT=${3:-7}
ROUNDS=${4:-3}
out=$(mktemp -d)
run() {
  "$RELIEF" render --dem data/puget_sound_1k.png --dx 160 --dy 160 --z-scale 0.1 \
    --eye 20000,15000,3000 --target 90000,80000,0 --fov 60 --size "$SIZE" \
    --repeat "$REPEAT" --json --out "$out/frame.png" "$@"
}
rows=()
for _ in $(seq "$ROUNDS"); do
  for fx in "" lighting shadows detail deformations fog water depth "lighting,shadows,fog"; do
    rows+=("$fx	$(run ${fx:+--effects "$fx"})")
  done
  rows+=("march	$(run --method march)")
done
printf '%s\n' "${rows[@]}" | python3 -c '
import json, sys
lines = [l.rstrip("\n").split("\t", 1) for l in sys.stdin if l.strip()]
best = {}
order = []
for name, js in lines:
    v = json.loads(js)
    if name not in best:
        order.append(name)
    if name not in best or v["frame_ms"] < best[name]["frame_ms"]:
        best[name] = v
res = [(n, best[n]) for n in order]
bare = res[0][1]["frame_ms"]
print("device:", res[0][1]["device"], "| image", res[0][1]["width"], "x", res[0][1]["height"], "| median of", res[0][1]["frames"], "frames, best of", len(lines) // len(order), "rounds")
print()
print("| scene | passes per frame | frame ms | vs bare frame |")
print("|---|---|---|---|")
for name, v in res:
    label = "bare (maxmip, no effects)" if name == "" else ("method march, no effects" if name == "march" else name)
    passes = ", ".join("%s %.1f" % (p["name"], p["ms"]) for p in v["passes"])
    print("| %s | %s | %.1f | %.2fx |" % (label, passes, v["frame_ms"], v["frame_ms"] / bare))
'

#!/usr/bin/env bash
# Terrains near one storage binding (128 MiB on lavapipe and many GPUs): which scenes a device
# renders and which it refuses in one line, because a scene allocates only the buffers it names
# (relief-wgpu's crate docs, "What fits a device").
#
#   bash adapters/wgpu/bench/large_terrains.sh [RELIEF]     # RELIEF defaults to target/release/relief
#
# Exits non-zero when a render ends otherwise than rendered (0) or refused in one line (2).
# Writes two synthetic raw f32 DEMs (python3, standard library only) to ${TMPDIR:-/tmp}:
# 5400 x 5400 (heights 117 MB fit; the max-mip pyramid, 155 MB, does not) and 4000 x 4000
# (the lit normal map's gradients, 128 MB at 8 bytes a sample, fit; at 16 they did not).
set -uo pipefail
RELIEF="${1:-target/release/relief}"
DIR="${TMPDIR:-/tmp}"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
for n in 5400 4000; do
  f="$DIR/relief-large-$n.f32"
  [ -f "$f" ] || python3 - "$n" "$f" <<'EOF'
import array, math, sys
n, path = int(sys.argv[1]), sys.argv[2]
row = array.array('f', [0.0] * n)
with open(path, 'wb') as out:
    for y in range(n):
        for x in range(n):
            row[x] = 300.0 * math.sin(x * 0.003) * math.cos(y * 0.004) + 50.0 * math.sin((x + y) * 0.02)
        row.tofile(out)
EOF
done
status=0
run() {
  local n=$1; shift
  local c=$((n / 2))
  echo "== ${n} x ${n}: $*"
  "$RELIEF" render --dem "$DIR/relief-large-$n.f32" --format raw-f32 --width "$n" --height "$n" \
    --eye -500,-500,1500 --target "$c,$c,0" --size 320x240 --out "$DIR/relief-large.png" \
    --json "$@" 2>&1 | tail -1 | cut -c1-400
  local rc=${PIPESTATUS[0]}
  echo "exit $rc"
  [ "$rc" = 0 ] || [ "$rc" = 2 ] || status=1
}
run 5400 --method march
run 5400 --method silhouette
run 5400 --method maxmip
run 4000 --effects lighting
run 4000 --method march --effects lighting
exit $status

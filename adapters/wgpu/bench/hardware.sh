#!/usr/bin/env bash
# The GPU passes on a hardware adapter: relief-wgpu's tests and golden images, and the effect
# costs with GPU timestamps (CI and the development machines only have Mesa's lavapipe).
#
#   bash adapters/wgpu/bench/hardware.sh build DIR   # here: release test binaries and examples into DIR
#   bash adapters/wgpu/bench/hardware.sh run DIR     # on the GPU machine, from the repository root
#
# `build` needs cargo; `run` needs only the binaries in DIR, the repository's tracked files
# (bundled DEM, golden images) and a Vulkan loader with the GPU's driver (WGPU_BACKEND picks
# another backend). The tests find their data through the path they were built at, so `run`
# links that path to this checkout when it differs. Prints the adapter, test results, the
# effect table at 640x360 and 1920x1080 (median of 15 frames), three `relief render --json`
# frames at 1080p (maxmip, cascades, mesh), three images past lavapipe's limits and the
# terrains of `large_terrains.sh` (rendered or refused in one line; that script needs python3 to
# write its DEMs); exits non-zero if a test fails or a run ends otherwise.
set -uo pipefail
cd "$(dirname "$0")/../../.."
mode=${1:-}
dir=${2:-}
[ -n "$mode" ] && [ -n "$dir" ] || { sed -n 2,12p "$0"; exit 2; }
case "$mode" in
build)
  mkdir -p "$dir"
  exes=$(cargo test --release -p relief-wgpu --no-run --message-format=json 2>/dev/null |
    python3 -c 'import json,sys
for l in sys.stdin:
    m = json.loads(l)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["kind"] != ["bin"]:
        print(m["target"]["name"], m["executable"])')
  [ -n "$exes" ] || { echo "no test binaries built" >&2; exit 1; }
  while read -r name exe; do cp "$exe" "$dir/test-$name"; done <<<"$exes"
  # Two builds: with `--example`, cargo builds only the example, not the CLI binary.
  cargo build --release -p relief-cli || exit 1
  cargo build --release -p relief-examples --example gpu_effects || exit 1
  cp target/release/relief target/release/examples/gpu_effects "$dir/"
  pwd >"$dir/built-at"
  strip "$dir"/test-* "$dir/relief" "$dir/gpu_effects" 2>/dev/null
  ls -l "$dir"
  ;;
run)
  dir=$(cd "$dir" && pwd)
  built=$(cat "$dir/built-at")
  if [ "$built" != "$PWD" ] && [ ! -e "$built" ]; then
    mkdir -p "$(dirname "$built")" && ln -s "$PWD" "$built"
  fi
  export RUST_BACKTRACE=1
  status=0
  for t in "$dir"/test-*; do
    echo "== $(basename "$t")"
    (cd adapters/wgpu && "$t" --test-threads=4 2>&1 | grep -v '^test .* ok$') || status=1
  done
  dem=data/puget_sound_1k.png
  for size in 640x360 1920x1080; do
    echo "== effects $size"
    "$dir/gpu_effects" "$dem" "$size" 15 || status=1
  done
  for m in maxmip cascades mesh; do
    echo "== relief render --method $m 1920x1080"
    "$dir/relief" render --dem "$dem" --dx 160 --dy 160 --z-scale 0.1 --eye 20000,15000,3000 \
      --target 90000,80000,0 --fov 60 --size 1920x1080 --repeat 9 --method "$m" --json \
      --out "${TMPDIR:-/tmp}/relief-hw-$m.png" || status=1
  done
  # Past lavapipe's limits (a 16384 texture side, 128 MiB bindings): a hardware adapter may
  # render these or refuse them in one line (exit 2); anything else is a failure.
  for args in "--size 4096x2160 --effects normals" "--size 8192x8192" "--size 20000x64 --method mesh"; do
    echo "== relief render $args"
    # shellcheck disable=SC2086
    "$dir/relief" render --dem "$dem" --dx 160 --dy 160 --z-scale 0.1 --eye 20000,15000,3000 \
      --target 90000,80000,0 --fov 60 $args --json --out "${TMPDIR:-/tmp}/relief-hw-big.png" \
      | cut -c1-400
    rc=${PIPESTATUS[0]}
    echo "exit $rc"
    [ "$rc" = 0 ] || [ "$rc" = 2 ] || status=1
  done
  # Terrains near one 128 MiB binding: march and silhouette without the pyramid, lit ones with
  # 8-byte gradients (each rendered or refused in one line).
  echo "== large terrains"
  bash adapters/wgpu/bench/large_terrains.sh "$dir/relief" || status=1
  exit $status
  ;;
*)
  sed -n 2,12p "$0"
  exit 2
  ;;
esac

#!/usr/bin/env bash
# Links ci/panic-check in release with --no-undefined: passes only if no public entry point it
# calls can reach a panic. With --prove, also shows the check catches an added `unwrap()`.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
export RUSTFLAGS="-C link-arg=-Wl,--no-undefined -C link-arg=-lc"
build() { cargo build --quiet --release --manifest-path "$1/Cargo.toml" 2>&1; }
if out=$(build "$here"); then
  echo "panic-freedom: no panic path reachable from the checked relief-core entry points"
else
  echo "$out" | grep -E "relief_core_has_a_reachable_panic|error" | head -5
  echo "panic-freedom check FAILED: a panic is reachable (see the undefined symbol above)"
  exit 1
fi
if [ "${1:-}" = "--prove" ]; then
  repo=$(cd "$here/../.." && pwd)
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  mkdir -p "$tmp/ci"
  cp -r "$repo/core" "$repo/Cargo.toml" "$tmp/"
  cp -r "$here" "$tmp/ci/panic-check"
  rm -rf "$tmp/ci/panic-check/target"
  # Make the copied root a workspace of the core alone.
  python3 - "$tmp/Cargo.toml" <<'PY'
import re, sys
p = sys.argv[1]; s = open(p).read()
s = re.sub(r"members = \[[^\]]*\]", 'members = ["core"]', s, flags=re.S)
s = re.sub(r'exclude = \[[^\]]*\]', 'exclude = ["ci"]', s)
open(p, "w").write(s)
PY
  # An unwrap() on a caller-controlled Option inside a public function.
  sed -i 's|        let (gx, gy) = crate::normals::central_gradient(self, x, y);|        let (gx, gy) = crate::normals::central_gradient(self, x, y);\n        let gx = if gx > 1e300 { None } else { Some(gx) }.unwrap();|' "$tmp/core/src/heightfield.rs"
  grep -q 'Some(gx) }.unwrap()' "$tmp/core/src/heightfield.rs" || { echo "could not plant the unwrap"; exit 1; }
  export CARGO_TARGET_DIR="$tmp/target"
  if out=$(build "$tmp/ci/panic-check"); then
    echo "FAIL: an added unwrap() was not caught"
    exit 1
  fi
  echo "$out" | grep -m1 -oE "undefined (reference to|symbol:) .?relief_core_has_a_reachable_panic" || { echo "$out" | tail -5; exit 1; }
  echo "panic-freedom: an added unwrap() in Terrain::gradient is caught (link fails as above)"
fi

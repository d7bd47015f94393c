#!/usr/bin/env bash
# What spade's exact in-circle path costs relief's greedy TIN (issue 9): relief built as is (A)
# against relief built with `robust` (spade's predicate crate) answering exactly representable
# in-circle determinants from its floating-point filter (B), pydelatin alternating with both.
#
# B is an experiment, never committed: the script copies robust 1.2.0 out of this machine's
# cargo registry into a temporary folder, inserts one early return into `robust::incircle`
# (when all six coordinate differences are integers below 2^12, every product and sum of the
# filter's determinant is exact in f64, so the filter's value *is* the exact determinant and its
# sign is the exact sign), and builds the CLI against that copy with
# `--config patch.crates-io.robust.path=...` into its own target folder. The repository's
# Cargo.toml and Cargo.lock are left as they were. Because B returns the same signs, its meshes
# must equal A's: the script checks the triangle counts and hashes of the OBJ files.
#
# usage: bench-peers/tin_robust_ab.sh      (env: ROUNDS=8, DATA=../shared/data, RELIEF=path of A)
ROUNDS=${ROUNDS:-8}
# shellcheck source=bench-peers/tin_common.sh
source "$(dirname "$0")/tin_common.sh"

# B: the same sources against a patched copy of robust.
(cd "$root" && cargo fetch -q)
src=$(find "${CARGO_HOME:-$HOME/.cargo}/registry/src" -maxdepth 2 -type d -name 'robust-1.2.0' | head -n 1)
[ -n "$src" ] || { echo "robust 1.2.0 not in the cargo registry" >&2; exit 1; }
cp -r "$src" "$tmp/robust"
chmod -R u+w "$tmp/robust"
python3 - "$tmp/robust/src/lib.rs" <<'EOF'
import sys
p = sys.argv[1]
s = open(p).read()
anchor = "    incircleadapt(pa, pb, pc, pd, permanent)\n}"
assert s.count(anchor) == 1, "robust's incircle is not the 1.2.0 one"
early = (
    "    let exact = |v: f64| v == v.trunc() && v.abs() < 4096.0;\n"
    "    if exact(adx) && exact(bdx) && exact(cdx) && exact(ady) && exact(bdy) && exact(cdy) {\n"
    "        return det;\n"
    "    }\n"
)
open(p, "w").write(s.replace(anchor, early + anchor))
EOF
# The patch rewrites Cargo.lock: put the repository's back on every exit, failed builds included.
cp "$root/Cargo.lock" "$tmp/Cargo.lock.saved"
trap 'cp "$tmp/Cargo.lock.saved" "$root/Cargo.lock"; rm -rf "$tmp"' EXIT
(cd "$root" && CARGO_TARGET_DIR="$root/target/robust-ab" cargo build --release -q -p relief-cli \
    --config "patch.crates-io.robust.path=\"$tmp/robust\"")
PATCHED="$root/target/robust-ab/release/relief"

# file : format : E list
specs=(
    "pymartini_terrarium.png:terrarium:1 5 20"
    "martini_fuji.png:terrain-rgb:1 5 20"
    "pysheds_dem.tif:tiff:0.5 1"
)
out="$tmp/results.jsonl"
for _ in $(seq "$ROUNDS"); do
for spec in "${specs[@]}"; do
    IFS=: read -r name fmt errors <<<"$spec"
    dem_raw "$name" "$fmt"
    # shellcheck disable=SC2086
    pydelatin_lines "$name" $errors >>"$out"
    for e in $errors; do
        relief_tin_line "$RELIEF" "$name" "$e" relief-A >>"$out"
        relief_tin_line "$PATCHED" "$name" "$e" relief-B >>"$out"
    done
done
done
.venv/bin/python - "$out" <<'EOF'
import collections, json, statistics, sys
cpu = collections.defaultdict(list)
meta = {}
for line in open(sys.argv[1]):
    r = json.loads(line)
    key = (r["dem"], r["max_error"], r["tool"])
    cpu[key].append(r["cpu_ms"])
    if r["tool"].startswith("relief"):
        meta.setdefault(key, set()).add((r["triangles"], r["obj"]))
print("| DEM | E | pydelatin CPU ms (fastest / median) | A: relief | B: relief, exact in-circle"
      " short-cut | A / pydelatin (fastest) | B / pydelatin (fastest) | B / A (median) | same meshes |")
print("|---|---|---|---|---|---|---|---|---|")
within = {"A": 0, "B": 0}
cases = sorted({k[:2] for k in cpu})
for dem, e in cases:
    p, a, b = (cpu[(dem, e, t)] for t in ("pydelatin", "relief-A", "relief-B"))
    same = meta[(dem, e, "relief-A")] == meta[(dem, e, "relief-B")] and len(meta[(dem, e, "relief-A")]) == 1
    ra, rb = min(a) / min(p), min(b) / min(p)
    within["A"] += ra <= 2
    within["B"] += rb <= 2
    f = lambda v: f"{min(v):.1f} / {statistics.median(v):.1f}"
    print(f"| {dem} | {e:g} | {f(p)} | {f(a)} | {f(b)} | {ra:.2f} | {rb:.2f} |"
          f" {statistics.median(b) / statistics.median(a):.3f} | {'yes' if same else 'NO'} |")
print(f"\n{len(cases)} cases: on-CPU time <= 2x pydelatin: A in {within['A']}, B in {within['B']}")
EOF

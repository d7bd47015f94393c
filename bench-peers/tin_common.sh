# shellcheck shell=bash
# Sourced by the TIN peer scripts (tin_peers.sh, tin_robust_ab.sh): strict mode, the folders
# they work in, pydelatin 0.4.0 (PyPI) installed into bench-peers/.venv, the relief binary and a
# scratch folder, and the steps both scripts take per DEM and error. Sets `here` (this folder,
# also the working directory), `root` (the repository), DATA and ROUNDS (defaults
# ../shared/data and 3), RELIEF (built from the repository unless given) and `tmp` (removed on
# exit).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(dirname "$here")
DATA=${DATA:-$root/../shared/data}
ROUNDS=${ROUNDS:-3}
cd "$here"
if [ ! -x .venv/bin/python ]; then python3 -m venv .venv; fi
.venv/bin/python -c "import pydelatin, numpy, PIL" 2>/dev/null ||
    .venv/bin/pip install -q "pydelatin==0.4.0" numpy pillow
if [ -z "${RELIEF:-}" ]; then
    (cd "$root" && cargo build --release -q -p relief-cli)
    RELIEF="${CARGO_TARGET_DIR:-$root/target}/release/relief"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# dem_raw NAME FORMAT: decodes $DATA/NAME once into raw f32 in $tmp (dem_to_raw.py, so that
# every tool reads identical heights); sets `raw`, `w` and `h`.
dem_raw() {
    raw="$tmp/${1%.*}.f32"
    [ -f "$raw" ] || .venv/bin/python dem_to_raw.py "$DATA/$1" "$2" "$raw" >"$raw.size"
    read -r w h <"$raw.size"
}

# pydelatin_lines NAME E...: pydelatin (2 builds per process) on `raw` at each E, one JSON line
# each, tagged with the DEM's NAME.
pydelatin_lines() {
    local name=$1
    shift
    .venv/bin/python pydelatin_run.py "$raw" "$w" "$h" 2 "$@" | sed "s/^{/{\"dem\": \"$name\", /"
}

# relief_tin_line BIN NAME E TOOL: one greedy TIN build of `raw` by the relief binary BIN at
# error E, as a JSON line tagged with the DEM's NAME and TOOL, with a hash of the OBJ written.
relief_tin_line() {
    "$1" mesh --method tin --dem "$raw" --format raw-f32 --width "$w" --height "$h" \
        --max-error "$3" --out "$tmp/tin.obj" --json >"$tmp/tin.json"
    .venv/bin/python -c '
import json, sys
r = json.load(sys.stdin)
print(json.dumps({"dem": sys.argv[1], "tool": sys.argv[2], "max_error": float(sys.argv[3]),
    "vertices": r["vertices"], "triangles": r["triangles"], "error": r["max_error_measured"],
    "ms": r["refine_ms"], "cpu_ms": r.get("refine_cpu_ms"), "obj": sys.argv[4]}))' \
        "$2" "$4" "$3" "$(sha256sum <"$tmp/tin.obj" | cut -c1-16)" <"$tmp/tin.json"
}

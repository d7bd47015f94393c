#!/usr/bin/env bash
# Shows that the no_std / no-alloc check is not vacuous: on a scratch copy of relief-core it adds
# a `std` use, then an `alloc` use, and requires `cargo check` of the check crate to fail with the
# expected error each time (and to pass on the unmodified copy). Exits non-zero otherwise.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cp -r "$repo/core" "$tmp/core"
cp -r "$repo/ci/nostd-check" "$tmp/check"
rm -rf "$tmp/check/target"
sed -i 's|path = "../../core"|path = "../core"|' "$tmp/check/Cargo.toml"
# Make the copied core standalone (it inherits fields from the root workspace).
python3 - "$tmp/core/Cargo.toml" "$repo/Cargo.toml" <<'PY'
import re, sys
core, root = sys.argv[1], open(sys.argv[2]).read()
s = open(core).read()
for key in ("rust-version", "license", "repository"):
    s = re.sub(rf"^{key}\.workspace = true\n", "", s, flags=re.M)
s = s.replace("version.workspace = true", 'version = "0.0.0"').replace("edition.workspace = true", 'edition = "2021"')
for dep in ("glam", "bytemuck", "libm", "proptest"):
    spec = re.search(rf"^{dep} = (.*)$", root, flags=re.M).group(1).strip()
    if spec.startswith('"'):
        spec = f"{{ version = {spec} }}"
    m = re.search(rf"^{dep} = \{{ workspace = true(?:, features = \[(.*?)\])? \}}$", s, flags=re.M)
    if not m:
        continue
    extra = m.group(1)
    if extra:
        # Merge the member's extra features into the workspace spec's list (or add one).
        if "features = [" in spec:
            spec = spec.replace("features = [", f"features = [{extra}, ", 1)
        else:
            spec = spec[:-1].rstrip() + f", features = [{extra}] }}"
    s = s[:m.start()] + f"{dep} = {spec}" + s[m.end():]
open(core, "w").write(s + "\n[workspace]\n")
PY
export CARGO_TARGET_DIR="$tmp/target"
check() { cargo check --quiet --manifest-path "$tmp/check/Cargo.toml" 2>&1; }
lib="$tmp/core/src/lib.rs"
cp "$lib" "$tmp/lib.rs.orig"
check >/dev/null || { echo "FAIL: the unmodified copy does not pass"; exit 1; }
echo "unmodified core: passes"
printf '/// uses std\npub fn uses_std() -> usize { extern crate std; std::process::id() as usize }\n' >>"$lib"
out=$(check || true)
grep -q "E0152" <<<"$out" || { echo "FAIL: a std use was not caught"; echo "$out"; exit 1; }
echo "core + std use: fails with $(grep -m1 E0152 <<<"$out")"
cp "$tmp/lib.rs.orig" "$lib"
printf '/// uses alloc\npub fn uses_alloc() -> usize { extern crate alloc; alloc::vec![1u8].len() }\n' >>"$lib"
out=$(check || true)
grep -q "no global memory allocator" <<<"$out" || { echo "FAIL: an alloc use was not caught"; echo "$out"; exit 1; }
echo "core + alloc use: fails with $(grep -m1 'no global memory allocator' <<<"$out" | cut -c1-80)"

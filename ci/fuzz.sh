#!/usr/bin/env bash
# Builds and runs every cargo-fuzz target for a short time (FUZZ_SECONDS each, default 60).
# Seeds are in fuzz/seeds/<target>; new corpus entries go to fuzz/corpus/<target> (ignored by git).
# A crash, a failed invariant, an out-of-memory or a time-out fails the script.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
secs=${FUZZ_SECONDS:-60}
if ! rustup toolchain list | grep -q '^nightly'; then
  echo "NOTICE: no nightly toolchain on this machine: cargo-fuzz cannot run; fuzzing SKIPPED"
  exit 0
fi
root=${CARGO_FUZZ_ROOT:-$HOME/.cache/relief-cargo-fuzz}
if [ ! -x "$root/bin/cargo-fuzz" ]; then
  cargo install cargo-fuzz --locked --root "$root" --quiet
fi
export PATH="$root/bin:$PATH"
cargo +nightly fuzz build
for t in $(cargo +nightly fuzz list); do
  mkdir -p "corpus/$t" "seeds/$t"
  echo "== fuzz $t for ${secs}s"
  cargo +nightly fuzz run "$t" "corpus/$t" "seeds/$t" -- \
    -max_total_time="$secs" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 2>&1 |
    grep -E '^(Done|stat::number_of_executed_units|stat::peak_rss_mb)|cov:.*DONE|SUMMARY|panicked|ERROR' || true
  # grep hides libFuzzer's chatter; the pipeline status of cargo decides.
  [ "${PIPESTATUS[0]}" -eq 0 ] || { echo "fuzz target $t FAILED (see fuzz/artifacts/$t)"; exit 1; }
done

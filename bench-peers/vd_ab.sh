#!/bin/sh
# A/B of `vd_bfs` binaries (benches/examples/vd_bfs.rs built from different commits) on the
# library's view-dependent walk: N rounds, each binary in turn, printing the three frames'
# warm M triangles/s of `grid_triangles` on linear records (each the fastest of 30 runs).
# On a disturbed machine read each binary's fastest over the rounds, as BENCHMARKS.md does.
#
# usage (from the repository root): bench-peers/vd_ab.sh N BIN_A BIN_B [...]
# e.g. cargo build --release -p relief-benches --example vd_bfs && cp target/release/examples/vd_bfs /tmp/vd-a
set -eu
n=$1
shift
i=0
while [ "$i" -lt "$n" ]; do
    for b in "$@"; do
        printf '%s ' "$(basename "$b")"
        ONLY="grid_triangles, linear" RUNS=30 "$b" | grep linear | awk '{printf "%s ", $(NF-1)}'
        echo
    done
    i=$((i + 1))
done
